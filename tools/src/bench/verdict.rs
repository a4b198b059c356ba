//! Who wins where: the fewest triangles at equal *measured* error, on the sparse visible
//! samples (the secondary verdict; the headline one, front to front on the dense error, is
//! `front_verdict.rs`, which reads the fronts with this file's `pareto_front` and `estimate`).
//!
//! The error levels are ours: the measured p99 (or max: `Statistic`) of each of our rows. At
//! each level, every other subject's triangle count is read off its own (error, triangles)
//! curve:
//! - the curve is its Pareto front (a row is kept only if it draws fewer triangles than every
//!   row with a smaller error), interpolated linearly in (log error, log triangles) between
//!   neighbours (linearly in error next to an error of 0);
//! - beyond its coarsest row, its coarsest count is an upper bound ("≤": it might do with
//!   fewer at a larger τ than measured);
//! - below its finest row's error, its finest count is a lower bound ("≥": it needs more detail
//!   than measured).
//!
//! The winner is the subject with the fewest triangles; a bound that leaves the order open is
//! reported as undecided.

use serde_json::json;

use super::trade_off::{Row, SubjectRows};

/// Which summary of the measured error sets the levels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Statistic {
    /// The 99th percentile of the samples.
    P99,
    /// The largest sample (a sampled lower bound of the visible two-sided distance).
    Max,
}

impl Statistic {
    fn of(self, row: &Row) -> Option<f64> {
        row.error.map(|e| match self {
            Statistic::P99 => e.p99_px,
            Statistic::Max => e.max_px,
        })
    }

    /// "p99" or "max".
    pub fn name(self) -> &'static str {
        match self {
            Statistic::P99 => "p99",
            Statistic::Max => "max",
        }
    }
}

/// A subject's triangle count at an error level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Estimate {
    /// One of its rows has exactly this error (ours).
    Measured(f64),
    /// Between two of its rows.
    Interpolated(f64),
    /// Coarser than its coarsest row: at most this many.
    AtMost(f64),
    /// Finer than its finest row: at least this many.
    AtLeast(f64),
}

impl Estimate {
    pub fn triangles(&self) -> f64 {
        match *self {
            Estimate::Measured(t)
            | Estimate::Interpolated(t)
            | Estimate::AtMost(t)
            | Estimate::AtLeast(t) => t,
        }
    }

    pub(super) fn text(&self) -> String {
        let t = group_digits(self.triangles());
        match self {
            Estimate::Measured(_) => t,
            Estimate::Interpolated(_) => format!("≈{t}"),
            Estimate::AtMost(_) => format!("≤{t}"),
            Estimate::AtLeast(_) => format!("≥{t}"),
        }
    }

    pub(super) fn kind(&self) -> &'static str {
        match self {
            Estimate::Measured(_) => "measured",
            Estimate::Interpolated(_) => "interpolated",
            Estimate::AtMost(_) => "at_most",
            Estimate::AtLeast(_) => "at_least",
        }
    }
}

/// One error level.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// Our τ whose measured error sets the level.
    pub tolerance: f32,
    /// The level: our row's error under `statistic`.
    pub statistic: Statistic,
    pub error_px: f64,
    pub estimates: Vec<(&'static str, Estimate)>,
    /// The subject with the fewest triangles, `None` when a bound leaves it open.
    pub winner: Option<&'static str>,
}

/// `n` with thousands separators.
pub fn group_digits(n: f64) -> String {
    let digits = format!("{:.0}", n.max(0.0));
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// The Pareto front of a subject's rows: (error, triangles), error ascending, triangles
/// strictly descending.
fn front(rows: &[Row], statistic: Statistic) -> Vec<(f64, f64)> {
    pareto_front(
        rows.iter()
            .filter_map(|r| Some((statistic.of(r)?, r.triangles))),
    )
}

/// The Pareto front of (error, triangles) points: error ascending, triangles strictly
/// descending (a point is kept only if it draws fewer triangles than every point with a
/// smaller or equal error); points with a non-finite error are left out.
pub fn pareto_front(points: impl IntoIterator<Item = (f64, f64)>) -> Vec<(f64, f64)> {
    let mut points: Vec<(f64, f64)> = points.into_iter().filter(|p| p.0.is_finite()).collect();
    points.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut kept: Vec<(f64, f64)> = Vec::new();
    for p in points {
        if kept.last().is_none_or(|last| p.1 < last.1) {
            kept.push(p);
        }
    }
    kept
}

/// A subject's triangles at measured `error`, from its front.
pub(super) fn estimate(front: &[(f64, f64)], error: f64) -> Option<Estimate> {
    let (first, last) = (front.first()?, front.last()?);
    if error < first.0 {
        return Some(Estimate::AtLeast(first.1));
    }
    if error >= last.0 {
        return Some(if error == last.0 {
            Estimate::Interpolated(last.1)
        } else {
            Estimate::AtMost(last.1)
        });
    }
    let k = front.partition_point(|p| p.0 <= error);
    let ((e0, t0), (e1, t1)) = (front[k - 1], front[k]);
    let s = if e0 > 0.0 {
        (error / e0).ln() / (e1 / e0).ln()
    } else {
        (error - e0) / (e1 - e0)
    };
    Some(Estimate::Interpolated((t0.ln() + s * (t1 / t0).ln()).exp()))
}

/// The comparisons at each of our rows' measured error under `statistic` (`ours` is the
/// subject they come from).
pub fn compare(
    ours: &SubjectRows,
    others: &[&SubjectRows],
    statistic: Statistic,
) -> Vec<Comparison> {
    let fronts: Vec<Vec<(f64, f64)>> = others.iter().map(|s| front(&s.rows, statistic)).collect();
    ours.rows
        .iter()
        .filter_map(|row| {
            let error = statistic.of(row).filter(|e| e.is_finite())?;
            let mut estimates = vec![(ours.name, Estimate::Measured(row.triangles))];
            for (s, f) in others.iter().zip(&fronts) {
                if let Some(e) = estimate(f, error) {
                    estimates.push((s.name, e));
                }
            }
            let best = estimates
                .iter()
                .min_by(|a, b| a.1.triangles().total_cmp(&b.1.triangles()))
                .map(|(name, e)| (*name, *e));
            // The best is certain unless it is only a lower bound, or someone else's upper
            // bound does not exceed it.
            let winner = best.filter(|(name, e)| {
                !matches!(e, Estimate::AtLeast(_))
                    && estimates.iter().all(|(other, o)| {
                        other == name
                            || !matches!(o, Estimate::AtMost(_))
                            || o.triangles() > e.triangles()
                    })
            });
            Some(Comparison {
                tolerance: row.tolerance,
                statistic,
                error_px: error,
                estimates,
                winner: winner.map(|(name, _)| name),
            })
        })
        .collect()
}

/// The human lines: one per error level and a tally.
pub fn lines(comparisons: &[Comparison]) -> Vec<String> {
    let mut lines = Vec::new();
    let mut wins: Vec<(&str, usize)> = Vec::new();
    for c in comparisons {
        let counts: Vec<String> = c
            .estimates
            .iter()
            .map(|(name, e)| format!("{name} {}", e.text()))
            .collect();
        let verdict = match c.winner {
            Some(w) => {
                match wins.iter_mut().find(|(n, _)| *n == w) {
                    Some((_, k)) => *k += 1,
                    None => wins.push((w, 1)),
                }
                let winner = c.estimates.iter().find(|(n, _)| *n == w).map(|x| x.1);
                let runner_up = c
                    .estimates
                    .iter()
                    .filter(|(n, _)| *n != w)
                    .min_by(|a, b| a.1.triangles().total_cmp(&b.1.triangles()));
                match (winner, runner_up) {
                    (Some(a), Some((n, b))) => format!(
                        "{w} ({:.2}× the triangles of {n})",
                        a.triangles() / b.triangles()
                    ),
                    _ => w.to_string(),
                }
            }
            None => "undecided (a bound leaves the order open)".to_string(),
        };
        lines.push(format!(
            "  {} {:.3} px (ours at τ = {}): {} → {verdict}",
            c.statistic.name(),
            c.error_px,
            c.tolerance,
            counts.join(", ")
        ));
    }
    let tally: Vec<String> = wins
        .iter()
        .map(|(n, k)| format!("{n} at {k} of {} levels", comparisons.len()))
        .collect();
    lines.push(format!(
        "  fewest triangles at equal measured {}: {}",
        comparisons.first().map_or("error", |c| c.statistic.name()),
        if tally.is_empty() {
            "no level decided".to_string()
        } else {
            tally.join("; ")
        }
    ));
    lines
}

/// The comparisons as JSON: per level `statistic`, `error_px` (also as `error_p99_px` or
/// `error_max_px`, the key scripts read before `statistic` was added), `tolerance`, each
/// subject's `triangles` (`value`, `kind`) and the `winner`.
pub fn to_json(comparisons: &[Comparison]) -> serde_json::Value {
    json!(comparisons
        .iter()
        .map(|c| {
            let mut v = json!({
                "tolerance": c.tolerance,
                "statistic": c.statistic.name(),
                "error_px": c.error_px,
                "triangles": c.estimates.iter().map(|(n, e)| (n.to_string(), json!({"value": e.triangles(), "kind": e.kind()}))).collect::<serde_json::Map<_, _>>(),
                "winner": c.winner,
            });
            v[format!("error_{}_px", c.statistic.name())] = json!(c.error_px);
            v
        })
        .collect::<Vec<_>>())
}

#[cfg(test)]
mod tests {
    use super::*;
    use tessera_runtime::measure::ErrorSummary;

    fn rows(points: &[(f64, f64)]) -> Vec<Row> {
        points
            .iter()
            .enumerate()
            .map(|(i, &(p99, triangles))| Row {
                tolerance: i as f32,
                views: 1,
                patches: 1.0,
                triangles,
                level: None,
                cpu_ms: 0.0,
                upload_ms: 0.0,
                wall_ms: 0.0,
                wall_ms_spread: (0.0, 0.0),
                runs: 1,
                gpu_ms: None,
                select_ms: None,
                raster_ms: None,
                error: Some(ErrorSummary {
                    samples: 1,
                    max_px: p99,
                    p99_px: p99,
                    mean_px: p99,
                }),
                error_to_original: None,
                error_to_cut: None,
                hidden_samples: 0,
                pixels_differing: None,
                psnr: None,
            })
            .collect()
    }

    #[test]
    fn fronts_drop_dominated_rows_and_interpolate_in_logs() {
        let f = front(
            &rows(&[(1.0, 1000.0), (4.0, 100.0), (2.0, 2000.0), (0.0, 5000.0)]),
            Statistic::P99,
        );
        assert_eq!(f, vec![(0.0, 5000.0), (1.0, 1000.0), (4.0, 100.0)]);
        // Halfway in log error between 1 and 4 is 2: halfway in log triangles, √(1000·100).
        let Some(Estimate::Interpolated(t)) = estimate(&f, 2.0) else {
            panic!()
        };
        assert!((t - (1000.0f64 * 100.0).sqrt()).abs() < 1e-6);
        // Linear next to 0.
        let Some(Estimate::Interpolated(t)) = estimate(&f, 0.5) else {
            panic!()
        };
        assert!((t - (5000.0f64 * 1000.0).sqrt()).abs() < 1e-6);
        assert_eq!(estimate(&f, 9.0), Some(Estimate::AtMost(100.0)));
        let g = front(&rows(&[(1.0, 10.0)]), Statistic::P99);
        assert_eq!(estimate(&g, 0.5), Some(Estimate::AtLeast(10.0)));
        assert_eq!(estimate(&[], 0.5), None);
    }

    /// The levels follow the statistic asked for; an infinite error (nothing drawn where the
    /// original shows) is no level and no point of a front.
    #[test]
    fn levels_are_the_statistic_asked_for() {
        let mut ours = rows(&[(1.0, 1000.0), (2.0, 500.0)]);
        ours[0].error.as_mut().unwrap().max_px = 3.0;
        ours[1].error.as_mut().unwrap().max_px = f64::INFINITY;
        assert_eq!(front(&ours, Statistic::Max), vec![(3.0, 1000.0)]);
        let ours = SubjectRows {
            name: "ours",
            rows: ours,
        };
        let c = compare(&ours, &[], Statistic::Max);
        assert_eq!(c.len(), 1);
        assert_eq!((c[0].statistic, c[0].error_px), (Statistic::Max, 3.0));
        assert_eq!(compare(&ours, &[], Statistic::P99).len(), 2);
        let j = to_json(&c);
        assert_eq!(j[0]["error_max_px"], 3.0);
        assert_eq!(j[0]["statistic"], "max");
    }

    #[test]
    fn the_fewest_triangles_win_unless_a_bound_leaves_it_open() {
        let ours = SubjectRows {
            name: "ours",
            rows: rows(&[(0.5, 900.0), (1.0, 400.0), (10.0, 50.0)]),
        };
        let peer = SubjectRows {
            name: "peer",
            rows: rows(&[(0.25, 2000.0), (2.0, 600.0)]),
        };
        let c = compare(&ours, &[&peer], Statistic::P99);
        assert_eq!(c.len(), 3);
        assert_eq!(c[0].winner, Some("ours"));
        assert_eq!(c[1].winner, Some("ours"));
        // At 10 px the peer is at most 600: ours (50) wins all the same.
        assert_eq!(c[2].winner, Some("ours"));
        let cheap = SubjectRows {
            name: "cheap",
            rows: rows(&[(2.0, 10.0)]),
        };
        let c = compare(&ours, &[&cheap], Statistic::P99);
        // Below its finest row the peer needs ≥ 10 — fewer than ours, or not: open.
        assert_eq!(c[0].winner, None);
        assert_eq!(c[1].winner, None);
        assert_eq!(c[2].winner, Some("cheap"));
        assert!(lines(&c).last().unwrap().contains("cheap at 1 of 3"));
        assert_eq!(group_digits(1234567.4), "1,234,567");
    }
}
