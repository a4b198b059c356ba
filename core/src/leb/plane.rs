//! Oriented planes through lattice points, with an exact side test for f64 query points that
//! is cheap in the common case: a floating-point filter with a rigorous error bound, falling
//! back to the adaptive exact predicate (`robust`) only when the point is too close to the
//! plane for the filter to decide.
//!
//! Point location classifies every input triangle's barycentre against a bisecting plane at
//! every level of the hierarchy, and the simplifier locates every new triangle in a diamond:
//! these tests dominate the construction's predicate cost, and almost all of them are far from
//! the plane.

use super::predicates::{orient2d_exact, orient3d_exact, LatticePoint};

/// An oriented plane through lattice points `a, b, c` in 3D, or the line through `a, b` in 2D
/// (z ignored). Sides are the exact sign of `n · (q − a)`, with the integer normal
/// `n = (b − a) × (c − a)` in 3D and `n = (a_y − b_y, b_x − a_x)` in 2D; that is
/// `−orient3d(a, b, c, q)` in 3D and `orient2d(a, b, q)` in 2D. Callers compare the signs of
/// two points, so only consistency matters.
#[derive(Clone, Copy, Debug)]
pub struct LatticePlane {
    dim: u8,
    points: [LatticePoint; 3],
    /// `a` in f64 (exact: lattice coordinates are i32).
    origin: [f64; 3],
    /// The integer normal rounded to f64 (exact while its components stay below 2^53, which
    /// holds on lattices of up to 2^26 units per side; the filter's bound covers the rounding
    /// otherwise).
    normal: [f64; 3],
}

/// The filter's relative error bound, 8u with u = 2^-53 the unit roundoff (see `side_of_point`).
const FILTER_BOUND: f64 = 1.0 / (1u64 << 50) as f64;

impl LatticePlane {
    /// The plane through `a, b, c` (3D) or the line through `a, b` (2D; `c` is ignored).
    pub fn through(dim: u8, a: LatticePoint, b: LatticePoint, c: LatticePoint) -> LatticePlane {
        let d = |p: LatticePoint, i: usize| p[i] as i128 - a[i] as i128;
        let normal: [i128; 3] = if dim == 3 {
            [
                d(b, 1) * d(c, 2) - d(b, 2) * d(c, 1),
                d(b, 2) * d(c, 0) - d(b, 0) * d(c, 2),
                d(b, 0) * d(c, 1) - d(b, 1) * d(c, 0),
            ]
        } else {
            [-d(b, 1), d(b, 0), 0]
        };
        LatticePlane {
            dim,
            points: [a, b, if dim == 3 { c } else { a }],
            origin: a.map(f64::from),
            normal: normal.map(|n| n as f64),
        }
    }

    /// Exact side (−1, 0, 1) of a lattice point.
    pub fn side_of_lattice_point(&self, p: LatticePoint) -> i32 {
        let [a, b, c] = self.points;
        if self.dim == 3 {
            -orient3d_exact(a, b, c, p)
        } else {
            orient2d_exact(a, b, p)
        }
    }

    /// Exact side (−1, 0, 1) of an f64 point; identical to the exact predicate for every input,
    /// NaN and infinities included (they always take the exact path).
    ///
    /// Filter: with `d_i = fl(q_i − a_i)` and `p_i = fl(n_i · d_i)`, the computed
    /// `v = fl(fl(p_0 + p_1) + p_2)` differs from the exact `Σ N_i (q_i − a_i)` by at most
    /// `((1 + u)^5 − 1) · Σ |N_i (q_i − a_i)|` (one rounding each for the normal, the
    /// difference, the product and two sums), and the computed `m = Σ |p_i|` is at least
    /// `(1 − u)^5` times that sum, so `8u · m` bounds the error with room to spare; the
    /// `f64::MIN_POSITIVE` term covers the absolute error of products that underflow. When
    /// `|v|` exceeds the bound, its sign is the exact sign; otherwise (points on or very near
    /// the plane, overflow, NaN) the adaptive exact predicate decides, including the zero that
    /// callers' tie rules depend on.
    #[inline]
    pub fn side_of_point(&self, q: [f64; 3]) -> i32 {
        let (n, a) = (&self.normal, &self.origin);
        let p0 = n[0] * (q[0] - a[0]);
        let p1 = n[1] * (q[1] - a[1]);
        // In 2D n[2] is 0; q[2] still enters so that a non-finite z takes the exact path,
        // which ignores it, as the 2D predicate always has.
        let p2 = n[2] * (q[2] - a[2]);
        let v = (p0 + p1) + p2;
        let bound = ((p0.abs() + p1.abs()) + p2.abs()) * FILTER_BOUND + f64::MIN_POSITIVE;
        if v > bound {
            1
        } else if v < -bound {
            -1
        } else {
            self.side_of_point_exact(q)
        }
    }

    /// The exact side by the adaptive predicate alone (the filter's fallback; also the
    /// reference the filter is tested against).
    pub fn side_of_point_exact(&self, q: [f64; 3]) -> i32 {
        let [a, b, c] = self.points;
        let r = if self.dim == 3 {
            -robust::orient3d(
                coord3(a),
                coord3(b),
                coord3(c),
                robust::Coord3D {
                    x: q[0],
                    y: q[1],
                    z: q[2],
                },
            )
        } else {
            robust::orient2d(coord2(a), coord2(b), robust::Coord { x: q[0], y: q[1] })
        };
        if r > 0.0 {
            1
        } else if r < 0.0 {
            -1
        } else {
            0
        }
    }
}

fn coord2(p: LatticePoint) -> robust::Coord<f64> {
    robust::Coord {
        x: p[0] as f64,
        y: p[1] as f64,
    }
}

fn coord3(p: LatticePoint) -> robust::Coord3D<f64> {
    robust::Coord3D {
        x: p[0] as f64,
        y: p[1] as f64,
        z: p[2] as f64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filter_defers_points_on_the_plane_to_the_exact_test() {
        let plane = LatticePlane::through(3, [0, 0, 0], [1 << 20, 0, 0], [0, 1 << 20, 0]);
        assert_eq!(plane.side_of_point([5.5, 7.25, 0.0]), 0);
        let above = plane.side_of_point([5.5, 7.25, f64::MIN_POSITIVE]);
        assert_eq!(
            above,
            plane.side_of_point_exact([5.5, 7.25, f64::MIN_POSITIVE])
        );
        assert_ne!(above, 0);
        assert_eq!(plane.side_of_lattice_point([3, 3, 1]), above);
        assert_eq!(
            plane.side_of_point([f64::NAN, 0.0, 0.0]),
            plane.side_of_point_exact([f64::NAN, 0.0, 0.0])
        );
    }
}
