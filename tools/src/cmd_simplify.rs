//! `tessera simplify INPUT -o OUT.{ply,glb} (--target-triangles N | --max-triangles-per-node T)`
//! `[--max-depth D] [--levels L] [--memory SIZE] [--temp DIR] [--no-measure] [--json]`
//!
//! Seed 004's out-of-core simplifier (`tessera_preprocess::cluster`): the mesh staged on
//! disk, an octree of end nodes, each node's interior collapsed to its generalised quadric's
//! vertex with its boundary kept, coarser levels from the finer. One mesh of N triangles
//! (±10 %), or the seed's levels one file each, as PLY or GLB.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Args;
use serde_json::json;
use tessera_preprocess::cluster::{self, ClusterSettings, ClusterSummary, Outputs};

use crate::progress::Stages;
use crate::Outcome;

#[derive(Args)]
#[command(group(clap::ArgGroup::new("size").required(true)
    .args(["target_triangles", "max_triangles_per_node"])))]
pub struct SimplifyArgs {
    /// Input mesh (PLY, OBJ, OFF, STL, glTF/GLB; .gz accepted).
    pub input: PathBuf,
    /// Output mesh, binary PLY (`.ply`) or binary glTF (`.glb`), with the input's normals,
    /// colours and texture coordinates (written to a temporary file, then renamed); with
    /// `--levels`, OUT's stem + `.levelK`.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Write one mesh of N triangles (within 10 %): the end-node size T is searched (from
    /// (1.83 × input / N)², a quarter at a time while the finest level has fewer than N), then a cut
    /// of the octree picked by splitting the node of largest quadric error first.
    #[arg(long, value_name = "N", conflicts_with = "levels",
          value_parser = clap::value_parser!(u64).range(1..))]
    pub target_triangles: Option<u64>,
    /// The seed's end-node size T: a node splits while it holds more than T triangles (and
    /// is shallower than D). Without `--levels`, writes level 0 (the end nodes simplified).
    #[arg(long, value_name = "T", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_triangles_per_node: Option<u64>,
    /// The octree's depth limit D (1–21).
    #[arg(long, value_name = "D", default_value_t = 21,
          value_parser = clap::value_parser!(u8).range(1..=21))]
    pub max_depth: u8,
    /// Write the seed's levels 0 to L-1 (level 0 the end nodes simplified, level k the nodes
    /// of height k simplified from their children), one file each: OUT's stem + `.levelK`.
    #[arg(long, value_name = "L", requires = "max_triangles_per_node",
          value_parser = clap::value_parser!(u8).range(1..=22))]
    pub levels: Option<u8>,
    /// Memory budget (`64M`, `1G`): the working sets of every stage are sized to it.
    #[arg(long, value_name = "SIZE", default_value = "512M",
          value_parser = crate::cmd_build::parse_size)]
    pub memory: u64,
    /// Directory of the temporary files (default: the output's directory). They have no
    /// names: nothing is left behind.
    #[arg(long, value_name = "DIR")]
    pub temp: Option<PathBuf>,
    /// Skip measuring the output's distance to the input (`error` is then null): the
    /// measure reads the input again and is most of the time at coarse targets.
    #[arg(long)]
    pub no_measure: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: SimplifyArgs) -> anyhow::Result<Outcome> {
    let start = Instant::now();
    let stages = Stages::new("simplify");
    let peaks = crate::peak_rss::StagePeaks::new(false);
    let started = std::sync::Mutex::new(Vec::<(String, Instant)>::new());
    let on_stage = |s: &str| {
        stages.stage(s);
        peaks.start(s);
        started
            .lock()
            .unwrap()
            .push((s.to_string(), Instant::now()));
    };
    tessera_preprocess::external::temp_usage::reset_peak();
    let extension = args
        .output
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if !matches!(extension.as_deref(), Some("ply" | "glb")) {
        bail!(
            "{}: simplify writes binary PLY or GLB: give an output ending in .ply or .glb",
            args.output.display()
        );
    }
    let temp_dir = crate::output::temp_dir_for(args.temp.as_deref(), &args.output)?;
    tessera_preprocess::external::allocator::arenas_for_budget(args.memory);
    let budget = args.memory as usize;
    on_stage("import");
    // Its outputs carry no texture: texture coordinates as the input has them (not moved
    // into bands, `texture_input.rs`).
    let no_textures = tessera_preprocess::import::ImportOptions { textures: false };
    let staged =
        tessera_preprocess::import::stage_mesh_with(&args.input, &temp_dir, budget, &no_textures)?;
    let import_seconds = start.elapsed().as_secs_f64();
    let output = match (args.target_triangles, args.levels) {
        (Some(n), _) => Outputs::Target {
            triangles: n,
            path: args.output.clone(),
        },
        (None, levels) => {
            let levels = levels.unwrap_or(1);
            let paths = if args.levels.is_some() {
                (0..levels)
                    .map(|k| cluster::level_path(&args.output, k))
                    .collect()
            } else {
                vec![args.output.clone()]
            };
            Outputs::Levels { levels, paths }
        }
    };
    let settings = ClusterSettings {
        max_triangles_per_node: args.max_triangles_per_node,
        max_depth: args.max_depth,
        output,
        budget,
        temp_dir,
        measure: !args.no_measure,
    };
    let summary = cluster::simplify_staged(&staged, &settings, &on_stage)
        .with_context(|| format!("simplifying {}", args.input.display()))?;
    drop(staged);
    stages.finish();
    let stage_peaks = peaks.finish();
    let seconds = start.elapsed().as_secs_f64();
    let peak = crate::peak_rss::peak_rss_bytes();
    if args.json {
        let mut value = summary_json(&summary);
        value["seconds"] = json!(seconds);
        value["import_seconds"] = json!(import_seconds);
        value["peak_rss_bytes"] = json!(peak);
        value["memory_budget_bytes"] = json!(args.memory);
        value["temp_bytes_peak"] = json!(tessera_preprocess::external::temp_usage::peak());
        // The peak resident memory so far at the end of each stage (the stages in order).
        let started = started.into_inner().unwrap();
        let end = Instant::now();
        value["stages"] = stage_peaks
            .iter()
            .enumerate()
            .map(|(i, (stage, peak))| {
                let until = started.get(i + 1).map_or(end, |s| s.1);
                let seconds = started.get(i).map(|s| (until - s.1).as_secs_f64());
                json!({"stage": stage, "seconds": seconds, "peak_rss_bytes": peak})
            })
            .collect();
        println!("{value}");
    } else {
        print_summary(&args, &summary, seconds, peak);
    }
    Ok(Outcome::Ok)
}

/// The `--json` object (stable keys).
fn summary_json(s: &ClusterSummary) -> serde_json::Value {
    let outputs: Vec<serde_json::Value> = s
        .written
        .iter()
        .map(|w| {
            let error = w.distance.map(|d| {
                json!({
                    "max": d.max,
                    "mean": d.mean,
                    "max_relative": d.max / s.diagonal,
                    "mean_relative": d.mean / s.diagonal,
                    "samples": d.samples,
                })
            });
            json!({
                "path": w.path.display().to_string(),
                "level": w.level,
                "nodes": w.nodes,
                "triangles": w.triangles,
                "vertices": w.vertices,
                "bytes": w.bytes,
                "error": error,
            })
        })
        .collect();
    let first = s.written.first();
    let ratios: Vec<f64> = s
        .level_triangles
        .windows(2)
        .map(|w| w[1] as f64 / w[0].max(1) as f64)
        .collect();
    json!({
        "input_triangles": s.input_triangles,
        "input_vertices": s.input_vertices,
        "output_triangles": first.map(|w| w.triangles),
        "output_vertices": first.map(|w| w.vertices),
        "error": outputs.first().map(|o| o["error"].clone()),
        "outputs": outputs,
        "attributes": {
            "normals": s.attributes.normals,
            "colors": s.attributes.colors,
            "uvs": s.attributes.uvs,
        },
        "diagonal": s.diagonal,
        "max_triangles_per_node": s.max_triangles_per_node,
        "tries": s.tries.iter().map(|(t, finest)| json!({"max_triangles_per_node": t, "level0_triangles": finest})).collect::<Vec<_>>(),
        "nodes": s.nodes,
        "leaves": s.leaves,
        "depth": s.depth,
        "levels": s.level_triangles.len(),
        "level_triangles": s.level_triangles,
        "level_ratios": ratios,
        "node_outcomes": {
            "fanned": s.stats.fanned,
            "centred": s.stats.centred,
            "kept": s.stats.kept,
            "irregular_boundary": s.stats.irregular,
        },
    })
}

fn print_summary(args: &SimplifyArgs, s: &ClusterSummary, seconds: f64, peak: Option<u64>) {
    println!(
        "{}: {} triangles, {} vertices",
        args.input.display(),
        s.input_triangles,
        s.input_vertices
    );
    println!(
        "octree: {} nodes ({} end nodes), depth {}, T = {}; levels (triangles, finest first): {:?}",
        s.nodes, s.leaves, s.depth, s.max_triangles_per_node, s.level_triangles
    );
    println!(
        "nodes: {} fanned, {} fanned to their centre (optimum far outside), {} kept, {} with a \
         boundary not one simple loop",
        s.stats.fanned, s.stats.centred, s.stats.kept, s.stats.irregular
    );
    for w in &s.written {
        let error = w.distance.map_or(String::new(), |d| {
            format!(
                "; distance to the input (sampled): max {:.3e} ({:.2e} of the diagonal), mean {:.3e}",
                d.max,
                d.max / s.diagonal,
                d.mean
            )
        });
        println!(
            "wrote {}: {} triangles, {} vertices{error}",
            w.path.display(),
            w.triangles,
            w.vertices
        );
    }
    println!(
        "{seconds:.2} s; peak resident memory {}",
        peak.map_or("unknown".to_string(), |p| format!(
            "{:.1} MiB",
            p as f64 / (1 << 20) as f64
        ))
    );
}
