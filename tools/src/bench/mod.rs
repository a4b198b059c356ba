//! `tessera bench REPO --source INPUT [--tolerances 0.25,0.5,1,2,4,8,16] [--views N]
//! [--size WxH] [--samples N] [--frames N] [--json] [--plot DIR]`: the trade-off benchmark —
//! triangles, frame time and *measured* screen-space error per tolerance τ, ours against its
//! peers, all measured in the same run on the same mesh, cameras and tolerances.
//!
//! Subjects (`tessera_bench::subject::Subject`): `ours` here, the repository on the GPU
//! renderer, and the peers in tessera-bench (`tessera_bench::peers`, one file each):
//! - `full_resolution`: the source in one draw (error 0 by definition; the time baseline and
//!   the reference picture);
//! - `discrete_lod`: meshopt levels (`--lod-fractions`, nine by default), one per object by
//!   distance (seed 004);
//! - `cluster_dag`: meshoptimizer's clusterlod DAG, cut per frame on the CPU.
//!
//! The measurements:
//! - `dense` (the headline error, issue 46): every subject's cut at each of the check's eyes
//!   (`--error-views`, 16) and τ, its own rule without culling, measured densely against the
//!   repository's leaves both ways in pixels exactly as `check --errors` measures ours; once,
//!   before any frame (errors are deterministic);
//! - `trade_off` (on `tessera_runtime::measure`): on every view, the surface each subject drew
//!   is sampled sparsely and measured against the original mesh in pixels over what the eye
//!   sees (a secondary column), and its image compared with the full resolution; frames are
//!   timed in interleaved rounds (the median of `--frames` runs, with the spread).
//!
//! Then `verdict` compares ours front to front with each peer on the dense error (and, as
//! before, our rows against the peers' fronts on the sparse p99 and max), `report` prints,
//! `plots` draws.
//!
//! Cameras: `--views` eyes outside the bounding sphere (`views::outside_views`, 1.3 to 4
//! bounding radii), looking at the centre of the box.

pub mod cpu_cut;
pub mod dense;
pub mod front_verdict;
pub mod ours;
pub mod plots;
pub mod report;
pub mod trade_off;
pub mod verdict;

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use serde_json::json;
use tessera_bench::peers::{cluster_dag, discrete_lod, full_resolution, peer_mesh};
use tessera_bench::subject::Subject;
use tessera_core::repository::format::Header;
use tessera_core::repository::reader::Repository;
use tessera_runtime::camera::{bounding_radius, Camera};
use tessera_runtime::faces::Faces;
use tessera_runtime::gpu::full_mesh::FullMeshRenderer;
use tessera_runtime::measure::{ReferenceMesh, SamplingConfig, PSNR_SATURATED_DB};
use tessera_runtime::views::outside_views;

use self::trade_off::{Settings, SubjectRows};
use crate::cmd_render::{default_up, parse_size, parse_vec3};
use crate::progress::Stages;
use crate::Outcome;

/// The measurement's definition, stated in `bench --json` (`measure::two_sided_errors`):
/// samples on the drawn cut against the original and samples on the original against the
/// drawn cut, each distance projected over the sample's Euclidean distance to the eye (as the
/// run-time rule projects; before 2026-12-02 17:45 UTC the depth along the view axis), only
/// samples inside the view frustum that their own surface does not hide from the eye (a
/// segment cast from the eye through the surface's BVH: an exact depth test); the `error_*`
/// columns pool both directions. Before 2026-12-03 the error was one-sided (cut → original)
/// over every sample in the frustum, hidden or not. Image columns (pixels differing, PSNR)
/// over the model's pixels (pixels where both frames show the background left out; over every
/// pixel before 2026-12-02 17:58 UTC).
static METRIC: std::sync::LazyLock<serde_json::Value> = std::sync::LazyLock::new(|| {
    json!({
        "distance": "euclidean",
        "sides": "two-sided",
        "visible_only": true,
        "visibility": "segment cast from the eye against the sampled surface",
        "image_pixels": "model",
    })
});

/// The metric as stated for a run drawn with `faces`.
fn metric(faces: Faces) -> serde_json::Value {
    let mut m = METRIC.clone();
    m["faces"] = json!(match faces {
        Faces::Front => "front (back faces culled by every subject; samples facing away not seen)",
        Faces::Both => "both (every subject draws both faces; no normal-cone culling)",
    });
    m
}

#[derive(Args)]
pub struct TradeArgs {
    /// Repository file (built from --source).
    #[arg(required = true)]
    pub repository: Option<PathBuf>,
    /// The mesh the repository was built from: the original the error is measured against,
    /// and the input of every peer.
    #[arg(long, required = true)]
    pub source: Option<PathBuf>,
    /// Pixel tolerances τ, one row each.
    #[arg(long, value_delimiter = ',', default_value = "0.25,0.5,1,2,4,8,16")]
    pub tolerances: Vec<f32>,
    /// Camera positions, all outside the bounding sphere, looking at the model.
    #[arg(long, default_value_t = 8)]
    pub views: usize,
    /// Target size, WIDTHxHEIGHT (τ is in pixels of this height).
    #[arg(long, default_value = "1920x1080", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Points sampled per view on each drawn surface (against the original) and on the
    /// original (against each drawn surface) to measure the sparse, visible error both ways.
    #[arg(long, default_value_t = 20_000)]
    pub samples: usize,
    /// Eyes of the dense error pass (`check --errors`'s views: one in eight inside the model's
    /// box): every subject's cut at each eye and τ, no culling, measured densely against the
    /// input both ways. 0: no dense pass (timings and the sparse error only).
    #[arg(long, default_value_t = 16)]
    pub error_views: usize,
    /// Timed runs: rounds of one frame per view, subject and τ (after one warm-up round); a
    /// row's times are the median run's, with the fastest and slowest run as the spread.
    #[arg(long, default_value_t = 5)]
    pub frames: usize,
    /// Up direction of the cameras (default 0,1,0 for meshes, 0,0,1 for terrains).
    #[arg(long, value_parser = parse_vec3)]
    pub up: Option<[f64; 3]>,
    /// Write triangles_vs_tau.png, error_vs_tau.png, frame_time_vs_tau.png and
    /// triangles_vs_max_error.png here (created if missing).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Every subject draws both faces of every triangle (ours and the cluster DAG without
    /// normal-cone culling), and the error counts samples on faces turned away. Default: back
    /// faces culled by every subject, as our default frame draws, and such samples not seen.
    #[arg(long)]
    pub two_sided: bool,
    /// After each timed frame, draw it again with its selection (ours: the GPU traversal,
    /// compaction and expansion; the cluster DAG: its CPU cut and upload) and its raster
    /// waited for apart: the rows' `select_ms` and `raster_ms` (medians over the runs).
    #[arg(long)]
    pub phases: bool,
    /// The peers' settings (boxed: `BenchArgs` stays small).
    #[command(flatten)]
    pub peers: Box<PeerArgs>,
    #[command(flatten)]
    pub gpu: crate::gpu_args::GpuArgs,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The peers' settings: each at its best for the dense comparison by default (BENCHMARKS.md,
/// "The cluster DAG's settings").
#[derive(Args)]
pub struct PeerArgs {
    /// The cluster DAG's clod_build settings over the bench's default, `key=value` pairs
    /// separated by `;`: triangles=N (per cluster), partition=N (clusters per group),
    /// permissive=BOOL, sloppy=BOOL (sloppy fallback), ratio=X, edge-limit=X.
    #[arg(long, default_value = "", value_parser = cluster_dag::DagSettings::parse)]
    pub dag: cluster_dag::DagSettings,
    /// The discrete LODs' levels, shares of the source's triangles, finest first: 1 (the
    /// source), then strictly decreasing.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "1,0.5,0.25,0.125,0.0625,0.03125,0.015625,0.0078125,0.00390625"
    )]
    pub lod_fractions: Vec<f64>,
}

/// `count` cameras outside the bounding sphere of the model of `h`, looking at its box's
/// centre, `size` pixels, 60°, `up` as given.
pub fn outside_cameras(h: &Header, count: usize, size: (u32, u32), up: [f64; 3]) -> Vec<Camera> {
    let centre = [0, 1, 2].map(|i| 0.5 * (h.bbox_min[i] + h.bbox_max[i]));
    let radius = bounding_radius(h.bbox_min, h.bbox_max);
    outside_views(h.bbox_min, h.bbox_max, count)
        .into_iter()
        .map(|eye| Camera {
            up,
            width: size.0,
            height: size.1,
            ..Camera::looking_at(eye, centre, radius)
        })
        .collect()
}

/// The original mesh relative to `origin`, as the measurement's reference.
pub fn reference_mesh(
    mesh: &tessera_preprocess::InputMesh,
    origin: [f64; 3],
) -> anyhow::Result<ReferenceMesh> {
    let positions = mesh
        .positions
        .iter()
        .map(|p| [0, 1, 2].map(|i| p[i] - origin[i]))
        .collect();
    ReferenceMesh::new(positions, mesh.triangles.clone()).context("the reference mesh")
}

fn validate(args: &TradeArgs) -> anyhow::Result<()> {
    if args.tolerances.is_empty() {
        anyhow::bail!("--tolerances needs at least one value");
    }
    if let Some(bad) = args.tolerances.iter().find(|t| !t.is_finite() || **t < 0.0) {
        anyhow::bail!("tolerance {bad} must be a finite number ≥ 0");
    }
    for (flag, value) in [
        ("--views", args.views),
        ("--samples", args.samples),
        ("--frames", args.frames),
    ] {
        if value == 0 {
            anyhow::bail!("{flag} must be at least 1");
        }
    }
    discrete_lod::check_fractions(&args.peers.lod_fractions)
        .map_err(|e| anyhow::anyhow!("--lod-fractions: {e}"))?;
    if args.up == Some([0.0; 3]) {
        anyhow::bail!("--up must not be the zero vector");
    }
    Ok(())
}

pub fn run(args: TradeArgs) -> anyhow::Result<Outcome> {
    // Everything the user typed, before any work.
    validate(&args)?;
    let (Some(repo_path), Some(source_path)) = (&args.repository, &args.source) else {
        anyhow::bail!("usage: tessera bench REPO --source INPUT (or tessera bench build|render)");
    };
    if let Some(dir) = &args.plot {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create --plot {}", dir.display()))?;
    }
    let stages = Stages::new("bench");

    // The model and its original.
    stages.stage("load");
    let repo = crate::repository_arg::open(repo_path, "bench")?;
    let h = *repo.header();
    let mesh = crate::cmd_bench_render::load_source_mesh(source_path, &repo)?;
    stages.stage("reference BVH");
    let t = Instant::now();
    let reference = reference_mesh(&mesh, h.origin)?;
    let reference_seconds = t.elapsed().as_secs_f64();
    let peer_mesh = peer_mesh::PeerMesh::new(&mesh, h.origin);
    drop(mesh);

    // The peers' offline work.
    stages.stage("discrete levels (meshopt::simplify)");
    let levels = discrete_lod::build_levels(&peer_mesh, &args.peers.lod_fractions);
    stages.stage("cluster DAG (meshopt::clod_build)");
    let dag = cluster_dag::build(&peer_mesh, &args.peers.dag);

    // The dense errors, once: CPU only, before the GPU holds anything.
    let centre = [0, 1, 2].map(|i| (0.5 * (h.bbox_min[i] + h.bbox_max[i]) - h.origin[i]) as f32);
    let radius = bounding_radius(h.bbox_min, h.bbox_max) as f32;
    let dense = match args.error_views {
        0 => None,
        views => Some(dense_pass(
            &repo,
            &peer_mesh,
            &dag,
            &levels,
            (centre, radius),
            &args,
            views,
            &stages,
        )?),
    };

    // Our stored attribute errors over the diamonds our cuts draw at the dense pass's eyes, as
    // `check` reports them (the peers store none).
    let attribute_errors = (args.error_views > 0)
        .then(|| {
            let config = tessera_runtime::geometric_check::CheckConfig {
                viewport_height: args.size.1,
                ..Default::default()
            };
            let metric = tessera_runtime::geometric_check::check_metric(&h, &config);
            let eyes =
                tessera_runtime::views::check_views(h.bbox_min, h.bbox_max, args.error_views);
            crate::attribute_cut::cut_attribute_errors(&repo, &metric, &eyes, &args.tolerances)
        })
        .flatten();
    let largest_side = crate::attribute_cut::largest_texture_side(&repo);

    // The GPU side: every subject resident at once.
    stages.stage("upload");
    let ctx = args.gpu.context()?;
    let size = args.size;
    let renderer = args.gpu.renderer(&ctx, &repo, (size.0, size.1))?;
    // One face rule for every subject and for the measurement.
    let faces = if args.two_sided {
        Faces::Both
    } else {
        Faces::Front
    };
    let mut ours = ours::Ours::new(&repo, renderer, faces);
    let full_renderer = FullMeshRenderer::new(
        &ctx,
        &peer_mesh.positions,
        &peer_mesh.triangles,
        h.origin,
        size,
        faces,
    )
    .with_context(|| format!("uploading {}", source_path.display()))?;
    let mut full = full_resolution::FullResolution::new(&peer_mesh, full_renderer);
    let mut discrete = discrete_lod::DiscreteLod::new(
        &ctx,
        &peer_mesh,
        levels,
        (centre, radius),
        h.origin,
        size,
        faces,
    )?;
    let mut cluster = cluster_dag::ClusterDag::new(&ctx, &peer_mesh, dag, h.origin, size, faces)?;

    // The measurement.
    let up = args.up.unwrap_or(default_up(h.dimension));
    let cameras = outside_cameras(&h, args.views, size, up);
    let settings = Settings {
        tolerances: args.tolerances.clone(),
        frames: args.frames,
        sampling: SamplingConfig {
            samples_per_view: args.samples,
            ..Default::default()
        },
        origin: h.origin,
        faces,
        phases: args.phases,
    };
    let t = Instant::now();
    let mut subjects: [&mut dyn Subject; 3] = [&mut ours, &mut discrete, &mut cluster];
    let (rows, full_rows) = trade_off::measure(
        &ctx,
        &cameras,
        &mut subjects,
        Some(&mut full),
        &reference,
        &settings,
        &|v| stages.stage(&format!("view {} of {}", v + 1, cameras.len())),
    )?;
    let measure_seconds = t.elapsed().as_secs_f64();
    stages.finish();
    let full_rows = full_rows.context("the full-resolution rows")?;
    let (ours_rows, peers) = (&rows[0], [&full_rows, &rows[1], &rows[2]]);
    let comparisons = verdict::compare(ours_rows, &peers, verdict::Statistic::P99);
    let comparisons_max = verdict::compare(ours_rows, &peers, verdict::Statistic::Max);
    let fronts = dense.as_ref().map(dense_verdict).unwrap_or_default();

    // The report.
    let all: Vec<&SubjectRows> = std::iter::once(ours_rows).chain(peers).collect();
    let plots = match &args.plot {
        Some(dir) => plots::write_plots(dir, &all, dense.as_ref().map(|d| &d.subjects[..]))?,
        None => Vec::new(),
    };
    // Each row with its dense figures (null without the dense pass).
    let rows_json = |s: &SubjectRows| -> Vec<serde_json::Value> {
        let dense_rows = dense
            .as_ref()
            .and_then(|d| d.subjects.iter().find(|d| d.name == s.name));
        s.rows
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let mut v = report::row_json(r);
                v["dense"] =
                    dense_rows.map_or(serde_json::Value::Null, |d| dense::row_json(&d.rows[i]));
                v
            })
            .collect()
    };
    let stats = cluster.stats();
    let value = json!({
        "adapter": ctx.adapter_description(),
        "backend": ctx.backend.name(),
        "repository": repo_path.display().to_string(),
        "source": source_path.display().to_string(),
        "model_triangles": h.input_triangle_count,
        "size": {"width": size.0, "height": size.1},
        "views": cameras.len(),
        "cameras": cameras.iter().map(|c| c.eye).collect::<Vec<_>>(),
        "samples_per_view": args.samples,
        "frames": args.frames,
        "psnr_saturated_db": PSNR_SATURATED_DB,
        // What the error columns measure.
        "metric": metric(faces),
        "rows": rows_json(ours_rows),
        "peers": peers.iter().map(|s| (s.name.to_string(), json!(rows_json(s)))).collect::<serde_json::Map<_, _>>(),
        // The dense pass and the headline verdict on it.
        "dense": dense.as_ref().map(|d| dense::pass_json(&d.pass)),
        // Ours only, at the dense pass's eyes (null without the pass or without a table).
        "attribute_errors": crate::attribute_cut::per_tolerance_json(
            attribute_errors.as_deref(),
            largest_side,
        ),
        "verdict_dense": front_verdict::fronts_to_json(&fronts),
        "discrete_lod_levels": discrete.levels().map(|l| json!({
            "fraction": l.fraction,
            "triangles": l.triangles.len(),
            "error": l.error,
            "seconds": l.seconds,
        })).collect::<Vec<_>>(),
        "cluster_dag": {
            "clusters": stats.clusters,
            "groups": stats.groups,
            "levels": stats.levels,
            "max_triangles": stats.settings.cluster_triangles,
            "settings": {
                "max_triangles": stats.settings.cluster_triangles,
                "partition_size": stats.settings.partition_size,
                "permissive": stats.settings.permissive,
                "fallback_sloppy": stats.settings.fallback_sloppy,
                "ratio": stats.settings.ratio,
                "edge_limit": stats.settings.edge_limit,
                "text": stats.settings.to_string(),
            },
            "seconds": stats.seconds,
        },
        "verdict": verdict::to_json(&comparisons),
        "verdict_max": verdict::to_json(&comparisons_max),
        "plots": plots.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "seconds": {
            "reference_bvh": reference_seconds,
            "dense": dense.as_ref().map(|d| d.pass.seconds),
            "measure": measure_seconds,
        },
    });
    if args.json {
        println!("{value}");
        return Ok(Outcome::Ok);
    }
    println!("adapter: {}", ctx.adapter_description());
    println!(
        "model: {} ({} triangles); {} views outside the bounding sphere, {}x{}; {} samples a \
         view; {} timed runs (one frame per view, subject and τ each) after 1 warm-up",
        repo_path.display(),
        h.input_triangle_count,
        cameras.len(),
        size.0,
        size.1,
        args.samples,
        args.frames
    );
    for s in &all {
        let title = match s.name {
            "ours" => "ours (GPU traversal, stateless cut, frustum + cone culling)".to_string(),
            "full_resolution" => "full_resolution (one draw; error 0 by definition)".to_string(),
            "discrete_lod" => format!(
                "discrete_lod (levels {}; one per object by distance; one draw)",
                discrete
                    .levels()
                    .map(|l| format!(
                        "{} tris err {:.2e}",
                        verdict::group_digits(l.triangles.len() as f64),
                        l.error
                    ))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            "cluster_dag" => format!(
                "cluster_dag (clod_build {}: {} clusters in {} groups, {} levels; CPU cut with \
                 frustum + cone culling, triangles uploaded per frame: upload_ms in --json, apart \
                 from its CPU ms, in its wall ms)",
                stats.settings, stats.clusters, stats.groups, stats.levels
            ),
            other => other.to_string(),
        };
        println!();
        for line in report::table(&title, &s.rows) {
            println!("{line}");
        }
    }
    println!();
    println!("differ %: pixels with a channel off by > 8 levels; PSNR saturates at 99 dB");
    if let Some(d) = &dense {
        println!();
        for line in dense_table(d) {
            println!("{line}");
        }
        println!("verdict (front to front at equal dense max error, ours ÷ peer triangles):");
        for line in front_verdict::front_lines(&fronts) {
            println!("{line}");
        }
    }
    println!("verdict (fewest triangles at equal measured p99 error):");
    for line in verdict::lines(&comparisons) {
        println!("{line}");
    }
    println!(
        "verdict (fewest triangles at equal sparse visible max error, a sampled lower bound):"
    );
    for line in verdict::lines(&comparisons_max) {
        println!("{line}");
    }
    if let Some(per_tau) = &attribute_errors {
        println!("ours, stored attribute errors of the cuts at the dense pass's eyes:");
        crate::attribute_cut::print_per_tolerance(per_tau, largest_side);
    }
    for p in &plots {
        println!("plot written to {}", p.display());
    }
    Ok(Outcome::Ok)
}

/// The dense pass with the subjects that have one, its rows with the full resolution's.
pub struct Dense {
    pub pass: dense::DensePass,
    /// Ours, the cluster DAG, the discrete LODs, the full resolution (error 0).
    pub subjects: Vec<dense::DenseRows>,
}

/// Runs the dense pass (`dense`) over ours and the peers at `views` eyes.
#[allow(clippy::too_many_arguments)]
fn dense_pass(
    repo: &Repository,
    peer_mesh: &peer_mesh::PeerMesh,
    dag: &cluster_dag::Dag,
    levels: &[discrete_lod::Level],
    sphere: ([f32; 3], f32),
    args: &TradeArgs,
    views: usize,
    stages: &Stages,
) -> anyhow::Result<Dense> {
    let subjects = [
        dense::Subject::Ours(repo),
        dense::Subject::ClusterDag(dag, peer_mesh),
        dense::Subject::DiscreteLod(levels, sphere, peer_mesh),
    ];
    let settings = dense::DenseSettings {
        views,
        tolerances: args.tolerances.clone(),
        viewport_height: args.size.1,
    };
    stages.stage("dense errors");
    let pass = dense::measure(repo, &subjects, &settings, &|done, total| {
        stages.stage(&format!("dense errors: cut {done} of {total}"))
    })?;
    let mut all = pass.subjects.clone();
    all.push(dense::full_resolution_rows(
        peer_mesh.triangles.len(),
        &args.tolerances,
        views,
    ));
    Ok(Dense {
        pass,
        subjects: all,
    })
}

/// Ours against each measured peer, front to front on the dense max error.
fn dense_verdict(d: &Dense) -> Vec<front_verdict::FrontComparison> {
    let points = |rows: &dense::DenseRows| -> Vec<(f64, f64)> {
        rows.rows.iter().map(|r| (r.max_px, r.triangles)).collect()
    };
    let Some(ours) = d.subjects.iter().find(|s| s.name == "ours") else {
        return Vec::new();
    };
    let ours = points(ours);
    d.subjects
        .iter()
        .filter(|s| s.name != "ours" && s.name != "full_resolution")
        .map(|s| front_verdict::front_to_front(&ours, (s.name, &points(s))))
        .collect()
}

/// The dense figures as a table: per τ and subject, triangles, max px, max ÷ τ, worst eye.
fn dense_table(d: &Dense) -> Vec<String> {
    let mut lines = vec![format!(
        "dense errors (as check --errors: {} eyes, no culling, both ways against the leaves; \
         {} cuts in {:.1} s):",
        d.pass.eyes.len(),
        d.pass.cuts_measured,
        d.pass.seconds
    )];
    lines.push(format!(
        "{:>6} {:>16} {:>10} {:>10} {:>8} {:>6}",
        "τ px", "subject", "triangles", "max px", "max/τ", "eye"
    ));
    let taus = d.subjects.first().map_or(0, |s| s.rows.len());
    for i in 0..taus {
        for s in d.subjects.iter().filter(|s| s.name != "full_resolution") {
            let r = &s.rows[i];
            lines.push(format!(
                "{:>6} {:>16} {:>10} {:>10.3} {:>8.2} {:>6}",
                r.tolerance,
                s.name,
                verdict::group_digits(r.triangles),
                r.max_px,
                r.max_px / r.tolerance as f64,
                r.worst_view
            ));
        }
    }
    lines
}
