//! Eye-relative precision on the position lattice (issue 11, item 4): a camera 10 m above an
//! ETOPO-scale terrain (40,000 km across) projects every vertex within 0.5 px of an f64
//! projection of the same vertex, read back from the GPU (`gpu::position_probe` runs the draw
//! pass's own position functions, `shaders/position.wgsl`); the former formula misses by far
//! more; and a vertex shared by patches gets the same clip bits in each.

use std::collections::HashMap;

use tessera_core::cull::CullTests;
use tessera_core::repository::format::{dequantize_position, quantize_position, unpack_position};
use tessera_core::repository::reader::Repository;
use tessera_core::repository::writer::write_repository;
use tessera_preprocess::dem::{HeightGrid, TerrainOptions};
use tessera_preprocess::{build_contents, BuildConfig, Domain, InputMesh};
use tessera_runtime::camera::{Camera, Z_UP};
use tessera_runtime::gpu::frame::{FrameUniforms, ShadingMode};
use tessera_runtime::gpu::position_probe::clip_positions;
use tessera_tests::gpu;

/// Samples per side of the grid (2^7 + 1).
const SAMPLES: usize = 129;
/// The terrain's width: the equator, 40,000 km.
const EXTENT: f64 = 40_000_000.0;
const WIDTH: u32 = 1920;
const HEIGHT: u32 = 1080;

/// A 129² height field 40,000 km across (312.5 km between samples), heights between about
/// −10 km and +8 km (ETOPO's range).
fn etopo_scale_mesh() -> InputMesh {
    let heights = (0..SAMPLES * SAMPLES)
        .map(|i| {
            let (r, c) = ((i / SAMPLES) as f64, (i % SAMPLES) as f64);
            (9_000.0 * (0.21 * r).sin() * (0.17 * c + 0.5).cos() - 1_000.0 + 37.0 * (r - c)) as f32
        })
        .collect();
    let grid = HeightGrid::unit(SAMPLES, SAMPLES, heights);
    grid.to_mesh(&TerrainOptions {
        spacing: Some(EXTENT / (SAMPLES - 1) as f64),
        ..Default::default()
    })
}

/// `etopo_scale_mesh` built as a height field.
fn etopo_scale_repository() -> Repository {
    let mesh = etopo_scale_mesh();
    let contents = build_contents(
        &mesh,
        &BuildConfig::for_domain(Domain::HeightField),
        &|_| {},
    )
    .expect("build")
    .0;
    let mut bytes = Vec::new();
    write_repository(&mut bytes, &contents).unwrap();
    Repository::from_bytes(bytes).unwrap()
}

#[test]
fn the_build_reports_its_quantisation_error_and_counts_it() {
    let mesh = etopo_scale_mesh();
    let (contents, summary) = build_contents(
        &mesh,
        &BuildConfig::for_domain(Domain::HeightField),
        &|_| {},
    )
    .unwrap();
    let s = summary.position_step;
    // 21 bits over 40,000 km: 19.07 m a step, 13.5 m half its diagonal (z's step is 9 mm).
    assert!((19.07..19.08).contains(&s[0]) && s[0] == s[1], "{s:?}");
    let half_diagonal = 0.5 * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
    assert_eq!(summary.quantisation_error, half_diagonal);
    eprintln!(
        "position step {s:?}, quantisation error {:.3} m, root error {:.1} m",
        summary.quantisation_error, summary.root_error
    );
    // Every stored vertex is within it of its input position...
    let h = &contents.header;
    let mut worst = 0.0f64;
    for (p, q) in mesh.positions.iter().zip(
        mesh.positions
            .iter()
            .map(|&p| quantize_position(p, h.bbox_min, h.position_step)),
    ) {
        let d = dequantize_position(q, h.bbox_min, h.position_step);
        worst = worst.max((0..3).map(|i| (d[i] - p[i]).powi(2)).sum::<f64>().sqrt());
    }
    assert!(
        worst <= summary.quantisation_error * (1.0 + 1e-9),
        "{worst}"
    );
    // ... and no split diamond's stored error is below it. (Here the floor, the largest step,
    // would ensure that alone; that it is added to each own error is pinned by
    // `saturate::tests::the_quantisation_error_is_added_to_every_own_error`.)
    let least = contents
        .diamonds
        .iter()
        .map(|d| d.error as f64)
        .fold(f64::INFINITY, f64::min);
    assert!(least >= summary.quantisation_error, "{least}");
}

/// Every distinct stored position of the repository (all patches, all levels).
fn stored_positions(repo: &Repository) -> Vec<[u32; 2]> {
    let mut all: Vec<[u32; 2]> = (0..repo.tets().len())
        .flat_map(|i| repo.patch(i).unwrap().view().packed_positions().to_vec())
        .collect();
    all.sort_unstable();
    all.dedup();
    all
}

/// A camera 10 m above the stored vertex at grid sample (row, column), 7.7 m behind it,
/// looking 25° down towards the terrain's centre: the vertex 11.2 m ahead, the terrain's far samples
/// near the top of the picture.
fn camera_above(repo: &Repository, row: usize, column: usize) -> ([u32; 3], Camera) {
    let h = repo.header();
    let spacing = EXTENT / (SAMPLES - 1) as f64;
    // The sample's height does not matter: take the stored vertex with its x, y.
    let xy = [column as f64 * spacing, row as f64 * spacing];
    let q = stored_positions(repo)
        .into_iter()
        .map(unpack_position)
        .find(|q| {
            let want = quantize_position([xy[0], xy[1], 0.0], h.bbox_min, h.position_step);
            q[0] == want[0] && q[1] == want[1]
        })
        .expect("a stored vertex at the sample");
    let v = dequantize_position(q, h.bbox_min, h.position_step);
    // Towards the terrain's centre (along (1, 0.7) from near it).
    let dir = {
        let (mut x, mut y) = (0.5 * EXTENT - v[0], 0.5 * EXTENT - v[1]);
        if x.hypot(y) < spacing {
            (x, y) = (1.0, 0.7);
        }
        let l = x.hypot(y);
        [x / l, y / l]
    };
    // 7.7 m, not 8: an offset that is a multiple of f32's spacing at 2e7 m (2 m) would round
    // eye and vertex alike and hide the former formula's error.
    let eye = [v[0] - 7.7 * dir[0], v[1] - 7.7 * dir[1], v[2] + 10.0];
    let down = 25f64.to_radians().tan();
    let target = [
        eye[0] + 100.0 * dir[0],
        eye[1] + 100.0 * dir[1],
        eye[2] - 100.0 * down,
    ];
    let camera = Camera {
        eye,
        target,
        up: Z_UP,
        fov_y_degrees: 60.0,
        width: WIDTH,
        height: HEIGHT,
        near: 0.05,
        far: f64::INFINITY,
    };
    (q, camera)
}

fn pixel(clip: [f32; 4]) -> [f64; 2] {
    let [x, y, _, w] = clip.map(|c| c as f64);
    [
        (x / w + 1.0) * 0.5 * WIDTH as f64,
        (1.0 - y / w) * 0.5 * HEIGHT as f64,
    ]
}

fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

/// The former vertex formula, on the CPU in f32 as draw.wgsl computed it:
/// `(bbox_min − origin) + f32(q) × step − (eye − origin)`, then the same matrix.
fn former_clip(
    uniforms: &FrameUniforms,
    repo: &Repository,
    camera: &Camera,
    q: [u32; 3],
) -> [f32; 4] {
    let h = repo.header();
    let eye = camera.eye_local(h.origin);
    let r = [0, 1, 2].map(|i| {
        (h.bbox_min[i] - h.origin[i]) as f32 + q[i] as f32 * h.position_step[i] as f32 - eye[i]
    });
    let m = uniforms.view_proj;
    [0, 1, 2, 3].map(|row| m[0][row] * r[0] + m[1][row] * r[1] + m[2][row] * r[2] + m[3][row])
}

#[test]
fn ten_metres_above_an_etopo_scale_terrain_every_vertex_is_within_half_a_pixel() {
    let ctx = gpu();
    let repo = etopo_scale_repository();
    let h = *repo.header();
    let step = h.position_step;
    assert!((19.0..19.1).contains(&step[0]), "x step {step:?}");
    let packed = stored_positions(&repo);
    let mut worst_former = 0.0f64;
    for (row, column) in [(2, 3), (64, 70), (126, 125), (128, 128)] {
        let (q0, camera) = camera_above(&repo, row, column);
        let uniforms = FrameUniforms::new(
            &camera,
            &camera,
            &h,
            1.0,
            &CullTests {
                frustum: None,
                cones: false,
            },
            ShadingMode::Lit,
            0,
        );
        let gpu_clip = clip_positions(&ctx, &uniforms, &packed).expect("clip positions read back");
        assert_eq!(gpu_clip.len(), packed.len());
        let (mut compared, mut new_max, mut old_max, mut mirror_max) = (0, 0.0f64, 0.0f64, 0.0f64);
        let mut nearest = f64::INFINITY;
        for (&p, &clip) in packed.iter().zip(&gpu_clip) {
            let q = unpack_position(p);
            let v = dequantize_position(q, h.bbox_min, h.position_step);
            let Some(want) = camera.project(v) else {
                continue;
            };
            let depth = {
                let b = camera.basis();
                (0..3)
                    .map(|i| (v[i] - camera.eye[i]) * b.forward[i])
                    .sum::<f64>()
            };
            let inside =
                (0.0..=WIDTH as f64).contains(&want[0]) && (0.0..=HEIGHT as f64).contains(&want[1]);
            if depth < camera.near || !inside {
                continue;
            }
            compared += 1;
            nearest = nearest.min(depth);
            new_max = new_max.max(distance(pixel(clip), want));
            let mirror = uniforms.clip_of_lattice_point(q.map(|c| c as i32));
            mirror_max = mirror_max.max(distance(pixel(clip), pixel(mirror)));
            old_max = old_max.max(distance(
                pixel(former_clip(&uniforms, &repo, &camera, q)),
                want,
            ));
        }
        eprintln!(
            "sample ({row}, {column}), vertex q {q0:?}: {compared} vertices in view (nearest \
             {nearest:.2} m); max px error: GPU {new_max:.2e}, former formula {old_max:.2}; \
             GPU vs CPU mirror {mirror_max:.2e}"
        );
        assert!(compared >= 100, "{compared} vertices in view");
        assert!(
            nearest < 12.0,
            "the vertex below is in view: nearest {nearest}"
        );
        assert!(new_max <= 0.5, "GPU projection off by {new_max} px");
        assert!(
            mirror_max <= 1e-2,
            "GPU and CPU mirror differ by {mirror_max} px"
        );
        worst_former = worst_former.max(old_max);
    }
    // The test fails the former formula: it rounded positions near 4e7 m to f32 (ulp 4 m).
    assert!(
        worst_former > 10.0,
        "former formula off by only {worst_former} px"
    );
}

#[test]
fn a_vertex_shared_by_patches_gets_the_same_clip_bits_in_each() {
    // Trivially true by construction: quantisation is a function of the position (so every
    // patch holding a vertex stores the same packed q), and the vertex stage's position reads
    // q and the frame uniforms and nothing else (no per-patch base). The test pins both.
    let ctx = gpu();
    let repo = etopo_scale_repository();
    let mut copies: HashMap<u32, Vec<(usize, [u32; 2])>> = HashMap::new();
    for i in 0..repo.tets().len() {
        let patch = repo.patch(i).unwrap();
        let patch = patch.view();
        for (id, &p) in patch.global_ids().zip(patch.packed_positions()) {
            copies.entry(id).or_default().push((i, p));
        }
    }
    let shared: Vec<&Vec<(usize, [u32; 2])>> = copies.values().filter(|c| c.len() >= 2).collect();
    assert!(shared.len() > 1000, "{} shared vertices", shared.len());
    let (_, camera) = camera_above(&repo, 126, 125);
    let uniforms = FrameUniforms::new(
        &camera,
        &camera,
        repo.header(),
        1.0,
        &CullTests {
            frustum: None,
            cones: false,
        },
        ShadingMode::Lit,
        0,
    );
    // Every copy of every shared vertex, in patch order.
    let packed: Vec<[u32; 2]> = shared
        .iter()
        .flat_map(|c| c.iter().map(|&(_, p)| p))
        .collect();
    let clip = clip_positions(&ctx, &uniforms, &packed).expect("clip positions read back");
    let mut at = 0;
    let mut pairs = 0;
    for c in &shared {
        let first = clip[at].map(f32::to_bits);
        for (k, &(patch, p)) in c.iter().enumerate() {
            assert_eq!(
                p, c[0].1,
                "patches {} and {patch} store one vertex differently",
                c[0].0
            );
            assert_eq!(
                clip[at + k].map(f32::to_bits),
                first,
                "patches {} and {patch}",
                c[0].0
            );
        }
        pairs += c.len() - 1;
        at += c.len();
    }
    eprintln!(
        "{} shared vertices, {pairs} extra copies: identical clip bits",
        shared.len()
    );
}
