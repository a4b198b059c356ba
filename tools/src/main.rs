//! `tessera`: the command-line tool. Pipeline scripts depend on it: keep the flags, the JSON
//! keys and the exit codes stable (docs/cli.md lists them).
//!
//! Exit codes: 0 success; 1 a check found problems; 2 bad usage or bad input (a clear message
//! on stderr, no output file left behind); 3 the GPU device failed (lost, out of memory, a
//! read-back that could not be mapped: a clear message on stderr, never a panic).

mod attribute_cut;
mod bench;
mod bench_breakdown_locks;
mod bench_render_stream;
mod bench_stream_loops;
mod bench_stream_plot;
mod build_checkpoint;
mod build_grid;
mod camera_path;
mod check_errors;
mod cmd_bench;
mod cmd_bench_breakdown;
mod cmd_bench_errors;
mod cmd_bench_render;
mod cmd_bench_stream;
mod cmd_build;
mod cmd_check;
mod cmd_compare;
mod cmd_demo;
mod cmd_gen;
mod cmd_gen_mesh;
mod cmd_info;
mod cmd_render;
mod cmd_repack;
mod cmd_simplify;
mod demo_terrain;
mod gpu_args;
mod input;
mod output;
mod peak_rss;
mod progress;
mod repository_arg;
mod terrain;
mod view;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "tessera",
    version,
    about = "Multiresolution rendering of huge triangle meshes (LEB / diamonds)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Build a repository from a mesh (PLY, OBJ, OFF, STL, glTF/GLB; .gz accepted) or a height
    /// field (netCDF, NumPy, GeoTIFF, PNG/PGM, raw f32, JSON grid).
    Build(cmd_build::BuildArgs),
    /// Describe a repository.
    Info(cmd_info::InfoArgs),
    /// Rewrite a repository with its patches entropy-coded (the default), packed or stored as
    /// drawn (`--no-compress`), without a rebuild.
    Repack(cmd_repack::RepackArgs),
    /// Render a view of a repository to PNG on the GPU (lavapipe works).
    Render(cmd_render::RenderArgs),
    /// Check the cuts of a repository for cracks, non-manifold edges and monotonicity.
    Check(cmd_check::CheckArgs),
    /// Compare two images of one view over the model's pixels: PSNR, pixel counts, the
    /// largest channel difference.
    Compare(cmd_compare::CompareArgs),
    /// Benchmarks with their peers measured in the same run: `bench REPO --source INPUT` (the
    /// trade-off: triangles, frame time and measured error per τ against discrete LODs, a
    /// cluster DAG and the full resolution), `bench build INPUT`, `bench render REPO`.
    Bench(Box<cmd_bench::BenchArgs>),
    /// Generate a procedural 1.3 M-triangle mesh and a terrain, build them, check them, render
    /// a few frames to PNG, print a summary. Without a GPU adapter the frames are skipped (the reason is
    /// printed); the check alone decides the exit code.
    Demo(cmd_demo::DemoArgs),
    /// Generate inputs: `gen terrain` (diamond-square with a map of regions, seed 002), `gen mesh`
    /// (a closed procedural mesh of any size, streamed as binary PLY).
    Gen(cmd_gen::GenArgs),
    /// Simplify a mesh out of core (seed 004: octree vertex clustering with generalised
    /// quadrics): one mesh of N triangles, or the seed's levels, as binary PLY.
    Simplify(cmd_simplify::SimplifyArgs),
    /// Browse a repository in a window (orbit, pan, zoom; overlay with statistics and the
    /// tolerance); `--script FILE` runs scripted actions and screenshots, then exits.
    View(view::ViewArgs),
}

/// What a command reports: success, or a check that found problems (exit 1).
pub enum Outcome {
    Ok,
    CheckFailed,
}

fn main() -> ExitCode {
    restore_default_sigpipe();
    let cli = Cli::parse();
    let opens_a_window = match &cli.command {
        Command::View(_) => true,
        Command::Demo(args) => args.view,
        _ => false,
    };
    if !opens_a_window {
        keep_window_systems_out();
    }
    let result = match cli.command {
        Command::Build(args) => cmd_build::run(args),
        Command::Info(args) => cmd_info::run(args),
        Command::Repack(args) => cmd_repack::run(args),
        Command::Render(args) => cmd_render::run(args),
        Command::Check(args) => cmd_check::run(args),
        Command::Compare(args) => cmd_compare::run(args),
        Command::Demo(args) => cmd_demo::run(args),
        Command::Bench(args) => cmd_bench::run(*args),
        Command::Gen(args) => cmd_gen::run(args),
        Command::Simplify(args) => cmd_simplify::run(args),
        Command::View(args) => view::run(args),
    };
    match result {
        Ok(Outcome::Ok) => ExitCode::SUCCESS,
        Ok(Outcome::CheckFailed) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: {}", error_message(&e));
            // A device that failed (lost, out of memory, a failed read-back) is exit 3; every
            // other error 2.
            let device_failed = e.chain().any(|cause| {
                cause.is::<gpu_args::DeviceFailure>()
                    || cause.is::<tessera_runtime::gpu::GpuFailure>()
            });
            if device_failed {
                ExitCode::from(3)
            } else {
                ExitCode::from(2)
            }
        }
    }
}

/// Ends the process quietly when its standard output is a pipe closed early (`tessera info
/// REPO | head`), as Unix tools do: Rust ignores SIGPIPE, so the next `println!` would panic.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any thread; SIG_DFL is a valid disposition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Keeps the window systems out of a headless command's GPU instance. wgpu enables every
/// surface extension the Vulkan driver offers; Mesa's device-selection layer (an implicit
/// layer of `mesa-vulkan-drivers`) then connects to Wayland and X11 to find the display's GPU,
/// and libwayland prints "error: XDG_RUNTIME_DIR is invalid or not set" on a machine without
/// a desktop, though nothing failed. The layer only reorders adapters, which tessera chooses
/// itself (`--adapter`, `TESSERA_ADAPTER`, else the first usable by kind), so a command that
/// opens no window disables it, through the loader's documented `NODEVICE_SELECT=1`, unless
/// the user set it or `MESA_VK_DEVICE_SELECT` to steer the layer.
fn keep_window_systems_out() {
    let set = |name: &str| std::env::var_os(name).is_some();
    if !set("NODEVICE_SELECT") && !set("MESA_VK_DEVICE_SELECT") {
        // Before any thread is started: nothing reads the environment concurrently.
        std::env::set_var("NODEVICE_SELECT", "1");
    }
}

/// The error and its causes, each cause added only if the text so far does not already say it
/// (our error types print their cause in their own message).
fn error_message(e: &anyhow::Error) -> String {
    let mut message = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if !message.contains(&text) {
            if !message.is_empty() {
                message.push_str(": ");
            }
            message.push_str(&text);
        }
    }
    message
}
