//! `tessera bench build INPUT`: the build benchmark with its peer measured in the same run.
//!
//! Times our build (hierarchy, diamond simplification, saturation, strips, file) and
//! meshoptimizer's `clod_build` (128-triangle clusters, the clusterlod DAG builder) on the same
//! welded mesh, and reports throughput, their ratio, peak RSS, repository bytes against the
//! binary PLY of the same mesh, and triangles per patch. `--sweep` repeats our build over leaf
//! sizes and adds what each costs at run time: the mean cut size at τ = 1 px over the check views,
//! and the *measured* error of the τ = 1 px cut (p99 and max over `MEASURE_VIEWS` views outside
//! the model, 1920×1080, `bench::cpu_cut`).

use std::path::PathBuf;
use std::time::Instant;

use clap::{Args, Subcommand};
use serde_json::json;
use tessera_core::cut::{diamond_rhos, select_stateless};
use tessera_core::metric::{eye_local, ScreenSpaceMetric};
use tessera_core::repository::reader::Repository;
use tessera_preprocess::{
    build_repository, BuildConfig, Construction, Domain, InputMesh, SimplifySettings,
};
use tessera_runtime::views::check_views;

use tessera_runtime::measure::{ErrorSummary, ReferenceMesh, SamplingConfig};

use crate::bench::{cpu_cut, outside_cameras, reference_mesh};
use crate::cmd_render::default_up;
use crate::output::write_binary_ply;
use crate::Outcome;

/// Views of the sweep's measured error (outside the bounding sphere, 1920×1080).
pub const MEASURE_VIEWS: usize = 8;

/// `tessera bench REPO --source INPUT ...` (the trade-off benchmark, `crate::bench`), or one of
/// the subcommands `build` and `render`: a first argument named like a subcommand is one.
#[derive(Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct BenchArgs {
    #[command(subcommand)]
    pub what: Option<BenchWhat>,
    #[command(flatten)]
    pub trade: crate::bench::TradeArgs,
}

#[derive(Subcommand)]
pub enum BenchWhat {
    /// Build throughput against meshopt's clod_build, repository size, peak memory.
    Build(BuildBenchArgs),
    /// Frame times (GPU, wall, CPU) per tolerance against the full mesh in one draw call.
    Render(crate::cmd_bench_render::RenderBenchArgs),
    /// A height field: ROAM, RUSTiC and tessera at equal triangle budgets (vertical error
    /// against the full grid, CPU ms per frame, frame time).
    Terrain(crate::terrain::bench::TerrainBenchArgs),
    /// A camera path under a residency budget, warm and cold: resident bytes, loads, missing
    /// units, max ρ/τ of the drawn cut and frame ms per frame (CPU traversal).
    Stream(crate::cmd_bench_stream::StreamBenchArgs),
    /// Object-space cuts against the input: the sampled two-sided distance of each cut to the
    /// leaves, against the largest error the cut's diamonds store (are they bounds?).
    Errors(crate::cmd_bench_errors::ErrorsBenchArgs),
    /// Where our triangles go (no GPU): each τ's cut with the sphere projection against a
    /// box projection of each diamond's own patches, and each level's reduction and the share
    /// of kept triangles on the locked border.
    Breakdown(crate::cmd_bench_breakdown::BreakdownBenchArgs),
}

#[derive(Args)]
pub struct BuildBenchArgs {
    /// Input mesh.
    pub input: PathBuf,
    /// Worker threads for our build (clod_build is single-threaded).
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Leaf size of our build.
    #[arg(long)]
    pub leaf_triangles: Option<usize>,
    /// Also build with each of these leaf sizes and report the run-time trade.
    #[arg(long, value_delimiter = ',')]
    pub sweep: Vec<usize>,
    /// Also build (default leaf size) with each of these simplifier `keep` shares: the share
    /// of its gathered triangles a diamond keeps (default 0.5).
    #[arg(long, value_delimiter = ',')]
    pub sweep_keep: Vec<f32>,
    /// Also build (default leaf size) with each of these normal weights (inputs with normals;
    /// default 0.05).
    #[arg(long, value_delimiter = ',')]
    pub sweep_normal_weight: Vec<f32>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub heightfield: crate::input::HeightFieldArgs,
}

pub fn run(args: BenchArgs) -> anyhow::Result<Outcome> {
    match args.what {
        Some(BenchWhat::Build(a)) => bench_build(a),
        Some(BenchWhat::Render(a)) => crate::cmd_bench_render::run(a),
        Some(BenchWhat::Terrain(a)) => crate::terrain::bench::run(a),
        Some(BenchWhat::Stream(a)) => crate::cmd_bench_stream::run(a),
        Some(BenchWhat::Errors(a)) => crate::cmd_bench_errors::run(a),
        Some(BenchWhat::Breakdown(a)) => crate::cmd_bench_breakdown::run(a),
        None => crate::bench::run(args.trade),
    }
}

fn bench_build(args: BuildBenchArgs) -> anyhow::Result<Outcome> {
    let t = Instant::now();
    let input = crate::input::load_input(&args.input, &args.heightfield)?;
    let (mut mesh, domain) = (input.mesh, input.domain);
    // As `tessera build` does (counted with the import).
    tessera_preprocess::normals::compute_missing_normals(&mut mesh);
    let import_seconds = t.elapsed().as_secs_f64();
    let dir = tempfile::tempdir()?;
    let ply_bytes = write_binary_ply(&mesh, &dir.path().join("mesh.ply"))?;
    let triangles = mesh.triangles.len() as f64;

    // Ours, first, so that the peak RSS read right after it is ours alone.
    let leaf = args
        .leaf_triangles
        .unwrap_or(domain.default_leaf_triangles());
    let defaults = BuildConfig::for_domain(domain).simplify;
    let ours = build_once(
        &mesh,
        domain,
        leaf,
        defaults,
        args.threads,
        &dir.path().join("ours.tsr"),
    )?;
    let peak_rss_bytes = peak_rss_bytes();

    // The peer: clod_build with 128-triangle clusters on the same positions and indices.
    let t = Instant::now();
    let (clusters, groups) = clod_build_count(&mesh);
    let clod_seconds = t.elapsed().as_secs_f64();

    let mut sweep = Vec::new();
    // The original, for the measured error: built once (every build of a mesh has one origin).
    let mut reference: Option<([f64; 3], ReferenceMesh)> = None;
    // Leaf sizes with the default simplifier, then simplifier settings at the default leaf size.
    let runs: Vec<(usize, SimplifySettings)> = args
        .sweep
        .iter()
        .map(|&n| (n, defaults))
        .chain(
            args.sweep_keep
                .iter()
                .map(|&keep| (leaf, SimplifySettings { keep, ..defaults })),
        )
        .chain(args.sweep_normal_weight.iter().map(|&normal_weight| {
            (
                leaf,
                SimplifySettings {
                    normal_weight,
                    ..defaults
                },
            )
        }))
        .collect();
    for (k, &(n, settings)) in runs.iter().enumerate() {
        let path = dir.path().join(format!("sweep{k}.tsr"));
        let mut r = build_once(&mesh, domain, n, settings, args.threads, &path)?;
        let repo = Repository::open(&path)?;
        let h = *repo.header();
        if reference.as_ref().is_none_or(|(o, _)| *o != h.origin) {
            reference = Some((h.origin, reference_mesh(&mesh, h.origin)?));
        }
        let reference = &reference.as_ref().expect("just made").1;
        let cameras = outside_cameras(&h, MEASURE_VIEWS, (1920, 1080), default_up(h.dimension));
        r.measured =
            cpu_cut::cut_error(&repo, reference, &cameras, 1.0, &SamplingConfig::default())?;
        sweep.push(r);
    }

    let ours_mtps = triangles / ours.seconds / 1e6;
    let clod_mtps = triangles / clod_seconds / 1e6;
    let value = json!({
        "input": args.input.display().to_string(),
        "input_triangles": mesh.triangles.len(),
        "import_seconds": import_seconds,
        "threads": args.threads,
        "ours": ours.to_json(),
        "ours_mtris_per_second": ours_mtps,
        "peak_rss_bytes": peak_rss_bytes,
        "binary_ply_bytes": ply_bytes,
        "repository_over_ply": ours.repository_bytes as f64 / ply_bytes as f64,
        "clod_build": {"seconds": clod_seconds, "clusters": clusters, "groups": groups, "mtris_per_second": clod_mtps},
        "throughput_ratio_ours_over_clod": ours_mtps / clod_mtps,
        "sweep": sweep.iter().map(BuildRun::to_json).collect::<Vec<_>>(),
    });
    if args.json {
        println!("{value}");
    } else {
        println!(
            "input: {} ({} triangles), import {import_seconds:.2} s",
            args.input.display(),
            mesh.triangles.len()
        );
        println!(
            "ours ({} threads, leaf {leaf}): {:.2} s = {ours_mtps:.3} M tri/s; peak RSS {:.0} MiB",
            args.threads,
            ours.seconds,
            peak_rss_bytes as f64 / (1 << 20) as f64
        );
        println!(
            "clod_build (128-tri clusters, 1 thread): {clod_seconds:.2} s = {clod_mtps:.3} M tri/s ({clusters} clusters, {groups} groups)"
        );
        println!(
            "throughput ratio ours / clod_build: {:.2}",
            ours_mtps / clod_mtps
        );
        println!(
            "repository {} bytes / binary PLY {} bytes = {:.3}",
            ours.repository_bytes,
            ply_bytes,
            ours.repository_bytes as f64 / ply_bytes as f64
        );
        println!(
            "mean triangles per patch: {:.1}",
            ours.mean_triangles_per_patch
        );
        if !sweep.is_empty() {
            println!("leaf  keep  nweight  seconds  bytes/ply  tris/patch  depth  root_err   cut@1px tris  cut@1px patches  p99@1px  max@1px");
            let px = |x: Option<f64>| x.map_or("n/a".to_string(), |x| format!("{x:.3}"));
            for r in &sweep {
                println!(
                    "{:5} {:5.2} {:8.3} {:8.2} {:10.3} {:11.1} {:6} {:9.2e} {:13.0} {:16.0} {:>8} {:>8}",
                    r.leaf,
                    r.settings.keep,
                    r.settings.normal_weight,
                    r.seconds,
                    r.repository_bytes as f64 / ply_bytes as f64,
                    r.mean_triangles_per_patch,
                    r.depth,
                    r.root_error,
                    r.cut_triangles,
                    r.cut_patches,
                    px(r.measured.map(|e| e.p99_px)),
                    px(r.measured.map(|e| e.max_px)),
                );
            }
            println!(
                "cut@1px: mean over 64 check views; p99/max@1px: measured error of the τ = 1 px \
                 cut, pixels, over {MEASURE_VIEWS} views outside the model at 1920x1080"
            );
        }
    }
    Ok(Outcome::Ok)
}

struct BuildRun {
    leaf: usize,
    settings: SimplifySettings,
    seconds: f64,
    repository_bytes: u64,
    mean_triangles_per_patch: f64,
    depth: u16,
    root_error: f64,
    /// Mean over the check views of the τ = 1 px cut.
    cut_triangles: f64,
    cut_patches: f64,
    /// Measured error of the τ = 1 px cut (sweep builds only).
    measured: Option<ErrorSummary>,
}

impl BuildRun {
    fn to_json(&self) -> serde_json::Value {
        json!({
            "leaf_triangles": self.leaf,
            "simplify_keep": self.settings.keep,
            "simplify_normal_weight": self.settings.normal_weight,
            "seconds": self.seconds,
            "repository_bytes": self.repository_bytes,
            "mean_triangles_per_patch": self.mean_triangles_per_patch,
            "depth": self.depth,
            "root_error": self.root_error,
            "cut_1px_triangles": self.cut_triangles,
            "cut_1px_patches": self.cut_patches,
            "measured_1px_error_p99_px": self.measured.map(|e| e.p99_px),
            "measured_1px_error_max_px": self.measured.map(|e| e.max_px),
            "measured_1px_error_mean_px": self.measured.map(|e| e.mean_px),
        })
    }
}

fn build_once(
    mesh: &InputMesh,
    domain: Domain,
    leaf: usize,
    settings: SimplifySettings,
    threads: usize,
    path: &std::path::Path,
) -> anyhow::Result<BuildRun> {
    let config = BuildConfig {
        construction: Construction::LeafTriangles(leaf),
        threads: Some(threads),
        simplify: settings,
        ..BuildConfig::for_domain(domain)
    };
    let t = Instant::now();
    let s = build_repository(mesh, &config, path, &|_| {})?;
    let seconds = t.elapsed().as_secs_f64();
    let repo = Repository::open(path)?;
    let h = repo.header();
    let size = (0..3)
        .map(|i| (h.bbox_max[i] - h.bbox_min[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    let metric = ScreenSpaceMetric::new(1080, 60.0, size * 1e-4);
    let views = check_views(h.bbox_min, h.bbox_max, 64);
    let (mut tris, mut patches) = (0usize, 0usize);
    for eye in &views {
        let rhos = diamond_rhos(repo.diamonds(), eye_local(*eye, h.origin), &metric);
        let cut = select_stateless(repo.tets(), &rhos, 1.0);
        patches += cut
            .iter()
            .filter(|&&i| repo.tets()[i as usize].triangle_count > 0)
            .count();
        tris += cut
            .iter()
            .map(|&i| repo.tets()[i as usize].triangle_count as usize)
            .sum::<usize>();
    }
    Ok(BuildRun {
        leaf,
        settings,
        seconds,
        repository_bytes: s.repository_bytes,
        mean_triangles_per_patch: s.patch_triangles as f64 / s.tetrahedra.max(1) as f64,
        depth: s.depth,
        root_error: s.root_error,
        cut_triangles: tris as f64 / views.len() as f64,
        cut_patches: patches as f64 / views.len() as f64,
        measured: None,
    })
}

/// Runs meshopt's clusterlod builder and counts what it produced.
fn clod_build_count(mesh: &InputMesh) -> (usize, usize) {
    let centre = mesh.positions[0];
    let positions: Vec<[f32; 3]> = mesh
        .positions
        .iter()
        .map(|p| [0, 1, 2].map(|i| (p[i] - centre[i]) as f32))
        .collect();
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let bytes: &[u8] = bytemuck::cast_slice(&positions);
    let adapter = meshopt::VertexDataAdapter::new(bytes, 12, 0).expect("packed positions");
    let clod_mesh = meshopt::ClodMesh::new(&indices, &adapter);
    let config = meshopt::clod_default_config(128);
    let (mut clusters, mut groups) = (0usize, 0usize);
    meshopt::clod_build(config, &clod_mesh, |_group, cs| {
        groups += 1;
        clusters += cs.len();
        groups as i32
    });
    (clusters, groups)
}

/// Peak resident set size of this process so far (Linux; 0 elsewhere).
fn peak_rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}
