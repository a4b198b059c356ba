//! The unlit modes (issue 47, item 5): `ShadingMode::Color` draws the stored per-vertex colours
//! exactly (`ALBEDO_GREY` on a model without colours) and `ShadingMode::Normals` the normal as
//! n × 0.5 + 0.5: on a unit sphere whose stored normals are its radii, every pixel's colour
//! decodes to the sphere's normal where the pixel's ray meets it; `NormalsFaces` (`--flat`)
//! to the facet's normal, close to it and constant over each facet.

use tessera_preprocess::procedural::demo_mesh;
use tessera_preprocess::{BuildConfig, Construction, InputMesh};
use tessera_runtime::camera::{Camera, Y_UP};
use tessera_runtime::gpu::target::BACKGROUND_RGBA8;
use tessera_runtime::gpu::{
    FrameRequest, GpuContext, Readback, Renderer, RendererOptions, ShadingMode, ALBEDO_GREY,
};
use tessera_tests::{build, gpu};

const SIZE: u32 = 200;

/// The frame of `mesh` (leaf patches of 64 triangles) in `mode` at τ from the orbit 30,20,2.5,
/// drawn indexed and by vertex pulling (a page's index region of one slot): the two frames
/// must be equal. Returns the frame and its camera.
fn frame(
    ctx: &GpuContext,
    mesh: &InputMesh,
    mode: ShadingMode,
    tau: f32,
) -> (image::RgbaImage, Camera) {
    let config = BuildConfig {
        construction: Construction::LeafTriangles(64),
        ..Default::default()
    };
    let built = build(mesh, &config);
    let h = *built.repo.header();
    let camera = Camera {
        width: SIZE,
        height: SIZE,
        ..Camera::orbit(h.bbox_min, h.bbox_max, Y_UP, 30.0, 20.0, 2.5)
    };
    let mut frames = Vec::new();
    for index_slots in [None, Some(1)] {
        let options = RendererOptions {
            width: SIZE,
            height: SIZE,
            index_slots,
            ..Default::default()
        };
        let mut renderer = Renderer::new(ctx, &built.repo, options).unwrap();
        let request = FrameRequest {
            mode,
            ..FrameRequest::new(camera, tau)
        };
        let readback = Readback {
            image: true,
            selection: false,
        };
        renderer.render(ctx, &request, readback);
        frames.push(renderer.read_image(ctx).unwrap());
        ctx.check().unwrap();
    }
    assert!(
        frames[0] == frames[1],
        "{mode:?}: the indexed and pulled draws differ"
    );
    (frames.pop().unwrap(), camera)
}

/// The pixels that are not the background, with their coordinates.
fn model_pixels(image: &image::RgbaImage) -> Vec<(u32, u32, [u8; 4])> {
    let out: Vec<_> = image
        .enumerate_pixels()
        .filter(|(_, _, p)| p.0 != BACKGROUND_RGBA8)
        .map(|(x, y, p)| (x, y, p.0))
        .collect();
    assert!(out.len() > 4000, "{} model pixels", out.len());
    out
}

#[test]
fn color_mode_draws_the_stored_colours_unlit() {
    let ctx = gpu();
    // One colour everywhere: exactly that colour on every model pixel, lit mode shades it.
    let mut mesh = demo_mesh(3);
    let colour = [200, 60, 30, 255];
    mesh.colors = Some(vec![colour; mesh.positions.len()]);
    let (image, _) = frame(&ctx, &mesh, ShadingMode::Color, 1.0);
    for (x, y, p) in model_pixels(&image) {
        assert_eq!(p, colour, "pixel ({x}, {y})");
    }
    let (lit, _) = frame(&ctx, &mesh, ShadingMode::Lit, 1.0);
    let shaded = model_pixels(&lit)
        .iter()
        .filter(|(_, _, p)| *p != colour)
        .count();
    assert!(
        shaded * 2 > model_pixels(&lit).len(),
        "lit mode shades the colour"
    );

    // Red above y = 0, blue below: every pixel is red and blue interpolated (green 0, red and
    // blue summing to 255 but for rounding), both pure colours shown.
    let positions = mesh.positions.clone();
    mesh.colors = Some(
        positions
            .iter()
            .map(|p| {
                if p[1] > 0.0 {
                    [255, 0, 0, 255]
                } else {
                    [0, 0, 255, 255]
                }
            })
            .collect(),
    );
    let (image, _) = frame(&ctx, &mesh, ShadingMode::Color, 1.0);
    let pixels = model_pixels(&image);
    for &(x, y, p) in &pixels {
        let sum = p[0] as i32 + p[2] as i32;
        assert!(
            p[1] == 0 && (254..=256).contains(&sum),
            "pixel ({x}, {y}): {p:?}"
        );
    }
    for pure in [[255, 0, 0, 255], [0, 0, 255, 255]] {
        let n = pixels.iter().filter(|(_, _, p)| *p == pure).count();
        assert!(n * 10 > pixels.len(), "{n} pixels of {pure:?}");
    }

    // No colours: the neutral grey.
    mesh.colors = None;
    let (image, _) = frame(&ctx, &mesh, ShadingMode::Color, 1.0);
    for (x, y, p) in model_pixels(&image) {
        assert_eq!(p, ALBEDO_GREY, "pixel ({x}, {y})");
    }
}

/// The unit sphere (the demo's icosphere before its relief), its stored normals the radii.
fn unit_sphere(subdivisions: u32) -> InputMesh {
    let mut mesh = demo_mesh(subdivisions);
    for p in &mut mesh.positions {
        let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        *p = p.map(|x| x / l);
    }
    mesh.normals = Some(mesh.positions.iter().map(|p| p.map(|x| x as f32)).collect());
    mesh
}

/// The unit normal of the unit sphere where the ray through pixel (x, y) meets it first, and
/// the cosine of its angle with the ray; `None` where the ray misses it.
fn sphere_normal(camera: &Camera, x: u32, y: u32) -> Option<([f64; 3], f64)> {
    let b = camera.basis();
    let tan_y = (0.5 * camera.fov_y_degrees.to_radians()).tan();
    let nx = 2.0 * (x as f64 + 0.5) / camera.width as f64 - 1.0;
    let ny = 1.0 - 2.0 * (y as f64 + 0.5) / camera.height as f64;
    let aspect = camera.width as f64 / camera.height as f64;
    let d =
        [0, 1, 2].map(|i| b.forward[i] + nx * tan_y * aspect * b.right[i] + ny * tan_y * b.up[i]);
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let d = d.map(|v| v / l);
    let e = camera.eye;
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    // |e + t d|² = 1.
    let (half_b, c) = (dot(e, d), dot(e, e) - 1.0);
    let disc = half_b * half_b - c;
    if disc < 0.0 {
        return None;
    }
    let t = -half_b - disc.sqrt();
    let n = [0, 1, 2].map(|i| e[i] + t * d[i]);
    Some((n, -dot(n, d)))
}

/// Largest angle (degrees) between each model pixel's decoded normal and the sphere's, over
/// the pixels whose ray meets the sphere at least 30° from grazing (the rim's pixels may show
/// the polyhedron where the sphere is missed); and the pixels compared.
fn worst_angle(image: &image::RgbaImage, camera: &Camera) -> (f64, usize) {
    let (mut worst, mut compared) = (0.0f64, 0);
    for (x, y, p) in model_pixels(image) {
        let Some((want, cos)) = sphere_normal(camera, x, y) else {
            continue;
        };
        if cos < 0.5 {
            continue;
        }
        let got = [0, 1, 2].map(|i| p[i] as f64 / 255.0 * 2.0 - 1.0);
        let l = (got[0] * got[0] + got[1] * got[1] + got[2] * got[2]).sqrt();
        assert!((l - 1.0).abs() < 0.02, "pixel ({x}, {y}) {p:?}: |n| = {l}");
        let c = (0..3).map(|i| got[i] * want[i]).sum::<f64>() / l;
        worst = worst.max(c.clamp(-1.0, 1.0).acos().to_degrees());
        compared += 1;
    }
    (worst, compared)
}

#[test]
fn normals_mode_draws_a_spheres_normals() {
    let ctx = gpu();
    let sphere = unit_sphere(4);
    // The leaves (τ = 1e-6): 5,120 triangles, edges of about 4°.
    let (smooth, camera) = frame(&ctx, &sphere, ShadingMode::Normals, 1e-6);
    let (flat, _) = frame(&ctx, &sphere, ShadingMode::NormalsFaces, 1e-6);
    let (smooth_worst, compared) = worst_angle(&smooth, &camera);
    let (flat_worst, _) = worst_angle(&flat, &camera);
    eprintln!("{compared} pixels: stored normals within {smooth_worst}°, faces {flat_worst}°");
    assert!(compared > 3000, "{compared} pixels compared");
    // Interpolated radii within the colour's 8-bit rounding (about 0.5°) of the sphere's
    // normal; facets within their own size.
    assert!(smooth_worst < 1.0, "stored normals {smooth_worst}° off");
    assert!(flat_worst < 4.0, "face normals {flat_worst}° off");
    assert!(flat_worst > smooth_worst + 0.5, "--flat shows the facets");
    // Face normals are constant over a facet: far fewer distinct colours.
    let distinct = |image: &image::RgbaImage| {
        let mut c: Vec<[u8; 4]> = model_pixels(image).iter().map(|p| p.2).collect();
        c.sort_unstable();
        c.dedup();
        c.len()
    };
    assert!(
        distinct(&flat) * 3 < distinct(&smooth),
        "{} vs {}",
        distinct(&flat),
        distinct(&smooth)
    );

    // Without stored normals, the normals mode draws the face normals.
    let mut plain = sphere.clone();
    plain.normals = None;
    let (faces, _) = frame(&ctx, &plain, ShadingMode::Normals, 1e-6);
    let (faces_worst, _) = worst_angle(&faces, &camera);
    assert!(faces_worst < 4.0, "face normals {faces_worst}° off");
}
