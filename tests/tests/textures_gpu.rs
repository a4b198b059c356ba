//! Texels streamed and drawn (issue 47, item 4): a flat model with texture coordinates seen
//! straight on, its textures given as pages (`MemoryPages`), on lavapipe and llvmpipe GL.
//! The view spans the model's [0, 1]² exactly, so pixel (x, y) sees model point
//! ((x + ½) / SIZE, 1 − (y + ½) / SIZE) and the expected texel is known on the CPU.

use std::sync::Arc;

use tessera_core::texture::{Band, TextureShape, Wrap, NO_TEXTURE};
use tessera_preprocess::{BuildConfig, Construction, InputMesh};
use tessera_runtime::camera::{Camera, Y_UP};
use tessera_runtime::gpu::texture_cache::layers_for;
use tessera_runtime::gpu::texture_memory::MemoryPages;
use tessera_runtime::gpu::texture_pages::TextureLayout;
use tessera_runtime::gpu::{
    Backend, FrameRequest, GpuContext, PageSource, PoolFormat, Renderer, RendererOptions,
    ShadingMode,
};
use tessera_tests::{build, gpu_on, Built};

const SIZE: u32 = 256;
/// Texels a side of the constant-colour blocks the test textures are made of.
const BLOCK: u32 = 16;
const BACKENDS: [Backend; 2] = [Backend::Vulkan, Backend::Gl];

/// A square `[x0, x1] × [y0, y1]` of `n × n` quads at z = 0, counter-clockwise seen from +z,
/// each vertex's (shifted) texture coordinate `uv(x, y)`, appended to `mesh`.
fn square(
    mesh: &mut InputMesh,
    [x0, x1, y0, y1]: [f64; 4],
    n: u32,
    uv: impl Fn(f64, f64) -> [f32; 2],
) {
    let first = mesh.positions.len() as u32;
    let uvs = mesh.uvs.get_or_insert_with(Vec::new);
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (
                x0 + (x1 - x0) * i as f64 / n as f64,
                y0 + (y1 - y0) * j as f64 / n as f64,
            );
            mesh.positions.push([x, y, 0.0]);
            uvs.push(uv(x, y));
        }
    }
    let at = |i: u32, j: u32| first + j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            mesh.triangles
                .push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            mesh.triangles
                .push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
}

/// The view's square [0, 1]² with texture coordinates (x, 1 − y): one texel a pixel for a
/// 256² texture; built.
fn straight_square() -> Built {
    let mut mesh = InputMesh::default();
    square(&mut mesh, [0.0, 1.0, 0.0, 1.0], 16, |x, y| {
        [x as f32, (1.0 - y) as f32]
    });
    built(&mesh)
}

/// The band `[0, 1)` naming texture 0, unshifted.
const BAND_0: Band = Band {
    start: 0,
    span: 1,
    shift: 0,
    texture: 0,
};

fn built(mesh: &InputMesh) -> Built {
    let config = BuildConfig {
        construction: Construction::LeafTriangles(256),
        ..Default::default()
    };
    build(mesh, &config)
}

/// The colour of block (bx, by) of texture `seed`: distinct, opaque.
fn block_colour(seed: u32, bx: u32, by: u32) -> [u8; 4] {
    let mut h = (bx * 73_856_093) ^ (by * 19_349_663) ^ (seed * 83_492_791);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    [
        (h & 0xff) as u8,
        (h >> 8 & 0xff) as u8,
        (h >> 16 & 0xff) as u8,
        255,
    ]
}

/// A `side × side` texture of BLOCK-texel blocks.
fn blocks(seed: u32, side: u32, wrap: Wrap) -> (TextureShape, Vec<u8>) {
    let shape = TextureShape::new(side, side, wrap, wrap).unwrap();
    let texels = (0..side)
        .flat_map(|y| (0..side).flat_map(move |x| block_colour(seed, x / BLOCK, y / BLOCK)))
        .collect();
    (shape, texels)
}

/// Straight down on [0, 1]², the view exactly that square.
fn camera() -> Camera {
    let d = 0.5 / 30f64.to_radians().tan();
    Camera {
        width: SIZE,
        height: SIZE,
        up: Y_UP,
        near: 1e-3,
        ..Camera::looking_at([0.5, 0.5, d], [0.5, 0.5, 0.0], 1.0)
    }
}

fn request(mode: ShadingMode) -> FrameRequest {
    FrameRequest {
        mode,
        ..FrameRequest::new(camera(), 0.5)
    }
}

/// The model point a pixel sees.
fn point(x: u32, y: u32) -> (f64, f64) {
    (
        (x as f64 + 0.5) / SIZE as f64,
        1.0 - (y as f64 + 0.5) / SIZE as f64,
    )
}

fn renderer(
    ctx: &GpuContext,
    built: &Built,
    pages: Option<(Arc<dyn PageSource>, Option<u32>)>,
) -> Renderer {
    let options = RendererOptions {
        width: SIZE,
        height: SIZE,
        ..Default::default()
    };
    let mut renderer = Renderer::new(ctx, &built.repo, options).unwrap();
    if let Some((source, layers)) = pages {
        let layout = TextureLayout::new(source.shapes(), source.bands()).unwrap();
        let format = PoolFormat::for_pages(ctx, source.encoding());
        let layers =
            layers.unwrap_or_else(|| layers_for(ctx, &layout, None, format, (SIZE, SIZE)).unwrap());
        renderer.set_textures(ctx, source, layers).unwrap();
    }
    renderer
}

/// The settled frame of `request`; it must settle within 8 steps.
fn settled(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    request: &FrameRequest,
) -> (image::RgbaImage, u32) {
    let (frame, settled) = renderer.render_settled(ctx, request, 8).unwrap();
    assert!(settled.settled, "{settled:?}");
    (frame.image, settled.steps)
}

/// The expected texel of the texture coordinate `(u, v)` of a `blocks(seed, side, wrap)`
/// texture, if it is at least 3 texels from a block edge (filtering and sub-texel placement
/// then cannot reach another block).
fn expected(seed: u32, side: u32, wrap: Wrap, u: f64, v: f64) -> Option<[u8; 4]> {
    let texel = |t: f64| {
        let p = t * side as f64;
        let inner =
            (p.rem_euclid(BLOCK as f64) - BLOCK as f64 / 2.0).abs() <= BLOCK as f64 / 2.0 - 3.0;
        let i = wrap.texel(p.floor() as i64, side);
        // Clamped coordinates outside the texture repeat the edge texel: no block edge there.
        let clamped = wrap == Wrap::Clamp && !(0.0..side as f64).contains(&p);
        (inner || clamped).then_some(i)
    };
    Some(block_colour(seed, texel(u)? / BLOCK, texel(v)? / BLOCK))
}

fn close(a: [u8; 4], b: [u8; 4], tolerance: u8) -> bool {
    (0..3).all(|c| a[c].abs_diff(b[c]) <= tolerance)
}

/// Checks every pixel whose expectation `expect` gives; returns how many.
fn check_texels(
    image: &image::RgbaImage,
    what: &str,
    expect: impl Fn(f64, f64) -> Option<[u8; 4]>,
) -> usize {
    let mut checked = 0;
    for (x, y, pixel) in image.enumerate_pixels() {
        let (mx, my) = point(x, y);
        let Some(want) = expect(mx, my) else { continue };
        assert!(
            close(pixel.0, want, 3),
            "{what}: pixel ({x}, {y}) is {:?}, the texel {want:?}",
            pixel.0
        );
        checked += 1;
    }
    checked
}

/// (a) A 256² texture over the view, one texel a pixel: every pixel inside a block draws its
/// block's colour (color mode, unlit), and the lit mode draws the same texels times one
/// shading factor (a flat model: face normal and light constant).
#[test]
fn one_texel_a_pixel_draws_the_texels() {
    let built = straight_square();
    let texture = blocks(1, 256, Wrap::Repeat);
    let pages: Arc<dyn PageSource> = Arc::new(MemoryPages::new(&[texture], &[BAND_0]).unwrap());
    for backend in BACKENDS {
        let ctx = gpu_on(backend);
        let mut renderer = renderer(&ctx, &built, Some((pages.clone(), None)));
        let (colour, steps) = settled(&ctx, &mut renderer, &request(ShadingMode::Color));
        assert!(
            steps >= 2,
            "{backend:?}: the level-0 pages were loaded ({steps} steps)"
        );
        let what = format!("{backend:?} color");
        let checked = check_texels(&colour, &what, |x, y| {
            expected(1, 256, Wrap::Repeat, x, 1.0 - y)
        });
        assert!(checked > 10_000, "{what}: {checked} pixels checked");
        let (lit, _) = settled(&ctx, &mut renderer, &request(ShadingMode::Lit));
        let mut factors = Vec::new();
        for (x, y, p) in colour.enumerate_pixels() {
            let (mx, my) = point(x, y);
            if expected(1, 256, Wrap::Repeat, mx, 1.0 - my).is_some() && p[0] > 100 {
                factors.push(lit.get_pixel(x, y)[0] as f64 / p[0] as f64);
            }
        }
        let (low, high) = factors
            .iter()
            .fold((f64::MAX, 0f64), |(l, h), &f| (l.min(f), h.max(f)));
        assert!(
            factors.len() > 1000 && high - low < 0.03 && low > 0.2,
            "{backend:?} lit: factors {low}..{high}"
        );
        ctx.check().unwrap();
    }
}

/// (b) Two bands naming two textures in one draw: the left half repeats a 64² texture over
/// [−0.5, 1.5]², the right half clamps another over the same range (its band shifted by 3).
#[test]
fn repeat_and_clamp_in_two_bands() {
    let mut mesh = InputMesh::default();
    // Texture coordinate (u, v) of a model point of a half starting at x0: [−0.5, 1.5]².
    let tex = |x0: f64, x: f64, y: f64| ((x - x0) / 0.45 * 2.0 - 0.5, (1.0 - y) * 2.0 - 0.5);
    square(&mut mesh, [0.0, 0.45, 0.0, 1.0], 16, |x, y| {
        let (u, v) = tex(0.0, x, y);
        [u as f32, v as f32]
    });
    square(&mut mesh, [0.55, 1.0, 0.0, 1.0], 16, |x, y| {
        let (u, v) = tex(0.55, x, y);
        [u as f32, (v + 3.0) as f32]
    });
    let built = built(&mesh);
    let bands = [
        Band {
            start: -1,
            span: 3,
            shift: 0,
            texture: 0,
        },
        Band {
            start: 2,
            span: 3,
            shift: 3,
            texture: 1,
        },
    ];
    let textures = [blocks(2, 64, Wrap::Repeat), blocks(3, 64, Wrap::Clamp)];
    let pages: Arc<dyn PageSource> = Arc::new(MemoryPages::new(&textures, &bands).unwrap());
    let expect = |x: f64, y: f64| {
        let inside = |x0: f64| x > x0 + 0.01 && x < x0 + 0.44 && y > 0.01 && y < 0.99;
        if inside(0.0) {
            let (u, v) = tex(0.0, x, y);
            expected(2, 64, Wrap::Repeat, u, v)
        } else if inside(0.55) {
            let (u, v) = tex(0.55, x, y);
            expected(3, 64, Wrap::Clamp, u, v)
        } else {
            None
        }
    };
    for backend in BACKENDS {
        let ctx = gpu_on(backend);
        let mut renderer = renderer(&ctx, &built, Some((pages.clone(), None)));
        let (image, _) = settled(&ctx, &mut renderer, &request(ShadingMode::Color));
        let what = format!("{backend:?} two bands");
        let checked = check_texels(&image, &what, expect);
        assert!(checked > 5_000, "{what}: {checked} pixels checked");
        // Clamping showed the edge texels outside [0, 1): the right half's top-left corner
        // is texel (0, 0)'s block, repeated ones elsewhere.
        let corner = image
            .get_pixel((0.6 * SIZE as f64) as u32, (0.05 * SIZE as f64) as u32)
            .0;
        assert!(
            close(corner, block_colour(3, 0, 0), 3),
            "{what}: clamped corner {corner:?}"
        );
        ctx.check().unwrap();
    }
}

/// (c) A pool of 13 layers for a 1024² texture of 85 pages: settled frames of two regions,
/// one after the other (the second evicts the first's pages), draw the expected texels and
/// are pixel-equal to those of an unlimited pool, and the pool never holds more than its
/// layers, on both backends (a 12-layer pool asked for is given 11: see
/// `texture_cache::not_cube_compatible`).
#[test]
fn a_small_pool_settles_to_the_unlimited_frame() {
    let mut mesh = InputMesh::default();
    // Two regions of 256 texels (one texel a pixel): u, v in [0.3, 0.55], and + 0.4.
    for (i, offset) in [0.0f64, 0.4].into_iter().enumerate() {
        let x0 = 2.0 * i as f64;
        square(&mut mesh, [x0, x0 + 1.0, 0.0, 1.0], 16, move |x, y| {
            [
                (0.3 + offset + (x - x0) * 0.25) as f32,
                (0.3 + offset + (1.0 - y) * 0.25) as f32,
            ]
        });
    }
    let built = built(&mesh);
    let source = Arc::new(MemoryPages::new(&[blocks(4, 1024, Wrap::Repeat)], &[BAND_0]).unwrap());
    let pages: Arc<dyn PageSource> = source.clone();
    let view = |x0: f64| {
        let mut c = camera();
        c.eye[0] += x0;
        c.target[0] += x0;
        FrameRequest {
            mode: ShadingMode::Color,
            ..FrameRequest::new(c, 0.5)
        }
    };
    for backend in BACKENDS {
        let ctx = gpu_on(backend);
        let mut unlimited = renderer(&ctx, &built, Some((pages.clone(), None)));
        let mut small = renderer(&ctx, &built, Some((pages.clone(), Some(13))));
        assert_eq!(small.textures().unwrap().capacity(), 13);
        for x0 in [0.0, 2.0] {
            let (want, _) = settled(&ctx, &mut unlimited, &view(x0));
            let (frame, settle) = small.render_settled(&ctx, &view(x0), 8).unwrap();
            let cache = small.textures().unwrap();
            assert!(
                cache.max_resident <= 13 && cache.resident() <= 13,
                "{backend:?}"
            );
            assert!(
                settle.settled && settle.steps >= 2,
                "{backend:?}: {settle:?}"
            );
            let got = frame.image;
            let offset = 0.2 * x0;
            let texel = |x: f64, y: f64| {
                let (u, v) = (0.3 + offset + x * 0.25, 0.3 + offset + (1.0 - y) * 0.25);
                expected(4, 1024, Wrap::Repeat, u, v)
            };
            let what = format!("{backend:?} view {x0}");
            assert!(check_texels(&want, &format!("{what}, unlimited"), texel) > 10_000);
            assert!(check_texels(&got, &format!("{what}, 12 layers"), texel) > 10_000);
            let differing: Vec<_> = got
                .enumerate_pixels()
                .filter(|&(x, y, p)| p != want.get_pixel(x, y))
                .map(|(x, y, p)| (x, y, p.0, want.get_pixel(x, y).0))
                .collect();
            assert!(
                differing.is_empty(),
                "{backend:?} view {x0}: the small pool's settled frame differs at {} pixels: {:?}",
                differing.len(),
                &differing[..differing.len().min(5)]
            );
        }
        let eleven = renderer(&ctx, &built, Some((pages.clone(), Some(12))));
        assert_eq!(
            eleven.textures().unwrap().capacity(),
            11,
            "not a multiple of 6"
        );
        assert!(
            unlimited.textures().unwrap().resident() > 13,
            "{backend:?}: the views need more than the pool"
        );
        ctx.check().unwrap();
    }
}

/// (d) Without textures a model with texture coordinates draws as before: textures whose
/// only band has none draw exactly the untextured renderer's pixels, lit and color.
#[test]
fn bands_without_texture_draw_as_without_textures() {
    let built = straight_square();
    let band = Band {
        start: -100,
        span: 200,
        shift: 0,
        texture: NO_TEXTURE,
    };
    let pages: Arc<dyn PageSource> =
        Arc::new(MemoryPages::new(&[blocks(5, 64, Wrap::Repeat)], &[band]).unwrap());
    for backend in BACKENDS {
        let ctx = gpu_on(backend);
        let mut plain = renderer(&ctx, &built, None);
        let mut textured = renderer(&ctx, &built, Some((pages.clone(), None)));
        for mode in [ShadingMode::Lit, ShadingMode::Color] {
            let (want, steps) = settled(&ctx, &mut plain, &request(mode));
            assert_eq!(steps, 1);
            let (got, _) = settled(&ctx, &mut textured, &request(mode));
            assert!(got == want, "{backend:?} {mode:?}: pixels differ");
        }
        ctx.check().unwrap();
    }
}

/// (e) Streaming under `--gpu-budget`: the texture cache takes at most a quarter of the
/// budget and at most `SCREEN_PAGES` times the pages the viewport fills (`layers_for`), a
/// budget too small for the pinned pages and 16 more is refused naming it, and the streamed
/// frames draw the expected texels once settled.
#[test]
fn streaming_under_a_budget_counts_the_pages() {
    use tessera_runtime::gpu::texture_cache::cache_bytes;
    use tessera_runtime::gpu::texture_pages::TextureError;
    use tessera_runtime::gpu::{GpuStreamer, Readback, StreamError};
    let mut mesh = InputMesh::default();
    square(&mut mesh, [0.0, 1.0, 0.0, 1.0], 64, |x, y| {
        [(0.3 + x * 0.25) as f32, (0.3 + (1.0 - y) * 0.25) as f32]
    });
    let built = built(&mesh);
    let repo = Arc::new(
        tessera_core::repository::reader::Repository::open(built.dir.path().join("model.tsr"))
            .unwrap(),
    );
    let pages: Arc<dyn PageSource> =
        Arc::new(MemoryPages::new(&[blocks(4, 1024, Wrap::Repeat)], &[BAND_0]).unwrap());
    let layout = TextureLayout::new(pages.shapes(), pages.bands()).unwrap();
    let options = |budget| RendererOptions {
        width: SIZE,
        height: SIZE,
        budget_bytes: budget,
        ..Default::default()
    };
    for backend in BACKENDS {
        let ctx = gpu_on(backend);
        let rgba8 = PoolFormat::Rgba8;
        let viewport = (SIZE, SIZE);
        for budget in [8u64 << 20, 64 << 20] {
            let layers = layers_for(&ctx, &layout, Some(budget), rgba8, viewport).unwrap();
            assert!(
                cache_bytes(&layout, layers, rgba8) <= budget / 4 && layers >= 17,
                "{budget}: {layers}"
            );
        }
        // 64 MiB would hold every page; the 256² viewport wants at most 8 × 4 pages' worth.
        assert_eq!(layout.total_pages(), 85);
        assert_eq!(
            layers_for(&ctx, &layout, Some(64 << 20), rgba8, viewport).unwrap(),
            32
        );
        assert_eq!(
            layers_for(&ctx, &layout, Some(64 << 20), rgba8, (2048, 2048)).unwrap(),
            85
        );
        assert_eq!(
            layers_for(&ctx, &layout, None, rgba8, viewport).unwrap(),
            85
        );
        // BC1 layers are 7.95 times smaller: 8 MiB holds every page the viewport allows.
        let bc1 = PoolFormat::Bc1;
        assert_eq!(
            layers_for(&ctx, &layout, Some(8 << 20), bc1, (2048, 2048)).unwrap(),
            85
        );
        let small = GpuStreamer::with_textures(
            &ctx,
            repo.clone(),
            options(1 << 20),
            256 << 10,
            Some(pages.clone()),
        );
        match small {
            Err(StreamError::Textures(e @ TextureError::BudgetTooSmall { budget, .. })) => {
                assert_eq!(budget, 1 << 20);
                assert!(
                    e.to_string().contains("--gpu-budget of 1048576 bytes"),
                    "{e}"
                );
            }
            Err(e) => panic!("{backend:?}: {e}"),
            Ok(_) => panic!("{backend:?}: a 1 MiB budget was accepted"),
        }
        let (mut renderer, mut streamer) = GpuStreamer::with_textures(
            &ctx,
            repo.clone(),
            options(32 << 20),
            256 << 10,
            Some(pages.clone()),
        )
        .unwrap();
        let readback = Readback {
            image: true,
            selection: false,
        };
        for _ in 0..40 {
            streamer
                .frame(&ctx, &mut renderer, &request(ShadingMode::Color), readback)
                .unwrap();
            ctx.wait_idle().unwrap();
        }
        let image = renderer.read_image(&ctx).unwrap();
        let what = format!("{backend:?} streamed");
        let checked = check_texels(&image, &what, |x, y| {
            expected(
                4,
                1024,
                Wrap::Repeat,
                0.3 + x * 0.25,
                0.3 + (1.0 - y) * 0.25,
            )
        });
        assert!(checked > 10_000, "{what}: {checked} pixels checked");
        assert!(
            renderer.textures().unwrap().resident() > 1,
            "{what}: pages were loaded"
        );
        ctx.check().unwrap();
    }
}

/// (f) BC1 pages (`--texture-encoding bc1`, the build's default): kept BC1 in the pool where
/// the adapter samples it, decoded to RGBA8 where it does not (forced here); both settle, draw
/// the expected texels, and differ by at most 2 levels (BC1's interpolation, rounded by the
/// adapter and by the decoder); a BC1 layer is 12,208 bytes.
#[test]
fn bc1_pages_draw_in_either_pool_format() {
    use tessera_core::texture::PageEncoding;
    let built = straight_square();
    let pages = MemoryPages::new(&[blocks(1, 256, Wrap::Repeat)], &[BAND_0]).unwrap();
    let pages: Arc<dyn PageSource> = Arc::new(pages.encoded(PageEncoding::Bc1));
    for backend in BACKENDS {
        let mut ctx = gpu_on(backend);
        assert!(
            ctx.capabilities.bc_textures,
            "{backend:?}: lavapipe and llvmpipe sample BC1"
        );
        let mut images = Vec::new();
        for compressed in [true, false] {
            ctx.capabilities.bc_textures = compressed;
            let mut renderer = renderer(&ctx, &built, Some((pages.clone(), None)));
            let cache = renderer.textures().unwrap();
            let format = if compressed {
                PoolFormat::Bc1
            } else {
                PoolFormat::Rgba8
            };
            assert_eq!(cache.format(), format);
            let (image, _) = settled(&ctx, &mut renderer, &request(ShadingMode::Color));
            let what = format!("{backend:?} {format:?}");
            let checked = check_texels(&image, &what, |x, y| {
                expected(1, 256, Wrap::Repeat, x, 1.0 - y)
            });
            assert!(checked > 10_000, "{what}: {checked} pixels checked");
            images.push(image);
            ctx.check().unwrap();
        }
        let worst = images[0]
            .pixels()
            .zip(images[1].pixels())
            .flat_map(|(a, b)| (0..3).map(move |c| a[c].abs_diff(b[c])))
            .max()
            .unwrap();
        assert!(
            worst <= 2,
            "{backend:?}: BC1 on the GPU and decoded differ by {worst}"
        );
    }
    assert_eq!(PoolFormat::Bc1.layer_bytes(), 12_208);
}

/// (g) Negative texture coordinates, as OBJ and PLY inputs store them (`shift − v`): the view's
/// square mapped to v in [−1, 0) of a repeating 240² texture draws the texels that v + 1 names,
/// on both backends. GLSL leaves `%` of a negative operand undefined (naga writes WGSL's `%`
/// as it is) and llvmpipe GL computed it as unsigned, right only for a power-of-two side: it
/// drew other texels here until `wrap_texel` stopped using it.
#[test]
fn negative_coordinates_wrap_on_every_backend() {
    let mut mesh = InputMesh::default();
    square(&mut mesh, [0.0, 1.0, 0.0, 1.0], 16, |x, y| {
        [x as f32, (1.0 - y) as f32 - 1.0]
    });
    let built = built(&mesh);
    let band = Band {
        start: -1,
        span: 1,
        shift: 0,
        texture: 0,
    };
    let pages: Arc<dyn PageSource> =
        Arc::new(MemoryPages::new(&[blocks(6, 240, Wrap::Repeat)], &[band]).unwrap());
    for backend in BACKENDS {
        let ctx = gpu_on(backend);
        let mut renderer = renderer(&ctx, &built, Some((pages.clone(), None)));
        let (image, _) = settled(&ctx, &mut renderer, &request(ShadingMode::Color));
        let what = format!("{backend:?} negative v");
        let checked = check_texels(&image, &what, |x, y| {
            expected(6, 240, Wrap::Repeat, x, 1.0 - y - 1.0)
        });
        assert!(checked > 10_000, "{what}: {checked} pixels checked");
        ctx.check().unwrap();
    }
}
