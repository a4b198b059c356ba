//! Eye-relative vertex positions formed on the position lattice, the CPU mirror of
//! `eye_relative_position` in `shaders/position.wgsl`.
//!
//! A stored position is a lattice point q (21-bit integers per axis, `format::POSITION_BITS`):
//! position = bbox_min + q × step. The eye's lattice coordinate (eye − bbox_min) / step is split
//! on the CPU, in f64, into an integer cell c (i32) and a remainder f (rounded to f32); the
//! vertex stage forms
//!
//! ```text
//! eye_relative(q) = (f32(q − c) − f) × step
//! ```
//!
//! with q − c in exact integer arithmetic. Near the eye q − c is small, so the result carries
//! the precision of a model at the origin whatever the model's extent: on a 40,000 km terrain
//! (step ≈ 19 m) a vertex 10 m from the eye is placed to about 1e-6 m, where the former
//! `bbox_min − origin + f32(q) × step − eye` (f32 throughout) lost metres to the rounding of
//! numbers near 4e7. The result depends on q and the frame alone, so a vertex shared by two
//! patches (same q) lands on the same bits in both.
//!
//! Ranges: q lies in `[0, 2^21)` (a terrain check's skirts reach a little below and above),
//! c is clamped to `±EYE_CELL_LIMIT` = ±2^23, so |q − c| < 2^24: no i32 overflow, and the
//! conversion to f32 is exact. An eye farther than that (more than 4 model extents from the
//! box along an axis) keeps the excess in f, which is then large but relatively exact: such an
//! eye is far from every vertex.

/// The largest |cell| of the eye, 2^23 lattice steps.
pub const EYE_CELL_LIMIT: i32 = 1 << 23;

/// Model units per lattice step on each axis, as the vertex stage scales: the position step,
/// or on a flat axis (step 0, where every stored q is 0) the largest positive step (1 if every
/// axis is flat), so that the eye's offset along it still splits into a cell and a fraction.
pub fn lattice_unit(position_step: [f64; 3]) -> [f64; 3] {
    let largest = position_step
        .iter()
        .copied()
        .filter(|s| *s > 0.0)
        .fold(0.0, f64::max);
    let fallback = if largest > 0.0 { largest } else { 1.0 };
    position_step.map(|s| if s > 0.0 { s } else { fallback })
}

/// The eye on the lattice, as the frame uniforms carry it (`Frame::eye_cell`,
/// `Frame::eye_fraction`, `Frame::step` in `shaders/records.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EyeLattice {
    /// ⌊(eye − bbox_min) / unit⌋ per axis, clamped to ±`EYE_CELL_LIMIT`.
    pub cell: [i32; 3],
    /// (eye − bbox_min) / unit − cell, computed in f64 and rounded: in [0, 1] unless clamped.
    pub fraction: [f32; 3],
    /// `lattice_unit` rounded to f32.
    pub unit: [f32; 3],
}

impl EyeLattice {
    /// Splits `eye` (model space, f64) on the lattice of a repository whose header has
    /// `bbox_min` and `position_step`.
    pub fn new(eye: [f64; 3], bbox_min: [f64; 3], position_step: [f64; 3]) -> EyeLattice {
        let unit = lattice_unit(position_step);
        let limit = EYE_CELL_LIMIT as f64;
        let mut cell = [0i32; 3];
        let mut fraction = [0.0f32; 3];
        for i in 0..3 {
            let e = (eye[i] - bbox_min[i]) / unit[i];
            // NaN stays NaN through clamp and becomes cell 0 through `as`.
            let c = e.floor().clamp(-limit, limit);
            cell[i] = c as i32;
            fraction[i] = (e - cell[i] as f64) as f32;
        }
        EyeLattice {
            cell,
            fraction,
            unit: unit.map(|u| u as f32),
        }
    }

    /// `eye_relative_position` of `shaders/position.wgsl`, operation for operation: the
    /// lattice difference in i32 (wrapping like the GPU's, though the ranges above keep it
    /// exact), converted to f32, minus the fraction, times the unit.
    pub fn eye_relative(&self, q: [i32; 3]) -> [f32; 3] {
        [0, 1, 2]
            .map(|i| (q[i].wrapping_sub(self.cell[i]) as f32 - self.fraction[i]) * self.unit[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::repository::format::{dequantize_position, position_step, POSITION_MAX};

    /// The exact eye-relative position (f64) of lattice point q.
    fn exact(q: [u32; 3], eye: [f64; 3], lo: [f64; 3], step: [f64; 3]) -> [f64; 3] {
        let p = dequantize_position(q, lo, step);
        [0, 1, 2].map(|i| p[i] - eye[i])
    }

    /// The former formula: `base + f32(q) × step − eye_local`, all f32, base and eye relative
    /// to the origin (= bbox_min).
    fn former(q: [u32; 3], eye: [f64; 3], lo: [f64; 3], step: [f64; 3]) -> [f32; 3] {
        [0, 1, 2].map(|i| 0.0f32 + q[i] as f32 * step[i] as f32 - (eye[i] - lo[i]) as f32)
    }

    fn max_error(a: [f32; 3], b: [f64; 3]) -> f64 {
        (0..3)
            .map(|i| (a[i] as f64 - b[i]).abs())
            .fold(0.0, f64::max)
    }

    /// An ETOPO-scale box: 40,000 km × 20,000 km × 20 km.
    const LO: [f64; 3] = [-2.0e7, -1.0e7, -11_000.0];
    const HI: [f64; 3] = [2.0e7, 1.0e7, 8_850.0];

    #[test]
    fn ten_metres_from_the_eye_the_lattice_formula_keeps_micrometres() {
        let step = position_step(LO, HI);
        assert!(step[0] > 19.0 && step[0] < 19.1, "{step:?}");
        let mut worst_new = 0.0f64;
        let mut worst_old = 0.0f64;
        for q0 in [
            [7, 9, 100],
            [POSITION_MAX - 3, POSITION_MAX - 5, 2_000_000],
            [1_234_567, 987_654, 1_500_000],
        ] {
            let p = dequantize_position(q0, LO, step);
            let eye = [p[0] + 3.25, p[1] - 2.5, p[2] + 10.0];
            let lattice = EyeLattice::new(eye, LO, step);
            for d in [[0i32, 0, 0], [1, 0, 0], [0, -1, 0], [1, 1, -1], [-3, 2, 5]] {
                let q = [0, 1, 2].map(|i| (q0[i] as i32 + d[i]) as u32);
                let want = exact(q, eye, LO, step);
                let got = lattice.eye_relative(q.map(|c| c as i32));
                worst_new = worst_new.max(max_error(got, want));
                worst_old = worst_old.max(max_error(former(q, eye, LO, step), want));
            }
        }
        // |q − c| ≤ 6 here: f32 of a fraction and a product, about 1e-6 of 100 m.
        assert!(worst_new < 1e-4, "lattice formula off by {worst_new} m");
        // The former formula rounded numbers near 4e7 (ulp 4 m).
        assert!(worst_old > 0.5, "former formula off by only {worst_old} m");
    }

    #[test]
    fn cells_are_clamped_and_flat_axes_still_place_the_eye() {
        let lo = [0.0, 0.0, 5.0];
        let step = position_step(lo, [100.0, 50.0, 5.0]); // z flat
        assert_eq!(step[2], 0.0);
        let unit = lattice_unit(step);
        assert_eq!(unit[2], step[0]);
        // Far away along x: clamped cell, the rest in the fraction.
        let eye = [1e12, 25.0, 7.0];
        let l = EyeLattice::new(eye, lo, step);
        assert_eq!(l.cell[0], EYE_CELL_LIMIT);
        let r = l.eye_relative([0, 0, 0]);
        assert!(((r[0] as f64) + 1e12).abs() < 1e12 * 1e-6, "{r:?}");
        assert!(((r[1] as f64) + 25.0).abs() < 1e-5, "{r:?}");
        // Flat z: q = 0 there, and the eye is 2 above the plane.
        assert!(((r[2] as f64) + 2.0).abs() < 1e-5, "{r:?}");
        // Every axis flat (a point model): unit 1.
        assert_eq!(lattice_unit([0.0; 3]), [1.0; 3]);
        // NaN eye: no panic, cell 0.
        assert_eq!(EyeLattice::new([f64::NAN; 3], lo, step).cell, [0; 3]);
    }
}
