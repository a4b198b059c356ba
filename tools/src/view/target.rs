//! The viewer's target modes: the tolerance τ adjusted each frame so that the frame time, or
//! the triangle count, holds a target.
//!
//! The controller works on logarithms: the error is e = ln(measured / target), and τ is
//! multiplied by exp(g·e) — more triangles or a slower frame than wanted raises τ. Why it
//! does not oscillate:
//! - a dead band: |e| below `DEAD_BAND` (2 % for triangles, 8 % for frame time) changes
//!   nothing, so the step function triangles(τ) (patches come whole) cannot make it hunt
//!   between two neighbouring cuts whose counts straddle the target by little;
//! - an adaptive gain, as a bracketing root search: the gain halves whenever e changes sign
//!   (the last step overshot) and grows by a quarter, up to `MAX_GAIN`, while it keeps its
//!   sign; a step is at most ×`MAX_STEP` either way;
//! - frame time is the median of the last `WINDOW` frames drawn at the current τ (the window
//!   restarts after every change, so a decision never sees frames of the previous τ), which
//!   the machine's noise moves far less than single frames;
//! - the triangle count waits while the stream is still loading towards a finer cut (it rises
//!   as units land), except when it is already too high.

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
/// The largest gain, and the starting one.
const MAX_GAIN: f64 = 1.0;
const START_GAIN: f64 = 0.5;
const MIN_GAIN: f64 = 1.0 / 64.0;
/// The largest change of τ in one step, a factor.
const MAX_STEP: f64 = 2.0;

#[derive(Clone, Debug)]
pub struct Controller {
    pub target: Target,
    gain: f64,
    last_sign: f64,
    frames: VecDeque<f64>,
}

impl Controller {
    pub fn new(target: Target) -> Controller {
        Controller {
            target,
            gain: START_GAIN,
            last_sign: 0.0,
            frames: VecDeque::new(),
        }
    }

    /// The relative error the controller ignores.
    pub fn dead_band(&self) -> f64 {
        match self.target {
            Target::FrameMs(_) => 0.08,
            Target::Triangles(_) => 0.02,
        }
    }

    /// The tolerance for the next frame, after a frame drawn at `tau` that took `frame_ms`
    /// (since the previous one) and drew `triangles`; `loading`: the stream has units pending.
    pub fn update(&mut self, tau: f32, frame_ms: f64, triangles: u64, loading: bool) -> f32 {
        let e = match self.target {
            Target::FrameMs(ms) => {
                self.frames.push_back(frame_ms);
                if self.frames.len() > WINDOW {
                    self.frames.pop_front();
                }
                if self.frames.len() < WINDOW {
                    return tau;
                }
                let mut sorted: Vec<f64> = self.frames.iter().copied().collect();
                sorted.sort_by(f64::total_cmp);
                (sorted[WINDOW / 2] / ms).ln()
            }
            Target::Triangles(n) => {
                let e = (triangles.max(1) as f64 / n.max(1) as f64).ln();
                if loading && e < 0.0 {
                    return tau;
                }
                e
            }
        };
        if !e.is_finite() || e.abs() <= self.dead_band().ln_1p() {
            return tau;
        }
        let sign = e.signum();
        if sign == -self.last_sign {
            self.gain = (self.gain * 0.5).max(MIN_GAIN);
        } else if sign == self.last_sign {
            self.gain = (self.gain * 1.25).min(MAX_GAIN);
        }
        self.last_sign = sign;
        let step = (self.gain * e).clamp(-MAX_STEP.ln(), MAX_STEP.ln());
        let next = (tau.max(TOLERANCE_RANGE.0) as f64 * step.exp()) as f32;
        self.frames.clear();
        next.clamp(TOLERANCE_RANGE.0, TOLERANCE_RANGE.1)
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
                tau = c.update(tau, 10.0, n, false);
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
                tau = c.update(tau, ms, triangles as u64, false);
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

    #[test]
    fn it_holds_still_inside_the_dead_band_and_waits_for_loads() {
        let mut c = Controller::new(Target::Triangles(1000));
        assert_eq!(c.update(2.0, 1.0, 1010, false), 2.0);
        assert_eq!(
            c.update(2.0, 1.0, 500, true),
            2.0,
            "loading: the count will rise"
        );
        assert!(
            c.update(2.0, 1.0, 2000, true) > 2.0,
            "too many: raised at once"
        );
    }
}
