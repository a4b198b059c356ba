//! `tessera demo`: the main job on a built-in default. Generates a procedural closed mesh with
//! detail at every scale (1.3 M triangles), builds its repository, checks every cut, renders a
//! few frames of it to PNG, and prints a summary. No input file, no download.
//!
//! With the frames comes the trade-off table of the model: per τ, triangles drawn, the *measured*
//! error (p99 and max pixels, against the generated mesh) and the frame time, over
//! `TRADE_VIEWS` views outside the model (the measurement of `tessera bench`, ours only).
//!
//! Then a generated terrain (`demo_terrain.rs`): a diamond-square height field with a map of
//! regions, built on the 2D hierarchy, checked, and with a GPU rendered and pixel-checked from
//! above and below.
//!
//! Rendering needs a GPU adapter (lavapipe works). Without one — or when the model does not fit
//! the GPU budget — the demo still builds and checks, says that rendering was skipped and why,
//! and the geometric check alone decides the exit code (0 clean, 1 cracks): the frames are a
//! picture of the result, not part of the verdict.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use tessera_core::repository::reader::Repository;
use tessera_preprocess::procedural::{demo_mesh, demo_mesh_refined, DEMO_SUBDIVISIONS};
use tessera_preprocess::{build_repository, BuildConfig};
use tessera_runtime::camera::Camera;
use tessera_runtime::faces::Faces;
use tessera_runtime::geometric_check::{check_cuts, decode_all_patches, CheckConfig};
use tessera_runtime::gpu::{
    FrameRequest, GpuContext, Readback, RenderError, Renderer, RendererOptions, ShadingMode,
};

use tessera_preprocess::InputMesh;
use tessera_runtime::measure::SamplingConfig;

use crate::bench::ours::Ours;
use crate::bench::trade_off::{measure, Settings};
use crate::bench::{outside_cameras, reference_mesh};
use crate::cmd_render::{default_up, parse_size};
use crate::output::{save_png, write_binary_ply};
use crate::progress::Stages;
use crate::Outcome;

/// Where the frames go unless `--frames-dir` says otherwise (relative to the current directory).
pub const DEFAULT_FRAMES_DIR: &str = "tessera-demo-frames";

/// The frames rendered: shading, τ in pixels, file name.
const FRAMES: [(ShadingMode, f32, &str); 4] = [
    (ShadingMode::Lit, 1.0, "lit-tau-1.png"),
    (ShadingMode::Lit, 4.0, "lit-tau-4.png"),
    (ShadingMode::Lit, 16.0, "lit-tau-16.png"),
    (ShadingMode::Patches, 1.0, "patches-tau-1.png"),
];

/// The trade-off table: tolerances, views outside the model, timed frames per view and τ,
/// samples per view; and the largest model it is measured on (the reference BVH takes about
/// 150 bytes a triangle).
const TRADE_TOLERANCES: [f32; 6] = [0.5, 1.0, 2.0, 4.0, 8.0, 16.0];
const TRADE_VIEWS: usize = 3;
const TRADE_FRAMES: usize = 2;
const TRADE_SAMPLES: usize = 5_000;
const TRADE_MAX_TRIANGLES: usize = 8_000_000;

/// Orbit of the demo camera: azimuth, elevation (degrees), distance (bounding radii of the
/// box; closer than `tessera render`'s 2.5 so the model fills the frame):
/// `tessera render REPO --orbit 30,20,1.5` shows the same view.
const ORBIT: [f64; 3] = [30.0, 20.0, 1.5];

#[derive(Args)]
pub struct DemoArgs {
    /// Keep the repository here (default: a temporary file, removed at the end).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Icosphere subdivisions: 20·4^s triangles (default 8: 1,310,720).
    #[arg(long, default_value_t = DEMO_SUBDIVISIONS)]
    pub subdivisions: u32,
    /// Then split every triangle flat into 4, this many times: 4^N times the triangles on the
    /// same surface (scaling benchmarks: the model grows, the visible detail does not).
    #[arg(long, default_value_t = 0)]
    pub refine: u32,
    /// Camera positions for the check.
    #[arg(long, default_value_t = 32)]
    pub views: usize,
    /// Directory for the rendered frames, relative to the current directory unless absolute
    /// (lit at τ = 1, 4, 16 px and patches at τ = 1 px: lit-tau-1.png, lit-tau-4.png,
    /// lit-tau-16.png, patches-tau-1.png), created if missing; files of those names are
    /// replaced. Without a GPU adapter nothing is written and the demo says why; the geometric
    /// check still decides the exit code (0 clean, 1 cracks).
    #[arg(long, default_value = DEFAULT_FRAMES_DIR)]
    pub frames_dir: PathBuf,
    /// Do not render frames (build and check only).
    #[arg(long, conflicts_with = "frames_dir")]
    pub no_frames: bool,
    /// Frame size, WIDTHxHEIGHT (τ is in pixels of this height).
    #[arg(long, default_value = "1920x1080", value_parser = parse_size)]
    pub frame_size: (u32, u32),
    /// Adapter name substring (default: $TESSERA_ADAPTER, else the best present).
    #[arg(long)]
    pub adapter: Option<String>,
    /// wgpu backend: vulkan, gl, metal or dx12 (default: $WGPU_BACKEND, else any).
    #[arg(long)]
    pub backend: Option<tessera_runtime::gpu::Backend>,
    /// Also write the generated mesh (positions and triangles) as a binary PLY, e.g. the
    /// `--source` of `tessera bench render`.
    #[arg(long)]
    pub save_mesh: Option<PathBuf>,
    /// Then open the demo model in `tessera view` (a window: needs a display; checked before
    /// the demo starts). The demo's exit code stands unless the viewer fails.
    #[arg(long)]
    pub view: bool,
    /// With `--view`: run this `tessera view --script` in the window, then exit (tests and
    /// pipelines).
    #[arg(long, requires = "view")]
    pub view_script: Option<PathBuf>,
}

impl DemoArgs {
    fn device_options(&self) -> tessera_runtime::gpu::DeviceOptions {
        tessera_runtime::gpu::DeviceOptions {
            adapter: self.adapter.clone(),
            backend: self.backend,
            limits: None,
        }
    }
}

pub fn run(args: DemoArgs) -> anyhow::Result<Outcome> {
    let levels = args.subdivisions + args.refine;
    if levels > 10 {
        anyhow::bail!(
            "--subdivisions {} with --refine {} would make {} triangles; at most 10 levels in all",
            args.subdivisions,
            args.refine,
            20u64 << (2 * levels)
        );
    }
    // A window needs a display: said before the long part (exit 2).
    if args.view {
        crate::view::display_present()?;
    }
    // Where the frames go, before the long part: a bad directory fails fast (exit 2).
    let frames_dir = (!args.no_frames).then_some(args.frames_dir.as_path());
    if let Some(dir) = frames_dir {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create --frames-dir {}", dir.display()))?;
    }
    let stages = Stages::new("demo");
    stages.stage("generate");
    let t = Instant::now();
    let mesh = if args.refine == 0 {
        demo_mesh(args.subdivisions)
    } else {
        demo_mesh_refined(args.subdivisions, args.refine)
    };
    let generate_seconds = t.elapsed().as_secs_f64();
    if let Some(path) = &args.save_mesh {
        stages.stage("save mesh");
        write_binary_ply(&mesh, path)?;
    }
    let temp = tempfile::tempdir()?;
    let path = args
        .output
        .clone()
        .unwrap_or_else(|| temp.path().join("demo.tsr"));
    let summary = build_repository(&mesh, &BuildConfig::default(), &path, &|s| stages.stage(s))?;
    // The trade-off table measures against the mesh: kept only when frames are rendered.
    let mesh = frames_dir.is_some().then_some(mesh);
    stages.stage("check");
    let t = Instant::now();
    let repo = Repository::open(&path)?;
    let patches = decode_all_patches(&repo)?;
    let config = CheckConfig {
        views: args.views,
        ..Default::default()
    };
    let report = check_cuts(&repo, &patches, &config);
    drop(patches);
    let check_seconds = t.elapsed().as_secs_f64();
    let frames = match frames_dir {
        Some(dir) => {
            stages.stage("render");
            Some(render_frames(&args, &repo, mesh.as_ref(), dir)?)
        }
        None => None,
    };
    stages.stage("terrain");
    let terrain = crate::demo_terrain::terrain_demo(
        temp.path(),
        args.views,
        frames_dir,
        &args.device_options(),
        args.frame_size,
    )?;
    stages.finish();
    println!("tessera demo: procedural displaced icosphere, {} subdivisions (generated in {generate_seconds:.2} s)", args.subdivisions);
    crate::cmd_build::print_summary(
        &summary,
        tessera_core::repository::format::POSITION_BITS,
        summary.seconds,
        0.0,
    );
    crate::cmd_check::print_report(&report, check_seconds);
    match frames {
        Some(Ok(lines)) => lines.iter().for_each(|l| println!("{l}")),
        Some(Err(why)) => println!("rendering skipped: {why}"),
        None => println!("rendering skipped: --no-frames"),
    }
    for line in &terrain.lines {
        println!("{line}");
    }
    if let Some(p) = &args.save_mesh {
        println!("mesh written to {}", p.display());
    }
    if args.view {
        drop(repo);
        crate::view::run(crate::view::ViewArgs {
            repository: path.clone(),
            script: args.view_script.clone(),
            gpu: crate::gpu_args::GpuArgs {
                adapter: args.adapter.clone(),
                backend: args.backend,
                gpu_budget: None,
            },
            ..crate::view::ViewArgs::defaults(path.clone())
        })?;
    }
    match &args.output {
        Some(p) => println!("repository kept at {}", p.display()),
        None => println!("(repository removed; pass -o FILE to keep it)"),
    }
    Ok(if report.is_clean() && terrain.clean {
        Outcome::Ok
    } else {
        Outcome::CheckFailed
    })
}

/// Renders `FRAMES` into `dir`, then measures the trade-off table against `mesh` (the
/// repository's source). The outer error is a file that could not be written (bad input:
/// exit 2); the inner one says why there is no GPU rendering (no adapter, model over the GPU
/// budget), which only skips the frames. Ok lines are the report, one per frame, then the
/// table.
fn render_frames(
    args: &DemoArgs,
    repo: &Repository,
    mesh: Option<&InputMesh>,
    dir: &Path,
) -> anyhow::Result<Result<Vec<String>, String>> {
    let ctx = match GpuContext::open(&args.device_options()) {
        Ok(ctx) => ctx,
        Err(e) => return Ok(Err(e.to_string().trim_end().to_string())),
    };
    let (width, height) = args.frame_size;
    let mut renderer = match Renderer::new(
        &ctx,
        repo,
        RendererOptions {
            width,
            height,
            ..Default::default()
        },
    ) {
        Ok(r) => r,
        // A size the adapter cannot draw is bad usage, not a missing GPU.
        Err(e @ RenderError::BadSize { .. }) => return Err(e).context("--frame-size"),
        Err(e) => return Ok(Err(format!("{e} (on {})", ctx.adapter_description()))),
    };
    let h = repo.header();
    let camera = Camera {
        width,
        height,
        ..Camera::orbit(
            h.bbox_min,
            h.bbox_max,
            default_up(h.dimension),
            ORBIT[0],
            ORBIT[1],
            ORBIT[2],
        )
    };
    let mut lines = vec![format!(
        "frames ({width}x{height}, camera as `tessera render --orbit {},{},{}`) on {}:",
        ORBIT[0],
        ORBIT[1],
        ORBIT[2],
        ctx.adapter_description()
    )];
    for (mode, tau, name) in FRAMES {
        let request = FrameRequest {
            mode,
            ..FrameRequest::new(camera, tau)
        };
        // A first, untimed frame, waited for: the second's GPU time is the steady one, and its
        // CPU time does not include waiting for the first.
        renderer.render(&ctx, &request, Readback::default());
        ctx.wait_idle()?;
        let frame = renderer.render_and_read(&ctx, &request)?;
        let (selection, triangles, gpu_ms, cpu_ms) = (
            &frame.selection,
            frame.triangles,
            frame.gpu_ms,
            frame.cpu_ms,
        );
        let path = dir.join(name);
        save_png(&frame.image, &path)?;
        lines.push(format!(
            "  {}: {:?} at τ = {tau} px: {} patches, {triangles} triangles, GPU {} ms, CPU {cpu_ms:.3} ms",
            path.display(),
            mode,
            selection.len(),
            gpu_ms.map_or("n/a".to_string(), |g| format!("{g:.2}")),
        ));
    }
    match mesh {
        Some(mesh) if mesh.triangles.len() <= TRADE_MAX_TRIANGLES => {
            lines.extend(trade_off_table(
                &ctx,
                renderer,
                repo,
                mesh,
                (width, height),
            )?);
        }
        Some(mesh) => lines.push(format!(
            "trade-off table skipped: {} triangles is over its {TRADE_MAX_TRIANGLES} (the \
             reference BVH would take ~{} MB)",
            mesh.triangles.len(),
            (mesh.triangles.len() * 150) >> 20
        )),
        None => {}
    }
    Ok(Ok(lines))
}

/// Ours at `TRADE_TOLERANCES` over `TRADE_VIEWS` views outside the model: triangles, measured
/// error against `mesh`, frame time (`bench::trade_off`, without peers).
fn trade_off_table(
    ctx: &GpuContext,
    renderer: Renderer,
    repo: &Repository,
    mesh: &InputMesh,
    size: (u32, u32),
) -> anyhow::Result<Vec<String>> {
    let h = *repo.header();
    let reference = reference_mesh(mesh, h.origin)?;
    let cameras = outside_cameras(&h, TRADE_VIEWS, size, default_up(h.dimension));
    let settings = Settings {
        tolerances: TRADE_TOLERANCES.to_vec(),
        frames: TRADE_FRAMES,
        sampling: SamplingConfig {
            samples_per_view: TRADE_SAMPLES,
            ..Default::default()
        },
        origin: h.origin,
        faces: Faces::Front,
        phases: false,
    };
    let mut ours = Ours::new(repo, renderer, Faces::Front);
    let (rows, _) = measure(
        ctx,
        &cameras,
        &mut [&mut ours],
        None,
        &reference,
        &settings,
        &|_| {},
    )?;
    let mut lines = vec![
        format!(
            "trade-off ({TRADE_VIEWS} views outside the model, {}x{}; error measured both ways \
             against the generated mesh over visible samples, {TRADE_SAMPLES} samples a view \
             and direction):",
            size.0, size.1
        ),
        format!(
            "  {:>6} {:>10} {:>9} {:>9} {:>7} {:>9}",
            "τ px", "triangles", "p99 px", "max px", "p99/τ", "wall ms"
        ),
    ];
    let px =
        |x: Option<f64>, digits: usize| x.map_or("n/a".to_string(), |x| format!("{x:.digits$}"));
    for r in &rows[0].rows {
        lines.push(format!(
            "  {:>6} {:>10.0} {:>9} {:>9} {:>7} {:>9.2}",
            r.tolerance,
            r.triangles,
            px(r.error.map(|e| e.p99_px), 3),
            px(r.error.map(|e| e.max_px), 3),
            px(r.error.map(|e| e.p99_px / r.tolerance as f64), 2),
            r.wall_ms,
        ));
    }
    Ok(lines)
}
