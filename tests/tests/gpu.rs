//! The GPU runtime on lavapipe (issue 3, "Must show"): the pixel crack check on closed scans,
//! the GPU traversal selecting exactly what the CPU reference selects, and a model far from
//! the origin rendering the same cut.

use tessera_core::cull::CullTests;
use tessera_core::cut::{diamond_rhos, select_visible};
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::{BuildConfig, InputMesh};
use tessera_runtime::camera::{bounding_radius, Camera, Y_UP};
use tessera_runtime::gpu::{FrameRequest, Readback, Renderer, RendererOptions, ShadingMode};
use tessera_runtime::pixel_check::{check_pixels, PixelCheckConfig};
use tessera_tests::{build, gpu, testdata};

fn scan(file: &str) -> InputMesh {
    load_mesh(&testdata(file)).expect("import").mesh
}

/// 32 views from outside × τ = 0.5, 1, 2, 4, 8 px at 1920 × 1080: no flag pixel, and every
/// frame's GPU selection equals the CPU reference.
fn check_closed_scan(file: &str) {
    let built = build(&scan(file), &BuildConfig::default());
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx, &built.repo, RendererOptions::default()).unwrap();
    let config = PixelCheckConfig::default();
    assert!(config.views >= 32 && config.tolerances == [0.5, 1.0, 2.0, 4.0, 8.0]);
    let report =
        check_pixels(&ctx, &mut renderer, &built.repo, &config).expect("the GPU device works");
    eprintln!("{file}: {report:?}");
    assert_eq!(report.frames, 160);
    assert_eq!(
        report.flag_pixels, 0,
        "{file}: cracks seen in {:?}",
        report.worst
    );
    assert_eq!(report.selection_mismatches, 0, "{file}");
    // The frames saw the model: at least 1% of the pixels on average.
    assert!(
        report.covered_pixels > 160 * 1920 * 1080 / 100,
        "{report:?}"
    );
}

#[test]
fn bunny_shows_no_crack_on_the_gpu() {
    check_closed_scan("mesh/bunny00.off");
}

#[test]
fn armadillo_shows_no_crack_on_the_gpu() {
    check_closed_scan("mesh/armadillo.off");
}

/// A tiny deterministic generator (tests must not depend on a random crate's stream).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// 120 random cameras (inside and around the model, any direction) and tolerances, culling on:
/// the GPU draws exactly the simplices the CPU reference selects.
#[test]
fn gpu_selection_equals_cpu_selection() {
    let built = build(&scan("mesh/armadillo.off"), &BuildConfig::default());
    let repo = &built.repo;
    let h = *repo.header();
    let ctx = gpu();
    let mut renderer = Renderer::new(
        &ctx,
        repo,
        RendererOptions {
            width: 320,
            height: 240,
            ..Default::default()
        },
    )
    .unwrap();
    let centre = [0, 1, 2].map(|i| 0.5 * (h.bbox_min[i] + h.bbox_max[i]));
    let radius = bounding_radius(h.bbox_min, h.bbox_max);
    let mut rng = Lcg(7);
    let (mut frames, mut drawn, mut cones_culled) = (0, 0, 0);
    for _ in 0..120 {
        let mut point = || {
            let d = 0.1 + 4.0 * rng.next();
            let v = [rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5];
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-9);
            [0, 1, 2].map(|i| centre[i] + v[i] / l * d * radius)
        };
        let (eye, target) = (point(), point());
        if eye == target {
            continue;
        }
        let camera = Camera {
            up: Y_UP,
            fov_y_degrees: 20.0 + 80.0 * rng.next(),
            width: 320,
            height: 240,
            ..Camera::looking_at(eye, target, radius)
        };
        let tau = (0.25 * 64f64.powf(rng.next())) as f32;
        let request = FrameRequest::new(camera, tau);
        renderer.render(
            &ctx,
            &request,
            Readback {
                image: false,
                selection: true,
            },
        );
        let gpu = renderer.read_selection(&ctx).expect("selection read back");
        let eye_local = camera.eye_local(h.origin);
        let rhos = diamond_rhos(repo.diamonds(), eye_local, &camera.metric());
        let mut cpu = select_visible(repo.tets(), &rhos, tau, eye_local, &request.cull);
        cpu.retain(|&i| repo.tets()[i as usize].strip_index_count > 0);
        assert_eq!(gpu, cpu, "eye {eye:?} target {target:?} τ {tau}");
        let unculled = select_visible(repo.tets(), &rhos, tau, eye_local, &CullTests::NONE).len();
        let frustum_only = select_visible(
            repo.tets(),
            &rhos,
            tau,
            eye_local,
            &CullTests {
                cones: false,
                ..request.cull
            },
        )
        .len();
        cones_culled += frustum_only - cpu.len().min(frustum_only);
        frames += 1;
        drawn += gpu.len();
        assert!(cpu.len() <= unculled);
    }
    assert!(frames >= 100);
    assert!(drawn > 0, "the cameras saw something");
    assert!(cones_culled > 0, "back-face culling was exercised");
}

/// Rounds to a multiple of 2^-29: adding 1e7 (< 2^24) to such a number is exact in f64.
fn snap(x: f64) -> f64 {
    (x * (1u64 << 29) as f64).round() / (1u64 << 29) as f64
}

/// The bunny translated by 1e7 along every axis, seen from the same relative cameras: the same
/// simplices are drawn, and the pixel check is clean. The translation is exact (coordinates
/// on a 2^-29 grid, 1/50 of the quantisation step), so the build, which works relative to the
/// model's own origin, makes the same hierarchy, patches, errors and spheres; only the
/// header's placement moves.
#[test]
fn a_model_far_from_the_origin_renders_the_same_cut() {
    const OFFSET: f64 = 1e7;
    let mut near = scan("mesh/bunny00.off");
    for p in &mut near.positions {
        *p = p.map(snap);
    }
    let mut far = near.clone();
    for p in &mut far.positions {
        *p = p.map(|x| x + OFFSET);
    }
    let a = build(&near, &BuildConfig::default());
    let b = build(&far, &BuildConfig::default());
    assert_eq!(
        a.repo.tets(),
        b.repo.tets(),
        "same simplices, patches and spheres"
    );
    assert_eq!(a.repo.diamonds(), b.repo.diamonds(), "same errors");
    assert_eq!(
        b.repo.header().origin,
        a.repo.header().origin.map(|x| x + OFFSET)
    );
    let ctx = gpu();
    let options = RendererOptions {
        width: 640,
        height: 360,
        ..Default::default()
    };
    let mut ra = Renderer::new(&ctx, &a.repo, options).unwrap();
    let mut rb = Renderer::new(&ctx, &b.repo, options).unwrap();
    let h = *a.repo.header();
    let mut frames = 0;
    for az in [0.0, 70.0, 140.0, 210.0, 280.0] {
        let orbit = Camera::orbit(h.bbox_min, h.bbox_max, Y_UP, az, 15.0, 1.7);
        let near_camera = Camera {
            eye: orbit.eye.map(snap),
            target: orbit.target.map(snap),
            width: 640,
            height: 360,
            ..orbit
        };
        let far_camera = Camera {
            eye: near_camera.eye.map(|x| x + OFFSET),
            target: near_camera.target.map(|x| x + OFFSET),
            ..near_camera
        };
        for tau in [0.5, 2.0, 8.0] {
            let selection = |renderer: &mut Renderer, camera: Camera| {
                renderer.render(
                    &ctx,
                    &FrameRequest::new(camera, tau),
                    Readback {
                        image: false,
                        selection: true,
                    },
                );
                renderer.read_selection(&ctx).expect("selection read back")
            };
            let sa = selection(&mut ra, near_camera);
            assert!(!sa.is_empty());
            assert_eq!(sa, selection(&mut rb, far_camera), "az {az} τ {tau}");
            frames += 1;
        }
    }
    assert_eq!(frames, 15);
    let report = check_pixels(
        &ctx,
        &mut rb,
        &b.repo,
        &PixelCheckConfig {
            views: 16,
            ..Default::default()
        },
    )
    .expect("the GPU device works");
    assert!(report.is_clean(), "{report:?}");
    assert!(report.covered_pixels > 0);
}

/// Every shading mode draws the model, and they differ.
#[test]
fn shading_modes_draw_the_model() {
    let built = build(&scan("mesh/bunny00.off"), &BuildConfig::default());
    let h = *built.repo.header();
    let ctx = gpu();
    let mut renderer = Renderer::new(
        &ctx,
        &built.repo,
        RendererOptions {
            width: 256,
            height: 256,
            ..Default::default()
        },
    )
    .unwrap();
    let camera = Camera {
        width: 256,
        height: 256,
        ..Camera::orbit(h.bbox_min, h.bbox_max, Y_UP, 30.0, 20.0, 1.6)
    };
    let mut images = Vec::new();
    for mode in [
        ShadingMode::Lit,
        ShadingMode::Patches,
        ShadingMode::Levels,
        ShadingMode::Check,
    ] {
        for wireframe in [false, true] {
            let request = FrameRequest {
                mode,
                wireframe,
                ..FrameRequest::new(camera, 1.0)
            };
            renderer.render(
                &ctx,
                &request,
                Readback {
                    image: true,
                    selection: false,
                },
            );
            let image = renderer.read_image(&ctx).expect("image read back");
            let background = *image.get_pixel(0, 0);
            let covered = image.pixels().filter(|p| **p != background).count();
            assert!(covered > 256 * 256 / 10, "{mode:?}: {covered} pixels");
            images.push(image);
        }
    }
    // Every mode differs from every other; the wireframe changes the picture where the adapter
    // has line mode, except in the check mode, which draws no overlay.
    for i in 0..images.len() {
        for j in i + 1..images.len() {
            let same_mode = i / 2 == j / 2;
            let check_mode = i >= 6;
            if !same_mode || (ctx.capabilities.wireframe && !check_mode) {
                assert_ne!(images[i], images[j], "images {i} and {j}");
            } else if check_mode {
                assert_eq!(images[i], images[j], "the check draws no wireframe");
            }
        }
    }
}

#[test]
fn a_model_over_the_budget_is_refused_with_the_numbers() {
    let built = build(&scan("mesh/bunny00.off"), &BuildConfig::default());
    let ctx = gpu();
    let err = Renderer::new(
        &ctx,
        &built.repo,
        RendererOptions {
            budget_bytes: 100_000,
            ..Default::default()
        },
    )
    .err()
    .expect("1.5 MB of patches do not fit in 100 kB");
    let message = err.to_string();
    assert!(
        message.contains("MiB")
            && message.contains("budget")
            && message.contains("which stream it"),
        "{message}"
    );
}

/// Back-face culling by normal cone drops only patches whose every face points away: the
/// lit picture is the same pixel for pixel with and without it, from every side.
#[test]
fn cone_culling_never_changes_the_picture() {
    let built = build(&scan("mesh/armadillo.off"), &BuildConfig::default());
    let h = *built.repo.header();
    let ctx = gpu();
    let options = RendererOptions {
        width: 640,
        height: 360,
        ..Default::default()
    };
    let mut renderer = Renderer::new(&ctx, &built.repo, options).unwrap();
    let mut culled_somewhere = false;
    for az in [0.0, 60.0, 120.0, 180.0, 240.0, 300.0] {
        let camera = Camera {
            width: 640,
            height: 360,
            ..Camera::orbit(h.bbox_min, h.bbox_max, Y_UP, az, 25.0, 1.4)
        };
        let mut frames = Vec::new();
        for cones in [false, true] {
            let request = FrameRequest {
                cull: CullTests {
                    frustum: Some(camera.view_volume()),
                    cones,
                },
                ..FrameRequest::new(camera, 1.0)
            };
            renderer.render(
                &ctx,
                &request,
                Readback {
                    image: true,
                    selection: true,
                },
            );
            frames.push((
                renderer.read_image(&ctx).expect("image read back"),
                renderer.read_selection(&ctx).expect("selection read back"),
            ));
        }
        assert_eq!(
            frames[0].0, frames[1].0,
            "az {az}: cone culling changed pixels"
        );
        culled_somewhere |= frames[1].1.len() < frames[0].1.len();
    }
    assert!(culled_somewhere, "the cones culled some patch");
}
