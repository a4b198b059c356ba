//! Who wins where: the fewest triangles at equal *measured* error.
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

    fn text(&self) -> String {
        let t = group_digits(self.triangles());
        match self {
            Estimate::Measured(_) => t,
            Estimate::Interpolated(_) => format!("≈{t}"),
            Estimate::AtMost(_) => format!("≤{t}"),
            Estimate::AtLeast(_) => format!("≥{t}"),
        }
    }

    fn kind(&self) -> &'static str {
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
fn estimate(front: &[(f64, f64)], error: f64) -> Option<Estimate> {
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

// Front to front (issue 46): the headline verdict, on the dense error.

/// The finest error level a front-to-front comparison reads (px).
pub const FIRST_LEVEL_PX: f64 = 0.5;

/// Ours ÷ a peer's triangles at one level, read off both fronts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ratio {
    /// Both counts on their fronts.
    Exact(f64),
    /// Ours an upper bound, or the peer's a lower bound: the ratio is at most this.
    AtMost(f64),
    /// Ours a lower bound, or the peer's an upper bound: the ratio is at least this.
    AtLeast(f64),
    /// Both bounds the same way: the order is open.
    Open(f64),
}

impl Ratio {
    fn of(ours: Estimate, peer: Estimate) -> Ratio {
        // -1: an upper bound (≤), 1: a lower bound (≥), 0: on the front.
        let side = |e: Estimate| match e {
            Estimate::Measured(_) | Estimate::Interpolated(_) => 0,
            Estimate::AtMost(_) => -1,
            Estimate::AtLeast(_) => 1,
        };
        let r = ours.triangles() / peer.triangles();
        // The ratio moves with ours and against the peer's.
        match (side(ours), -side(peer)) {
            (0, 0) => Ratio::Exact(r),
            (a, b) if a <= 0 && b <= 0 => Ratio::AtMost(r),
            (a, b) if a >= 0 && b >= 0 => Ratio::AtLeast(r),
            _ => Ratio::Open(r),
        }
    }

    pub fn value(&self) -> f64 {
        match *self {
            Ratio::Exact(r) | Ratio::AtMost(r) | Ratio::AtLeast(r) | Ratio::Open(r) => r,
        }
    }

    /// "exact", "at_most", "at_least" or "open".
    pub fn kind(&self) -> &'static str {
        match self {
            Ratio::Exact(_) => "exact",
            Ratio::AtMost(_) => "at_most",
            Ratio::AtLeast(_) => "at_least",
            Ratio::Open(_) => "open",
        }
    }

    fn text(&self) -> String {
        let r = self.value();
        match self {
            Ratio::Exact(_) => format!("{r:.2}×"),
            Ratio::AtMost(_) => format!("≤ {r:.2}×"),
            Ratio::AtLeast(_) => format!("≥ {r:.2}×"),
            Ratio::Open(_) => format!("{r:.2}× (open)"),
        }
    }
}

/// Both counts at one error level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelRatio {
    pub error_px: f64,
    pub ours: Estimate,
    pub peer: Estimate,
    pub ratio: Ratio,
}

/// Ours against one peer, front to front.
#[derive(Clone, Debug, PartialEq)]
pub struct FrontComparison {
    pub peer: &'static str,
    /// Both fronts: (error, triangles), error ascending.
    pub ours_front: Vec<(f64, f64)>,
    pub peer_front: Vec<(f64, f64)>,
    pub levels: Vec<LevelRatio>,
    /// The level with the largest ratio that is reached (exact, or a lower bound); `None`
    /// when no level has one.
    pub worst: Option<LevelRatio>,
}

/// The error levels from `first` to `last`: `first`·√2^k below `last`, then `last` (none when
/// `last` < `first`).
pub fn levels_between(first: f64, last: f64) -> Vec<f64> {
    if !(first > 0.0 && last.is_finite() && last >= first) {
        return Vec::new();
    }
    let mut levels: Vec<f64> = (0..)
        .map(|k| first * 2f64.powf(k as f64 / 2.0))
        .take_while(|&e| e < last * (1.0 - 1e-9))
        .collect();
    levels.push(last);
    levels
}

/// Ours against `peer` front to front: each subject's Pareto front of its (error, triangles)
/// points (`pareto_front`: a row beaten by another of its own rows does not count), read at
/// error levels from `FIRST_LEVEL_PX` to the peer's coarsest (`levels_between`), both counts
/// interpolated in (log error, log triangles), bounds (`Estimate::AtMost`, `AtLeast`) where
/// a level lies outside a front; the ratio ours ÷ peer at each and the worst.
pub fn front_to_front(ours: &[(f64, f64)], peer: (&'static str, &[(f64, f64)])) -> FrontComparison {
    let ours_front = pareto_front(ours.iter().copied());
    let peer_front = pareto_front(peer.1.iter().copied());
    let coarsest = peer_front.last().map_or(0.0, |p| p.0);
    let levels: Vec<LevelRatio> = levels_between(FIRST_LEVEL_PX, coarsest)
        .into_iter()
        .filter_map(|error_px| {
            let o = estimate(&ours_front, error_px)?;
            let p = estimate(&peer_front, error_px)?;
            Some(LevelRatio {
                error_px,
                ours: o,
                peer: p,
                ratio: Ratio::of(o, p),
            })
        })
        .collect();
    let worst = levels
        .iter()
        .filter(|l| matches!(l.ratio, Ratio::Exact(_) | Ratio::AtLeast(_)))
        .max_by(|a, b| a.ratio.value().total_cmp(&b.ratio.value()))
        .copied();
    FrontComparison {
        peer: peer.0,
        ours_front,
        peer_front,
        levels,
        worst,
    }
}

/// The human lines of front-to-front comparisons: per peer, one line a level and the worst.
pub fn front_lines(comparisons: &[FrontComparison]) -> Vec<String> {
    let mut lines = Vec::new();
    for c in comparisons {
        lines.push(format!(
            "  against {} (levels {:.2} px to its coarsest, {:.2} px):",
            c.peer,
            FIRST_LEVEL_PX,
            c.peer_front.last().map_or(0.0, |p| p.0)
        ));
        for l in &c.levels {
            lines.push(format!(
                "    {:>7.2} px: ours {}, {} {} → ours/{} {}",
                l.error_px,
                l.ours.text(),
                c.peer,
                l.peer.text(),
                c.peer,
                l.ratio.text()
            ));
        }
        lines.push(match &c.worst {
            Some(w) => format!(
                "    worst ratio ours/{}: {} at {:.2} px",
                c.peer,
                w.ratio.text(),
                w.error_px
            ),
            None => format!("    worst ratio ours/{}: none decided", c.peer),
        });
    }
    lines
}

/// Front-to-front comparisons as JSON: per peer `peer`, `ours_front` and `peer_front`
/// ([error_px, triangles] pairs), `levels` (`error_px`, `ours` and `peer` as {`value`,
/// `kind`}, `ratio` as {`value`, `kind`}) and `worst` (a level, or null).
pub fn fronts_to_json(comparisons: &[FrontComparison]) -> serde_json::Value {
    let level = |l: &LevelRatio| {
        json!({
            "error_px": l.error_px,
            "ours": {"value": l.ours.triangles(), "kind": l.ours.kind()},
            "peer": {"value": l.peer.triangles(), "kind": l.peer.kind()},
            "ratio": {"value": l.ratio.value(), "kind": l.ratio.kind()},
        })
    };
    json!(comparisons
        .iter()
        .map(|c| json!({
            "peer": c.peer,
            "ours_front": c.ours_front.iter().map(|p| [p.0, p.1]).collect::<Vec<_>>(),
            "peer_front": c.peer_front.iter().map(|p| [p.0, p.1]).collect::<Vec<_>>(),
            "levels": c.levels.iter().map(level).collect::<Vec<_>>(),
            "worst": c.worst.as_ref().map(level),
        }))
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

    /// Front to front: our own dominated row does not count against us, both counts come off
    /// the fronts, the levels run from 0.5 px to the peer's coarsest, bounds where a level is
    /// outside a front.
    #[test]
    fn front_to_front_reads_both_fronts() {
        // Our τ = 1 row (32,823 at 3.37 px) is beaten by our τ = 2 row (16,705 at 3.00 px):
        // the dragon's rows of 2026-12-04.
        let ours = [
            (0.31, 128_462.0),
            (0.76, 65_446.0),
            (3.37, 32_823.0),
            (3.0, 16_705.0),
        ];
        let peer = [
            (0.33, 106_016.0),
            (0.59, 57_722.0),
            (3.24, 31_558.0),
            (3.15, 17_623.0),
        ];
        let c = front_to_front(&ours, ("cluster_dag", &peer));
        assert_eq!(
            c.ours_front,
            vec![(0.31, 128_462.0), (0.76, 65_446.0), (3.0, 16_705.0)]
        );
        assert_eq!(
            c.peer_front,
            vec![(0.33, 106_016.0), (0.59, 57_722.0), (3.15, 17_623.0)]
        );
        let errors: Vec<f64> = c.levels.iter().map(|l| l.error_px).collect();
        let expected = [
            0.5,
            0.5 * 2f64.sqrt(),
            1.0,
            2f64.sqrt(),
            2.0,
            2.0 * 2f64.sqrt(),
            3.15,
        ];
        assert_eq!(errors.len(), expected.len(), "{errors:?}");
        for (e, x) in errors.iter().zip(expected) {
            assert!((e - x).abs() < 1e-12, "{errors:?}");
        }
        // At 3.15 px the peer is on its front, and past our coarsest (3.0): ours is at most
        // 16,705.
        let last = c.levels.last().unwrap();
        assert_eq!(last.peer, Estimate::Interpolated(17_623.0));
        assert_eq!(last.ours, Estimate::AtMost(16_705.0));
        assert_eq!(last.ratio, Ratio::AtMost(16_705.0 / 17_623.0));
        for l in &c.levels {
            assert!(
                matches!(l.ratio, Ratio::Exact(_) | Ratio::AtMost(_)),
                "{l:?}"
            );
        }
        // At 2 px both interpolate in logs.
        let two = c.levels.iter().find(|l| l.error_px == 2.0).unwrap();
        let log_interp = |(e0, t0): (f64, f64), (e1, t1): (f64, f64), e: f64| -> f64 {
            let s = (e / e0).ln() / (e1 / e0).ln();
            (f64::ln(t0) + s * (t1 / t0).ln()).exp()
        };
        let o = log_interp((0.76, 65_446.0), (3.0, 16_705.0), 2.0);
        let p = log_interp((0.59, 57_722.0), (3.15, 17_623.0), 2.0);
        assert!((two.ratio.value() - o / p).abs() < 1e-9, "{two:?}");
        assert!(matches!(two.ratio, Ratio::Exact(_)));
        // The worst is the largest ratio that is reached.
        let worst = c.worst.unwrap();
        let reached = c
            .levels
            .iter()
            .filter(|l| matches!(l.ratio, Ratio::Exact(_)))
            .map(|l| l.ratio.value())
            .fold(0.0, f64::max);
        assert_eq!(worst.ratio.value(), reached);
        let j = fronts_to_json(std::slice::from_ref(&c));
        assert_eq!(j[0]["peer"], "cluster_dag");
        assert_eq!(j[0]["levels"].as_array().unwrap().len(), 7);
        assert_eq!(j[0]["levels"][6]["ratio"]["kind"], "at_most");
    }

    /// Bounds combine: ours finer than measured (≥) against a peer on its front is a lower
    /// bound of the ratio; both lower bounds leave it open; a peer coarser than 0.5 px at
    /// its coarsest gives no level.
    #[test]
    fn front_ratios_carry_their_bounds() {
        let ours = [(2.0, 1000.0), (8.0, 100.0)];
        let peer = [(0.25, 4000.0), (1.0, 2000.0), (4.0, 400.0)];
        let c = front_to_front(&ours, ("peer", &peer));
        let first = c.levels[0];
        assert_eq!(first.error_px, 0.5);
        assert_eq!(first.ours, Estimate::AtLeast(1000.0));
        assert!(matches!(first.ratio, Ratio::AtLeast(_)));
        assert_eq!(c.levels.last().unwrap().error_px, 4.0);
        assert!(matches!(c.levels.last().unwrap().ratio, Ratio::Exact(_)));
        assert_eq!(
            Ratio::of(Estimate::AtLeast(10.0), Estimate::AtLeast(5.0)),
            Ratio::Open(2.0)
        );
        assert_eq!(
            Ratio::of(Estimate::AtMost(10.0), Estimate::AtLeast(5.0)),
            Ratio::AtMost(2.0)
        );
        assert_eq!(
            Ratio::of(Estimate::Interpolated(10.0), Estimate::AtMost(5.0)),
            Ratio::AtLeast(2.0)
        );
        let fine = front_to_front(&ours, ("fine", &[(0.1, 10.0), (0.4, 5.0)]));
        assert!(fine.levels.is_empty() && fine.worst.is_none());
        assert!(levels_between(0.5, 0.4).is_empty());
        assert_eq!(levels_between(0.5, 0.5), vec![0.5]);
        assert!(front_lines(&[c])
            .iter()
            .any(|l| l.contains("worst ratio ours/peer")));
    }
}
