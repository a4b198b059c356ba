//! Front to front (issue 46): the headline verdict, on the dense error. Each subject's
//! Pareto front over τ in (dense max error, triangles); ours against each peer at error levels
//! from [`FIRST_LEVEL_PX`] to the peer's coarsest, both counts read off their fronts
//! (`verdict::estimate`), with bounds where a level lies outside a front.

use serde_json::json;

use super::verdict::{estimate, pareto_front, Estimate};

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
