//! `tessera view REPO [--size WxH] [--tolerance PX] [--orbit AZ,EL,DIST] [--mode ..]
//! [--gpu-budget MB] [--backend ..] [--script FILE] [--json]`: an interactive viewer.
//!
//! A winit window with a wgpu surface; each frame the streaming renderer of `render` draws the
//! camera into its offscreen target at `--size`, which is scaled (letterboxed) into the window
//! with an egui overlay on top (`app.rs`). Files: `app` (event loop, window, drawing a
//! frame), `actions` (keys, script actions, picks, fly moves, freezing, targets, export,
//! bookmarks and paths between frames), `input` (window events to navigation and actions), `model_frame` (the model's frame: request, redraws under a triangle budget, statistics), `blit` (texture to target), `navigation` (orbit
//! around a pivot, pan, zoom towards a point, fly), `pick` (rays against the drawn cut),
//! `pointer` (mouse drags and wheel to navigation), `overlay` (statistics and controls), `graph` (the overlay's frame-time graph),
//! `target` (the frame-time and triangle controller), `export` (the cut as PLY, `export_glb` as binary glTF), `script`
//! (`--script` actions).

mod actions;
mod app;
mod blit;
pub mod export;
mod export_glb;
mod export_textures;
mod graph;
mod input;
mod model_frame;
mod navigation;
mod overlay;
mod pick;
mod pointer;
mod script;
mod target;

use std::path::PathBuf;
use std::sync::Arc;

use clap::Args;
use tessera_core::repository::reader::Repository;
use winit::event_loop::EventLoop;

use crate::cmd_render::{default_up, parse_size, parse_vec3, Mode};
use crate::Outcome;

#[derive(Args)]
pub struct ViewArgs {
    /// Repository file.
    pub repository: PathBuf,
    /// Render size, WIDTHxHEIGHT (the window opens at this size; a resized window shows the
    /// image scaled, letterboxed).
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Pixel tolerance τ at start (the overlay's slider changes it).
    #[arg(long, default_value_t = 1.0)]
    pub tolerance: f32,
    /// Initial view: azimuth and elevation in degrees, distance in bounding radii (`R` comes
    /// back to it).
    #[arg(long, value_parser = parse_vec3, default_value = "30,20,2.5")]
    pub orbit: [f64; 3],
    /// Up direction (default 0,1,0 for meshes, 0,0,1 for terrains).
    #[arg(long, value_parser = parse_vec3)]
    pub up: Option<[f64; 3]>,
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 60.0)]
    pub fov: f64,
    /// Display mode at start.
    #[arg(long, value_enum, default_value_t = Mode::Lit)]
    pub mode: Mode,
    /// Start with face normals in the lit and normals modes (each triangle flat) instead of
    /// the stored normals.
    #[arg(long)]
    pub flat: bool,
    #[command(flatten)]
    pub gpu: crate::gpu_args::GpuArgs,
    /// Run the JSON-lines script in the window, then exit (docs/cli.md lists the actions).
    #[arg(long)]
    pub script: Option<PathBuf>,
    /// Print one JSON object per screenshot on stdout.
    #[arg(long)]
    pub json: bool,
    /// Bookmarks file (`B` adds the current view, 1-9 go to one; a camera path that `bench
    /// stream --path` can fly). Default: beside the repository, `NAME.bookmarks.json`.
    #[arg(long)]
    pub bookmarks: Option<PathBuf>,
    /// Where `K` writes the camera path it records (default: the first free
    /// `tessera-path-NNN.json` of the current directory).
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// Write one JSON object per frame drawn to this file (`frame, frame_ms, gpu_ms, cpu_ms,
    /// triangles, patches, tolerance, settled, pending_units, redraws, eye`): what the target
    /// modes are measured with.
    #[arg(long)]
    pub frame_log: Option<PathBuf>,
    /// Hold this frame time (ms) from the start, adjusting the tolerance each frame.
    #[arg(long, conflicts_with = "target_triangles")]
    pub target_ms: Option<f64>,
    /// Hold this triangle count from the start, adjusting the tolerance each frame.
    #[arg(long)]
    pub target_triangles: Option<u64>,
}

impl ViewArgs {
    /// The command line's defaults for `repository` (`demo --view`).
    pub fn defaults(repository: PathBuf) -> ViewArgs {
        ViewArgs {
            repository,
            size: (1280, 720),
            tolerance: 1.0,
            orbit: [30.0, 20.0, 2.5],
            up: None,
            fov: 60.0,
            mode: Mode::Lit,
            flat: false,
            gpu: crate::gpu_args::GpuArgs {
                adapter: None,
                backend: None,
                gpu_budget: None,
            },
            script: None,
            json: false,
            bookmarks: None,
            record: None,
            frame_log: None,
            target_ms: None,
            target_triangles: None,
        }
    }
}

/// `NAME.bookmarks.json` beside the repository `NAME.EXT`.
pub(super) fn default_bookmarks(repository: &std::path::Path) -> PathBuf {
    let stem = repository.file_stem().unwrap_or_default();
    repository.with_file_name(format!("{}.bookmarks.json", stem.to_string_lossy()))
}

/// Ok when a display server is named in the environment, else what is missing.
pub fn display_present() -> anyhow::Result<()> {
    let set = |name: &str| std::env::var_os(name).is_some_and(|v| !v.is_empty());
    if cfg!(all(unix, not(target_os = "macos"))) && !set("DISPLAY") && !set("WAYLAND_DISPLAY") {
        anyhow::bail!(
            "no display: neither DISPLAY nor WAYLAND_DISPLAY is set, so `tessera view` cannot \
             open a window (run it in a desktop session, or under `xvfb-run -a`; `tessera \
             render` writes PNGs without a display)"
        );
    }
    Ok(())
}

pub fn run(args: ViewArgs) -> anyhow::Result<Outcome> {
    if !(args.tolerance >= 0.0 && args.tolerance.is_finite()) {
        anyhow::bail!("--tolerance {} must be a finite number ≥ 0", args.tolerance);
    }
    if args.orbit[2] <= 0.0 {
        anyhow::bail!("--orbit distance {} must be positive", args.orbit[2]);
    }
    if args
        .target_ms
        .is_some_and(|ms| !(ms > 0.0 && ms.is_finite()))
    {
        anyhow::bail!("--target-ms must be a positive number of milliseconds");
    }
    if args.target_triangles == Some(0) {
        anyhow::bail!("--target-triangles must be at least 1");
    }
    if !(args.fov > 0.0 && args.fov < 180.0) {
        anyhow::bail!("--fov {} must be between 0 and 180 degrees", args.fov);
    }
    // The script first: a bad line is reported before any window opens.
    let script = args.script.as_deref().map(script::load).transpose()?;
    crate::repository_arg::refuse_input_file(&args.repository, "view")?;
    display_present()?;
    let shared = Arc::new(Repository::open(&args.repository)?);
    let event_loop = EventLoop::new().map_err(|e| {
        let named = |n: &str| std::env::var(n).map_or(String::new(), |v| format!(" {n}={v:?}"));
        anyhow::anyhow!(
            "cannot open a window: winit could not connect to the display{}{}: {e}",
            named("DISPLAY"),
            named("WAYLAND_DISPLAY")
        )
    })?;
    let h = *shared.header();
    let up = args.up.unwrap_or(default_up(h.dimension));
    if up == [0.0; 3] {
        anyhow::bail!("--up must not be the zero vector");
    }
    let navigation = navigation::Navigation::new(h.bbox_min, h.bbox_max, up, args.fov, args.orbit);
    let ctx = args
        .gpu
        .context_for_display(Box::new(event_loop.owned_display_handle()))?;
    let budget_bytes = args.gpu.budget_bytes(&ctx);
    let streaming = args.gpu.streaming(&ctx, shared.clone(), args.size)?;
    let mut controls = overlay::Controls::new(args.tolerance, args.mode);
    controls.flat = args.flat;
    controls.budget_mib = budget_bytes as f64 / (1u64 << 20) as f64;
    if let Some(ms) = args.target_ms {
        (controls.target, controls.target_ms) = (overlay::TargetChoice::FrameTime, ms);
    }
    if let Some(n) = args.target_triangles {
        (controls.target, controls.target_triangles) = (overlay::TargetChoice::Triangles, n);
    }
    let bookmarks = (args.bookmarks.clone()).unwrap_or_else(|| default_bookmarks(&args.repository));
    let setup = app::Setup {
        repo: shared.clone(),
        navigation,
        controls,
        budget_bytes,
        script,
        json: args.json,
        bookmarks,
        bookmarks_given: args.bookmarks.is_some(),
        gpu: args.gpu.clone(),
        up: args.up,
        record: args.record.clone(),
        frame_log: match &args.frame_log {
            Some(p) => Some(std::io::BufWriter::new(std::fs::File::create(p).map_err(
                |e| anyhow::anyhow!("cannot write the frame log {}: {e}", p.display()),
            )?)),
            None => None,
        },
    };
    let mut app = app::App::new(ctx, streaming, setup);
    event_loop
        .run_app(&mut app)
        .map_err(|e| anyhow::anyhow!("the window's event loop failed: {e}"))?;
    match app.error.take() {
        Some(e) => Err(e),
        None => Ok(Outcome::Ok),
    }
}

#[cfg(test)]
mod defaults_tests {
    use clap::Parser;

    use super::ViewArgs;

    #[derive(Parser)]
    struct Wrapper {
        #[command(flatten)]
        view: ViewArgs,
    }

    /// `ViewArgs::defaults` (what `demo --view` opens with) is what the command line gives.
    #[test]
    fn the_defaults_are_the_command_lines() {
        let parsed = Wrapper::parse_from(["tessera", "model.tsr"]).view;
        let made = ViewArgs::defaults("model.tsr".into());
        assert_eq!(parsed.repository, made.repository);
        assert_eq!(parsed.size, made.size);
        assert_eq!(parsed.tolerance, made.tolerance);
        assert_eq!(parsed.orbit, made.orbit);
        assert_eq!(parsed.up, made.up);
        assert_eq!(parsed.fov, made.fov);
        assert_eq!(parsed.mode, made.mode);
        assert_eq!(parsed.flat, made.flat);
        assert_eq!(parsed.script, made.script);
        assert_eq!(parsed.json, made.json);
        assert_eq!(parsed.gpu.gpu_budget, made.gpu.gpu_budget);
    }
}
