//! Deterministic area-weighted samples on a triangle surface: a triangle by its area in the
//! CDF, a point in it by uniform barycentrics, from a fixed seed — the same surface gives the
//! same samples on every run and machine (`geometric_error` measures at them).

use super::geometric_error::Surface;
use crate::vec3::{cross, dot, sub};

/// SplitMix64: a small, fixed, portable generator (the samples must not depend on a crate's
/// version).
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `count` area-weighted points on `surface` (none when it has no area), each with its
/// triangle (its index in `surface.triangles`).
pub fn sample_triangles(surface: Surface<'_>, count: usize, seed: u64) -> Vec<([f64; 3], usize)> {
    let corners = |t: &[u32; 3]| t.map(|v| surface.positions[v as usize]);
    // Cumulative areas (twice the area; the factor cancels).
    let mut cumulative = Vec::with_capacity(surface.triangles.len());
    let mut total = 0.0;
    for t in surface.triangles {
        let [a, b, c] = corners(t);
        let n = cross(sub(b, a), sub(c, a));
        total += dot(n, n).sqrt();
        cumulative.push(total);
    }
    if !(total > 0.0 && total.is_finite()) {
        return Vec::new();
    }
    let mut rng = SplitMix64(seed);
    (0..count)
        .map(|_| {
            let target = rng.next_f64() * total;
            let k = cumulative
                .partition_point(|&c| c <= target)
                .min(cumulative.len() - 1);
            let [a, b, c] = corners(&surface.triangles[k]);
            // Uniform on the triangle: (1 − √r1, √r1 (1 − r2), √r1 r2).
            let (r1, r2) = (rng.next_f64().sqrt(), rng.next_f64());
            let (wb, wc) = (r1 * (1.0 - r2), r1 * r2);
            let wa = 1.0 - wb - wc;
            ([0, 1, 2].map(|i| wa * a[i] + wb * b[i] + wc * c[i]), k)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampling_is_deterministic_and_area_weighted() {
        // Two triangles: the second has 3× the area of the first.
        let positions = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [3.0, 0.0, 0.0],
            [4.0, 0.0, 0.0],
            [3.0, 3.0, 0.0],
        ];
        let triangles = vec![[0, 1, 2], [3, 4, 5]];
        let surface = Surface {
            positions: &positions,
            triangles: &triangles,
        };
        let points = |seed| -> Vec<[f64; 3]> {
            sample_triangles(surface, 4000, seed)
                .into_iter()
                .map(|(p, _)| p)
                .collect()
        };
        let a = points(1);
        assert_eq!(a, points(1));
        assert_ne!(a, points(2));
        let second = a.iter().filter(|p| p[0] >= 3.0).count() as f64 / 4000.0;
        assert!((second - 0.75).abs() < 0.03, "{second}");
        assert!(a.iter().all(|p| p[0] + p[1] <= 1.0 + 1e-12 || p[0] >= 3.0));
        // Each point comes with the triangle it lies on.
        assert!(sample_triangles(surface, 500, 3)
            .iter()
            .all(|&(p, k)| (k == 1) == (p[0] >= 3.0)));
        // No area, no samples.
        let flat = vec![[0, 0, 1]];
        let none = Surface {
            positions: &positions,
            triangles: &flat,
        };
        assert!(sample_triangles(none, 10, 1).is_empty());
    }
}
