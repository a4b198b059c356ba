//! `tessera bench terrain DEM [--budgets ...] [--views N] [--frames F] [--cluster-sizes ...]
//! [--size WxH] [--json] [--plot DIR]`: ROAM, RUSTiC and tessera's 2D path on one height
//! field, at equal triangle budgets, with the same cameras — RUSTiC's table 4.1 extended with
//! frame costs.
//!
//! Per method and budget, over `views` camera paths above the terrain (`views::terrain_views`,
//! those from above), each `frames` frames long (the eye moves forward 0.2 % of the terrain's
//! width a frame, so ROAM's frame-to-frame coherence works as it would in a flight):
//! - triangles drawn (mean over the paths' last frames);
//! - vertical error of the last frame's surface against the full grid at every grid sample
//!   (`grid::vertical_error`; metres): max over views, mean over views;
//! - CPU ms per frame: everything a method does on the CPU per frame — ROAM's (RUSTiC's)
//!   split/merge update, gathering its triangles and uploading their indices, recording and
//!   submitting the draw; tessera's uniforms, recording and submit (the GPU traverses) —
//!   median over frames after each path's first;
//! - frame ms: from the frame's start to the end of the GPU's work (on lavapipe the CPU
//!   rasterises), median likewise.
//!
//! Equal budgets: ROAM and RUSTiC take the budget as their target (RUSTiC as ⌈budget / mean
//! cluster size⌉ ROAM triangles); tessera is τ-driven, so each path's τ is found by bisection
//! (on the CPU reference selection at the path's first eye) to draw the budget. Culling is off
//! for every method (every method's whole surface is measured against the whole grid); the
//! cameras use one metric, 60° and the target's height in pixels.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::bail;
use clap::Args;
use serde_json::json;
use tessera_bench::terrain::grid::{sample_triangle, vertical_error, BinGrid, VerticalError};
use tessera_bench::terrain::roam::{Roam, RoamView, WedgieErrors};
use tessera_bench::terrain::rustic::{Rustic, RusticFrame, RusticRenderer};
use tessera_bench::terrain::square_mesh::SquareMesh;
use tessera_core::cull::CullTests;
use tessera_core::cut::{diamond_rhos, select_stateless};
use tessera_core::repository::format::dequantize_position;
use tessera_core::repository::reader::Repository;
use tessera_preprocess::{build_repository, BuildConfig, Domain};
use tessera_runtime::camera::{bounding_radius, Camera, Z_UP};
use tessera_runtime::gpu::{FrameRequest, GpuContext, Readback, ShadingMode};
use tessera_runtime::views::terrain_views;

use crate::input::HeightFieldArgs;
use crate::Outcome;

#[derive(Args)]
pub struct TerrainBenchArgs {
    /// The height field (any DEM format `tessera build` reads).
    pub dem: PathBuf,
    #[command(flatten)]
    pub heightfield: HeightFieldArgs,
    /// Triangle budgets, one row per method each (budgets ≥ the full grid are left out).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "5000,10000,20000,40000,80000"
    )]
    pub budgets: Vec<usize>,
    /// RUSTiC cluster sizes (adaptive merge), one row set each.
    #[arg(long, value_delimiter = ',', default_value = "16,32,64,128")]
    pub cluster_sizes: Vec<usize>,
    /// Camera paths (views from above the terrain).
    #[arg(long, default_value_t = 4)]
    pub views: usize,
    /// Frames per path (≥ 2: the first frame of a path is not timed).
    #[arg(long, default_value_t = 6)]
    pub frames: usize,
    /// Target size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1920x1080", value_parser = crate::cmd_render::parse_size)]
    pub size: (u32, u32),
    /// Write error_vs_triangles.png, cpu_vs_triangles.png, frame_time_vs_triangles.png here.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    #[command(flatten)]
    pub gpu: crate::gpu_args::GpuArgs,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// One method at one budget.
#[derive(Clone, Debug, PartialEq)]
pub struct TerrainRow {
    pub budget: usize,
    /// RUSTiC's cluster size.
    pub cluster_size: Option<usize>,
    /// Mean over views of the last frame's triangles.
    pub triangles: f64,
    /// RUSTiC: mean ROAM triangles (clusters); tessera: mean patches.
    pub units: f64,
    pub error_max_m: f64,
    pub error_mean_m: f64,
    pub cpu_ms: f64,
    pub frame_ms: f64,
    /// tessera: mean τ (pixels) over the views.
    pub tau: Option<f64>,
}

impl TerrainRow {
    fn json(&self) -> serde_json::Value {
        let mut v = json!({
            "budget": self.budget,
            "triangles": self.triangles,
            "error_max_m": self.error_max_m,
            "error_mean_m": self.error_mean_m,
            "cpu_ms": self.cpu_ms,
            "frame_ms": self.frame_ms,
        });
        if let Some(n) = self.cluster_size {
            v["cluster_size"] = json!(n);
            v["clusters"] = json!(self.units);
        }
        if let Some(tau) = self.tau {
            v["tau"] = json!(tau);
            v["patches"] = json!(self.units);
        }
        v
    }
}

/// Per-view accumulation of one (method, budget).
#[derive(Default)]
struct Accumulator {
    triangles: Vec<f64>,
    units: Vec<f64>,
    errors: Vec<VerticalError>,
    cpu_ms: Vec<f64>,
    frame_ms: Vec<f64>,
    taus: Vec<f64>,
}

impl Accumulator {
    fn row(&self, budget: usize, cluster_size: Option<usize>) -> TerrainRow {
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        TerrainRow {
            budget,
            cluster_size,
            triangles: mean(&self.triangles),
            units: mean(&self.units),
            error_max_m: self.errors.iter().map(|e| e.max).fold(0.0, f64::max),
            error_mean_m: mean(&self.errors.iter().map(|e| e.mean).collect::<Vec<_>>()),
            cpu_ms: median(&self.cpu_ms),
            frame_ms: median(&self.frame_ms),
            tau: (!self.taus.is_empty()).then(|| mean(&self.taus)),
        }
    }
}

fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut v = v.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// The camera paths: `views` paths of `frames` cameras each.
fn camera_paths(repo: &Repository, args: &TerrainBenchArgs) -> Vec<Vec<Camera>> {
    let h = repo.header();
    let radius = bounding_radius(h.bbox_min, h.bbox_max);
    let width = (h.bbox_max[0] - h.bbox_min[0]).max(h.bbox_max[1] - h.bbox_min[1]);
    terrain_views(h.bbox_min, h.bbox_max, 2 * args.views)
        .into_iter()
        .filter(|v| !v.from_below)
        .map(|v| {
            let d = [v.target[0] - v.eye[0], v.target[1] - v.eye[1]];
            let l = (d[0] * d[0] + d[1] * d[1]).sqrt().max(1e-30);
            let step = [d[0] / l * 0.002 * width, d[1] / l * 0.002 * width];
            (0..args.frames)
                .map(|f| {
                    let shift =
                        |p: [f64; 3]| [p[0] + f as f64 * step[0], p[1] + f as f64 * step[1], p[2]];
                    Camera {
                        up: Z_UP,
                        width: args.size.0,
                        height: args.size.1,
                        ..Camera::looking_at(shift(v.eye), shift(v.target), radius)
                    }
                })
                .collect()
        })
        .collect()
}

/// ROAM's view of a camera, with frustum culling off (all methods refine the whole terrain).
fn roam_view(camera: &Camera) -> RoamView {
    RoamView {
        frustum: [[0.0, 0.0, 0.0, 1.0]; 6],
        ..RoamView::from_camera(camera)
    }
}

/// ρ of every diamond from `camera` (what tessera's selections at any τ share).
fn camera_rhos(repo: &Repository, camera: &Camera) -> Vec<f32> {
    let origin = repo.header().origin;
    diamond_rhos(repo.diamonds(), camera.eye_local(origin), &camera.metric())
}

/// tessera's selection at `tau` without culling: (simplices, triangles).
fn tessera_cut(repo: &Repository, rhos: &[f32], tau: f32) -> (Vec<u32>, usize) {
    let cut = select_stateless(repo.tets(), rhos, tau);
    let triangles = cut
        .iter()
        .map(|&i| repo.tets()[i as usize].triangle_count as usize)
        .sum();
    (cut, triangles)
}

/// The τ whose cut from `camera` draws closest to `budget` triangles (bisection on log τ).
fn tau_for_budget(repo: &Repository, camera: &Camera, budget: usize) -> f32 {
    let rhos = camera_rhos(repo, camera);
    let count = |t: f64| tessera_cut(repo, &rhos, t as f32).1;
    let (mut lo, mut hi) = (1e-4f64, 1e6f64);
    for _ in 0..40 {
        let mid = (lo * hi).sqrt();
        if count(mid) > budget {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let miss = |t: f64| count(t).abs_diff(budget);
    if miss(lo) < miss(hi) {
        lo as f32
    } else {
        hi as f32
    }
}

/// The triangles of a tessera cut in sample coordinates (column, row, height).
fn tessera_surface(
    repo: &Repository,
    grid: &BinGrid,
    cut: &[u32],
) -> anyhow::Result<Vec<[[f64; 3]; 3]>> {
    let h = repo.header();
    let mut out = Vec::new();
    for &i in cut {
        let patch = repo.patch(i as usize)?;
        let patch = patch.view();
        let positions: Vec<[f64; 3]> = (0..patch.vertex_count())
            .map(|v| {
                let p = dequantize_position(patch.position(v), h.bbox_min, h.position_step);
                [
                    (p[0] - grid.origin[0]) / grid.spacing[0],
                    (p[1] - grid.origin[1]) / grid.spacing[1],
                    p[2],
                ]
            })
            .collect();
        out.extend(patch.triangles().map(|t| t.map(|v| positions[v as usize])));
    }
    Ok(out)
}

pub fn run(args: TerrainBenchArgs) -> anyhow::Result<Outcome> {
    if args.frames < 2 || args.views == 0 {
        bail!("--frames must be at least 2 and --views at least 1");
    }
    if args.budgets.is_empty() || args.budgets.contains(&0) {
        bail!("--budgets must list positive triangle counts");
    }
    if args.cluster_sizes.iter().any(|&n| !(1..=4096).contains(&n)) {
        bail!("--cluster-sizes must be in 1..=4096");
    }
    let started = Instant::now();
    let options = args.heightfield.terrain_options()?;
    let dem = args.heightfield.load_grid(&args.dem)?;
    let mesh = dem.to_mesh(&options);
    let full = mesh.triangles.len();
    let budgets: Vec<usize> = args.budgets.iter().copied().filter(|&b| b < full).collect();
    if budgets.is_empty() {
        bail!("every budget is ≥ the full grid's {full} triangles");
    }

    // tessera's repository, built as `tessera build` would.
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("terrain.tsr");
    let config = BuildConfig::for_domain(Domain::HeightField);
    let t = Instant::now();
    build_repository(&mesh, &config, &path, &|_| {})?;
    let build_seconds = t.elapsed().as_secs_f64();
    drop(mesh);
    let repo = Repository::open(&path)?;
    let origin = repo.header().origin;

    let grid = BinGrid::new(&dem, &options);
    let paths = camera_paths(&repo, &args);
    let ctx = args.gpu.context()?;
    let mut square = SquareMesh::new(&ctx, &grid, origin, args.size)?;
    let mut ours = args.gpu.renderer(&ctx, &repo, args.size)?;
    let progress = |what: &str| {
        if !args.json {
            eprintln!("[{:6.1} s] {what}", started.elapsed().as_secs_f64());
        }
    };

    // ROAM: nested wedgies over the whole square; one triangulation kept across frames.
    progress("ROAM");
    let t = Instant::now();
    let mut roam = Roam::new(&grid, WedgieErrors::from_grid(&grid));
    let roam_setup_seconds = t.elapsed().as_secs_f64();
    let mut roam_rows = Vec::new();
    for &budget in &budgets {
        let acc = measure_baseline(&ctx, &grid, &mut square, &paths, |camera| {
            roam.update(&grid, &roam_view(camera), budget);
            let triangles: Vec<[[i32; 2]; 3]> = roam.leaves().iter().map(|t| t.corners()).collect();
            let count = triangles.len();
            (triangles, count)
        })?;
        roam_rows.push(acc.row(budget, None));
    }
    drop(roam);

    // RUSTiC: clusters per size, then ROAM over them.
    let mut rustic_rows = Vec::new();
    let mut rustic_builds = Vec::new();
    for &size in &args.cluster_sizes {
        progress(&format!("RUSTiC, clusters of {size}"));
        let t = Instant::now();
        let clusters = Rustic::build(&grid, size);
        let build = t.elapsed().as_secs_f64();
        rustic_builds.push(json!({
            "cluster_size": size,
            "seconds": build,
            "mean_cluster_triangles": clusters.mean_cluster_triangles(),
            "bytes": clusters.heap_bytes(),
        }));
        let mut renderer = RusticRenderer::new(&grid, clusters);
        for &budget in &budgets {
            let acc = measure_baseline(&ctx, &grid, &mut square, &paths, |camera| {
                let frame: RusticFrame = renderer.update(&grid, &roam_view(camera), budget);
                (renderer.triangles(), frame.roam_triangles)
            })?;
            rustic_rows.push(acc.row(budget, Some(size)));
        }
    }

    // tessera: τ per path for the budget; the GPU traverses.
    progress("tessera");
    let mut tessera_rows = Vec::new();
    let no_culling = CullTests {
        frustum: None,
        cones: false,
    };
    for &budget in &budgets {
        let mut acc = Accumulator::default();
        for path in &paths {
            let tau = tau_for_budget(&repo, &path[0], budget);
            time_path(&ctx, path, &mut acc, |camera| {
                let request = FrameRequest {
                    camera: *camera,
                    tau,
                    cull: no_culling,
                    mode: ShadingMode::Lit,
                    wireframe: false,
                    two_sided: false,
                    draw_camera: None,
                };
                Ok(ours.render(&ctx, &request, Readback::default()))
            })?;
            let last = path.last().expect("frames ≥ 2");
            let (cut, triangles) = tessera_cut(&repo, &camera_rhos(&repo, last), tau);
            acc.triangles.push(triangles as f64);
            acc.units.push(cut.len() as f64);
            acc.taus.push(tau as f64);
            let surface = tessera_surface(&repo, &grid, &cut)?;
            acc.errors.push(vertical_error(&grid, &surface));
        }
        tessera_rows.push(acc.row(budget, None));
    }

    let plots = match &args.plot {
        Some(dir) => super::plots::write_plots(dir, &roam_rows, &rustic_rows, &tessera_rows)?,
        None => Vec::new(),
    };
    let summary = json!({
        "dem": args.dem.display().to_string(),
        "grid": {"columns": dem.columns, "rows": dem.rows, "triangles": full,
                 "square_side": grid.side},
        "size": [args.size.0, args.size.1],
        "views": paths.len(),
        "frames_per_view": args.frames,
        "adapter": ctx.adapter_description(),
        "backend": ctx.backend.name(),
        "tessera_build_seconds": build_seconds,
        "roam_setup_seconds": roam_setup_seconds,
        "rustic_builds": rustic_builds,
        "roam": roam_rows.iter().map(TerrainRow::json).collect::<Vec<_>>(),
        "rustic": rustic_rows.iter().map(TerrainRow::json).collect::<Vec<_>>(),
        "tessera": tessera_rows.iter().map(TerrainRow::json).collect::<Vec<_>>(),
        "plots": plots.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "seconds": started.elapsed().as_secs_f64(),
    });
    if args.json {
        println!("{summary}");
    } else {
        print_table(&args, &dem, &ctx, &roam_rows, &rustic_rows, &tessera_rows);
        for p in &plots {
            println!("wrote {}", p.display());
        }
    }
    Ok(Outcome::Ok)
}

/// A baseline over every path: `frame` updates its triangulation for a camera and returns its
/// triangles (sample-point corners) and its draw units; the frame's CPU time runs from the
/// update to the submit, its frame time to the end of the GPU's work; the error is the last
/// frame's of each path.
fn measure_baseline(
    ctx: &GpuContext,
    grid: &BinGrid,
    square: &mut SquareMesh,
    paths: &[Vec<Camera>],
    mut frame: impl FnMut(&Camera) -> (Vec<[[i32; 2]; 3]>, usize),
) -> anyhow::Result<Accumulator> {
    let mut acc = Accumulator::default();
    for path in paths {
        let mut last = (Vec::new(), 0);
        time_path(ctx, path, &mut acc, |camera| {
            let start = Instant::now();
            last = frame(camera);
            square.draw(ctx, camera, &last.0)?;
            Ok(start.elapsed().as_secs_f64() * 1e3)
        })?;
        acc.triangles.push(last.0.len() as f64);
        acc.units.push(last.1 as f64);
        let surface: Vec<_> = last.0.iter().map(|&c| sample_triangle(grid, c)).collect();
        acc.errors.push(vertical_error(grid, &surface));
    }
    Ok(acc)
}

/// Runs `frame` for every camera of `path` (it returns the frame's CPU milliseconds), waits
/// for the GPU after each, and records the frames after the path's first (the first is a
/// jump from wherever the method was).
fn time_path(
    ctx: &GpuContext,
    path: &[Camera],
    acc: &mut Accumulator,
    mut frame: impl FnMut(&Camera) -> anyhow::Result<f64>,
) -> anyhow::Result<()> {
    for (f, camera) in path.iter().enumerate() {
        let start = Instant::now();
        let cpu_ms = frame(camera)?;
        ctx.wait_idle()?;
        if f > 0 {
            acc.cpu_ms.push(cpu_ms);
            acc.frame_ms.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    Ok(())
}

fn print_table(
    args: &TerrainBenchArgs,
    dem: &tessera_preprocess::dem::HeightGrid,
    ctx: &GpuContext,
    roam: &[TerrainRow],
    rustic: &[TerrainRow],
    tessera: &[TerrainRow],
) {
    println!(
        "{}: {} × {} grid; {} views × {} frames at {}x{}; {}",
        args.dem.display(),
        dem.columns,
        dem.rows,
        args.views,
        args.frames,
        args.size.0,
        args.size.1,
        ctx.adapter_description()
    );
    println!(
        "{:>8} {:>10} {:>8} {:>10} {:>12} {:>12} {:>9} {:>9}",
        "budget", "method", "cluster", "triangles", "max err m", "mean err m", "CPU ms", "frame ms"
    );
    let mut all: Vec<(&str, &TerrainRow)> = roam.iter().map(|r| ("roam", r)).collect();
    all.extend(rustic.iter().map(|r| ("rustic", r)));
    all.extend(tessera.iter().map(|r| ("tessera", r)));
    all.sort_by_key(|(_, r)| r.budget);
    for (name, r) in all {
        println!(
            "{:>8} {:>10} {:>8} {:>10.0} {:>12.2} {:>12.3} {:>9.3} {:>9.2}",
            r.budget,
            name,
            r.cluster_size.map_or("-".into(), |n| n.to_string()),
            r.triangles,
            r.error_max_m,
            r.error_mean_m,
            r.cpu_ms,
            r.frame_ms
        );
    }
}
