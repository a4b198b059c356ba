//! `tessera bench render REPO [--source INPUT] [--tolerances 0.5,1,2,4] [--frames N]
//! [--size WxH] [--orbit AZ,EL,DIST] [--stream] [--json]`: the rendering benchmark with its
//! peer measured in the same run (`--stream`: the streaming renderer, no peer).
//!
//! One camera, one target size. For each tolerance τ, our renderer (stateless traversal +
//! batched strip draws, one submit a frame); with `--source`, also the full-resolution peer
//! (`FullMeshRenderer`: the source mesh in one indexed draw, same camera, target and shading).
//! Every subject renders `WARM_UP_FRAMES` frames, then `--frames` timed frames. Frames are
//! *interleaved* — round r draws frame r of every subject in turn — so that the machine's
//! load drifting during the run (the CPU driver lavapipe shares its cores with everything
//! else) hits every subject alike. Each frame is waited for before the next is submitted.
//!
//! Per subject: median and p90 GPU ms (timestamps: traversal start to end of the draws),
//! median wall ms (render call to completion: recording, submit, GPU, wait), median CPU ms
//! (the render call's own return: recording + submit, the per-frame CPU cost), patches and
//! triangles drawn (read back from one extra, untimed frame), and the speed-up over the full
//! resolution: ratio of median GPU ms (`speedup_vs_full`) and of median wall ms
//! (`wall_speedup_vs_full`; on a CPU driver such as lavapipe, whose timestamps may not cover
//! all of a frame's work, the wall ratio is the safer one).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use serde_json::json;
use tessera_core::repository::reader::Repository;
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::InputMesh;
use tessera_runtime::camera::{bounding_radius, Camera};
use tessera_runtime::faces::Faces;
use tessera_runtime::gpu::full_mesh::{relative_positions, FullMeshRenderer};
use tessera_runtime::gpu::{FrameRequest, Readback};

use crate::cmd_render::{default_up, parse_size, parse_vec3};
use crate::output::save_png;
use crate::Outcome;

/// Untimed frames each subject draws before the timed ones (pipelines, caches, lazy driver
/// state).
pub const WARM_UP_FRAMES: usize = 3;

/// Orbit of the default camera: azimuth, elevation (degrees), distance (bounding radii), as
/// `tessera render`.
const DEFAULT_ORBIT: [f64; 3] = [30.0, 20.0, 2.5];

#[derive(Args)]
pub struct RenderBenchArgs {
    /// Repository file.
    pub repository: PathBuf,
    /// The mesh the repository was built from: adds the full-resolution peer (the whole mesh
    /// in one indexed draw). Without it, only our renderer is measured.
    #[arg(long)]
    pub source: Option<PathBuf>,
    /// Pixel tolerances τ, one row each.
    #[arg(long, value_delimiter = ',', default_value = "0.5,1,2,4")]
    pub tolerances: Vec<f32>,
    /// Timed frames per subject (after 3 warm-up frames).
    #[arg(long, default_value_t = 20)]
    pub frames: usize,
    /// Target size, WIDTHxHEIGHT (τ is in pixels of this height).
    #[arg(long, default_value = "1920x1080", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Azimuth and elevation in degrees around the up axis, and distance in bounding radii from
    /// the centre of the model (default 30,20,2.5, as `tessera render`).
    #[arg(long, value_parser = parse_vec3)]
    pub orbit: Option<[f64; 3]>,
    /// Up direction (default 0,1,0 for meshes, 0,0,1 for terrains).
    #[arg(long, value_parser = parse_vec3)]
    pub up: Option<[f64; 3]>,
    /// Write one more, untimed frame of every subject here as PNG (full.png, tau-1.png, ...).
    #[arg(long)]
    pub save_frames: Option<PathBuf>,
    /// Draw through the streaming renderer, as `tessera render` does (a page pool within
    /// `--gpu-budget`, the roots resident, the rest loaded as the view asks): per τ, frames
    /// until the stream settles, then the warm-up and timed frames (τ after τ, not
    /// interleaved: each τ has its own resident set). Without it the renderer uploads the
    /// whole repository. Not with `--source`.
    #[arg(long, conflicts_with = "source")]
    pub stream: bool,
    #[command(flatten)]
    pub gpu: crate::gpu_args::GpuArgs,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The timings of one subject's timed frames.
#[derive(Clone, Debug, Default)]
pub(crate) struct Timings {
    pub gpu_ms: Vec<f64>,
    pub wall_ms: Vec<f64>,
    pub cpu_ms: Vec<f64>,
}

impl Timings {
    pub fn gpu_median(&self) -> Option<f64> {
        percentile(&self.gpu_ms, 0.5)
    }
}

/// The nearest-rank percentile `q` in (0, 1] of `values`; `None` when empty.
pub(crate) fn percentile(values: &[f64], q: f64) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let rank = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    Some(sorted[rank - 1])
}

/// One frame's numbers.
struct Frame {
    gpu_ms: Option<f64>,
    wall_ms: f64,
    cpu_ms: f64,
}

/// A subject of the benchmark: our renderer at one τ, or the full-resolution peer.
enum Subject {
    Ours { tau: f32 },
    Full,
}

/// The source mesh, positioned in the repository's frame.
struct Source {
    path: PathBuf,
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
}

pub fn run(args: RenderBenchArgs) -> anyhow::Result<Outcome> {
    // Everything the user typed, before any work.
    if args.tolerances.is_empty() {
        anyhow::bail!("--tolerances needs at least one value");
    }
    if let Some(bad) = args.tolerances.iter().find(|t| !t.is_finite() || **t < 0.0) {
        anyhow::bail!("tolerance {bad} must be a finite number ≥ 0");
    }
    if args.frames == 0 {
        anyhow::bail!("--frames must be at least 1");
    }
    let orbit = args.orbit.unwrap_or(DEFAULT_ORBIT);
    if orbit[2] <= 0.0 {
        anyhow::bail!("--orbit distance {} must be positive", orbit[2]);
    }
    if args.up == Some([0.0; 3]) {
        anyhow::bail!("--up must not be the zero vector");
    }

    // The model, the peer's mesh and the camera.
    // Opened (and its directory validated) once; `--stream` shares it with the streamer.
    let repo = std::sync::Arc::new(crate::repository_arg::open(
        &args.repository,
        "bench render",
    )?);
    let h = *repo.header();
    let source = match &args.source {
        Some(path) => Some(load_source(path, &repo)?),
        None => None,
    };
    let up = args.up.unwrap_or(default_up(h.dimension));
    let camera = Camera {
        width: args.size.0,
        height: args.size.1,
        ..Camera::orbit(h.bbox_min, h.bbox_max, up, orbit[0], orbit[1], orbit[2])
    };
    if let Some(dir) = &args.save_frames {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create --save-frames {}", dir.display()))?;
    }

    // The GPU side: both renderers resident at once.
    let ctx = args.gpu.context()?;
    if args.stream {
        return crate::bench_render_stream::run_streaming(&args, &ctx, repo, camera, orbit);
    }
    let mut renderer = args
        .gpu
        .renderer(&ctx, &repo, (camera.width, camera.height))?;
    let mut full = match &source {
        Some(s) => Some(
            FullMeshRenderer::new(
                &ctx,
                &s.positions,
                &s.triangles,
                h.origin,
                (camera.width, camera.height),
                // As ours draws: `FrameRequest::new`, one-sided.
                Faces::Front,
            )
            .with_context(|| format!("uploading {}", s.path.display()))?,
        ),
        None => None,
    };
    drop(source);

    // What each τ draws: one untimed frame with the selection read back.
    let drawn: Vec<(usize, u64)> = args
        .tolerances
        .iter()
        .map(|&tau| -> anyhow::Result<(usize, u64)> {
            renderer.render(
                &ctx,
                &FrameRequest::new(camera, tau),
                Readback {
                    image: false,
                    selection: true,
                },
            );
            let selection = renderer.read_selection(&ctx)?;
            let triangles = selection
                .iter()
                .map(|&i| repo.tets()[i as usize].triangle_count as u64)
                .sum();
            Ok((selection.len(), triangles))
        })
        .collect::<anyhow::Result<_>>()?;

    // The timed rounds, interleaved over the subjects.
    let mut subjects: Vec<Subject> = Vec::new();
    if full.is_some() {
        subjects.push(Subject::Full);
    }
    subjects.extend(args.tolerances.iter().map(|&tau| Subject::Ours { tau }));
    let mut timings = vec![Timings::default(); subjects.len()];
    // With --save-frames, one more untimed round copies the images out.
    let timed = WARM_UP_FRAMES..WARM_UP_FRAMES + args.frames;
    let rounds = timed.end + args.save_frames.is_some() as usize;
    for round in 0..rounds {
        let save = round == timed.end;
        for (subject, timing) in subjects.iter().zip(&mut timings) {
            let frame = match subject {
                Subject::Ours { tau } => {
                    let start = Instant::now();
                    let cpu_ms = renderer.render(
                        &ctx,
                        &FrameRequest::new(camera, *tau),
                        Readback {
                            image: save,
                            selection: false,
                        },
                    );
                    ctx.wait_idle()?;
                    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
                    if save {
                        let image = renderer.read_image(&ctx)?;
                        save_frame(&image, args.save_frames.as_deref(), &format!("tau-{tau}"))?;
                    }
                    Frame {
                        gpu_ms: renderer.read_gpu_ms(&ctx)?,
                        wall_ms,
                        cpu_ms,
                    }
                }
                Subject::Full => {
                    let full = full.as_mut().expect("a full subject has its renderer");
                    let start = Instant::now();
                    let cpu_ms = full.render(&ctx, &camera, save);
                    ctx.wait_idle()?;
                    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
                    if save {
                        let image = full.read_image(&ctx)?;
                        save_frame(&image, args.save_frames.as_deref(), "full")?;
                    }
                    Frame {
                        gpu_ms: full.read_gpu_ms(&ctx)?,
                        wall_ms,
                        cpu_ms,
                    }
                }
            };
            if timed.contains(&round) {
                timing.gpu_ms.extend(frame.gpu_ms);
                timing.wall_ms.push(frame.wall_ms);
                timing.cpu_ms.push(frame.cpu_ms);
            }
        }
    }

    // The report.
    let full_timing = full.is_some().then(|| &timings[0]);
    let ours_timings = &timings[subjects.len() - args.tolerances.len()..];
    let full_gpu = full_timing.and_then(Timings::gpu_median);
    let timing_json = |t: &Timings| {
        json!({
            "gpu_ms_median": t.gpu_median(),
            "gpu_ms_p90": percentile(&t.gpu_ms, 0.9),
            "wall_ms_median": percentile(&t.wall_ms, 0.5),
            "cpu_ms_median": percentile(&t.cpu_ms, 0.5),
            "cpu_ms_p90": percentile(&t.cpu_ms, 0.9),
        })
    };
    let speedup = |t: &Timings| Some(full_gpu? / t.gpu_median()?);
    let full_wall = full_timing.and_then(|t| percentile(&t.wall_ms, 0.5));
    let wall_speedup = |t: &Timings| Some(full_wall? / percentile(&t.wall_ms, 0.5)?);
    let rows: Vec<serde_json::Value> = args
        .tolerances
        .iter()
        .zip(&drawn)
        .zip(ours_timings)
        .map(|((&tau, &(patches, triangles)), t)| {
            let mut row = timing_json(t);
            row["tolerance"] = json!(tau);
            row["patches"] = json!(patches);
            row["triangles"] = json!(triangles);
            row["speedup_vs_full"] = json!(speedup(t));
            row["wall_speedup_vs_full"] = json!(wall_speedup(t));
            row
        })
        .collect();
    let full_json = full.as_ref().zip(full_timing).map(|(f, t)| {
        let mut v = timing_json(t);
        v["source"] = json!(args.source.as_ref().map(|p| p.display().to_string()));
        v["triangles"] = json!(f.triangle_count());
        v["vertices"] = json!(f.vertex_count());
        v["draw_calls"] = json!(1);
        v
    });
    let mut value = report(
        &args,
        &ctx,
        (h.input_triangle_count, repo.tets().len()),
        &camera,
        orbit,
        rows,
    );
    value["full_resolution"] = json!(full_json);
    value["memory"] = crate::peak_rss::MemoryNow::json(crate::peak_rss::MemoryNow::read(), None);
    if args.json {
        println!("{value}");
    } else {
        print_table(&value);
    }
    Ok(Outcome::Ok)
}

/// The fields every `bench render` report has (the subjects add theirs).
pub(crate) fn report(
    args: &RenderBenchArgs,
    ctx: &tessera_runtime::gpu::GpuContext,
    (model_triangles, simplices): (u64, usize),
    camera: &Camera,
    orbit: [f64; 3],
    rows: Vec<serde_json::Value>,
) -> serde_json::Value {
    json!({
        "adapter": ctx.adapter_description(),
        "backend": ctx.backend.name(),
        "repository": args.repository.display().to_string(),
        "model_triangles": model_triangles,
        "simplices": simplices,
        "size": {"width": camera.width, "height": camera.height},
        "camera": {
            "orbit": orbit,
            "eye": camera.eye,
            "target": camera.target,
            "up": camera.up,
            "fov_y_degrees": camera.fov_y_degrees,
        },
        "frames": args.frames,
        "warm_up_frames": WARM_UP_FRAMES,
        "rows": rows,
    })
}

/// Loads the source mesh and places it in the repository's frame; refuses a mesh that is
/// visibly not the one the repository was built from (another triangle count or box).
fn load_source(path: &Path, repo: &Repository) -> anyhow::Result<Source> {
    let mesh = load_source_mesh(path, repo)?;
    Ok(Source {
        path: path.to_path_buf(),
        positions: relative_positions(&mesh.positions, repo.header().origin),
        triangles: mesh.triangles,
    })
}

/// Loads (and welds) the mesh a repository was built from, refusing one that is visibly not
/// it: another triangle count after welding, or another bounding box (beyond 1e-4 of the
/// bounding radius).
pub(crate) fn load_source_mesh(path: &Path, repo: &Repository) -> anyhow::Result<InputMesh> {
    let h = repo.header();
    // A height field is meshed as `build` meshes it with its default options (a build with
    // --spacing or --exaggeration does not match, and is refused below).
    let mesh = if tessera_preprocess::dem::DemFormat::from_path(path).is_some() {
        use tessera_preprocess::dem::{load_dem, DemOptions, TerrainOptions};
        load_dem(path, &DemOptions::default())?.to_mesh(&TerrainOptions::default())
    } else {
        load_mesh(path)?.mesh
    };
    if mesh.triangles.len() as u64 != h.input_triangle_count {
        anyhow::bail!(
            "--source {} has {} triangles after welding, but the repository was built from {}: \
             not its source",
            path.display(),
            mesh.triangles.len(),
            h.input_triangle_count
        );
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &mesh.positions {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    let slack = 1e-4 * bounding_radius(h.bbox_min, h.bbox_max);
    let off = (0..3)
        .map(|i| {
            (lo[i] - h.bbox_min[i])
                .abs()
                .max((hi[i] - h.bbox_max[i]).abs())
        })
        .fold(0.0, f64::max);
    if off > slack {
        anyhow::bail!(
            "--source {}: its bounding box {lo:?}..{hi:?} is not the repository's {:?}..{:?}: \
             not its source",
            path.display(),
            h.bbox_min,
            h.bbox_max
        );
    }
    Ok(mesh)
}

pub(crate) fn save_frame(
    image: &image::RgbaImage,
    dir: Option<&Path>,
    name: &str,
) -> anyhow::Result<()> {
    match dir {
        Some(dir) => save_png(image, &dir.join(format!("{name}.png"))),
        None => Ok(()),
    }
}

/// The human table, from the JSON report.
pub(crate) fn print_table(v: &serde_json::Value) {
    // Numbers with `digits` decimals, integers and strings as they are, null as "n/a".
    let cell = |x: &serde_json::Value, digits: usize| match x {
        serde_json::Value::Null => "n/a".to_string(),
        serde_json::Value::String(s) => s.clone(),
        serde_json::Value::Number(n) if n.is_f64() => {
            format!("{:.digits$}", n.as_f64().unwrap_or(f64::NAN))
        }
        other => other.to_string(),
    };
    let line = |cells: [String; 9]| {
        println!(
            "{:>15} {:>8} {:>10} {:>11} {:>9} {:>12} {:>11} {:>9} {:>9}",
            cells[0],
            cells[1],
            cells[2],
            cells[3],
            cells[4],
            cells[5],
            cells[6],
            cells[7],
            cells[8]
        )
    };
    let camera = &v["camera"];
    println!("adapter: {}", cell(&v["adapter"], 0));
    println!(
        "model: {} ({} triangles, {} simplices); target {}x{}; camera orbit {} (eye {})",
        cell(&v["repository"], 0),
        v["model_triangles"],
        v["simplices"],
        v["size"]["width"],
        v["size"]["height"],
        camera["orbit"],
        camera["eye"],
    );
    println!(
        "{} timed frames per subject after {} warm-up, subjects interleaved, each frame waited for",
        v["frames"], v["warm_up_frames"],
    );
    line(
        [
            "τ px",
            "patches",
            "triangles",
            "GPU ms med",
            "GPU p90",
            "wall ms med",
            "CPU ms med",
            "GPU ×",
            "wall ×",
        ]
        .map(String::from),
    );
    let full = &v["full_resolution"];
    if !full.is_null() {
        line([
            "full resolution".to_string(),
            "1 draw".to_string(),
            cell(&full["triangles"], 0),
            cell(&full["gpu_ms_median"], 2),
            cell(&full["gpu_ms_p90"], 2),
            cell(&full["wall_ms_median"], 2),
            cell(&full["cpu_ms_median"], 3),
            "1.00".to_string(),
            "1.00".to_string(),
        ]);
    }
    for row in v["rows"].as_array().into_iter().flatten() {
        line([
            cell(&row["tolerance"], 1),
            cell(&row["patches"], 0),
            cell(&row["triangles"], 0),
            cell(&row["gpu_ms_median"], 2),
            cell(&row["gpu_ms_p90"], 2),
            cell(&row["wall_ms_median"], 2),
            cell(&row["cpu_ms_median"], 3),
            cell(&row["speedup_vs_full"], 2),
            cell(&row["wall_speedup_vs_full"], 2),
        ]);
    }
    if full.is_null() {
        println!("(no --source: no full-resolution peer, no speed-up)");
    } else {
        println!("GPU ×, wall ×: speed-up over the full resolution, ratio of median GPU / wall ms");
    }
}

#[cfg(test)]
mod tests {
    use super::percentile;

    #[test]
    fn percentiles_are_nearest_rank() {
        let v: Vec<f64> = (1..=20).rev().map(f64::from).collect();
        assert_eq!(percentile(&v, 0.5), Some(10.0));
        assert_eq!(percentile(&v, 0.9), Some(18.0));
        assert_eq!(percentile(&[3.0], 0.9), Some(3.0));
        assert_eq!(percentile(&[], 0.5), None);
    }
}
