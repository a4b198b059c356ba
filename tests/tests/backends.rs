//! The renderer draws the same picture on every wgpu backend this machine has (issue 11): the
//! same view of a closed scan and of a terrain through wgpu's Vulkan backend (lavapipe) and
//! its GL backend (llvmpipe through EGL), and the pixel crack check clean on GL. Before the
//! compacted non-indexed draw, GL drew strips without primitive restart: 11 dB on a closed
//! scan, 15–21 dB on terrains.
//!
//! Both backends must be present: a missing one fails with what to install (CI installs
//! `mesa-vulkan-drivers` and `libegl1 libegl-mesa0`), it never passes silently.

use tessera_core::repository::reader::Repository;
use tessera_preprocess::dem::{load_dem, DemOptions, TerrainOptions};
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::{BuildConfig, Domain};
use tessera_runtime::camera::{Camera, Y_UP, Z_UP};
use tessera_runtime::gpu::{
    Backend, FrameRequest, GpuContext, Renderer, RendererOptions, ShadingMode,
};
use tessera_runtime::pixel_check::{check_pixels, PixelCheckConfig};
use tessera_tests::{build, gpu_on, testdata, Built};

const WIDTH: u32 = 640;
const HEIGHT: u32 = 360;

/// One lit frame of `repo` at τ = 1 px from `camera`: the image and the selection.
fn frame(ctx: &GpuContext, repo: &Repository, camera: Camera) -> (image::RgbaImage, Vec<u32>) {
    frame_with(ctx, repo, camera, None)
}

/// `frame` with at most `index_slots` strip slots per page in the index buffer.
fn frame_with(
    ctx: &GpuContext,
    repo: &Repository,
    camera: Camera,
    index_slots: Option<u64>,
) -> (image::RgbaImage, Vec<u32>) {
    let options = RendererOptions {
        width: WIDTH,
        height: HEIGHT,
        index_slots,
        ..Default::default()
    };
    let mut renderer = Renderer::new(ctx, repo, options).expect("the model fits the GPU budget");
    let request = FrameRequest {
        mode: ShadingMode::Lit,
        ..FrameRequest::new(camera, 1.0)
    };
    let f = renderer
        .render_and_read(ctx, &request)
        .expect("frame read back");
    (f.image, f.selection)
}

/// The background colour of the lit frames, within a level of rounding.
fn is_background(p: &image::Rgba<u8>) -> bool {
    let b = tessera_runtime::gpu::target::BACKGROUND;
    let expected = [b.r, b.g, b.b].map(|c| c * 255.0);
    (0..3).all(|c| (p.0[c] as f64 - expected[c]).abs() <= 1.5)
}

/// PSNR (dB) of the RGB channels over the model's pixels (not background in either image),
/// and how many there are.
fn model_psnr(a: &image::RgbaImage, b: &image::RgbaImage) -> (f64, u64) {
    let (mut pixels, mut squared) = (0u64, 0u64);
    for (p, q) in a.pixels().zip(b.pixels()) {
        if is_background(p) && is_background(q) {
            continue;
        }
        pixels += 1;
        for c in 0..3 {
            let d = p.0[c].abs_diff(q.0[c]) as u64;
            squared += d * d;
        }
    }
    let mse = squared as f64 / (3 * pixels.max(1)) as f64;
    (
        tessera_runtime::measure::image_diff::psnr_of_mse(mse),
        pixels,
    )
}

/// Renders `built` from `camera` on Vulkan and on GL: the same selection, and a PSNR of at
/// least 30 dB over the model's pixels, which cover at least `min_share` of the frame.
fn same_picture_on_both_backends(name: &str, built: &Built, camera: Camera, min_share: f64) {
    let camera = Camera {
        width: WIDTH,
        height: HEIGHT,
        ..camera
    };
    let (vulkan, vulkan_selection) = frame(&gpu_on(Backend::Vulkan), &built.repo, camera);
    let (gl, gl_selection) = frame(&gpu_on(Backend::Gl), &built.repo, camera);
    assert_eq!(
        vulkan_selection, gl_selection,
        "{name}: the traversals differ"
    );
    let (psnr, pixels) = model_psnr(&vulkan, &gl);
    eprintln!("{name}: {psnr:.1} dB over {pixels} model pixels");
    assert!(
        pixels as f64 >= min_share * (WIDTH * HEIGHT) as f64,
        "{name}: the view shows only {pixels} model pixels"
    );
    assert!(
        psnr >= 30.0,
        "{name}: Vulkan and GL pictures differ: {psnr:.1} dB over {pixels} model pixels"
    );
}

#[test]
fn a_closed_scan_draws_the_same_on_vulkan_and_gl() {
    let mesh = load_mesh(&testdata("mesh/bunny00.off"))
        .expect("import")
        .mesh;
    let built = build(&mesh, &BuildConfig::default());
    let h = *built.repo.header();
    let camera = Camera::orbit(h.bbox_min, h.bbox_max, Y_UP, 30.0, 20.0, 2.0);
    same_picture_on_both_backends("bunny", &built, camera, 0.05);
}

#[test]
fn a_terrain_draws_the_same_on_vulkan_and_gl() {
    let grid = load_dem(
        &testdata("dem/jacksboro_fault_dem.npz"),
        &DemOptions::default(),
    )
    .expect("read the DEM");
    let mesh = grid.to_mesh(&TerrainOptions::default());
    let built = build(&mesh, &BuildConfig::for_domain(Domain::HeightField));
    let h = *built.repo.header();
    let camera = Camera::orbit(h.bbox_min, h.bbox_max, Z_UP, 30.0, 35.0, 1.6);
    same_picture_on_both_backends("Jacksboro", &built, camera, 0.2);
}

/// The pixel crack check (front faces grey, back faces flagged where no front face is) on the
/// GL backend: no flag pixel on the bunny, and the GPU selection equal to the CPU reference.
#[test]
fn the_pixel_check_is_clean_on_gl() {
    let mesh = load_mesh(&testdata("mesh/bunny00.off"))
        .expect("import")
        .mesh;
    let built = build(&mesh, &BuildConfig::default());
    let ctx = gpu_on(Backend::Gl);
    let options = RendererOptions {
        width: WIDTH,
        height: HEIGHT,
        ..Default::default()
    };
    let mut renderer = Renderer::new(&ctx, &built.repo, options).unwrap();
    let config = PixelCheckConfig {
        views: 16,
        ..Default::default()
    };
    let report =
        check_pixels(&ctx, &mut renderer, &built.repo, &config).expect("the GPU device works");
    eprintln!("bunny on GL: {report:?}");
    assert_eq!(report.frames, 16 * config.tolerances.len());
    assert_eq!(report.flag_pixels, 0, "cracks on GL: {:?}", report.worst);
    assert_eq!(report.selection_mismatches, 0);
    assert!(
        report.covered_pixels > report.frames as u64 * (WIDTH * HEIGHT) as u64 / 100,
        "{report:?}"
    );
}

/// A frame selecting more strip slots than the index buffer holds is drawn by vertex pulling:
/// the same picture as the indexed draw, on both backends.
#[test]
fn the_vertex_pulling_fallback_draws_the_indexed_picture() {
    let mesh = load_mesh(&testdata("mesh/bunny00.off"))
        .expect("import")
        .mesh;
    let built = build(&mesh, &BuildConfig::default());
    let h = *built.repo.header();
    let camera = Camera {
        width: WIDTH,
        height: HEIGHT,
        ..Camera::orbit(h.bbox_min, h.bbox_max, Y_UP, 120.0, 10.0, 2.0)
    };
    for backend in [Backend::Vulkan, Backend::Gl] {
        let ctx = gpu_on(backend);
        let (indexed, indexed_selection) = frame_with(&ctx, &built.repo, camera, None);
        let (pulled, pulled_selection) = frame_with(&ctx, &built.repo, camera, Some(16));
        assert_eq!(indexed_selection, pulled_selection, "{backend}");
        let (psnr, pixels) = model_psnr(&indexed, &pulled);
        eprintln!("{backend}: indexed vs pulled {psnr:.1} dB over {pixels} model pixels");
        assert!(
            pixels > (WIDTH * HEIGHT / 20) as u64,
            "{backend}: {pixels} model pixels"
        );
        assert!(psnr >= 50.0, "{backend}: {psnr:.1} dB");
    }
}
