//! `check --errors`: every cut the check draws (each view, each tolerance, the run-time rule
//! without culling) measured against the repository's leaves in pixels, both ways, sampled
//! (`core::repository::surface::measure_screen_cut`): the largest value against τ. Stored
//! errors that are bounds (`build --bounded-errors`) keep it at or below τ; the default's
//! estimates need not, so it is reported, not failed. Holds every leaf in memory and samples
//! all of them for every cut: use fewer `--views` on large models.

use std::time::Instant;

use serde_json::json;
use tessera_core::repository::surface::{leaf_surface, measure_screen_cut};
use tessera_core::repository::Repository;
use tessera_runtime::geometric_check::{check_metric, CheckConfig};
use tessera_runtime::views::check_views;

/// Lattice steps a side: 15 points on each drawn triangle, 6 on each leaf.
pub const STEPS: (usize, usize) = (4, 2);

pub struct ErrorReport {
    pub cuts: usize,
    pub samples: u64,
    pub max_px: f64,
    /// The largest measured error over its τ, and the (view, τ) where it is.
    pub max_over_tau: f64,
    pub worst: Option<(usize, f32)>,
    pub seconds: f64,
}

pub fn measure(repo: &Repository, views: usize, tolerances: &[f32]) -> anyhow::Result<ErrorReport> {
    let start = Instant::now();
    let h = repo.header();
    let metric = check_metric(h, &CheckConfig::default());
    let leaves = leaf_surface(repo)?;
    let mut report = ErrorReport {
        cuts: 0,
        samples: 0,
        max_px: 0.0,
        max_over_tau: 0.0,
        worst: None,
        seconds: 0.0,
    };
    for (view, eye) in check_views(h.bbox_min, h.bbox_max, views)
        .into_iter()
        .enumerate()
    {
        for &tau in tolerances.iter().filter(|&&t| t > 0.0) {
            let m = measure_screen_cut(repo, &leaves, eye, &metric, tau, STEPS)?;
            report.cuts += 1;
            report.samples += m.samples;
            report.max_px = report.max_px.max(m.max_px);
            let over = m.max_px / tau as f64;
            if over > report.max_over_tau || report.worst.is_none() {
                report.max_over_tau = over;
                report.worst = Some((view, tau));
            }
        }
    }
    report.seconds = start.elapsed().as_secs_f64();
    Ok(report)
}

pub fn report_json(r: &ErrorReport) -> serde_json::Value {
    json!({
        "cuts": r.cuts,
        "samples": r.samples,
        "error_max_px": r.max_px,
        "error_max_over_tolerance": r.max_over_tau,
        "worst": r.worst.map(|(view, tau)| json!({"view": view, "tolerance": tau})),
        "metric": {"distance": "euclidean", "sides": "two-sided", "visible_only": false,
                   "against": "leaves", "sampled": "lower bound"},
        "seconds": r.seconds,
    })
}

pub fn print_report(r: &ErrorReport) {
    println!(
        "errors against the leaves: {} cuts, {} samples in {:.2} s: largest {:.3} px, {:.3} × its τ{}",
        r.cuts,
        r.samples,
        r.seconds,
        r.max_px,
        r.max_over_tau,
        r.worst
            .map(|(view, tau)| format!(" (view {view}, τ = {tau} px)"))
            .unwrap_or_default()
    );
}
