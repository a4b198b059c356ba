//! Terrains (issue 5) through both crack checks: every DEM of the test data, a generated grid
//! with nodata holes, and a terrain broken on purpose (the pixel check from above and below can
//! fail).

use std::collections::{BTreeSet, HashMap};

use tessera_core::cut::{diamond_rhos, select_stateless};
use tessera_core::repository::format::{dequantize_position, pack_position, quantize_position};
use tessera_core::repository::reader::Repository;
use tessera_core::repository::writer::{write_repository, RepositoryContents};
use tessera_preprocess::dem::{load_dem, DemOptions, HeightGrid, TerrainOptions};
use tessera_preprocess::diamond_square::{generate, TerrainParams};
use tessera_preprocess::{build_contents, BuildConfig, Domain, InputMesh};
use tessera_runtime::camera::Camera;
use tessera_runtime::geometric_check::{check_cuts, decode_all_patches, CheckConfig, CheckReport};
use tessera_runtime::views::terrain_views;
use tessera_tests::{check_pixels_small, gpu, testdata};

fn height_field_config() -> BuildConfig {
    BuildConfig::for_domain(Domain::HeightField)
}

fn contents_of(mesh: &InputMesh) -> RepositoryContents {
    build_contents(mesh, &height_field_config(), &|_| {})
        .expect("build")
        .0
}

/// `contents_of` with the patches stored raw, for the tests that edit them in place.
fn raw_contents_of(mesh: &InputMesh) -> RepositoryContents {
    let config = BuildConfig {
        codec: tessera_core::repository::PatchCodec::Raw,
        ..height_field_config()
    };
    build_contents(mesh, &config, &|_| {}).expect("build").0
}

fn open(contents: &RepositoryContents) -> Repository {
    let mut bytes = Vec::new();
    write_repository(&mut bytes, contents).unwrap();
    Repository::from_bytes(bytes).unwrap()
}

fn geometric(repo: &Repository) -> CheckReport {
    let patches = decode_all_patches(repo).unwrap();
    check_cuts(repo, &patches, &CheckConfig::default())
}

/// Edges used by one triangle: the grid's outline and the borders of its holes.
fn border_edges(mesh: &InputMesh) -> usize {
    let mut count: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    count.values().filter(|&&n| n == 1).count()
}

#[test]
fn every_dem_of_the_test_data_is_crack_free_from_above_and_below() {
    let ctx = gpu();
    for name in ["volcano.json", "jacksboro_fault_dem.npz", "etopo20.cdf"] {
        let grid = load_dem(&testdata(&format!("dem/{name}")), &DemOptions::default()).unwrap();
        let mesh = grid.to_mesh(&TerrainOptions::default());
        let repo = open(&contents_of(&mesh));
        assert_eq!(repo.header().dimension, 2);
        let report = geometric(&repo);
        assert!(report.is_clean(), "{name}: {report:?}");
        assert!(report.cuts_checked >= 64 * 5, "{name}");
        let px = check_pixels_small(&ctx, &repo, 16);
        eprintln!("{name}: {report:?}\n{px:?}");
        assert!(px.is_clean(), "{name}: {px:?}");
        // The views saw the terrain: most of each frame is covered.
        assert!(
            px.covered_pixels > px.frames as u64 * 480 * 270 / 4,
            "{name}: {px:?}"
        );
    }
}

/// A 257² diamond-square terrain with nodata cells: round lakes, single cells, a notch in the
/// outline, a one-sample-wide diagonal cut, an island inside a lake, a checkerboard of missing
/// samples.
fn holed_grid() -> HeightGrid {
    let mut grid = generate(&TerrainParams {
        levels: 8,
        regions: vec!["MH".into(), "VP".into()],
        ..Default::default()
    })
    .unwrap();
    let n = grid.columns;
    let mut hole = |r: usize, c: usize| grid.heights[r * n + c] = f32::NAN;
    for r in 0..n {
        for c in 0..n {
            let d = |r0: f64, c0: f64| ((r as f64 - r0).powi(2) + (c as f64 - c0).powi(2)).sqrt();
            let lake = d(60.0, 70.0) < 18.0 && d(60.0, 70.0) > 4.0; // a ring: the island stays
            let pond = d(190.0, 180.0) < 9.5;
            let notch = r < 30 && (120..140).contains(&c);
            let diagonal = r == c && (150..220).contains(&r);
            let speck = r % 37 == 11 && c % 41 == 7;
            let checker = (200..220).contains(&r) && (30..50).contains(&c) && (r + c) % 2 == 0;
            if lake || pond || notch || diagonal || speck || checker {
                hole(r, c);
            }
        }
    }
    grid
}

#[test]
fn a_grid_with_nodata_holes_is_crack_free() {
    let grid = holed_grid();
    let missing = grid.heights.iter().filter(|h| h.is_nan()).count();
    assert!(missing > 1500, "{missing}");
    let mesh = grid.to_mesh(&TerrainOptions::default());
    let outline = 4 * (grid.columns - 1);
    assert!(
        border_edges(&mesh) > outline + 500,
        "the holes have borders: {} border edges",
        border_edges(&mesh)
    );
    let repo = open(&contents_of(&mesh));
    let report = geometric(&repo);
    assert!(report.is_clean(), "{report:?}");
    let px = check_pixels_small(&gpu(), &repo, 16);
    eprintln!("{report:?}\n{px:?}");
    assert!(px.is_clean(), "{px:?}");
}

/// Border vertices of one coarse terrain patch moved horizontally towards its centre by a
/// twentieth of the terrain's width, in that patch only: a gap the pixel check must see from
/// above and from below (and the geometric check by position).
#[test]
fn a_nudged_terrain_patch_is_caught_from_above_and_below() {
    let grid = load_dem(
        &testdata("dem/jacksboro_fault_dem.npz"),
        &DemOptions::default(),
    )
    .unwrap();
    let mut contents = raw_contents_of(&grid.to_mesh(&TerrainOptions::default()));
    let repo = open(&contents);
    let h = *repo.header();
    // The patch the check's own views draw most often, from above and from below.
    let mut drawn = vec![(0usize, 0usize); repo.tets().len()];
    let (lo, hi) = (h.bbox_min, h.bbox_max);
    let radius = tessera_runtime::camera::bounding_radius(lo, hi);
    for view in terrain_views(lo, hi, 16) {
        let camera = Camera {
            width: 480,
            height: 270,
            ..Camera::looking_at(view.eye, view.target, radius)
        };
        let rhos = diamond_rhos(
            repo.diamonds(),
            camera.eye_local(h.origin),
            &camera.metric(),
        );
        for tau in [0.5, 1.0, 2.0, 4.0, 8.0] {
            for i in select_stateless(repo.tets(), &rhos, tau) {
                let d = &mut drawn[i as usize];
                if view.from_below {
                    d.1 += 1;
                } else {
                    d.0 += 1;
                }
            }
        }
    }
    let victim = (0..repo.tets().len())
        .filter(|&i| repo.tets()[i].vertex_count > 20)
        .max_by_key(|&i| drawn[i].0.min(drawn[i].1))
        .expect("a drawn patch");
    assert!(
        drawn[victim].0.min(drawn[victim].1) > 0,
        "{:?}",
        drawn[victim]
    );
    let patch = repo.patch(victim).unwrap();
    let patch = patch.view();
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for t in patch.triangles() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let border: BTreeSet<u32> = edges
        .iter()
        .filter(|(_, &n)| n == 1)
        .flat_map(|((a, b), _)| [*a, *b])
        .collect();
    let positions: Vec<[f64; 3]> = (0..patch.vertex_count())
        .map(|v| dequantize_position(patch.position(v), h.bbox_min, h.position_step))
        .collect();
    let centre =
        [0, 1].map(|k| positions.iter().map(|p| p[k]).sum::<f64>() / positions.len() as f64);
    let width = (h.bbox_max[0] - h.bbox_min[0]).max(h.bbox_max[1] - h.bbox_min[1]);
    for &local in &border {
        let p = positions[local as usize];
        let d = ((centre[0] - p[0]).powi(2) + (centre[1] - p[1]).powi(2)).sqrt();
        let moved = [
            p[0] + (centre[0] - p[0]) / d * 0.05 * width,
            p[1] + (centre[1] - p[1]) / d * 0.05 * width,
            p[2],
        ];
        let packed = pack_position(quantize_position(moved, h.bbox_min, h.position_step));
        let at = contents.tets[victim].patch_offset as usize + 8 * local as usize;
        contents.patch_blob[at..at + 8].copy_from_slice(bytemuck::cast_slice(&packed));
    }
    drop(repo);
    let broken = open(&contents);
    let report = geometric(&broken);
    assert!(report.position_mismatches > 0, "{report:?}");
    let px = check_pixels_small(&gpu(), &broken, 16);
    eprintln!("{px:?}");
    assert!(px.flag_pixels > 0 && !px.is_clean(), "{px:?}");
    assert!(
        px.flag_pixels_from_below > 0 && px.flag_pixels_from_below < px.flag_pixels,
        "seen from both sides: {px:?}"
    );
    assert_eq!(px.selection_mismatches, 0, "only positions changed");
}

/// With border chains free to shorten, the geometric check still finds cracks: a triangle
/// taken out of each patch in the middle of the terrain (one not touching the input's border)
/// leaves edges used once that simplify no border chain, and one taken from along the
/// outline leaves the outline's vertices drawn on both sides of the gap.
#[test]
fn the_terrain_geometric_check_still_finds_cracks() {
    let grid = load_dem(
        &testdata("dem/jacksboro_fault_dem.npz"),
        &DemOptions::default(),
    )
    .unwrap();
    let mesh = grid.to_mesh(&TerrainOptions::default());
    let outline: std::collections::HashSet<u32> = {
        let mut count: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &mesh.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *count.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        count
            .into_iter()
            .filter(|&(_, n)| n == 1)
            .flat_map(|((a, b), _)| [a, b])
            .collect()
    };
    let repo = open(&contents_of(&mesh));
    let intact = decode_all_patches(&repo).unwrap();
    let config = CheckConfig {
        views: 8,
        ..Default::default()
    };
    assert!(check_cuts(&repo, &intact, &config).is_clean());
    for on_outline in [false, true] {
        let mut broken = intact.clone();
        for patch in broken.iter_mut() {
            if let Some(k) = patch
                .iter()
                .position(|t| t.iter().any(|v| outline.contains(v)) == on_outline)
            {
                patch.remove(k);
            }
        }
        let report = check_cuts(&repo, &broken, &config);
        assert!(
            report.cracks > 0,
            "on the outline: {on_outline}: {report:?}"
        );
    }
}
