//! The trade-off report: rows as JSON (the keys pipeline scripts parse) and as a table.
//!
//! Row keys, fixed: `tolerance`, `patches`, `triangles`, `cpu_ms`, `gpu_ms`, `error_max_px`,
//! `error_p99_px`, `error_mean_px`, `pixels_differing`, `psnr`; added: `wall_ms`, `views`,
//! `upload_ms` (per-frame uploads, apart from `cpu_ms`: the cluster DAG's), `select_ms` and
//! `raster_ms` (with `--phases`, else null: the frame's two phases waited for apart), `wall_ms_min`
//! and `wall_ms_max` (the fastest and slowest of `runs` timed runs; the times
//! are the runs' median), `error_samples`, `error_to_original` and `error_to_cut` (each direction's `max_px`, `p99_px`,
//! `mean_px`, `samples`; the `error_*` keys pool both), `hidden_samples`, and `level` for a
//! subject with discrete levels. `pixels_differing` is a
//! share in [0, 1] (mean over views); `psnr` is in dB, of the views' mean MSE, saturated at
//! 99 (identical frames); `gpu_ms` is null
//! without timestamps (and misses compute passes on lavapipe: compare `wall_ms` there).

use serde_json::json;

use tessera_runtime::measure::ErrorSummary;

use super::trade_off::Row;
use super::verdict::group_digits;

/// A row as JSON.
pub fn row_json(row: &Row) -> serde_json::Value {
    let mut v = json!({
        "tolerance": row.tolerance,
        "patches": row.patches,
        "triangles": row.triangles,
        "cpu_ms": row.cpu_ms,
        "upload_ms": row.upload_ms,
        "gpu_ms": row.gpu_ms,
        "select_ms": row.select_ms,
        "raster_ms": row.raster_ms,
        "wall_ms": row.wall_ms,
        "wall_ms_min": row.wall_ms_spread.0,
        "wall_ms_max": row.wall_ms_spread.1,
        "runs": row.runs,
        "error_max_px": row.error.map(|e| e.max_px),
        "error_p99_px": row.error.map(|e| e.p99_px),
        "error_mean_px": row.error.map(|e| e.mean_px),
        "error_samples": row.error.map_or(0, |e| e.samples),
        "error_to_original": row.error_to_original.map(summary_json),
        "error_to_cut": row.error_to_cut.map(summary_json),
        "hidden_samples": row.hidden_samples,
        "pixels_differing": row.pixels_differing,
        "psnr": row.psnr,
        "views": row.views,
    });
    if let Some(level) = row.level {
        v["level"] = json!(level);
    }
    v
}

fn summary_json(e: ErrorSummary) -> serde_json::Value {
    json!({"max_px": e.max_px, "p99_px": e.p99_px, "mean_px": e.mean_px, "samples": e.samples})
}

fn number(x: Option<f64>, digits: usize) -> String {
    x.filter(|x| x.is_finite())
        .map_or("n/a".to_string(), |x| format!("{x:.digits$}"))
}

/// The table of one subject's rows, a title line first.
pub fn table(title: &str, rows: &[Row]) -> Vec<String> {
    let mut lines = vec![title.to_string()];
    lines.push(format!(
        "{:>6} {:>9} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>7} {:>8} {:>6} {:>20} {:>8} {:>8}",
        "τ px",
        "patches",
        "triangles",
        "p99 px",
        "max px",
        "mean px",
        "max c→o",
        "max o→c",
        "p99/τ",
        "differ %",
        "PSNR",
        "wall ms (runs)",
        "GPU ms",
        "CPU ms",
    ));
    for r in rows {
        let ratio = r
            .error
            .filter(|_| r.tolerance > 0.0)
            .map(|e| e.p99_px / r.tolerance as f64);
        lines.push(format!(
            "{:>6} {:>9} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>7} {:>8} {:>6} {:>20} {:>8} {:>8}",
            r.tolerance,
            group_digits(r.patches),
            group_digits(r.triangles),
            number(r.error.map(|e| e.p99_px), 3),
            number(r.error.map(|e| e.max_px), 3),
            number(r.error.map(|e| e.mean_px), 3),
            number(r.error_to_original.map(|e| e.max_px), 3),
            number(r.error_to_cut.map(|e| e.max_px), 3),
            number(ratio, 2),
            number(r.pixels_differing.map(|d| 100.0 * d), 2),
            number(r.psnr, 1),
            format!(
                "{} ({}–{})",
                number(Some(r.wall_ms), 2),
                number(Some(r.wall_ms_spread.0), 1),
                number(Some(r.wall_ms_spread.1), 1)
            ),
            number(r.gpu_ms, 2),
            number(Some(r.cpu_ms), 3),
        ));
    }
    // With `--phases`: the two phases, beside the row's wall time.
    if rows.iter().any(|r| r.select_ms.is_some()) {
        for (line, r) in lines[2..].iter_mut().zip(rows) {
            line.push_str(&format!(
                " {:>9} {:>9}",
                number(r.select_ms, 2),
                number(r.raster_ms, 2)
            ));
        }
        lines[1].push_str(&format!(" {:>9} {:>9}", "select ms", "raster ms"));
    }
    lines
}
