//! `tessera check REPO [--views N] [--tolerances a,b,...] [--json]`

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use serde_json::json;
use tessera_core::repository::reader::Repository;
use tessera_runtime::geometric_check::{check_cuts, decode_all_patches, CheckConfig, CheckReport};

use crate::Outcome;

#[derive(Args)]
pub struct CheckArgs {
    /// Repository file.
    pub repository: PathBuf,
    /// Number of camera positions (around and inside the model).
    #[arg(long, default_value_t = 64)]
    pub views: usize,
    /// Pixel tolerances, at 1920×1080 with a 60° vertical field of view.
    #[arg(long, value_delimiter = ',', default_value = "0.5,1,2,4,8")]
    pub tolerances: Vec<f32>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: CheckArgs) -> anyhow::Result<Outcome> {
    if let Some(bad) = args.tolerances.iter().find(|t| !t.is_finite() || **t < 0.0) {
        anyhow::bail!("tolerance {bad} must be a finite number ≥ 0");
    }
    let start = Instant::now();
    let repo = Repository::open(&args.repository)?;
    let config = CheckConfig {
        views: args.views,
        tolerances: args.tolerances.clone(),
        ..Default::default()
    };
    let patches = decode_all_patches(&repo)?;
    let report = check_cuts(&repo, &patches, &config);
    let seconds = start.elapsed().as_secs_f64();
    if args.json {
        println!("{}", report_json(&report, seconds));
    } else {
        print_report(&report, seconds);
    }
    Ok(if report.is_clean() {
        Outcome::Ok
    } else {
        Outcome::CheckFailed
    })
}

pub fn report_json(r: &CheckReport, seconds: f64) -> serde_json::Value {
    json!({
        "cuts_checked": r.cuts_checked,
        "cracks": r.cracks,
        "nonmanifold_introduced": r.nonmanifold_introduced,
        "monotonicity_violations": r.monotonicity_violations,
        "traversal_mismatches": r.traversal_mismatches,
        "min_triangles": r.min_triangles,
        "max_triangles": r.max_triangles,
        "worst": r.worst.as_ref().map(|(view, tau, cracks)| json!({"view": view, "tolerance": tau, "cracks": cracks})),
        "seconds": seconds,
    })
}

pub fn print_report(r: &CheckReport, seconds: f64) {
    println!(
        "{} cuts checked in {:.2} s: {} cracks, {} non-manifold edges introduced, {} monotonicity violations, {} traversal mismatches",
        r.cuts_checked, seconds, r.cracks, r.nonmanifold_introduced, r.monotonicity_violations, r.traversal_mismatches
    );
    println!(
        "triangles per cut: {} .. {}",
        r.min_triangles, r.max_triangles
    );
    if let Some((view, tau, cracks)) = &r.worst {
        println!("worst cut: view {view} at τ = {tau} px with {cracks} cracks");
    }
    println!("{}", if r.is_clean() { "CLEAN" } else { "FAILED" });
}
