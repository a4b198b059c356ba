//! A frozen cut seen from elsewhere (`FrameRequest::draw_camera`, issue 14): the traversal,
//! culling and streaming follow `camera`, the drawing follows `draw_camera`. On lavapipe: a
//! draw camera equal to the camera draws the plain frame byte for byte; another one draws
//! exactly the camera's selection, in a picture that is neither the camera's frame nor the
//! draw camera's own; the streaming renderer loads nothing for the draw camera and draws what
//! the fully resident one draws.

use std::sync::Arc;

use tessera_core::repository::format::Header;
use tessera_core::repository::Repository;
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::BuildConfig;
use tessera_runtime::camera::{Camera, Y_UP};
use tessera_runtime::gpu::frame::FrameUniforms;
use tessera_runtime::gpu::{
    Frame, FrameRequest, GpuContext, GpuStreamer, Readback, Renderer, RendererOptions, ShadingMode,
};
use tessera_tests::{build, gpu, testdata};

const TAU: f32 = 1.0;
const SIZE: (u32, u32) = (320, 240);

fn options(budget_bytes: u64) -> RendererOptions {
    RendererOptions {
        width: SIZE.0,
        height: SIZE.1,
        budget_bytes,
        ..Default::default()
    }
}

fn orbit(h: &Header, azimuth: f64, elevation: f64, distance: f64) -> Camera {
    Camera {
        width: SIZE.0,
        height: SIZE.1,
        ..Camera::orbit(h.bbox_min, h.bbox_max, Y_UP, azimuth, elevation, distance)
    }
}

/// The cut's camera, close in, and the one it is inspected from: 90° around, further away.
fn cameras(h: &Header) -> (Camera, Camera) {
    (orbit(h, 30.0, 20.0, 1.4), orbit(h, 120.0, 25.0, 2.6))
}

fn request(camera: Camera, draw_camera: Option<Camera>, mode: ShadingMode) -> FrameRequest {
    FrameRequest {
        mode,
        draw_camera,
        ..FrameRequest::new(camera, TAU)
    }
}

fn covered(f: &Frame) -> usize {
    let background = *f.image.get_pixel(0, 0);
    f.image.pixels().filter(|&&p| p != background).count()
}

/// The uniforms: the traversal's rows from the camera, the drawing's from the draw camera, and
/// the same camera twice gives the plain uniforms.
#[test]
fn uniforms_split_between_the_two_cameras() {
    let header = Header {
        origin: [10.0, -3.0, 2.5],
        bbox_min: [9.0, -4.0, 1.5],
        bbox_max: [11.0, -2.0, 3.5],
        position_step: [1.0 / 4096.0; 3],
        ..bytemuck::Zeroable::zeroed()
    };
    let (camera, draw) = cameras(&header);
    let cull = FrameRequest::new(camera, TAU).cull;
    let new =
        |c: &Camera, d: &Camera| FrameUniforms::new(c, d, &header, TAU, &cull, ShadingMode::Lit, 7);
    let plain = new(&camera, &camera);
    let seen = new(&draw, &draw);
    let frozen = new(&camera, &draw);
    assert_ne!(plain, seen);
    // Traversal.
    assert_eq!(frozen.eye_tau, plain.eye_tau);
    assert_eq!(frozen.planes, plain.planes);
    assert_eq!(frozen.forward_near, plain.forward_near);
    assert_eq!(frozen.metric, plain.metric);
    assert_eq!(frozen.counts, plain.counts);
    // Drawing.
    assert_eq!(frozen.view_proj, seen.view_proj);
    assert_eq!(frozen.eye_cell, seen.eye_cell);
    assert_eq!(frozen.eye_fraction, seen.eye_fraction);
    assert_eq!(frozen.step, seen.step);
    assert_eq!(frozen.light, seen.light);
    assert_eq!(frozen.eye_lattice(), seen.eye_lattice());
    let q = [5, -7, 11];
    assert_eq!(
        frozen.clip_of_lattice_point(q),
        seen.clip_of_lattice_point(q)
    );
    // `FrameRequest::drawn_from` picks the draw camera, else the camera.
    assert_eq!(
        request(camera, None, ShadingMode::Lit).drawn_from().eye,
        camera.eye
    );
    assert_eq!(
        request(camera, Some(draw), ShadingMode::Lit)
            .drawn_from()
            .eye,
        draw.eye
    );
}

/// The fully resident renderer: (a) `Some(camera)` is `None` byte for byte; (b) another draw
/// camera draws the camera's selection, and a picture unlike both plain frames.
#[test]
fn a_frozen_cut_draws_the_cameras_selection_from_the_draw_camera() {
    let input = load_mesh(&testdata("mesh/armadillo.off")).expect("import");
    let built = build(&input.mesh, &BuildConfig::default());
    let repo = &built.repo;
    let (camera, draw) = cameras(repo.header());
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx, repo, options(1 << 40)).expect("fits");
    let mut frame = |r: &FrameRequest| renderer.render_and_read(&ctx, r).expect("read back");

    for mode in [ShadingMode::Lit, ShadingMode::Patches, ShadingMode::Check] {
        let plain = frame(&request(camera, None, mode));
        let same = frame(&request(camera, Some(camera), mode));
        assert_eq!(same.selection, plain.selection, "{mode:?}");
        assert!(same.image == plain.image, "{mode:?}: the image differs");
        assert!(covered(&plain) > 0, "{mode:?}: nothing drawn");
    }

    let plain = frame(&request(camera, None, ShadingMode::Lit));
    let seen = frame(&request(draw, None, ShadingMode::Lit));
    let frozen = frame(&request(camera, Some(draw), ShadingMode::Lit));
    eprintln!(
        "selections: camera {}, draw camera {}, frozen {}; covered pixels: {} {} {}",
        plain.selection.len(),
        seen.selection.len(),
        frozen.selection.len(),
        covered(&plain),
        covered(&seen),
        covered(&frozen)
    );
    assert_ne!(
        seen.selection, plain.selection,
        "pick cameras whose cuts differ"
    );
    assert_eq!(frozen.selection, plain.selection, "the cut is not frozen");
    assert_eq!(frozen.triangles, plain.triangles);
    assert!(covered(&frozen) > 0, "the frozen cut is not in view");
    assert!(frozen.image != plain.image, "drawn from the camera");
    assert!(
        frozen.image != seen.image,
        "the draw camera's own cut was drawn"
    );
}

/// The smallest budget whose pool holds `pool` bytes at this file's renderer size.
fn budget_for_pool(ctx: &GpuContext, repo: &Repository, pool: u64) -> u64 {
    tessera_tests::budget_for_pool(ctx, repo, options, pool)
}

/// (c) Streaming: settled on the camera, frames drawn from the draw camera load nothing, draw
/// the settled selection, and equal the fully resident renderer's frozen frame under the same
/// `may_refine` flags.
#[test]
fn a_streamed_frozen_cut_loads_nothing_for_the_draw_camera() {
    let input = load_mesh(&testdata("mesh/armadillo.off")).expect("import");
    let built = build(&input.mesh, &BuildConfig::default());
    let repo = Arc::new(Repository::open(built.dir.path().join("model.tsr")).expect("reopen"));
    let (camera, draw) = cameras(repo.header());
    let ctx = gpu();
    let blob = tessera_tests::drawn_blob_bytes(&repo);
    let budget = budget_for_pool(&ctx, &repo, blob / 2);
    let (mut renderer, mut streamer) =
        GpuStreamer::new(&ctx, repo.clone(), options(budget), 256 << 10).expect("streamer");
    streamer.set_cpu_reference(true);
    let mut full = Renderer::new(&ctx, &repo, options(1 << 40)).expect("fits");
    let both = Readback {
        image: true,
        selection: true,
    };

    let plain = request(camera, None, ShadingMode::Lit);
    let mut settled = None;
    for _ in 0..200 {
        let f = streamer
            .frame(&ctx, &mut renderer, &plain, both)
            .expect("frame");
        if f.settled {
            settled = Some(renderer.read_selection(&ctx).expect("selection"));
            break;
        }
    }
    let settled = settled.expect("the stream settles within 200 frames");
    let loads_before = streamer.residency().stats();

    let frozen = request(camera, Some(draw), ShadingMode::Lit);
    for i in 0..3 {
        let f = streamer
            .frame(&ctx, &mut renderer, &frozen, both)
            .expect("frame");
        assert!(f.settled, "frozen frame {i}: not settled");
        assert_eq!(f.loads, 0, "frozen frame {i}: the draw camera drove loads");
        let selection = renderer.read_selection(&ctx).expect("selection");
        assert_eq!(selection, settled, "frozen frame {i}: the cut moved");
        let image = renderer.read_image(&ctx).expect("image");
        full.set_may_refine(&ctx, &f.may_refine_words).unwrap();
        let reference = full.render_and_read(&ctx, &frozen).expect("read back");
        assert_eq!(reference.selection, selection, "frozen frame {i}");
        assert!(
            reference.image == image,
            "frozen frame {i}: the image differs from the fully resident one"
        );
        let background = *image.get_pixel(0, 0);
        assert!(image.pixels().any(|&p| p != background), "nothing drawn");
    }
    assert_eq!(
        streamer.residency().stats(),
        loads_before,
        "the residency changed"
    );
}
