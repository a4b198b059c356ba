//! Where `gen mesh` puts a vertex: cube point → equal-angle cube map onto the unit sphere →
//! density warp → the demo's relief (`procedural::relief_radius`) along the direction.
//!
//! The density warp is a Möbius dilation of the sphere along z: in the stereographic chart
//! from the north pole, w ↦ w / s. It is conformal (triangles keep their shape, no slivers),
//! smooth and bijective; its linear scale goes from 1/s at the south pole to s at the north
//! pole, so triangle areas vary by s⁴ = R (`--density-range R`) from the densest to the
//! sparsest region, while the equal-angle map alone varies them by 1.3. The relief is a
//! function of the warped direction, so R changes the sampling, not the surface.
//! Positions are pure functions of their cube point: a vertex shared by faces is computed
//! once, and the same parameters give the same bits on every machine.

use crate::procedural::relief_radius;

/// Largest accepted density range: beyond it the smallest triangles of a billion-triangle
/// mesh come near f32's resolution.
pub const MAX_DENSITY_RANGE: f64 = 1e6;

/// The geometry of one generated surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// Noise seed of the relief.
    pub noise_seed: u32,
    /// Linear scale of the warp at the north pole (s = R^¼).
    pub dilation: f64,
}

impl Surface {
    /// The surface for `seed` and density range `r` (in [1, [`MAX_DENSITY_RANGE`]]).
    pub fn new(seed: u64, density_range: f64) -> Surface {
        Surface {
            noise_seed: (splitmix64(seed ^ 0x6d65_7368) >> 32) as u32,
            dilation: density_range.powf(0.25),
        }
    }

    /// The position of cube point `q` ∈ [−1, 1]³ (on the cube's surface).
    pub fn position(&self, q: [f64; 3]) -> [f64; 3] {
        let t = q.map(|x| (x * std::f64::consts::FRAC_PI_4).tan());
        let d = self.warp(normalize(t));
        let r = relief_radius(d, self.noise_seed);
        d.map(|x| x * r)
    }

    /// The density warp of a unit vector (module docs), computed in the chart away from the
    /// vector's pole so both halves stay accurate.
    pub fn warp(&self, [x, y, z]: [f64; 3]) -> [f64; 3] {
        let s = self.dilation;
        if s == 1.0 {
            return [x, y, z];
        }
        if z <= 0.0 {
            // North chart: w = (x, y) / (1 − z), w' = w / s.
            let k = 1.0 / ((1.0 - z) * s);
            let (wx, wy) = (x * k, y * k);
            let w2 = wx * wx + wy * wy;
            [2.0 * wx, 2.0 * wy, w2 - 1.0].map(|c| c / (w2 + 1.0))
        } else {
            // South chart: u = (x, y) / (1 + z) = w / |w|², u' = s · u.
            let k = s / (1.0 + z);
            let (ux, uy) = (x * k, y * k);
            let u2 = ux * ux + uy * uy;
            [2.0 * ux, 2.0 * uy, 1.0 - u2].map(|c| c / (1.0 + u2))
        }
    }
}

/// SplitMix64's finaliser.
pub(crate) fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|x| x / l)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
        (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
    }

    #[test]
    fn warp_is_continuous_unit_and_scales_by_s_at_the_poles() {
        let s = Surface::new(1, 10_000.0);
        assert!((s.dilation - 10.0).abs() < 1e-12);
        for d in [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [0.6, 0.0, 0.8],
            [0.0, 0.6, -0.8],
        ] {
            let w = s.warp(d);
            assert!((dist(w, [0.0; 3]) - 1.0).abs() < 1e-12);
        }
        // Both charts agree at the equator.
        let e = normalize([0.3, 0.7, 0.0]);
        let below = s.warp(normalize([0.3, 0.7, -1e-12]));
        let above = s.warp(normalize([0.3, 0.7, 1e-12]));
        assert!(dist(below, above) < 1e-9 && dist(s.warp(e), below) < 1e-9);
        // Poles are fixed; small steps scale by 1/s (south) and s (north).
        assert!(dist(s.warp([0.0, 0.0, -1.0]), [0.0, 0.0, -1.0]) < 1e-15);
        let h = 1e-6;
        let south = dist(s.warp(normalize([h, 0.0, -1.0])), [0.0, 0.0, -1.0]);
        let north = dist(s.warp(normalize([h, 0.0, 1.0])), [0.0, 0.0, 1.0]);
        assert!((south / h - 0.1).abs() < 1e-4, "{}", south / h);
        assert!((north / h - 10.0).abs() < 1e-3, "{}", north / h);
        // R = 1 is the identity; another seed is another relief.
        let one = Surface::new(1, 1.0);
        assert_eq!(one.warp(e), e);
        assert_ne!(Surface::new(2, 1.0).noise_seed, one.noise_seed);
    }

    #[test]
    fn positions_stay_within_the_relief_bounds() {
        let s = Surface::new(7, 100.0);
        for q in [
            [1.0, 0.25, -1.0],
            [-1.0, -1.0, 1.0],
            [0.0, 1.0, 0.0],
            [0.5, -0.5, 1.0],
        ] {
            let r = dist(s.position(q), [0.0; 3]);
            assert!(r > 0.6 && r < 1.4, "{q:?}: radius {r}");
        }
    }
}
