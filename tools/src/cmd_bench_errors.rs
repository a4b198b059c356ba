//! `tessera bench errors REPO`: how far the cuts of a repository are from its input, against
//! the errors it stores (issue 13: "stored errors that are bounds").
//!
//! Object-space cuts: a simplex is drawn iff err(its diamond) ≤ ε < err(its parent diamond),
//! the run-time rule with distances taken out. For each ε (a geometric sweep from the
//! smallest diamond error to the root's), the two-sided distance between the drawn patches
//! and the leaves (the input on the position lattice) is sampled: `--cut-steps` lattice steps
//! a side on each drawn triangle, `--leaf-steps` on each leaf, exact nearest-triangle distances. A sample's
//! distance is exact, so the largest is a lower bound on the true distance: a ratio
//! `distance / largest drawn error` above 1 proves the stored errors are not bounds there; below
//! 1 is what bounds (`build --bounded-errors`) must give. Comparing two builds of one input at
//! equal measured distance (their triangles at the same `distance`) is the trade the errors
//! buy.
//!
//! `--write-cuts DIR` writes the leaves (`leaves.ply`) and every cut (`cut-K.ply`, K from 0,
//! finest first) as binary PLY in the same model coordinates, so that an independent tool
//! can measure the same distances (`tools/independent-hausdorff.py`: PyMeshLab's Hausdorff
//! filter, both ways).
//!
//! A measurement, not an out-of-core tool: it holds every leaf triangle in memory with a grid
//! over them (221 MB peak on the dragon's 871 K leaves), so size it to the machine.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use serde_json::json;
use tessera_core::repository::cut_mesh::CutMesh;
use tessera_core::repository::surface::{
    leaf_surface, measure_object_cut, object_cut, patch_surface, PatchSurface,
};

use crate::view::export::write_ply;

use crate::Outcome;

#[derive(Args)]
pub struct ErrorsBenchArgs {
    /// The repository.
    pub repo: PathBuf,
    /// Number of cuts, geometrically spaced from the smallest diamond error to the root's.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub cuts: u32,
    /// Barycentric lattice steps a side on each drawn triangle ((s+1)(s+2)/2 points: 66 at
    /// 10, the least of 4, 8, 10 and 12 at which PyMeshLab's Hausdorff filter agrees within
    /// 5 % on every cut of the dragon: BENCHMARKS.md).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub cut_steps: u32,
    /// The same on each leaf triangle (6 points at 2: corners and edge midpoints).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub leaf_steps: u32,
    /// Also write the leaves (`leaves.ply`) and each cut (`cut-K.ply`, finest first) into
    /// this directory (created if missing), binary PLY with double positions in model
    /// coordinates, for an independent measurement of the same distances.
    #[arg(long, value_name = "DIR")]
    pub write_cuts: Option<PathBuf>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// One cut's figures.
struct CutRow {
    epsilon: f32,
    tets: usize,
    triangles: usize,
    largest_error: f64,
    distance: f64,
    samples: u64,
    seconds: f64,
}

pub fn run(args: ErrorsBenchArgs) -> anyhow::Result<Outcome> {
    let repo = crate::repository_arg::open(&args.repo, "bench errors")
        .with_context(|| format!("cannot open {}", args.repo.display()))?;
    let errors: Vec<f32> = repo.diamonds().iter().map(|d| d.error).collect();
    let smallest = errors
        .iter()
        .copied()
        .filter(|&e| e > 0.0)
        .fold(f32::MAX, f32::min);
    let root = errors.iter().copied().fold(0.0f32, f32::max);
    if errors.is_empty() || root <= 0.0 {
        anyhow::bail!(
            "{} has no split diamond: nothing to cut",
            args.repo.display()
        );
    }
    let leaves = leaf_surface(&repo)?;
    let leaf_triangles = leaves.triangle_count();
    if let Some(dir) = &args.write_cuts {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        write_surface(&leaves, &dir.join("leaves.ply"))?;
    }
    let mut rows = Vec::new();
    for k in 0..args.cuts {
        let start = Instant::now();
        let f = if args.cuts == 1 {
            1.0
        } else {
            k as f64 / (args.cuts - 1) as f64
        };
        let epsilon = (smallest as f64 * (root as f64 / smallest as f64).powf(f)) as f32;
        let m = measure_object_cut(
            &repo,
            &leaves,
            epsilon,
            args.cut_steps as usize,
            args.leaf_steps as usize,
        )?;
        if let Some(dir) = &args.write_cuts {
            let drawn = object_cut(&repo, epsilon);
            let cut = patch_surface(&repo, drawn.iter().map(|&t| t as usize))?;
            write_surface(&cut, &dir.join(format!("cut-{k}.ply")))?;
        }
        rows.push(CutRow {
            epsilon,
            tets: m.simplices,
            triangles: m.triangles,
            largest_error: m.largest_error,
            distance: m.distance,
            samples: m.samples,
            seconds: start.elapsed().as_secs_f64(),
        });
    }
    if args.json {
        let cuts: Vec<serde_json::Value> = rows
            .iter()
            .map(|r| {
                json!({
                    "epsilon": r.epsilon,
                    "simplices": r.tets,
                    "triangles": r.triangles,
                    "largest_drawn_error": r.largest_error,
                    "sampled_distance": r.distance,
                    "ratio": r.distance / r.largest_error.max(f64::MIN_POSITIVE),
                    "samples": r.samples,
                    "seconds": r.seconds,
                })
            })
            .collect();
        println!(
            "{}",
            json!({
                "repository": args.repo.display().to_string(),
                "leaf_triangles": leaf_triangles,
                "metric": {"space": "object", "sides": "two-sided", "distance": "sampled lower bound"},
                "cuts": cuts,
            })
        );
    } else {
        println!(
            "{}: {} leaf triangles; object-space cuts, two-sided distance to the leaves \
             (sampled: a lower bound)",
            args.repo.display(),
            leaf_triangles
        );
        println!("        ε   triangles  largest error   distance  ratio    samples");
        for r in &rows {
            println!(
                "{:9.3e} {:11} {:14.3e} {:10.3e} {:6.2} {:10}",
                r.epsilon,
                r.triangles,
                r.largest_error,
                r.distance,
                r.distance / r.largest_error.max(f64::MIN_POSITIVE),
                r.samples
            );
        }
    }
    Ok(Outcome::Ok)
}

/// `surface` as a binary PLY at `path` (positions only).
fn write_surface(surface: &PatchSurface, path: &std::path::Path) -> anyhow::Result<()> {
    let mesh = CutMesh {
        positions: surface.positions.clone(),
        normals: None,
        colors: None,
        uvs: None,
        indices: surface.indices.clone(),
    };
    write_ply(&mesh, path).with_context(|| format!("cannot write {}", path.display()))
}
