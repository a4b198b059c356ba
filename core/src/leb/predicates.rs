//! Exact orientation predicates on the integer lattice (i128 arithmetic, no rounding) and on
//! f64 query points (Shewchuk's adaptive predicates from the `robust` crate).
//!
//! Sign convention: positive when `d` lies on the side of the oriented plane (a, b, c) that
//! `robust::orient3d` calls positive; callers only ever compare signs of two calls.

/// Lattice point; 2D simplices use z = 0.
pub type LatticePoint = [i32; 3];

/// Exact sign of the 2D orientation of (a, b, p) using x and y only.
pub fn orient2d_exact(a: LatticePoint, b: LatticePoint, p: LatticePoint) -> i32 {
    let (ax, ay) = (a[0] as i128, a[1] as i128);
    let det = (b[0] as i128 - ax) * (p[1] as i128 - ay) - (b[1] as i128 - ay) * (p[0] as i128 - ax);
    det.signum() as i32
}

/// Exact sign of the 3D orientation determinant of (a, b, c, p).
pub fn orient3d_exact(a: LatticePoint, b: LatticePoint, c: LatticePoint, p: LatticePoint) -> i32 {
    let d = |u: LatticePoint| {
        [
            u[0] as i128 - p[0] as i128,
            u[1] as i128 - p[1] as i128,
            u[2] as i128 - p[2] as i128,
        ]
    };
    let (a, b, c) = (d(a), d(b), d(c));
    let det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0]);
    det.signum() as i32
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

/// Exact sign of orient2d(a, b, q) for an f64 query point (lattice coordinates are exact in f64).
pub fn orient2d_point(a: LatticePoint, b: LatticePoint, q: [f64; 3]) -> i32 {
    let r = robust::orient2d(coord2(a), coord2(b), robust::Coord { x: q[0], y: q[1] });
    sign(r)
}

/// Exact sign of orient3d(a, b, c, q) for an f64 query point.
pub fn orient3d_point(a: LatticePoint, b: LatticePoint, c: LatticePoint, q: [f64; 3]) -> i32 {
    let r = robust::orient3d(
        coord3(a),
        coord3(b),
        coord3(c),
        robust::Coord3D {
            x: q[0],
            y: q[1],
            z: q[2],
        },
    );
    sign(r)
}

fn sign(r: f64) -> i32 {
    if r > 0.0 {
        1
    } else if r < 0.0 {
        -1
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_and_float_predicates_agree_on_lattice_points() {
        let a = [0, 0, 0];
        let b = [1 << 20, 0, 0];
        let c = [0, 1 << 20, 0];
        for p in [[3, 5, 7], [3, 5, -7], [9, 9, 0]] {
            let q = [p[0] as f64, p[1] as f64, p[2] as f64];
            assert_eq!(orient3d_exact(a, b, c, p), orient3d_point(a, b, c, q));
            assert_eq!(orient2d_exact(a, b, p), orient2d_point(a, b, q));
        }
        // Far beyond i64 products: exact arithmetic still decides.
        let big = [i32::MAX, i32::MAX, i32::MAX];
        assert_eq!(
            orient3d_exact(a, b, c, big),
            orient3d_point(a, b, c, [big[0] as f64; 3])
        );
    }
}
