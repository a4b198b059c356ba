//! One face rule for the patch cones and the rasteriser (issue 11, item 6): on an open scan
//! seen from behind, the picture depends on τ no more than seen from the front, in both face
//! modes. With cone culling on and back faces drawn (the old lit mode), the finest cut showed
//! holes where coarser cuts showed the back side: which patches the cones dropped depended on τ.

use std::collections::HashMap;

use tessera_core::repository::Repository;
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::BuildConfig;
use tessera_runtime::camera::{bounding_radius, Camera, Y_UP};
use tessera_runtime::geometric_check::decode_all_patches;
use tessera_runtime::gpu::{FrameRequest, GpuContext, Renderer, RendererOptions, ShadingMode};
use tessera_tests::{build, gpu, testdata};

const SIZE: (u32, u32) = (640, 360);

/// Edges used by one input triangle: the scan's borders (it must have some to be open).
fn border_edges(repo: &Repository) -> usize {
    let patches = decode_all_patches(repo).unwrap();
    let mut count: HashMap<(u32, u32), u32> = HashMap::new();
    for (i, t) in repo.tets().iter().enumerate() {
        if t.first_child == u32::MAX {
            for tri in &patches[i] {
                for k in 0..3 {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    *count.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
        }
    }
    count.values().filter(|&&n| n == 1).count()
}

/// The direction the scan faces: the leaves' normal-cone axes weighted by their triangles.
fn facing(repo: &Repository) -> [f64; 3] {
    let mut n = [0.0f64; 3];
    for t in repo.tets().iter().filter(|t| t.first_child == u32::MAX) {
        for (sum, axis) in n.iter_mut().zip(t.cone_axis) {
            *sum += axis as f64 * t.triangle_count as f64;
        }
    }
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    n.map(|x| x / l)
}

fn frame(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    camera: Camera,
    tau: f32,
    two_sided: bool,
) -> image::RgbaImage {
    let request = FrameRequest {
        mode: ShadingMode::Lit,
        ..FrameRequest::new(camera, tau)
    };
    let request = if two_sided {
        request.two_sided()
    } else {
        request
    };
    assert_eq!(request.cull.cones, !two_sided);
    assert!(request.cull.frustum.is_some());
    renderer
        .render_and_read(ctx, &request)
        .expect("frame read back")
        .image
}

fn differing(a: &image::RgbaImage, b: &image::RgbaImage) -> usize {
    a.pixels()
        .zip(b.pixels())
        .filter(|(p, q)| (0..3).any(|c| p.0[c].abs_diff(q.0[c]) > 8))
        .count()
}

#[test]
fn an_open_scan_looks_the_same_at_every_tolerance_from_behind_too() {
    let input = load_mesh(&testdata("mesh/lion-head.off")).expect("import");
    let built = build(&input.mesh, &BuildConfig::default());
    let repo = &built.repo;
    assert!(border_edges(repo) > 0, "the test needs an open scan");
    let h = repo.header();
    let centre = [0, 1, 2].map(|i| 0.5 * (h.bbox_min[i] + h.bbox_max[i]));
    let radius = bounding_radius(h.bbox_min, h.bbox_max);
    let n = facing(repo);
    let ctx = gpu();
    let options = RendererOptions {
        width: SIZE.0,
        height: SIZE.1,
        ..Default::default()
    };
    let mut renderer = Renderer::new(&ctx, repo, options).expect("renderer");
    let camera = |side: f64| {
        let eye = [0, 1, 2].map(|i| centre[i] + side * 2.2 * radius * n[i]);
        Camera {
            width: SIZE.0,
            height: SIZE.1,
            up: Y_UP,
            ..Camera::looking_at(eye, centre, radius)
        }
    };
    for two_sided in [false, true] {
        let mut diff = [0usize; 2];
        for (k, side) in [1.0, -1.0].into_iter().enumerate() {
            let fine = frame(&ctx, &mut renderer, camera(side), 1e-6, two_sided);
            let coarse = frame(&ctx, &mut renderer, camera(side), 0.5, two_sided);
            diff[k] = differing(&fine, &coarse);
        }
        eprintln!(
            "two-sided {two_sided}: pixels differing between tau 1e-6 and 0.5: front {}, \
             behind {} (frames {}x{})",
            diff[0], diff[1], SIZE.0, SIZE.1
        );
        assert!(
            diff[1] <= diff[0],
            "two-sided {two_sided}: seen from behind, tau changes {} pixels; from the front {}",
            diff[1],
            diff[0]
        );
    }
}
