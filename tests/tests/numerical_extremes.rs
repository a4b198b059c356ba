//! Numerical extremes (issue 4): models far from the origin and at extreme scales, extreme
//! tolerances, extreme cameras and degenerate inputs. Every case builds, renders on the GPU
//! (lavapipe in CI), and passes the geometric crack check (`check_cuts`: edges by global id,
//! shared positions bit-identical) and, for closed models seen from outside, the GPU pixel
//! check (`check_pixels`: no hole in the front layer, GPU selection = CPU selection).
//!
//! How each kind of check can fail (and so is not a rubber stamp):
//! - "same tables": compares the repository files byte for byte after the header; the negative
//!   control in `a_translated_model_renders_the_same_cut` shows that moving the positions by
//!   a few 1e-9 (an inexact translation) already changes them;
//! - "GPU selection = CPU selection": the GPU's draw list read back against
//!   `select_visible`; a culling test or ρ evaluated differently on one side, or a NaN on
//!   either, shows as a mismatch (the far-plane control below shows both sides cull);
//! - `check_cuts`: `tests/check_can_fail.rs` breaks a repository on purpose and sees cracks,
//!   position mismatches and monotonicity violations;
//! - `check_pixels`: the same file nudges a border vertex and sees flag pixels;
//! - "covers every pixel" from inside a closed model: any crack or missing patch shows the
//!   black background.

use std::collections::BTreeMap;

use tessera_core::cull::CullTests;
use tessera_core::cut::{diamond_rhos, own_rho, parent_rho, select_stateless, select_visible};
use tessera_core::metric::center_minus_eye;
use tessera_core::repository::format::{DiamondRecord, Header, TetRecord, HEADER_SIZE, NO_INDEX};
use tessera_core::repository::reader::Repository;
use tessera_preprocess::import::{load_mesh, ImportReport};
use tessera_preprocess::{build_contents, BuildConfig, BuildError, InputMesh};
use tessera_runtime::camera::{bounding_radius, Camera, Y_UP};
use tessera_runtime::geometric_check::{
    check_cuts, check_cuts_at, decode_all_patches, CheckConfig, CheckEye, CheckReport,
};
use tessera_runtime::gpu::frame::FrameUniforms;
use tessera_runtime::gpu::{
    FrameRequest, GpuContext, Readback, Renderer, RendererOptions, ShadingMode, FLAG_COLOUR,
};
use tessera_runtime::pixel_check::{check_pixels, check_pixels_at, PixelCheckConfig};
use tessera_tests::{build, gpu, testdata, Built};

// ---------------------------------------------------------------------------------------------
// Shared helpers.

/// Target size of every frame here: the checks compare selections and count pixels, which a
/// small target does as well as 1080p at a tenth of the cost on lavapipe. (ρ depends on the
/// camera's height, which is the target's.)
const WIDTH: u32 = 320;
const HEIGHT: u32 = 240;
const TOLERANCES: [f32; 5] = [0.5, 1.0, 2.0, 4.0, 8.0];

fn bunny() -> InputMesh {
    load_mesh(&testdata("mesh/bunny00.off"))
        .expect("import")
        .mesh
}

fn renderer(ctx: &GpuContext, repo: &Repository) -> Renderer {
    let options = RendererOptions {
        width: WIDTH,
        height: HEIGHT,
        ..Default::default()
    };
    Renderer::new(ctx, repo, options).expect("the model fits")
}

/// A camera of the target's size, y up, 60°.
fn camera(eye: [f64; 3], target: [f64; 3], near: f64) -> Camera {
    Camera {
        up: Y_UP,
        width: WIDTH,
        height: HEIGHT,
        near,
        ..Camera::looking_at(eye, target, 1.0)
    }
}

/// An orbit camera around the repository's box at `distance` bounding radii.
fn orbit(h: &Header, azimuth: f64, elevation: f64, distance: f64) -> Camera {
    Camera {
        width: WIDTH,
        height: HEIGHT,
        ..Camera::orbit(h.bbox_min, h.bbox_max, Y_UP, azimuth, elevation, distance)
    }
}

/// A frame in the check shading (background black, front faces grey, back faces magenta
/// where no front face is) with the given culling.
fn request(camera: Camera, tau: f32, cull: CullTests) -> FrameRequest {
    FrameRequest {
        mode: ShadingMode::Check,
        cull,
        ..FrameRequest::new(camera, tau)
    }
}

/// Frustum and normal-cone culling, as a viewer renders.
fn viewer_culling(camera: &Camera) -> CullTests {
    FrameRequest::new(*camera, 1.0).cull
}

/// What one GPU frame drew, and what the CPU reference selects for it.
struct Shot {
    gpu: Vec<u32>,
    cpu: Vec<u32>,
    /// RGBA8 pixels.
    pixels: Vec<u8>,
    /// Pixels not black (the model's, in the check shading).
    covered: usize,
    /// Pixels of `FLAG_COLOUR` (back faces where no front face is).
    flagged: usize,
}

fn shoot(ctx: &GpuContext, renderer: &mut Renderer, repo: &Repository, r: &FrameRequest) -> Shot {
    renderer.render(
        ctx,
        r,
        Readback {
            image: true,
            selection: true,
        },
    );
    let pixels = renderer
        .read_image(ctx)
        .expect("image read back")
        .into_raw();
    let gpu = renderer.read_selection(ctx).expect("selection read back");
    let covered = pixels
        .chunks_exact(4)
        .filter(|p| p[..3] != [0, 0, 0])
        .count();
    let flagged = pixels.chunks_exact(4).filter(|p| *p == FLAG_COLOUR).count();
    Shot {
        gpu,
        cpu: cpu_selection(repo, r),
        pixels,
        covered,
        flagged,
    }
}

/// `select_visible` for a frame, restricted to the patches that have something to draw (the
/// GPU lists only those).
fn cpu_selection(repo: &Repository, r: &FrameRequest) -> Vec<u32> {
    let eye = r.camera.eye_local(repo.header().origin);
    let rhos = diamond_rhos(repo.diamonds(), eye, &r.camera.metric());
    let mut selected = select_visible(repo.tets(), &rhos, r.tau, eye, &r.cull);
    selected.retain(|&i| repo.tets()[i as usize].strip_index_count > 0);
    selected
}

/// `check_cuts` at the default views (16 of them, about one in eight inside the box) and at
/// `cameras` with their own metric, at every tolerance of `TOLERANCES`; both must be clean.
fn assert_cuts_clean(name: &str, built: &Built, cameras: &[Camera]) -> CheckReport {
    let patches = decode_all_patches(&built.repo).expect("patches decode");
    let config = CheckConfig {
        views: 16,
        tolerances: TOLERANCES.to_vec(),
        ..Default::default()
    };
    let report = check_cuts(&built.repo, &patches, &config);
    assert!(report.is_clean(), "{name}: {report:?}");
    assert_eq!(report.cuts_checked, 16 * TOLERANCES.len());
    let eyes: Vec<CheckEye> = cameras
        .iter()
        .map(|c| CheckEye {
            eye: c.eye,
            metric: c.metric(),
        })
        .collect();
    let at_cameras = check_cuts_at(&built.repo, &patches, &eyes, &TOLERANCES);
    assert!(at_cameras.is_clean(), "{name}, own cameras: {at_cameras:?}");
    assert_eq!(at_cameras.cuts_checked, cameras.len() * TOLERANCES.len());
    report
}

/// Triangles as rotation-normalised id triples with their multiplicity (a triangle's identity
/// regardless of where its strip starts; duplicates count).
fn triangle_set(tris: impl Iterator<Item = [u32; 3]>) -> BTreeMap<[u32; 3], usize> {
    let mut set = BTreeMap::new();
    for mut t in tris {
        let m = (0..3).min_by_key(|&i| t[i]).unwrap();
        t.rotate_left(m);
        *set.entry(t).or_insert(0) += 1;
    }
    set
}

/// Six times the signed volume: positive for a closed, outward-oriented surface (what the
/// pixel check assumes).
fn signed_volume(mesh: &InputMesh) -> f64 {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
            a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0])
        })
        .sum()
}

fn centre(h: &Header) -> [f64; 3] {
    [0, 1, 2].map(|i| 0.5 * (h.bbox_min[i] + h.bbox_max[i]))
}

fn radius(h: &Header) -> f64 {
    bounding_radius(h.bbox_min, h.bbox_max)
}

// ---------------------------------------------------------------------------------------------
// 1. Translation: the bunny moved by 1e4, 1e6 and 1e8 draws the same simplices.

/// Multiples of 2^-26 (1.5e-8). For |x| < 2 and an offset up to 1e8 (< 2^27, where f64's
/// spacing is 2^-26), x + offset is exact. The bunny's quantisation step is 4.8e-7 (its box is
/// about 1 unit, 2^21 steps), 32 times coarser, and snapping keeps every vertex distinct
/// (asserted), so the snapped bunny is the bunny as far as the repository can tell.
const GRID: f64 = 1.0 / (1u64 << 26) as f64;

fn snap(x: f64) -> f64 {
    (x / GRID).round() * GRID
}

fn snapped(mut mesh: InputMesh) -> InputMesh {
    for p in &mut mesh.positions {
        *p = p.map(snap);
    }
    mesh
}

fn translated(mesh: &InputMesh, offset: f64) -> InputMesh {
    let mut moved = mesh.clone();
    for p in &mut moved.positions {
        *p = p.map(|x| x + offset);
    }
    moved
}

/// The repository file's bytes after the header: tables, patches, ids.
fn body(built: &Built) -> Vec<u8> {
    let bytes = std::fs::read(built.dir.path().join("model.tsr")).unwrap();
    bytes[HEADER_SIZE..].to_vec()
}

/// The model translated exactly by `offset` builds the same tables (the build works relative
/// to the model's box), and from exactly translated cameras the GPU gets the same uniforms,
/// draws the same simplices (= the CPU reference) and the same pixels; both checks are clean.
fn check_translation(ctx: &GpuContext, base: &InputMesh, a: &Built, offset: f64) {
    let moved = translated(base, offset);
    // Exact: had x + offset rounded, (x + offset) − offset would differ from x.
    for (p, q) in base.positions.iter().zip(&moved.positions) {
        assert_eq!(q.map(|x| x - offset), *p, "offset {offset} is inexact");
    }
    let b = build(&moved, &BuildConfig::default());
    assert!(body(a) == body(&b), "offset {offset}: other tables");
    let (ha, hb) = (a.repo.header(), b.repo.header());
    assert_eq!(hb.origin, ha.origin.map(|x| x + offset));
    assert_eq!(hb.bbox_max, ha.bbox_max.map(|x| x + offset));
    assert_eq!(hb.position_step, ha.position_step);
    assert_eq!(hb.lattice_unit, ha.lattice_unit);

    let mut ra = renderer(ctx, &a.repo);
    let mut rb = renderer(ctx, &b.repo);
    let mut cameras = Vec::new();
    for az in [0.0, 100.0, 200.0, 300.0] {
        let near_camera = {
            let c = orbit(ha, az, 20.0, 1.7);
            Camera {
                eye: c.eye.map(snap),
                target: c.target.map(snap),
                ..c
            }
        };
        let far_camera = Camera {
            eye: near_camera.eye.map(|x| x + offset),
            target: near_camera.target.map(|x| x + offset),
            ..near_camera
        };
        cameras.push(far_camera);
        for tau in [0.5, 2.0, 8.0] {
            let (qa, qb) = (
                request(near_camera, tau, viewer_culling(&near_camera)),
                request(far_camera, tau, viewer_culling(&far_camera)),
            );
            // The reason: the eye relative to the origin is the same f32 vector, so the GPU
            // receives the same bytes.
            let uniforms = |r: &FrameRequest, h: &Header| {
                FrameUniforms::new(&r.camera, r.drawn_from(), h, tau, &r.cull, r.mode, 0)
            };
            assert_eq!(uniforms(&qa, ha), uniforms(&qb, hb), "offset {offset}");
            let (sa, sb) = (
                shoot(ctx, &mut ra, &a.repo, &qa),
                shoot(ctx, &mut rb, &b.repo, &qb),
            );
            assert!(!sa.gpu.is_empty() && sa.covered > 0);
            assert_eq!(sa.gpu, sa.cpu);
            assert_eq!(sb.gpu, sb.cpu, "offset {offset} az {az} τ {tau}");
            assert_eq!(sa.gpu, sb.gpu, "offset {offset} az {az} τ {tau}");
            assert!(sa.pixels == sb.pixels, "offset {offset} az {az} τ {tau}");
        }
    }
    assert_cuts_clean(&format!("bunny + {offset}"), &b, &cameras);
    let pixels = check_pixels(
        ctx,
        &mut rb,
        &b.repo,
        &PixelCheckConfig {
            views: 6,
            tolerances: vec![0.5, 4.0],
            ..Default::default()
        },
    )
    .expect("the GPU device works");
    assert!(pixels.is_clean(), "offset {offset}: {pixels:?}");
    assert!(pixels.covered_pixels > 0);
}

#[test]
fn a_translated_model_renders_the_same_cut() {
    let original = bunny();
    let base = snapped(original.clone());
    let a = build(&base, &BuildConfig::default());
    let h = a.repo.header();
    assert!(
        h.position_step.iter().all(|&s| s > 16.0 * GRID),
        "the grid is finer than the quantisation: {:?}",
        h.position_step
    );
    let mut distinct: Vec<[u64; 3]> = base.positions.iter().map(|p| p.map(f64::to_bits)).collect();
    distinct.sort_unstable();
    distinct.dedup();
    assert_eq!(
        distinct.len(),
        base.positions.len(),
        "snapping welded nothing"
    );

    let ctx = gpu();
    for offset in [1e4, 1e6, 1e8] {
        check_translation(&ctx, &base, &a, offset);
    }

    // Negative control: the comparison sees last-bit changes. The un-snapped bunny moved by
    // 1e8 has its coordinates rounded by up to 7e-9 (f64's spacing at 1e8 is 1.5e-8), and
    // that alone builds other tables.
    let plain = build(&original, &BuildConfig::default());
    let moved = build(&translated(&original, 1e8), &BuildConfig::default());
    assert!(body(&plain) != body(&moved));
}

// ---------------------------------------------------------------------------------------------
// 2. Scale: the bunny scaled by 1e-6 and 1e6 draws the same simplices, up to f32 ties.

fn scaled(mesh: &InputMesh, factor: f64) -> InputMesh {
    let mut s = mesh.clone();
    for p in &mut s.positions {
        *p = p.map(|x| x * factor);
    }
    s
}

/// |x − y| in units of 2^-24 of `scale` (f32's relative precision: one rounding of a value of
/// that size is at most 1/2 unit).
fn rounding_units(x: f64, y: f64, scale: f64) -> f64 {
    (x - y).abs() / scale.abs() * (1u64 << 24) as f64
}

/// The largest rounding unit of a sphere's centre and radius against the scaled reference
/// sphere, counted at the sphere's own size (max(|centre|, radius): what an f32 centre can
/// resolve).
fn sphere_units(reference: ([f32; 3], f32), factor: f64, sphere: ([f32; 3], f32)) -> f64 {
    let (c, r) = (sphere.0.map(|x| x as f64), sphere.1 as f64);
    let (c0, r0) = (
        reference.0.map(|x| x as f64 * factor),
        reference.1 as f64 * factor,
    );
    let size = c.iter().fold(r, |m, x| m.max(x.abs()));
    (0..3)
        .map(|k| rounding_units(c0[k], c[k], size))
        .fold(rounding_units(r0, r, size), f64::max)
}

/// Whether the decision "ρ ≤ τ" can differ between two ρ of one diamond only by rounding: they
/// lie on both sides of τ (or one on it) and both within `units` of τ.
fn is_tie(rho_a: f32, rho_b: f32, tau: f32, units: f64) -> bool {
    let t = tau as f64;
    (rho_a <= tau) != (rho_b <= tau)
        && rounding_units(rho_a as f64, t, t) <= units
        && rounding_units(rho_b as f64, t, t) <= units
}

/// The scaled model builds the same hierarchy, patches (ids), quantised positions and normal
/// cones bit for bit; errors and spheres equal up to f32 rounding. From the scaled cameras
/// every selection at a tolerance away from ties is the same, on the CPU and the GPU; at a
/// tolerance placed exactly on a diamond's ρ, every difference is that tie. Both checks are
/// clean.
///
/// Returns how many simplices the tie on purpose decided differently (rounding does move
/// decisions at a tie, so "the same selection" away from ties is not vacuous).
fn check_scale(ctx: &GpuContext, base: &InputMesh, a: &Built, factor: f64) -> usize {
    let b = build(&scaled(base, factor), &BuildConfig::default());
    let (ta, tb) = (a.repo.tets(), b.repo.tets());
    let (da, db) = (a.repo.diamonds(), b.repo.diamonds());
    // The hierarchy and the patches: identical.
    assert_eq!(ta.len(), tb.len());
    assert_eq!(da.len(), db.len());
    assert_eq!(
        decode_all_patches(&a.repo).unwrap(),
        decode_all_patches(&b.repo).unwrap(),
        "×{factor}: other patches"
    );
    let mut worst_tet = 0.0f64;
    for (i, (x, y)) in ta.iter().zip(tb).enumerate() {
        let geometry_free = |t: &TetRecord| TetRecord {
            center: [0.0; 3],
            radius: 0.0,
            ..*t
        };
        assert_eq!(geometry_free(x), geometry_free(y), "×{factor}: tet {i}");
        assert_eq!((x.cone_axis, x.cone_cos), (y.cone_axis, y.cone_cos));
        let (qa, qb) = (a.repo.patch(i).unwrap(), b.repo.patch(i).unwrap());
        let (qa, qb) = (qa.view(), qb.view());
        for v in 0..x.vertex_count as usize {
            assert_eq!(qa.position(v), qb.position(v), "×{factor}: tet {i}");
        }
        worst_tet = worst_tet.max(sphere_units(
            (x.center, x.radius),
            factor,
            (y.center, y.radius),
        ));
    }
    let (mut worst_error, mut worst_sphere) = (0.0f64, 0.0f64);
    for (i, (x, y)) in da.iter().zip(db).enumerate() {
        let geometry_free = |d: &DiamondRecord| DiamondRecord {
            center: [0.0; 3],
            radius: 0.0,
            error: 0.0,
            ..*d
        };
        assert_eq!(geometry_free(x), geometry_free(y), "×{factor}: diamond {i}");
        let e = y.error as f64;
        worst_error = worst_error.max(rounding_units(x.error as f64 * factor, e, e));
        worst_sphere = worst_sphere.max(sphere_units(
            (x.center, x.radius),
            factor,
            (y.center, y.radius),
        ));
    }
    // Measured: errors within 2.8 units (the meshopt error times the model size, the
    // saturation's margins, the rounding up to f32, and the reference's own rounding), spheres
    // within 2.3 units of their size (the f32 centre, the radius grown by that rounding): a
    // few roundings, nothing systematic.
    assert!(
        worst_error <= 4.0 && worst_sphere <= 4.0 && worst_tet <= 4.0,
        "×{factor}: rounding units: errors {worst_error}, diamond spheres {worst_sphere}, \
         patch spheres {worst_tet}"
    );

    let ha = *a.repo.header();
    let mut ra = renderer(ctx, &a.repo);
    let mut rb = renderer(ctx, &b.repo);
    let mut cameras = Vec::new();
    let mut frames = 0;
    let mut tie_differences = 0;
    let mut widest_tie = 0.0f64;
    for (az, el, distance) in [(0.0, 10.0, 1.7), (130.0, -30.0, 3.0), (250.0, 60.0, 0.3)] {
        let ca = orbit(&ha, az, el, distance);
        let cb = Camera {
            eye: ca.eye.map(|x| x * factor),
            target: ca.target.map(|x| x * factor),
            near: ca.near * factor,
            ..ca
        };
        cameras.push(cb);
        let rhos = |repo: &Repository, c: &Camera| {
            diamond_rhos(
                repo.diamonds(),
                c.eye_local(repo.header().origin),
                &c.metric(),
            )
        };
        let (rho_a, rho_b) = (rhos(&a.repo, &ca), rhos(&b.repo, &cb));
        // A tolerance exactly on the ρ of a diamond this view refines: a tie on purpose.
        let on_tie = rho_a
            .iter()
            .copied()
            .filter(|&r| r > 1.0)
            .fold(f32::MAX, f32::min);
        for tau in TOLERANCES.into_iter().chain([on_tie]) {
            let gap = rho_a
                .iter()
                .map(|&r| rounding_units(r as f64, tau as f64, tau as f64))
                .fold(f64::INFINITY, f64::min);
            let (qa, qb) = (
                request(ca, tau, viewer_culling(&ca)),
                request(cb, tau, viewer_culling(&cb)),
            );
            let sa = shoot(ctx, &mut ra, &a.repo, &qa);
            let sb = shoot(ctx, &mut rb, &b.repo, &qb);
            assert_eq!(sa.gpu, sa.cpu);
            assert_eq!(sb.gpu, sb.cpu, "×{factor} az {az} τ {tau}");
            frames += 1;
            if tau != on_tie {
                // Away from ties: no ρ within 1,000 roundings of τ, and the same selection.
                assert!(
                    gap > 1000.0,
                    "×{factor} az {az}: τ {tau} is {gap} units from a ρ"
                );
                assert_eq!(sa.gpu, sb.gpu, "×{factor} az {az} τ {tau}");
                continue;
            }
            // On the tie: every simplex drawn on one side only is decided by a ρ that ties.
            let only_a = sa.gpu.iter().filter(|t| !sb.gpu.contains(t));
            let only_b = sb.gpu.iter().filter(|t| !sa.gpu.contains(t));
            for &t in only_a.chain(only_b) {
                let tet = &ta[t as usize];
                let (own, parent) = (
                    (own_rho(tet, &rho_a), own_rho(tet, &rho_b)),
                    (parent_rho(tet, &rho_a), parent_rho(tet, &rho_b)),
                );
                let tie = [own, parent]
                    .into_iter()
                    .find(|&(x, y)| is_tie(x, y, tau, 8.0));
                let (x, y) = tie.unwrap_or_else(|| {
                    panic!(
                        "×{factor} az {az}: simplex {t} differs without a tie: {own:?} {parent:?}"
                    )
                });
                let t = tau as f64;
                widest_tie = widest_tie
                    .max(rounding_units(x as f64, t, t))
                    .max(rounding_units(y as f64, t, t));
                tie_differences += 1;
            }
        }
    }
    eprintln!(
        "×{factor}: {frames} frames; {tie_differences} simplices decided by the tie, \
         its ρ within {widest_tie:.1} units of τ"
    );
    assert_cuts_clean(&format!("bunny × {factor}"), &b, &cameras);
    let pixels = check_pixels(
        ctx,
        &mut rb,
        &b.repo,
        &PixelCheckConfig {
            views: 6,
            tolerances: vec![0.5, 4.0],
            ..Default::default()
        },
    )
    .expect("the GPU device works");
    assert!(pixels.is_clean(), "×{factor}: {pixels:?}");
    assert!(pixels.covered_pixels > 0);
    tie_differences
}

#[test]
fn a_scaled_model_renders_the_same_cut_up_to_ties() {
    let base = bunny();
    let a = build(&base, &BuildConfig::default());
    let ctx = gpu();
    let decided_by_ties: usize = [1e-6, 1e6]
        .into_iter()
        .map(|factor| check_scale(&ctx, &base, &a, factor))
        .sum();
    assert!(decided_by_ties > 0, "the ties on purpose moved no decision");
}

// ---------------------------------------------------------------------------------------------
// 3. Tolerance extremes: τ = 1e-6 px draws the input, τ = 1e12 px the roots, on the GPU too
// (the tube's close-ups give the levels above its cube ρ up to 2.2e10 px: their errors are
// bounds summed along the chain, `saturate.rs`).

/// What a tolerance must select.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Expect {
    /// Every leaf: exactly the input triangles.
    Leaves,
    /// Only the roots.
    Roots,
}

/// A model and a view of it.
struct Extreme<'a> {
    name: &'a str,
    input: &'a InputMesh,
    built: &'a Built,
    camera: Camera,
}

/// At `tau`, from the view's camera, the rule selects `expect` and nothing else (on the CPU,
/// and on the GPU with culling off), and τ really is beyond every ρ of this view (so the rule
/// has no choice). A selection of the other kind, or a mix (τ = 1 px, the control), fails the
/// same comparisons. `renderer` holds the view's model.
fn check_tolerance_extreme(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    view: &Extreme,
    tau: f32,
    expect: Expect,
) {
    let Extreme {
        name,
        input,
        built,
        camera,
    } = *view;
    let repo = &built.repo;
    let tets = repo.tets();
    let eye = camera.eye_local(repo.header().origin);
    let rhos = diamond_rhos(repo.diamonds(), eye, &camera.metric());
    let (lowest, highest) = rhos.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &r| {
        (lo.min(r), hi.max(r))
    });
    let expected: Vec<u32> = match expect {
        Expect::Leaves => {
            assert!(
                lowest > tau,
                "{name}: a diamond's ρ {lowest} is below τ {tau}"
            );
            (0..tets.len() as u32)
                .filter(|&i| tets[i as usize].first_child == NO_INDEX)
                .collect()
        }
        Expect::Roots => {
            assert!(
                highest <= tau,
                "{name}: a diamond's ρ {highest} is above τ {tau}"
            );
            (0..repo.header().root_tet_count as u32).collect()
        }
    };
    let stateless = select_stateless(tets, &rhos, tau);
    assert_eq!(stateless, expected, "{name}: τ {tau}");
    if expect == Expect::Leaves {
        let patches = decode_all_patches(repo).unwrap();
        let drawn = triangle_set(stateless.iter().flat_map(|&i| patches[i as usize].clone()));
        let input_set = triangle_set(input.triangles.iter().copied());
        assert!(drawn == input_set, "{name}: τ {tau} is not the input");
    }
    let shot = shoot(ctx, renderer, repo, &request(camera, tau, CullTests::NONE));
    let mut drawable = expected.clone();
    drawable.retain(|&i| tets[i as usize].strip_index_count > 0);
    assert_eq!(shot.cpu, drawable, "{name}: τ {tau}");
    assert_eq!(shot.gpu, drawable, "{name}: τ {tau} on the GPU");
    // The leaves fill the close-ups; the roots' coarsest version (≤ 1 % of the input) of the
    // tube may lie outside them, so only the bunny's views must show it.
    assert!(
        shot.covered > 0 || (expect == Expect::Roots && name == "tube"),
        "{name}: τ {tau} covers no pixel"
    );
    // Control: at 1 px the same comparisons see a mix (neither every leaf nor the roots).
    let middle = select_stateless(tets, &rhos, 1.0);
    assert!(middle != expected, "{name}: τ = 1 px selects the same");
}

#[test]
fn extreme_tolerances_draw_the_input_or_the_roots() {
    let ctx = gpu();
    // The bunny from outside and from inside its bounding sphere; close-ups of the long thin
    // tube of `degenerate_inputs_build_and_check_clean`.
    for (name, input) in [("bunny", bunny()), ("tube", tube())] {
        let built = build(&input, &BuildConfig::default());
        let h = built.repo.header();
        let cameras = match name {
            "bunny" => vec![orbit(h, 30.0, 20.0, 1.7), orbit(h, 200.0, -40.0, 0.8)],
            _ => tube_cameras()[..2].to_vec(),
        };
        let mut renderer = renderer(&ctx, &built.repo);
        for camera in cameras {
            for (tau, expect) in [(1e-6, Expect::Leaves), (1e12, Expect::Roots)] {
                let view = Extreme {
                    name,
                    input: &input,
                    built: &built,
                    camera,
                };
                check_tolerance_extreme(&ctx, &mut renderer, &view, tau, expect);
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 4. Cameras: inside the model, at the near plane, on a sphere, far away, extreme planes.

/// What a camera must see.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Sees {
    /// The closed model from outside: the pixel check applies.
    Outside,
    /// From inside the closed model: with cones off, every pixel shows the surface (a crack
    /// or a missing patch would show the black background). The control: cone culling drops
    /// the patches facing away, which from inside are the ones seen, and pixels go missing.
    Inside,
    /// The near plane cuts the surface: through the cut, the inside shows (back faces where no
    /// front face is, which the pixel check would count).
    CutByNearPlane,
    /// A dot at most a few pixels across; only the roots are drawn.
    FarAway,
    /// The far plane is before the model: nothing at all (a control: both sides cull it).
    Nothing,
}

/// Renders `camera` at several τ with the viewer's culling and with frustum culling only: the
/// GPU selects what the CPU reference selects, every ρ is finite, the picture is what `sees`
/// says, and the geometric check from this eye (with this camera's metric) is clean.
fn check_camera(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    built: &Built,
    name: &str,
    camera: Camera,
    sees: Sees,
) {
    let repo = &built.repo;
    let eye = camera.eye_local(repo.header().origin);
    let rhos = diamond_rhos(repo.diamonds(), eye, &camera.metric());
    assert!(
        rhos.iter().all(|r| r.is_finite() && *r >= 0.0),
        "{name}: ρ not finite"
    );
    let uniforms = FrameUniforms::new(
        &camera,
        &camera,
        repo.header(),
        1.0,
        &viewer_culling(&camera),
        ShadingMode::Check,
        0,
    );
    // The f32 members: everything before `counts`.
    let floats: &[f32] = bytemuck::cast_slice(&bytemuck::bytes_of(&uniforms)[..4 * 56]);
    assert!(floats.iter().all(|x| !x.is_nan()), "{name}: {uniforms:?}");
    let all = (WIDTH * HEIGHT) as usize;
    for tau in [0.5, 2.0, 8.0] {
        let frustum_only = CullTests {
            frustum: Some(camera.view_volume()),
            cones: false,
        };
        for cull in [viewer_culling(&camera), frustum_only] {
            let shot = shoot(ctx, renderer, repo, &request(camera, tau, cull));
            assert_eq!(shot.gpu, shot.cpu, "{name}: τ {tau} {cull:?}");
            let detail = format!(
                "{name}: τ {tau}, cones {}: {} simplices, {} pixels, {} flagged",
                cull.cones,
                shot.gpu.len(),
                shot.covered,
                shot.flagged
            );
            eprintln!("{detail}");
            match sees {
                Sees::Outside => assert!(shot.covered > all / 100, "{detail}"),
                Sees::Inside if !cull.cones => assert_eq!(shot.covered, all, "{detail}"),
                Sees::Inside => assert!(0 < shot.covered && shot.covered < all, "{detail}"),
                Sees::CutByNearPlane => assert!(shot.flagged > 0, "{detail}"),
                Sees::FarAway => {
                    assert!(shot.covered <= 4, "{detail}");
                    assert!(shot.gpu.iter().all(|&i| repo.tets()[i as usize].is_root()));
                }
                Sees::Nothing => {
                    assert!(shot.gpu.is_empty() && shot.covered == 0, "{detail}")
                }
            }
        }
    }
    let patches = decode_all_patches(repo).unwrap();
    let eyes = [CheckEye {
        eye: camera.eye,
        metric: camera.metric(),
    }];
    let report = check_cuts_at(repo, &patches, &eyes, &TOLERANCES);
    assert!(report.is_clean(), "{name}: {report:?}");
    if sees == Sees::Outside {
        let pixels = check_pixels_at(ctx, renderer, repo, &[camera], &TOLERANCES)
            .expect("the GPU device works");
        assert!(pixels.is_clean(), "{name}: {pixels:?}");
        assert!(pixels.covered_pixels > 0);
    }
}

/// Whether `p` is inside the closed `mesh`: the parity of the triangles a ray from `p` crosses
/// (an irrational-ish direction, so it meets no edge of a real mesh).
fn inside(mesh: &InputMesh, p: [f64; 3]) -> bool {
    let d = [0.5773, 0.3141, 0.7536];
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let crossings = mesh
        .triangles
        .iter()
        .filter(|t| {
            // Möller–Trumbore.
            let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
            let (e1, e2) = (sub(b, a), sub(c, a));
            let h = cross(d, e2);
            let det = dot(e1, h);
            if det.abs() < 1e-300 {
                return false;
            }
            let s = sub(p, a);
            let u = dot(s, h) / det;
            let q = cross(s, e1);
            let v = dot(d, q) / det;
            u >= 0.0 && v >= 0.0 && u + v <= 1.0 && dot(e2, q) / det > 0.0
        })
        .count();
    crossings % 2 == 1
}

/// A point exactly on a sphere (centre and radius as stored, relative to the origin) along
/// `axis`, as the GPU sees it: |centre − eye| − radius is 0 in f32.
fn on_sphere(center: [f32; 3], radius: f32, axis: usize, sign: f32) -> Option<[f32; 3]> {
    let mut p = center;
    let mut x = center[axis] + sign * radius;
    for _ in 0..8 {
        p[axis] = x;
        let c = center_minus_eye(center, p);
        let distance = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        if distance - radius == 0.0 {
            return Some(p);
        }
        x = if (distance < radius) == (sign > 0.0) {
            x.next_up()
        } else {
            x.next_down()
        };
    }
    None
}

/// An eye (model space) exactly on one of the given spheres, outside the model's box (so
/// outside the closed model), looking at the model's centre.
fn eye_on_a_sphere(h: &Header, spheres: impl Iterator<Item = ([f32; 3], f32)>) -> Camera {
    let extent = [0, 1, 2].map(|i| (h.bbox_max[i] - h.bbox_min[i]) as f32);
    for (center, r) in spheres {
        for axis in 0..3 {
            for sign in [1.0, -1.0] {
                let Some(p) = on_sphere(center, r, axis, sign) else {
                    continue;
                };
                if p.iter().zip(extent).all(|(&x, e)| (0.0..=e).contains(&x)) {
                    continue; // inside the box
                }
                // origin + p is exact in f64 (both have few significant bits), so the eye
                // comes back to p exactly.
                let eye = [0, 1, 2].map(|i| h.origin[i] + p[i] as f64);
                let camera = camera(eye, centre(h), radius(h) * 1e-5);
                assert_eq!(camera.eye_local(h.origin), p);
                return camera;
            }
        }
    }
    panic!("no sphere reaches outside the box")
}

#[test]
fn extreme_cameras_render_and_select_what_the_cpu_selects() {
    let input = bunny();
    let built = build(&input, &BuildConfig::default());
    let h = *built.repo.header();
    let (c, r) = (centre(&h), radius(&h));
    let ctx = gpu();
    let mut renderer = renderer(&ctx, &built.repo);

    // Inside: a point of the bunny's body (checked by ray parity), looking along +x.
    let body = [c[0], c[1] - 0.1 * r, c[2]];
    assert!(inside(&input, body), "the eye is inside the closed bunny");
    assert!(
        !inside(&input, [c[0], c[1], c[2] + 2.0 * r]),
        "parity sees outside"
    );
    let inside_camera = camera(body, [c[0] + r, body[1], c[2]], r * 1e-5);

    // The near plane cuts the surface: 1e-3 radii off a point of the surface along its normal,
    // looking back in, with the near plane 10 times further than the surface.
    let (point, normal) = {
        let t = input.triangles[1234];
        let [a, b, p] = t.map(|v| input.positions[v as usize]);
        let (u, v) = (
            [0, 1, 2].map(|i| b[i] - a[i]),
            [0, 1, 2].map(|i| p[i] - a[i]),
        );
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        (
            [0, 1, 2].map(|i| (a[i] + b[i] + p[i]) / 3.0),
            n.map(|x| x / l),
        )
    };
    let d = 1e-3 * r;
    let near_plane_camera = camera(
        [0, 1, 2].map(|i| point[i] + d * normal[i]),
        [0, 1, 2].map(|i| point[i] - r * normal[i]),
        10.0 * d,
    );
    // The same eye with the near plane before the surface: a close view from outside.
    let before_the_surface = Camera {
        near: 0.01 * d,
        ..near_plane_camera
    };

    // Exactly on the sphere of the largest patch, and of the coarsest diamond (where ρ's
    // distance clamps to the near distance), that reach outside the box.
    let tets = built.repo.tets();
    let mut by_size: Vec<usize> = (0..tets.len())
        .filter(|&i| tets[i].strip_index_count > 0)
        .collect();
    by_size.sort_by(|&x, &y| tets[y].radius.total_cmp(&tets[x].radius));
    let patch_sphere_camera = eye_on_a_sphere(
        &h,
        by_size.iter().map(|&i| (tets[i].center, tets[i].radius)),
    );
    let diamond_sphere_camera = eye_on_a_sphere(
        &h,
        built.repo.diamonds().iter().map(|d| (d.center, d.radius)),
    );

    // 1e12 units away.
    let far_camera = {
        let dir = [0.6, 0.48, 0.64];
        camera([0, 1, 2].map(|i| c[i] + 1e12 * dir[i]), c, r * 1e-5)
    };

    // Near plane 1e-6, far plane 1e12 (a culling distance; the projection's far plane is
    // infinite), from outside and from inside.
    let extreme_planes = |camera: Camera| Camera {
        near: 1e-6,
        far: 1e12,
        ..camera
    };
    let outside_camera = orbit(&h, 40.0, 25.0, 1.7);

    // Control: the far plane before the model culls everything, on both sides.
    let short_sight = Camera {
        far: 0.3 * r,
        ..outside_camera
    };

    let cases = [
        ("inside", inside_camera, Sees::Inside),
        (
            "near plane cuts the surface",
            near_plane_camera,
            Sees::CutByNearPlane,
        ),
        (
            "1e-3 radii before the surface",
            before_the_surface,
            Sees::Outside,
        ),
        ("on a patch sphere", patch_sphere_camera, Sees::Outside),
        ("on a diamond sphere", diamond_sphere_camera, Sees::Outside),
        ("1e12 away", far_camera, Sees::FarAway),
        (
            "near 1e-6, far 1e12",
            extreme_planes(outside_camera),
            Sees::Outside,
        ),
        (
            "near 1e-6, far 1e12, inside",
            extreme_planes(inside_camera),
            Sees::Inside,
        ),
        ("far plane before the model", short_sight, Sees::Nothing),
    ];
    for (name, camera, sees) in cases {
        check_camera(&ctx, &mut renderer, &built, name, camera, sees);
    }
}

// ---------------------------------------------------------------------------------------------
// 5. Inputs: zero-area triangles, slivers, duplicates, coincident vertices, a flat model, a
// single triangle, a long thin model; directly and through a file.

/// Whether the model is a closed surface (the pixel check applies).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Surface {
    /// Closed (geometrically: positions, not necessarily ids) and outward-oriented.
    Closed,
    /// Open: the pixel check does not apply. Through a hole, or from behind an open sheet, a
    /// back face shows with no crack at all, so flag pixels would mean nothing; instead the GPU
    /// must select what the CPU selects, and draw something.
    Open,
}

/// Builds `mesh`; `check_cuts` is clean at the default views and at `cameras`; τ = 0 gives back
/// exactly the input triangles (duplicates counted); from every camera the GPU selects what the
/// CPU selects and draws something somewhere; a closed model passes the pixel check from
/// `cameras` (all outside it).
fn check_input(
    ctx: &GpuContext,
    name: &str,
    mesh: &InputMesh,
    surface: Surface,
    cameras: &[Camera],
) {
    if surface == Surface::Closed {
        assert!(signed_volume(mesh) > 0.0, "{name}: not outward");
    }
    let built = build(mesh, &BuildConfig::default());
    let repo = &built.repo;
    let report = assert_cuts_clean(name, &built, cameras);
    if mesh.triangles.len() > 1000 {
        assert!(
            report.min_triangles < report.max_triangles,
            "{name}: {report:?}"
        );
    }
    let patches = decode_all_patches(repo).unwrap();
    let eye = cameras[0].eye_local(repo.header().origin);
    let rhos = diamond_rhos(repo.diamonds(), eye, &cameras[0].metric());
    let finest = select_stateless(repo.tets(), &rhos, 0.0);
    let drawn = triangle_set(finest.iter().flat_map(|&i| patches[i as usize].clone()));
    assert!(
        drawn == triangle_set(mesh.triangles.iter().copied()),
        "{name}: τ = 0 is not the input"
    );
    eprintln!("{name}: depth {}, {report:?}", built.summary.depth);
    let mut renderer = renderer(ctx, repo);
    let mut covered = 0;
    for &camera in cameras {
        for tau in [1.0, 8.0] {
            let frustum_only = CullTests {
                frustum: Some(camera.view_volume()),
                cones: false,
            };
            for cull in [viewer_culling(&camera), frustum_only] {
                let shot = shoot(ctx, &mut renderer, repo, &request(camera, tau, cull));
                assert_eq!(shot.gpu, shot.cpu, "{name}: τ {tau} {cull:?}");
                covered += shot.covered;
            }
        }
    }
    eprintln!("{name}: {covered} pixels drawn");
    assert!(covered > 0, "{name}: nothing drawn");
    if surface == Surface::Closed {
        let pixels = check_pixels_at(ctx, &mut renderer, repo, cameras, &TOLERANCES)
            .expect("the GPU device works");
        eprintln!("{name}: {pixels:?}");
        assert!(pixels.is_clean(), "{name}: {pixels:?}");
        assert!(pixels.covered_pixels > 0);
    }
}

/// Orbit cameras around a mesh's box, from every side (below included).
fn orbits(mesh: &InputMesh, distance: f64) -> Vec<Camera> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &mesh.positions {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    [(0.0, 20.0), (120.0, 50.0), (240.0, -35.0), (60.0, -80.0)]
        .into_iter()
        .map(|(az, el)| Camera {
            width: WIDTH,
            height: HEIGHT,
            ..Camera::orbit(lo, hi, Y_UP, az, el, distance)
        })
        .collect()
}

/// Every `every`-th triangle (a, b, c) whose edge ab has a neighbour (b, a, d) gets a new
/// vertex m on ab, moved towards c by `lift` × |ab|: (a, b, c) becomes (a, m, c) and (m, b, c),
/// and the T-junction is closed by (a, b, m), a triangle of area zero (`lift` = 0: m is the
/// exact midpoint, so the three corners are exactly collinear) or a sliver of that aspect.
/// The surface stays closed and outward. Returns the mesh and the added triangles.
fn with_t_junctions(mesh: &InputMesh, every: usize, lift: f64) -> (InputMesh, Vec<[u32; 3]>) {
    let mut m = mesh.clone();
    let mut owner = std::collections::HashMap::new();
    for (i, t) in m.triangles.iter().enumerate() {
        for k in 0..3 {
            owner.insert((t[k], t[(k + 1) % 3]), i);
        }
    }
    let mut touched = vec![false; m.triangles.len()];
    let mut added = Vec::new();
    for i in (0..mesh.triangles.len()).step_by(every) {
        let [a, b, c] = m.triangles[i];
        let Some(&j) = owner.get(&(b, a)) else {
            continue;
        };
        if touched[i] || touched[j] {
            continue;
        }
        touched[i] = true;
        touched[j] = true;
        let [pa, pb, pc] = [a, b, c].map(|v| m.positions[v as usize]);
        let mid = [0, 1, 2].map(|k| 0.5 * (pa[k] + pb[k]));
        let length = (0..3).map(|k| (pb[k] - pa[k]).powi(2)).sum::<f64>().sqrt();
        let towards = [0, 1, 2].map(|k| pc[k] - mid[k]);
        let l = towards.iter().map(|x| x * x).sum::<f64>().sqrt();
        let v = m.positions.len() as u32;
        m.positions
            .push([0, 1, 2].map(|k| mid[k] + lift * length * towards[k] / l));
        m.triangles[i] = [a, v, c];
        m.triangles.push([v, b, c]);
        m.triangles.push([a, b, v]);
        added.push([a, b, v]);
    }
    (m, added)
}

/// Every `every`-th triangle (a, b, c) whose edge ab has a neighbour (b, a, d) gets a new
/// vertex a' on ab at `ratio` × |ab| from a: (a, b, c) becomes (a', b, c) and the needle
/// (a, a', c), (b, a, d) becomes (b, a', d) and the needle (a', a, d). The needles' short edge
/// is `ratio` of their long ones (at 1e-9, far below f32's resolution of the model, where the
/// simplifier's copy of a and a' coincides). The surface stays closed and outward.
fn with_needles(mesh: &InputMesh, every: usize, ratio: f64) -> InputMesh {
    let mut m = mesh.clone();
    let mut owner = std::collections::HashMap::new();
    for (i, t) in m.triangles.iter().enumerate() {
        for k in 0..3 {
            owner.insert((t[k], t[(k + 1) % 3]), i);
        }
    }
    let mut touched = vec![false; m.triangles.len()];
    for i in (0..mesh.triangles.len()).step_by(every) {
        let [a, b, c] = m.triangles[i];
        let Some(&j) = owner.get(&(b, a)) else {
            continue;
        };
        if touched[i] || touched[j] {
            continue;
        }
        touched[i] = true;
        touched[j] = true;
        let d = m.triangles[j]
            .into_iter()
            .find(|&v| v != a && v != b)
            .unwrap();
        let [pa, pb] = [a, b].map(|v| m.positions[v as usize]);
        let a2 = m.positions.len() as u32;
        m.positions
            .push([0, 1, 2].map(|k| pa[k] + ratio * (pb[k] - pa[k])));
        m.triangles[i] = [a2, b, c];
        m.triangles.push([a, a2, c]);
        m.triangles[j] = [b, a2, d];
        m.triangles.push([a2, a, d]);
    }
    m
}

/// `count` triangles repeated, every other one with the opposite winding.
fn with_duplicates(mesh: &InputMesh, count: usize) -> InputMesh {
    let mut m = mesh.clone();
    let step = mesh.triangles.len() / count;
    for k in 0..count {
        let t = mesh.triangles[k * step];
        m.triangles
            .push(if k % 2 == 0 { t } else { [t[1], t[0], t[2]] });
    }
    m
}

/// Every vertex used by a triangle on the +x side of the box's centre gets a twin (a new id at
/// the same position) used by those triangles only: a seam of coincident, distinct vertices
/// (open by ids, closed by positions). Returns the mesh and the number of twins.
fn with_seam(mesh: &InputMesh) -> (InputMesh, usize) {
    let mut m = mesh.clone();
    let (lo, hi) = m
        .positions
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p[0]), hi.max(p[0]))
        });
    let cx = 0.5 * (lo + hi);
    let mut twin = std::collections::HashMap::new();
    for t in 0..m.triangles.len() {
        let tri = m.triangles[t];
        let x = tri.iter().map(|&v| m.positions[v as usize][0]).sum::<f64>() / 3.0;
        if x > cx {
            m.triangles[t] = tri.map(|v| {
                *twin.entry(v).or_insert_with(|| {
                    m.positions.push(m.positions[v as usize]);
                    m.positions.len() as u32 - 1
                })
            });
        }
    }
    let twins = twin.len();
    (m, twins)
}

/// A flat sheet in the plane z = 0: a jittered grid of `n` × `n` cells, normals +z.
fn flat_sheet(n: usize) -> InputMesh {
    let mut mesh = InputMesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let jitter = 0.3 * ((i * 7 + j * 13) as f64).sin();
            mesh.positions
                .push([(i as f64 + jitter) / n as f64, j as f64 / n as f64, 0.0]);
        }
    }
    for j in 0..n {
        for i in 0..n {
            let v = (j * (n + 1) + i) as u32;
            let w = v + (n + 1) as u32;
            mesh.triangles.push([v, v + 1, w + 1]);
            mesh.triangles.push([v, w + 1, w]);
        }
    }
    mesh
}

/// The long thin model: a closed tube along x, 1e6 long and 1 thick (aspect 1e6 : 1), 12
/// sides, 2,048 segments, capped, outward.
fn tube() -> InputMesh {
    const SIDES: u32 = 12;
    const SEGMENTS: u32 = 2048;
    const LENGTH: f64 = 1e6;
    let mut mesh = InputMesh::default();
    for k in 0..=SEGMENTS {
        let x = LENGTH * k as f64 / SEGMENTS as f64;
        for j in 0..SIDES {
            let a = std::f64::consts::TAU * j as f64 / SIDES as f64;
            mesh.positions.push([x, 0.5 * a.cos(), 0.5 * a.sin()]);
        }
    }
    let v = |k: u32, j: u32| k * SIDES + j % SIDES;
    for k in 0..SEGMENTS {
        for j in 0..SIDES {
            mesh.triangles.push([v(k, j), v(k + 1, j + 1), v(k + 1, j)]);
            mesh.triangles.push([v(k, j), v(k, j + 1), v(k + 1, j + 1)]);
        }
    }
    let caps = mesh.positions.len() as u32;
    mesh.positions.push([0.0, 0.0, 0.0]);
    mesh.positions.push([LENGTH, 0.0, 0.0]);
    for j in 0..SIDES {
        mesh.triangles.push([caps, v(0, j + 1), v(0, j)]);
        mesh.triangles
            .push([caps + 1, v(SEGMENTS, j), v(SEGMENTS, j + 1)]);
    }
    mesh
}

/// Close-ups of the tube, 3 units from its axis at both ends and along it, and one looking at
/// a cap: at 1e6 units away (the default views) it is far below a pixel.
fn tube_cameras() -> Vec<Camera> {
    let mut cameras: Vec<Camera> = [0.0, 0.37, 0.999]
        .into_iter()
        .map(|s| {
            let x = s * 1e6;
            camera([x + 2.0, 2.0, 2.0], [x, 0.0, 0.0], 1e-3)
        })
        .collect();
    cameras.push(camera([-4.0, 1.0, 0.5], [0.0, 0.0, 0.0], 1e-3));
    cameras
}

/// Writes `mesh` as an OFF file (the shortest decimal that reads back exactly) and
/// imports it back.
fn through_off_file(mesh: &InputMesh) -> ImportReport {
    use std::fmt::Write as _;
    let mut text = format!("OFF\n{} {} 0\n", mesh.positions.len(), mesh.triangles.len());
    for p in &mesh.positions {
        writeln!(text, "{:e} {:e} {:e}", p[0], p[1], p[2]).unwrap();
    }
    for t in &mesh.triangles {
        writeln!(text, "3 {} {} {}", t[0], t[1], t[2]).unwrap();
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("input.off");
    std::fs::write(&path, text).unwrap();
    load_mesh(&path).expect("import")
}

#[test]
fn degenerate_inputs_build_and_check_clean() {
    let ctx = gpu();
    let bunny = bunny();
    let around_bunny = orbits(&bunny, 1.7);
    // The bunny's coordinates snapped to 2^-26, so that midpoints are exact.
    let grid_bunny = snapped(bunny.clone());

    let (zero_area, added) = with_t_junctions(&grid_bunny, 97, 0.0);
    assert!(added.len() > 500);
    for t in &added {
        let [a, b, c] = t.map(|v| zero_area.positions[v as usize]);
        let (u, v) = (
            [0, 1, 2].map(|i| b[i] - a[i]),
            [0, 1, 2].map(|i| c[i] - a[i]),
        );
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        assert_eq!(n, [0.0; 3], "exactly zero area");
    }
    let (slivers, added) = with_t_junctions(&grid_bunny, 97, 1e-9);
    assert!(added.len() > 500);
    let needles = with_needles(&bunny, 97, 1e-9);
    assert!(needles.triangles.len() > bunny.triangles.len() + 1000);
    let duplicates = with_duplicates(&bunny, 100);
    let (seam, twins) = with_seam(&bunny);
    assert!(twins > 1000);
    let flat = flat_sheet(60);
    let single = InputMesh {
        positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        triangles: vec![[0, 1, 2]],
        ..Default::default()
    };
    let tube = tube();

    // The importer path: zero-area triangles, slivers, a flat model, a single triangle and the
    // tube come through a file unchanged (so the checks of the meshes below cover that path
    // too); duplicate triangles are dropped and coincident vertices welded, which gives back
    // the bunny.
    for mesh in [&zero_area, &slivers, &needles, &flat, &single, &tube] {
        assert!(through_off_file(mesh).mesh == *mesh);
    }
    let dropped = through_off_file(&duplicates);
    assert_eq!(dropped.duplicate_triangles, 100);
    let welded = through_off_file(&seam);
    assert_eq!(welded.welded_vertices, twins);
    assert!(dropped.mesh == bunny && welded.mesh == bunny);

    let cases: [(&str, &InputMesh, Surface, Vec<Camera>); 9] = [
        (
            "zero-area triangles",
            &zero_area,
            Surface::Closed,
            around_bunny.clone(),
        ),
        (
            "slivers (aspect 1e-9)",
            &slivers,
            Surface::Closed,
            around_bunny.clone(),
        ),
        (
            "needles (aspect 1e-9)",
            &needles,
            Surface::Closed,
            around_bunny.clone(),
        ),
        (
            "duplicate triangles",
            &duplicates,
            Surface::Closed,
            around_bunny.clone(),
        ),
        (
            "coincident vertices",
            &seam,
            Surface::Closed,
            around_bunny.clone(),
        ),
        (
            "through a file: cleaned",
            &welded.mesh,
            Surface::Closed,
            around_bunny.clone(),
        ),
        ("flat (z = 0)", &flat, Surface::Open, orbits(&flat, 1.5)),
        (
            "a single triangle",
            &single,
            Surface::Open,
            orbits(&single, 1.5),
        ),
        (
            "long thin (1e6 : 1)",
            &tube,
            Surface::Closed,
            tube_cameras(),
        ),
    ];
    for (name, mesh, surface, cameras) in &cases {
        check_input(&ctx, name, mesh, *surface, cameras);
    }

    // A triangle that uses one vertex twice cannot be stored (no strip holds it): refused at
    // the door with its index, instead of silently dropped.
    let mut repeated = single.clone();
    repeated.triangles.push([2, 0, 2]);
    match build_contents(&repeated, &BuildConfig::default(), &|_| {}) {
        Err(BuildError::RepeatedVertex { index, vertex }) => assert_eq!((index, vertex), (1, 2)),
        other => panic!("{:?}", other.map(|(_, s)| s)),
    }
}

/// A model spanning more than f32 can bound is refused with a clear error, not written with
/// infinite spheres.
#[test]
fn a_model_too_large_for_f32_bounds_is_refused() {
    let mesh = InputMesh {
        positions: vec![[0.0, 0.0, 0.0], [1e300, 0.0, 0.0], [0.0, 1.0, 0.0]],
        triangles: vec![[0, 1, 2]],
        ..Default::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge.tsr");
    let err = tessera_preprocess::build_repository(&mesh, &BuildConfig::default(), &path, &|_| {})
        .unwrap_err();
    assert!(err.to_string().contains("spans 1e300"), "{err}");
    assert!(!path.exists());
}
