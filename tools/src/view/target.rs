//! The viewer's target modes: the tolerance τ adjusted each frame so that the frame time, or
//! the triangle count, holds a target.
//!
//! Two loops, both on logarithms (an error is e = ln(measured / wanted), a correction a
//! factor exp(g·e)):
//! - the inner loop holds a triangle count, every frame: τ ← τ·exp(g·(e + d)) — more
//!   triangles than wanted raises τ. The count answers at once (the frame's selection is read
//!   back), so this loop can be fast. d predicts the next frame's change from the camera's
//!   motion: the part of the last change of ln(count) that the change of τ does not explain
//!   (counts taken as ∝ 1/τ), averaged over frames; a flight into a close-up is met as it
//!   happens instead of one frame late;
//! - the frame-time mode adds an outer loop that moves the inner loop's goal: every `WINDOW`
//!   frames, the goal ← goal·exp(−g·e) with e from the median frame time of those frames.
//!   Frame times are noisy (a shared machine, the loader thread, the compositor); triangle
//!   counts are not, so the noise only reaches the slow loop, and a camera that flies from a
//!   coarse view into a close-up is followed at once by the fast one.
//!
//! Why neither oscillates:
//! - a dead band: |e| below 2 % (triangles) or 8 % (frame time) changes nothing, so the step
//!   function triangles(τ) (patches come whole) cannot make the inner loop hunt between two
//!   neighbouring cuts whose counts straddle the goal by little;
//! - an adaptive gain, as a bracketing root search: a loop's gain halves whenever its e
//!   changes sign (the last step overshot) and grows by a quarter, up to its largest, while it
//!   keeps its sign; an error past `FAR` (the view moved, the target changed) brings the gain
//!   back to its start, so a gain halved while hunting near the goal never leaves the loop
//!   slow for the next change; a step is at most ×`MAX_STEP` either way;
//! - the outer loop decides on frames drawn since its last decision only;
//! - no wind-up: a run of raises stops at ×`WIND_UP` the τ at which the count last fell by
//!   `WIND_UP_FALL` (τ no longer moves it: the eye is inside the spheres of the
//!   diamonds drawn, or only roots are left), and τ never passes `ceiling` (twice the largest
//!   ρ of the root diamonds for this view: above it only the roots are drawn); the motion
//!   drift is believed up to `MAX_DRIFT` a frame. So a target the coarsest cut misses does not
//!   drive τ to its limit, from where coming back would take many frames (lowering is not
//!   bounded: τ's range stops it);
//! - the inner loop does not lower τ while the stream is still loading towards a finer cut
//!   (the count rises as units land), only raises it when the count is already too high.

use std::collections::VecDeque;

/// What the controller holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// Milliseconds between frames (wall clock, what the user feels).
    FrameMs(f64),
    /// Triangles drawn.
    Triangles(u64),
}

/// The tolerance's range under control, pixels.
pub const TOLERANCE_RANGE: (f32, f32) = (0.05, 4096.0);
/// Frames of the frame-time median.
pub const WINDOW: usize = 5;
/// The largest change of τ, or of the triangle goal, in one step: a factor.
const MAX_STEP: f64 = 2.0;
/// |e| past which a loop's gain restarts (4 %: twice the triangle dead band).
const FAR: f64 = 0.04;

/// One loop's gain: halved when the error changes sign, grown while it keeps it.
#[derive(Clone, Debug)]
struct Gain {
    gain: f64,
    start: f64,
    max: f64,
    min: f64,
    last_sign: f64,
}

impl Gain {
    fn new(start: f64, max: f64, min: f64) -> Gain {
        Gain {
            gain: start,
            start,
            max,
            min,
            last_sign: 0.0,
        }
    }

    /// The step g·e (clamped) for an error e outside the dead band.
    fn step(&mut self, e: f64) -> f64 {
        let sign = e.signum();
        if e.abs() > FAR {
            self.gain = self.gain.max(self.start);
        }
        if sign == -self.last_sign {
            self.gain = (self.gain * 0.5).max(self.min);
        } else if sign == self.last_sign {
            self.gain = (self.gain * 1.25).min(self.max);
        }
        self.last_sign = sign;
        (self.gain * e).clamp(-MAX_STEP.ln(), MAX_STEP.ln())
    }
}

#[derive(Clone, Debug)]
pub struct Controller {
    pub target: Target,
    /// The inner loop's goal (the target itself in the triangle mode; `None` until the outer
    /// loop's first decision in the frame-time mode).
    goal: Option<f64>,
    inner: Gain,
    outer: Gain,
    frames: VecDeque<f64>,
    /// ln(count) and ln(τ) of the last frame, and the averaged motion drift d.
    last: Option<(f64, f64)>,
    drift: f64,
    /// Where the current run of raises began: its τ and count.
    raising_from: Option<(f64, f64)>,
}

/// A run of raises that has multiplied τ by this much while the count fell by less than
/// `WIND_UP_FALL` stops raising: τ no longer moves the count (the eye is inside the
/// spheres of the diamonds drawn, or only roots are left).
const WIND_UP: f64 = 4.0;
const WIND_UP_FALL: f64 = 0.1;
/// The largest motion drift believed, per frame (ln of a count ratio).
const MAX_DRIFT: f64 = 0.1;

/// The weight of the newest frame in the drift's average.
const DRIFT_WEIGHT: f64 = 0.5;

/// One frame's redraw attempts: the largest τ that drew too many triangles and the smallest
/// that drew too few.
#[derive(Clone, Copy, Debug, Default)]
pub struct Bracket {
    pub too_many: Option<f32>,
    pub too_few: Option<f32>,
}

/// Dead bands, relative.
const TRIANGLE_BAND: f64 = 0.02;
const FRAME_BAND: f64 = 0.08;

impl Controller {
    pub fn new(target: Target) -> Controller {
        Controller {
            target,
            goal: match target {
                Target::Triangles(n) => Some(n.max(1) as f64),
                Target::FrameMs(_) => None,
            },
            inner: Gain::new(0.75, 1.0, 1.0 / 64.0),
            outer: Gain::new(0.5, 1.0, 1.0 / 16.0),
            frames: VecDeque::new(),
            last: None,
            drift: 0.0,
            raising_from: None,
        }
    }

    /// The tolerance for the next frame, after a frame drawn at `tau` that took `frame_ms`
    /// (since the previous one) and drew `triangles`; `loading`: the stream has units pending.
    /// `ceiling`: the largest useful τ for this view (see the module comment).
    pub fn update(
        &mut self,
        tau: f32,
        frame_ms: f64,
        triangles: u64,
        loading: bool,
        ceiling: f32,
    ) -> f32 {
        let triangles = triangles.max(1) as f64;
        if let Target::FrameMs(ms) = self.target {
            if frame_ms > 0.0 {
                self.frames.push_back(frame_ms);
            }
            if self.frames.len() >= WINDOW {
                let mut sorted: Vec<f64> = self.frames.drain(..).collect();
                sorted.sort_by(f64::total_cmp);
                let e = (sorted[sorted.len() / 2] / ms).ln();
                // The first decision starts from the count drawn, scaled as if frame time were
                // proportional to it; later ones step. A frame slower than wanted lowers the
                // goal, which stays near what the cut can give (no wind-up while τ sits at a
                // limit).
                let goal = self.goal.unwrap_or(triangles);
                let stepped = match self.goal {
                    None if e.is_finite() => goal * (-e).exp(),
                    Some(_) if e.is_finite() && e.abs() > FRAME_BAND.ln_1p() => {
                        goal * (-self.outer.step(e)).exp()
                    }
                    _ => goal,
                };
                self.goal = Some(stepped.clamp(triangles / MAX_STEP, triangles * MAX_STEP));
            }
            if self.goal.is_none() {
                return tau;
            }
        }
        let goal = self.goal.expect("set above");
        let (ln_count, ln_tau) = (triangles.ln(), (tau.max(TOLERANCE_RANGE.0) as f64).ln());
        if let Some((count0, tau0)) = self.last {
            // What τ's change does not explain (counts ∝ 1/τ): the view's motion. Not while
            // loading: then the count also rises with the units landing.
            let moved = (ln_count - count0) + (ln_tau - tau0);
            if !loading && moved.is_finite() {
                let moved = moved.clamp(-MAX_DRIFT, MAX_DRIFT);
                self.drift += DRIFT_WEIGHT * (moved - self.drift);
            }
        }
        self.last = Some((ln_count, ln_tau));
        let e = (triangles / goal.max(1.0)).ln() + self.drift;
        if e <= 0.0 {
            self.raising_from = None;
        }
        if (loading && e < 0.0) || !e.is_finite() || e.abs() <= TRIANGLE_BAND.ln_1p() {
            return tau;
        }
        let mut next = tau.max(TOLERANCE_RANGE.0) as f64 * self.inner.step(e).exp();
        if e > 0.0 {
            // The reference moves to wherever the count last responded.
            let (tau0, count0) = *self.raising_from.get_or_insert((tau as f64, triangles));
            if triangles <= count0 * (1.0 - WIND_UP_FALL) {
                self.raising_from = Some((tau as f64, triangles));
            } else if next > tau0 * WIND_UP {
                next = (tau as f64).max(tau0 * WIND_UP).min(next);
            }
        }
        if ceiling.is_finite() && ceiling > 0.0 {
            next = next.min(ceiling as f64);
        }
        (next as f32).clamp(TOLERANCE_RANGE.0, TOLERANCE_RANGE.1)
    }

    /// In the triangle mode, when a frame's count misses the budget by more than `miss`
    /// (relative): the τ to draw the same view again with (the camera has not moved since).
    /// `tried` holds this frame's earlier attempts: once one drew too many triangles and one
    /// too few, the next τ bisects them (geometric mean), else it is one Newton step on
    /// counts ∝ 1/τ from the count just read. `None` otherwise.
    pub fn redraw_tolerance(
        &self,
        tau: f32,
        triangles: u64,
        miss: f64,
        tried: &mut Bracket,
    ) -> Option<f32> {
        let Target::Triangles(budget) = self.target else {
            return None;
        };
        let ratio = triangles.max(1) as f64 / budget.max(1) as f64;
        if (ratio - 1.0).abs() <= miss {
            return None;
        }
        if ratio > 1.0 {
            tried.too_many = Some(tried.too_many.map_or(tau, |t| t.max(tau)));
        } else {
            tried.too_few = Some(tried.too_few.map_or(tau, |t| t.min(tau)));
        }
        let next = match (tried.too_many, tried.too_few) {
            (Some(a), Some(b)) => (a as f64 * b as f64).sqrt(),
            _ => tau.max(TOLERANCE_RANGE.0) as f64 * ratio.clamp(1.0 / MAX_STEP, MAX_STEP),
        };
        Some((next as f32).clamp(TOLERANCE_RANGE.0, TOLERANCE_RANGE.1))
    }

    /// The triangle count the inner loop holds now.
    pub fn goal(&self) -> Option<f64> {
        self.goal
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model whose triangle count falls as a step function of τ (patches of 1,000
    /// triangles): the controller settles within its dead band and stays there.
    #[test]
    fn the_triangle_budget_settles_without_hunting() {
        let triangles = |tau: f32| ((2.0e6 / tau.max(1e-3) as f64) / 1000.0).round() as u64 * 1000;
        for budget in [50_000u64, 300_000, 1_000_000] {
            let mut c = Controller::new(Target::Triangles(budget));
            let mut tau = 1.0f32;
            let mut last = Vec::new();
            for frame in 0..200 {
                let n = triangles(tau);
                tau = c.update(tau, 10.0, n, false, f32::INFINITY);
                if frame >= 150 {
                    last.push((tau, triangles(tau)));
                }
            }
            for &(t, n) in &last {
                let off = (n as f64 / budget as f64 - 1.0).abs();
                assert!(off <= 0.05, "budget {budget}: {n} triangles at τ {t}");
                assert_eq!(t, last[0].0, "settled: τ no longer moves");
            }
        }
    }

    /// Frame time proportional to the triangles plus a fixed cost, with ±15 % noise: the
    /// median of every 30-frame window after settling is within ±20 % of the target.
    #[test]
    fn the_frame_time_target_holds_through_noise() {
        let mut seed = 12345u64;
        let mut noise = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 33) as f64 / (1u64 << 31) as f64) * 0.3 - 0.15
        };
        for target in [15.0, 40.0] {
            let mut c = Controller::new(Target::FrameMs(target));
            let mut tau = 1.0f32;
            let mut times = Vec::new();
            for _ in 0..600 {
                let triangles = 2.0e6 / tau as f64;
                let ms = (5.0 + triangles * 2e-5) * (1.0 + noise());
                times.push(ms);
                tau = c.update(tau, ms, triangles as u64, false, f32::INFINITY);
            }
            for window in times[300..].chunks(30) {
                let mut w = window.to_vec();
                w.sort_by(f64::total_cmp);
                let median = w[w.len() / 2];
                assert!(
                    (median / target - 1.0).abs() <= 0.2,
                    "target {target} ms: a window's median is {median:.2} ms"
                );
            }
        }
    }

    /// A camera flying in and out: the count at a given τ changes by up to 4 % a frame; the
    /// budget is held within 5 % on at least nine frames in ten, and its 30-frame medians
    /// within 2 %.
    #[test]
    fn the_triangle_budget_follows_a_moving_view() {
        let budget = 200_000u64;
        let mut c = Controller::new(Target::Triangles(budget));
        let mut tau = 1.0f32;
        let mut counts = Vec::new();
        for frame in 0..600 {
            // The scene's detail: ×3 over a 160-frame cycle (≤ 4 % a frame).
            let detail = 1.5e6 * (1.0 + 0.5 * (frame as f64 * std::f64::consts::TAU / 160.0).sin());
            let n = (detail / tau as f64) as u64;
            counts.push(n as f64);
            tau = c.update(tau, 10.0, n, false, f32::INFINITY);
        }
        let off: Vec<f64> = counts[100..]
            .iter()
            .map(|n| (n / budget as f64 - 1.0).abs())
            .collect();
        let within = off.iter().filter(|&&o| o <= 0.05).count();
        assert!(
            within * 10 >= off.len() * 9,
            "{within} of {} frames within 5 %",
            off.len()
        );
        for w in counts[100..].chunks(30) {
            let mut w = w.to_vec();
            w.sort_by(f64::total_cmp);
            let median = w[w.len() / 2];
            assert!(
                (median / budget as f64 - 1.0).abs() <= 0.02,
                "a window's median {median}"
            );
        }
    }

    /// A budget below what the coarsest cut draws: τ rises until the count stops changing,
    /// then stays (no wind-up), and comes back down at once when the budget allows more.
    #[test]
    fn a_budget_out_of_reach_does_not_wind_up() {
        let triangles = |tau: f32| (2.0e6 / tau as f64).max(5_000.0) as u64;
        let mut c = Controller::new(Target::Triangles(1_000));
        let mut tau = 1.0f32;
        for _ in 0..200 {
            tau = c.update(tau, 10.0, triangles(tau), false, f32::INFINITY);
        }
        // The count first stops changing within one doubling past the knee at τ = 400.
        assert!(tau <= 2.0 * 400.0 * WIND_UP as f32, "τ wound up to {tau}");
        let mut c = Controller::new(Target::Triangles(100_000));
        let mut frames = 0;
        while (triangles(tau) as f64 / 100_000.0 - 1.0).abs() > 0.05 {
            tau = c.update(tau, 10.0, triangles(tau), false, f32::INFINITY);
            frames += 1;
            assert!(frames < 20, "slow to come back: τ {tau}");
        }
    }

    #[test]
    fn a_missed_budget_is_redrawn_at_a_corrected_tolerance() {
        let c = Controller::new(Target::Triangles(100_000));
        let fresh = Bracket::default;
        assert_eq!(
            c.redraw_tolerance(2.0, 104_000, 0.05, &mut fresh()),
            None,
            "within 5 %"
        );
        assert_eq!(
            c.redraw_tolerance(2.0, 120_000, 0.05, &mut fresh()),
            Some(2.4)
        );
        assert_eq!(
            c.redraw_tolerance(2.0, 80_000, 0.05, &mut fresh()),
            Some(1.6)
        );
        // Across a jump: 1.6 drew too many, then 1.8 too few: the next try is between.
        let mut tried = fresh();
        assert_eq!(
            c.redraw_tolerance(1.6, 110_000, 0.05, &mut tried),
            Some(1.76)
        );
        let next = c.redraw_tolerance(1.8, 91_000, 0.05, &mut tried).unwrap();
        assert!((next - (1.6f32 * 1.8).sqrt()).abs() < 1e-6, "{next}");
        let t = Controller::new(Target::FrameMs(30.0));
        assert_eq!(
            t.redraw_tolerance(2.0, 1, 0.05, &mut fresh()),
            None,
            "frame-time mode never redraws"
        );
    }

    /// A budget that needs τ = 2000 where only roots are drawn above 40: τ stops at the
    /// ceiling; and a count that τ does not move (the eye inside the spheres drawn), creeping
    /// up with the camera, stops the raises at ×`WIND_UP`.
    #[test]
    fn tau_stops_at_the_ceiling_and_where_it_no_longer_moves_the_count() {
        let mut c = Controller::new(Target::Triangles(1_000));
        let mut tau = 1.0f32;
        for _ in 0..100 {
            tau = c.update(tau, 10.0, (2.0e6 / tau) as u64, false, 40.0);
            assert!(tau <= 40.0, "τ {tau}");
        }
        assert_eq!(tau, 40.0);
        let mut c = Controller::new(Target::Triangles(1_000));
        let mut tau = 1.0f32;
        for frame in 0..100 {
            tau = c.update(tau, 10.0, 50_000 + frame, false, f32::INFINITY);
        }
        assert!(tau <= WIND_UP as f32, "τ {tau}");
    }

    #[test]
    fn it_holds_still_inside_the_dead_band_and_waits_for_loads() {
        let mut c = Controller::new(Target::Triangles(1000));
        assert_eq!(c.update(2.0, 1.0, 1010, false, f32::INFINITY), 2.0);
        assert_eq!(
            c.update(2.0, 1.0, 500, true, f32::INFINITY),
            2.0,
            "loading: the count will rise"
        );
        assert!(
            c.update(2.0, 1.0, 2000, true, f32::INFINITY) > 2.0,
            "too many: raised at once"
        );
    }
}
