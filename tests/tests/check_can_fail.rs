//! The geometric check is not a rubber stamp: a repository broken on purpose is caught.

use tessera_core::cut::{diamond_rhos, select_stateless};
use tessera_core::metric::{eye_local, ScreenSpaceMetric};
use tessera_core::repository::format::{
    dequantize_position, pack_position, quantize_position, NO_INDEX,
};
use tessera_core::repository::global_ids::encode_global_ids;
use tessera_core::repository::reader::Repository;
use tessera_core::repository::writer::{write_repository_file, RepositoryContents};
use tessera_core::repository::PatchCodec;
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::{build_contents, BuildConfig};
use tessera_runtime::cut_patches::RepositoryPatches;
use tessera_runtime::geometric_check::{
    check_cuts, check_metric, decode_all_patches, position_mismatches_within, CheckConfig,
    CheckReport, CutChecker,
};
use tessera_runtime::gpu::{Renderer, RendererOptions};
use tessera_runtime::pixel_check::{check_pixels, PixelCheckConfig};
use tessera_runtime::views::check_views;
use tessera_tests::{gpu, testdata};

/// The bunny built with `codec`: the tests that edit patch bytes in place build it raw.
fn bunny_contents(codec: PatchCodec) -> RepositoryContents {
    let input = load_mesh(&testdata("mesh/bunny00.off")).unwrap().mesh;
    let config = BuildConfig {
        codec,
        ..BuildConfig::default()
    };
    build_contents(&input, &config, &|_| {}).unwrap().0
}

/// The check's report, asserted the same three ways: every patch decoded first; decoded as
/// the cuts reach them (`check`'s way); and the input's edges and the stored positions
/// gathered in many small passes (as a 100 M-triangle repository's are), cut by cut.
fn check(contents: &RepositoryContents, config: &CheckConfig) -> CheckReport {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.tsr");
    write_repository_file(&path, contents).unwrap();
    let repo = Repository::open(&path).unwrap();
    let patches = decode_all_patches(&repo).unwrap();
    let report = check_cuts(&repo, &patches, config);

    let streamed = RepositoryPatches::new(&repo).unwrap();
    assert_eq!(
        check_cuts(&repo, &streamed, config),
        report,
        "decoded as needed"
    );
    const SMALL_PASS: usize = 64 << 10;
    let whole = CutChecker::new(&repo, &patches);
    let split = CutChecker::with_pass_bytes(&repo, &streamed, SMALL_PASS);
    let h = repo.header();
    let metric = check_metric(h, config);
    for eye in check_views(h.bbox_min, h.bbox_max, config.views) {
        let rhos = diamond_rhos(repo.diamonds(), eye_local(eye, h.origin), &metric);
        for &tau in &config.tolerances {
            let cut = select_stateless(repo.tets(), &rhos, tau);
            assert_eq!(
                split.check(&cut),
                whole.check(&cut),
                "eye {eye:?}, tau {tau}"
            );
        }
    }
    assert_eq!(
        position_mismatches_within(&repo, SMALL_PASS).unwrap(),
        report.position_mismatches,
        "positions in small passes"
    );
    report
}

/// A scan with borders (the lion's head is open at the neck): the border chains' check reads
/// the same in small passes.
#[test]
fn a_scan_with_borders_is_clean_however_the_check_reads_it() {
    let input = load_mesh(&testdata("mesh/lion-head.off")).unwrap().mesh;
    let contents = build_contents(&input, &BuildConfig::default(), &|_| {})
        .unwrap()
        .0;
    let report = check(
        &contents,
        &CheckConfig {
            views: 8,
            ..Default::default()
        },
    );
    assert!(report.is_clean(), "{report:?}");
}

#[test]
fn an_intact_repository_is_clean() {
    let report = check(
        &bunny_contents(PatchCodec::Packed),
        &CheckConfig {
            views: 8,
            ..Default::default()
        },
    );
    assert!(report.is_clean(), "{report:?}");
}

#[test]
fn a_vertex_swapped_in_one_coarse_patch_is_a_crack() {
    let mut contents = bunny_contents(PatchCodec::Raw);
    let config = CheckConfig {
        views: 8,
        ..Default::default()
    };
    // Pick an internal simplex that the first view's coarsest cut draws.
    let repo = Repository::from_bytes(to_bytes(&contents)).unwrap();
    let h = repo.header();
    let size = (0..3)
        .map(|i| (h.bbox_max[i] - h.bbox_min[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    let metric = ScreenSpaceMetric::new(config.viewport_height, config.fov_degrees, size * 1e-4);
    let eye = check_views(h.bbox_min, h.bbox_max, config.views)[0];
    let rhos = diamond_rhos(repo.diamonds(), eye_local(eye, h.origin), &metric);
    let tau = *config.tolerances.last().unwrap();
    let victim = select_stateless(repo.tets(), &rhos, tau)
        .into_iter()
        .find(|&i| {
            let t = &repo.tets()[i as usize];
            t.first_child != NO_INDEX && t.vertex_count > 8
        })
        .expect("the coarse cut draws an internal patch") as usize;
    // Point one of its border vertices at another vertex of the same patch's neighbourhood:
    // the triangles stay valid, the shared edges no longer match.
    let patch = repo.patch(victim).unwrap();
    let patch = patch.view();
    let ids: Vec<u32> = patch.global_ids().collect();
    let mut local_edges = std::collections::HashMap::new();
    for t in patch.triangles() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *local_edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let border_vertex = local_edges
        .iter()
        .find(|(_, &n)| n == 1)
        .map(|((a, _), _)| *a as usize)
        .expect("a patch of a closed model has a border inside the cut");
    // Re-encode every patch's ids with the victim's border vertex renamed.
    let replacement = (0..u32::MAX).find(|g| !ids.contains(g)).unwrap();
    let mut all_ids: Vec<Vec<u32>> = (0..repo.tets().len())
        .map(|i| repo.patch(i).unwrap().view().global_ids().collect())
        .collect();
    drop(repo);
    all_ids[victim][border_vertex] = replacement;
    contents.id_blob.clear();
    for (tet, ids) in contents.tets.iter_mut().zip(&all_ids) {
        tet.id_offset = contents.id_blob.len() as u64;
        tet.id_bytes = encode_global_ids(ids, &mut contents.id_blob) as u32;
    }
    let report = check(&contents, &config);
    assert!(report.cracks > 0, "{report:?}");
    assert!(!report.is_clean());
}

#[test]
fn an_unsaturated_error_is_a_monotonicity_violation() {
    let mut contents = bunny_contents(PatchCodec::Packed);
    // The root diamond's error below its children's.
    contents.diamonds[0].error = 1e-30;
    let report = check(
        &contents,
        &CheckConfig {
            views: 8,
            ..Default::default()
        },
    );
    assert!(report.monotonicity_violations > 0, "{report:?}");
}

fn to_bytes(contents: &RepositoryContents) -> Vec<u8> {
    let mut bytes = Vec::new();
    tessera_core::repository::writer::write_repository(&mut bytes, contents).unwrap();
    bytes
}

/// A border vertex of one coarse patch moved inwards by a tenth of the model's radius, in that
/// patch only (its neighbours keep it where it was): the ids still match, so the edge check
/// sees nothing, but the position check does, and the GPU sees the gap as flag pixels.
#[test]
fn a_border_vertex_nudged_in_one_patch_is_caught_by_both_checks() {
    let mut contents = bunny_contents(PatchCodec::Raw);
    let repo = Repository::from_bytes(to_bytes(&contents)).unwrap();
    let h = *repo.header();
    // The patches of a coarse cut, largest first: each is drawn by many views at τ = 8 px.
    let mut coarse: Vec<usize> = (0..repo.tets().len())
        .filter(|&i| repo.tets()[i].level <= 4 && repo.tets()[i].vertex_count > 20)
        .collect();
    coarse.sort_by_key(|&i| std::cmp::Reverse(repo.tets()[i].triangle_count));
    let victim = coarse[0];
    let patch = repo.patch(victim).unwrap();
    let patch = patch.view();
    let mut local_edges = std::collections::HashMap::new();
    for t in patch.triangles() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *local_edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let border: std::collections::BTreeSet<u32> = local_edges
        .iter()
        .filter(|(_, &n)| n == 1)
        .flat_map(|((a, b), _)| [*a, *b])
        .collect();
    assert!(
        border.len() > 3,
        "a coarse patch of a closed model has a border"
    );
    // Every border vertex of the patch moves a tenth of the radius towards the centre.
    let radius = 0.5
        * (0..3)
            .map(|i| (h.bbox_max[i] - h.bbox_min[i]).powi(2))
            .sum::<f64>()
            .sqrt();
    let centre = [0, 1, 2].map(|i| 0.5 * (h.bbox_min[i] + h.bbox_max[i]));
    for &local in &border {
        let q = patch.position(local as usize);
        let p = dequantize_position(q, h.bbox_min, h.position_step);
        let d = (0..3)
            .map(|i| (p[i] - centre[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        let moved = [0, 1, 2].map(|i| p[i] + (centre[i] - p[i]) / d * 0.1 * radius);
        let packed = pack_position(quantize_position(moved, h.bbox_min, h.position_step));
        let at = contents.tets[victim].patch_offset as usize + 8 * local as usize;
        contents.patch_blob[at..at + 8].copy_from_slice(bytemuck::cast_slice(&packed));
    }
    drop(repo);

    let config = CheckConfig {
        views: 8,
        ..Default::default()
    };
    let report = check(&contents, &config);
    assert_eq!(report.cracks, 0, "the ids still match: {report:?}");
    assert_eq!(report.position_mismatches, border.len(), "{report:?}");
    assert!(!report.is_clean());

    let broken = Repository::from_bytes(to_bytes(&contents)).unwrap();
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx, &broken, RendererOptions::default()).unwrap();
    let pixels = check_pixels(&ctx, &mut renderer, &broken, &PixelCheckConfig::default())
        .expect("the GPU device works");
    assert!(pixels.flag_pixels > 0, "{pixels:?}");
    assert!(!pixels.is_clean());
    assert_eq!(pixels.selection_mismatches, 0, "only positions changed");
}

/// The build's conformity assertion (issue 12, `preprocess/src/simplify/conformity.rs`) is not
/// a rubber stamp either: a simplifier that ignores its locks moves diamond borders, and the
/// build stops naming the diamond and the edge instead of writing a cracked repository.
#[test]
fn a_simplifier_that_ignores_locks_fails_the_build() {
    let broken = |input: &tessera_preprocess::InputMesh, mut config: BuildConfig| {
        config.simplify.fault_ignore_locks = true;
        match build_contents(input, &config, &|_| {}) {
            Err(tessera_preprocess::BuildError::Conformity(e)) => e,
            Err(other) => panic!("expected a conformity error, got {other}"),
            Ok(_) => panic!("a build without locks passed the conformity assertion"),
        }
    };
    let bunny = load_mesh(&testdata("mesh/bunny00.off")).unwrap().mesh;
    let error = broken(&bunny, BuildConfig::default());
    let message = error.to_string();
    assert!(
        message.contains("conformity broken at diamond"),
        "{message}"
    );
    assert!(
        message.contains(&format!("level {}", error.level)),
        "{message}"
    );
    assert_ne!(error.gathered_uses % 2, error.output_uses % 2, "{error:?}");
    // The same input with the simplifier intact builds.
    assert!(build_contents(&bunny, &BuildConfig::default(), &|_| {}).is_ok());

    // A height field, whose outline chains are free to shorten: the border with the rest of
    // the mesh is still held.
    use tessera_preprocess::dem::{load_dem, DemOptions, TerrainOptions};
    let terrain = load_dem(&testdata("dem/volcano.json"), &DemOptions::default())
        .unwrap()
        .to_mesh(&TerrainOptions::default());
    let config = BuildConfig::for_domain(tessera_preprocess::Domain::HeightField);
    broken(&terrain, config.clone());
    assert!(build_contents(&terrain, &config, &|_| {}).is_ok());
}
