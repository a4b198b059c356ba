//! `tessera render REPO -o frame.png [--tolerance PX] [--size WxH] [--fov DEG]
//! [--eye x,y,z --target x,y,z | --orbit AZ,EL,DIST]
//! [--mode lit|patches|levels|check|color|normals] [--flat] [--json]`

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};
use serde_json::json;
use tessera_runtime::camera::{bounding_radius, Camera, Y_UP, Z_UP};
use tessera_runtime::gpu::{FrameRequest, Readback, ShadingMode};

use crate::gpu_args::device_failure;
use crate::output::save_png;
use crate::Outcome;

#[derive(Args)]
pub struct RenderArgs {
    /// Repository file.
    pub repository: PathBuf,
    /// Output image (PNG).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Pixel tolerance τ: the largest screen-space error allowed, in pixels.
    #[arg(long, default_value_t = 1.0)]
    pub tolerance: f32,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1920x1080", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 60.0)]
    pub fov: f64,
    /// Eye position, model units (with --target); a leading minus sign needs no `=`.
    #[arg(long, value_parser = parse_vec3, requires = "target", conflicts_with = "orbit",
          allow_hyphen_values = true)]
    pub eye: Option<[f64; 3]>,
    /// Point looked at, model units (with --eye).
    #[arg(long, value_parser = parse_vec3, requires = "eye", allow_hyphen_values = true)]
    pub target: Option<[f64; 3]>,
    /// Azimuth and elevation in degrees around the up axis, and distance in bounding radii from
    /// the centre of the model (default 30,20,2.5).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub orbit: Option<[f64; 3]>,
    /// Up direction (default 0,1,0 for meshes, as scans and glTF have it; 0,0,1 for terrains).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub up: Option<[f64; 3]>,
    /// Near plane, model units (default 1e-5 of the model's bounding radius).
    #[arg(long)]
    pub near: Option<f64>,
    /// Shading.
    #[arg(long, value_enum, default_value_t = Mode::Lit)]
    pub mode: Mode,
    /// Also write the cut this view's rule selects, the whole model at its resolution without
    /// culling, as `view`'s X does: binary glTF for a `.glb` name, else binary PLY with the
    /// stored normals, colours and texture coordinates.
    #[arg(long, value_name = "FILE")]
    pub export: Option<std::path::PathBuf>,
    /// Face normals in the lit and normals modes: each triangle flat, whatever normals the
    /// model stores.
    #[arg(long)]
    pub flat: bool,
    /// Overlay the triangle edges (where the adapter has line mode).
    #[arg(long)]
    pub wireframe: bool,
    /// Draw both sides of every face; also switches normal-cone culling off (by default back
    /// faces are dropped by the patch cones and by the rasteriser alike).
    #[arg(long)]
    pub two_sided: bool,
    #[command(flatten)]
    pub gpu: crate::gpu_args::GpuArgs,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    /// Most frames drawn while the stream settles (the last one is written).
    #[arg(long, default_value_t = 1000)]
    pub max_frames: u32,
    /// Draw K times wider and taller at τ × K (the cut of τ at --size) and write the mean of
    /// each K×K block: K² samples a pixel, no aliasing of sub-pixel detail (1 to 8).
    #[arg(long, value_name = "K", default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(1..=8))]
    pub supersample: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Mode {
    Lit,
    Patches,
    Levels,
    /// Front faces grey, back faces magenta (what `check --gpu` counts).
    Check,
    /// Unlit albedo: the stored per-vertex colours, a neutral grey (204) where the model has
    /// none.
    Color,
    /// The normal as a colour, n × 0.5 + 0.5 (x red, y green, z blue): the stored normals,
    /// else (and with `--flat`) the face normal turned towards the eye.
    Normals,
}

impl From<Mode> for ShadingMode {
    fn from(m: Mode) -> ShadingMode {
        match m {
            Mode::Lit => ShadingMode::Lit,
            Mode::Patches => ShadingMode::Patches,
            Mode::Levels => ShadingMode::Levels,
            Mode::Check => ShadingMode::Check,
            Mode::Color => ShadingMode::Color,
            Mode::Normals => ShadingMode::Normals,
        }
    }
}

/// The shading of `mode`, with face normals when `flat` (`--flat`; lit and normals only).
pub fn shading(mode: Mode, flat: bool) -> ShadingMode {
    match (mode, flat) {
        (Mode::Lit, true) => ShadingMode::LitFaces,
        (Mode::Normals, true) => ShadingMode::NormalsFaces,
        (mode, _) => mode.into(),
    }
}

/// Whether `--flat` means something in `mode` (it picks the normals lit and normals use).
pub fn has_normals(mode: Mode) -> bool {
    matches!(mode, Mode::Lit | Mode::Normals)
}

/// `image` with each `k`×`k` block replaced by one pixel, the rounded mean of its channels
/// (`--supersample`); `image` itself when `k` is 1. The size must be a multiple of `k`.
pub fn box_average(image: image::RgbaImage, k: u32) -> image::RgbaImage {
    if k == 1 {
        return image;
    }
    assert!(image.width().is_multiple_of(k) && image.height().is_multiple_of(k));
    let n = k * k;
    image::RgbaImage::from_fn(image.width() / k, image.height() / k, |x, y| {
        let mut sum = [0u32; 4];
        for (dx, dy) in (0..k).flat_map(|dx| (0..k).map(move |dy| (dx, dy))) {
            let p = image.get_pixel(x * k + dx, y * k + dy);
            for (s, c) in sum.iter_mut().zip(p.0) {
                *s += u32::from(c);
            }
        }
        image::Rgba(sum.map(|s| ((s + n / 2) / n) as u8))
    })
}

/// Adds `extra`'s keys to the object `value`.
pub fn merge(value: &mut serde_json::Value, extra: serde_json::Value) {
    if let (Some(v), serde_json::Value::Object(e)) = (value.as_object_mut(), extra) {
        v.extend(e);
    }
}

pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("{s:?} is not WIDTHxHEIGHT"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("{v:?} in {s:?} is not a positive pixel count"))
    };
    Ok((parse(w)?, parse(h)?))
}

pub fn parse_vec3(s: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        return Err(format!("{s:?} is not three comma-separated numbers"));
    }
    let mut v = [0.0; 3];
    for (x, p) in v.iter_mut().zip(&parts) {
        *x = p
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{p:?} in {s:?} is not a finite number"))?;
    }
    Ok(v)
}

/// The default up axis of a repository: z for height fields (2D hierarchies), else y.
pub fn default_up(dimension: u32) -> [f64; 3] {
    if dimension == 2 {
        Z_UP
    } else {
        Y_UP
    }
}

/// The camera the flags describe for a repository with this bounding box.
pub fn camera_from_args(
    args: &RenderArgs,
    lo: [f64; 3],
    hi: [f64; 3],
    dimension: u32,
) -> anyhow::Result<Camera> {
    let up = args.up.unwrap_or(default_up(dimension));
    if up == [0.0; 3] {
        anyhow::bail!("--up must not be the zero vector");
    }
    let mut camera = match (args.eye, args.target) {
        (Some(eye), Some(target)) => {
            if eye == target {
                anyhow::bail!("--eye and --target are the same point");
            }
            Camera {
                up,
                ..Camera::looking_at(eye, target, bounding_radius(lo, hi))
            }
        }
        _ => {
            let [az, el, dist] = args.orbit.unwrap_or([30.0, 20.0, 2.5]);
            if dist <= 0.0 {
                anyhow::bail!("--orbit distance {dist} must be positive");
            }
            Camera::orbit(lo, hi, up, az, el, dist)
        }
    };
    if !(args.fov > 0.0 && args.fov < 180.0) {
        anyhow::bail!("--fov {} must be between 0 and 180 degrees", args.fov);
    }
    camera.fov_y_degrees = args.fov;
    (camera.width, camera.height) = args.size;
    if let Some(near) = args.near {
        if !(near > 0.0 && near.is_finite()) {
            anyhow::bail!("--near {near} must be a positive number");
        }
        camera.near = near;
    }
    Ok(camera)
}

/// Still frames a texture cache may take to settle before the written frame.
const TEXTURE_SETTLE_STEPS: u32 = 16;

pub fn run(args: RenderArgs) -> anyhow::Result<Outcome> {
    if !(args.tolerance >= 0.0 && args.tolerance.is_finite()) {
        anyhow::bail!("--tolerance {} must be a finite number ≥ 0", args.tolerance);
    }
    // Opened (and its directory validated) once: the streamer shares this map.
    if args.flat && !has_normals(args.mode) {
        anyhow::bail!(
            "--flat draws --mode lit or normals with face normals; --mode {} uses no normals",
            args.mode
                .to_possible_value()
                .map_or(String::new(), |v| v.get_name().to_string())
        );
    }
    let shared = std::sync::Arc::new(crate::repository_arg::open(&args.repository, "render")?);
    let h = *shared.header();
    let mut camera = camera_from_args(&args, h.bbox_min, h.bbox_max, h.dimension)?;
    // --supersample K: K² samples a pixel; τ × K pixels at K times the size selects the cut τ
    // selects at the size asked for (the projected error scales with the image's height).
    let k = args.supersample;
    let (width, height) = (camera.width, camera.height);
    (camera.width, camera.height) = (width.saturating_mul(k), height.saturating_mul(k));
    let tolerance = args.tolerance * k as f32;
    let ctx = args.gpu.context()?;
    let (mut renderer, mut streamer) =
        args.gpu
            .streaming(&ctx, shared.clone(), (camera.width, camera.height))?;
    let mut request = FrameRequest {
        mode: shading(args.mode, args.flat),
        wireframe: args.wireframe,
        ..FrameRequest::new(camera, tolerance)
    };
    if args.two_sided {
        request = request.two_sided();
    }
    // Streaming: frames until nothing is issued, loading or waiting (or the cap), then one
    // more frame, read back and written.
    let mut frames_to_converge = None;
    // RssAnon after every frame (on a CPU adapter the GPU's buffers are anonymous memory).
    let mut anon_peak = crate::peak_rss::AnonPeak::default();
    anon_peak.sample();
    for k in 1..args.max_frames.max(1) {
        let f = streamer
            .frame(&ctx, &mut renderer, &request, Readback::default())
            .map_err(device_failure)?;
        ctx.wait_idle()?;
        anon_peak.sample();
        if f.settled {
            frames_to_converge = Some(k);
            break;
        }
    }
    // Texture pages: still frames until one asks for no page that is not resident (the
    // geometry's flags as the streamer left them), so the written frame samples each texel
    // at the level its pixels want.
    let textures = match renderer.textures().is_some() {
        true => Some(
            renderer
                .render_settled(&ctx, &request, TEXTURE_SETTLE_STEPS)
                .map_err(|e| anyhow::anyhow!("drawing the textures: {e}"))?
                .1,
        ),
        false => None,
    };
    anon_peak.sample();
    // The written frame also runs the CPU reference (its max ρ/τ for the report).
    streamer.set_cpu_reference(true);
    let started = std::time::Instant::now();
    let last = streamer
        .frame(
            &ctx,
            &mut renderer,
            &request,
            Readback {
                image: true,
                selection: true,
            },
        )
        .map_err(device_failure)?;
    // CPU ms of the written frame: recording and submitting it, and the streaming work
    // (landing units, feedback, plan; the CPU reference of this frame included).
    let cpu_ms = started.elapsed().as_secs_f64() * 1e3;
    let image = box_average(renderer.read_image(&ctx)?, k);
    let selection = &renderer.read_selection(&ctx)?;
    let (triangles, gpu_ms) = (
        renderer.triangles_of(selection),
        renderer.read_gpu_ms(&ctx)?,
    );
    let frame = tessera_runtime::gpu::Frame {
        image,
        selection: selection.clone(),
        triangles,
        gpu_ms,
        cpu_ms,
    };
    let (stats, gpu) = (last.stats, streamer.stats());
    let memory = anon_peak.sample();
    save_png(&frame.image, &args.output)?;
    let exported = match &args.export {
        Some(path) => {
            let (triangles, vertices) =
                crate::view::export::export_cut(&shared, &camera, tolerance, path)
                    .with_context(|| format!("exporting the cut to {}", path.display()))?;
            Some((path, triangles, vertices))
        }
        None => None,
    };
    if args.json {
        let mut value = json!({
                "output": args.output.display().to_string(),
                "patches": frame.selection.len(),
                "triangles": frame.triangles,
                "gpu_ms": frame.gpu_ms,
                "cpu_ms": frame.cpu_ms,
                "adapter": ctx.adapter_description(),
                "backend": ctx.backend.name(),
                "tolerance": args.tolerance,
                "width": width,
                "height": height,
                "supersample": k,
                "eye": camera.eye,
                "target": camera.target,
                "resident_bytes": gpu.gpu_bytes,
                "budget_bytes": args.gpu.budget_bytes(&ctx),
                "fixed_bytes": gpu.fixed_bytes,
                "record_slots": gpu.record_slots,
                "record_bytes": gpu.record_bytes,
                "pool_bytes": gpu.pool_bytes,
                "pool_pages": gpu.pool_pages,
                "pool_growths": gpu.pool_growths,
                "max_resident_bytes": gpu.max_gpu_bytes,
                "resident_patch_bytes": stats.peak_resident_bytes,
                "resident_patches": streamer.resident_patches(),
                "loaded_bytes": stats.loaded_bytes,
                "evictions": stats.evictions,
                "pending_units": stats.pending_units,
                "frames_to_converge": frames_to_converge,
                "pool_fragmentation": gpu.fragmentation,
                "max_error_over_tau": last.reference.max_error_over_tau,
        });
        merge(
            &mut value,
            crate::peak_rss::MemoryNow::json(memory, anon_peak.bytes()),
        );
        if let Some(t) = &textures {
            let cache = renderer.textures().expect("textures drawn");
            value["textures"] = json!({
                "settle_steps": t.steps,
                "settled": t.settled,
                "page_loads": t.loads,
                "pages_refused": t.refused,
                "pages_wanted": t.wanted,
                "pool_layers": cache.capacity(),
                "pool_format": match cache.format() {
                    tessera_runtime::gpu::PoolFormat::Bc1 => "bc1",
                    tessera_runtime::gpu::PoolFormat::Rgba8 => "rgba8",
                },
                "pool_bytes": cache.bytes(),
                "resident_pages": cache.resident(),
            });
        }
        if let Some((path, triangles, vertices)) = exported {
            value["export"] = json!({
                "path": path.display().to_string(),
                "triangles": triangles,
                "vertices": vertices,
            });
        }
        println!("{value}");
    } else {
        println!(
            "{}: {} patches, {} triangles at τ = {} px; GPU {} ms on {}; streamed: {} of {} \
             budget bytes allocated, {} patches resident, {} bytes loaded, {} evictions, {}",
            args.output.display(),
            selection.len(),
            frame.triangles,
            args.tolerance,
            frame
                .gpu_ms
                .map_or("n/a".to_string(), |g| format!("{g:.2}")),
            ctx.adapter_description(),
            gpu.gpu_bytes,
            args.gpu.budget_bytes(&ctx),
            streamer.resident_patches(),
            stats.loaded_bytes,
            stats.evictions,
            frames_to_converge.map_or(
                format!("not settled after {} frames", args.max_frames),
                |k| format!("settled after {k} frames")
            ),
        );
        if let Some((path, triangles, vertices)) = exported {
            println!(
                "{}: the cut, {triangles} triangles, {vertices} vertices",
                path.display()
            );
        }
    }
    Ok(Outcome::Ok)
}
