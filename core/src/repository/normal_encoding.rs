//! Stored normals: octahedral i16 pairs, and the 10-bit grid the build puts them on (issue 49).
//! Re-exported by `format.rs`.

fn sign_not_zero(x: f32) -> f32 {
    if x < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// Octahedral encoding of a normal as 2 × i16 snorm (Cigolle et al., "A Survey of Efficient
/// Representations for Independent Unit Vectors", 2014). Angular error ≤ ~0.0001 rad.
///
/// `n` need not be unit length; a zero or non-finite normal encodes as +Z.
pub fn oct_encode_normal(n: [f32; 3]) -> [i16; 2] {
    let l1 = n[0].abs() + n[1].abs() + n[2].abs();
    if !(l1 > 0.0 && l1.is_finite()) {
        return [0, 0];
    }
    let (mut x, mut y) = (n[0] / l1, n[1] / l1);
    if n[2] < 0.0 {
        (x, y) = (
            (1.0 - y.abs()) * sign_not_zero(x),
            (1.0 - x.abs()) * sign_not_zero(y),
        );
    }
    [x, y].map(|v| (v.clamp(-1.0, 1.0) * 32767.0).round() as i16)
}

/// Steps per unit of the octahedral grid the build stores normals on (issue 49): 10 bits per
/// component (2·511 + 1 values each), carried in the same i16 snorm fields, so decoding is
/// unchanged and a reader cannot tell it from a 16-bit normal.
pub const NORMAL_GRID_STEPS: i32 = 511;

/// Proven worst-case angle (radians) between a unit normal and its decoded grid normal.
/// Rounding moves the octahedral point (x, y) by at most h/2 per axis, h = 1/`NORMAL_GRID_STEPS`;
/// the map to the octahedron |x|+|y|+|z| = 1 is piecewise linear with |Δ3| ≤ √(dx²+dy²+(|dx|+|dy|)²)
/// ≤ √1.5·h, the octahedron's points are at least 1/√3 from the origin, so the angle is at most
/// asin(√3·√1.5·h) = asin(3h/√2); the extra i16 rounding and f32 arithmetic add ≤ 1e-4 rad.
pub fn normal_grid_max_angle() -> f64 {
    (3.0 / (std::f64::consts::SQRT_2 * NORMAL_GRID_STEPS as f64)).asin() + 1e-4
}

/// `oct_encode_normal` snapped to the `NORMAL_GRID_STEPS` grid: each component is
/// round(k · 32767 / 511) for an integer |k| ≤ 511, so its decoding is k/511 to within f32.
/// Idempotent: re-encoding a decoded grid normal gives the same i16 pair (the decoded
/// coordinates are within ~1e-6 of the grid, far from a rounding boundary).
pub fn oct_encode_normal_grid(n: [f32; 3]) -> [i16; 2] {
    let m = NORMAL_GRID_STEPS;
    let mut k = oct_encode_normal(n).map(|v| (v as f64 * m as f64 / 32767.0).round() as i32);
    // On the square's border (|x| = 1 or |y| = 1) the fold loses the other coordinate's sign:
    // (±1, y) and (±1, −y) decode alike. Keep the sign that re-encoding the decoded normal
    // gives (positive), so that encoding stays idempotent.
    if k[0].abs() == m {
        k[1] = k[1].abs();
    }
    if k[1].abs() == m {
        k[0] = k[0].abs();
    }
    k.map(|k| (k as f64 * 32767.0 / m as f64).round() as i16)
}

/// Inverse of `oct_encode_normal`: a unit vector for every input (−32768 reads as −1).
pub fn oct_decode_normal(e: [i16; 2]) -> [f32; 3] {
    let mut x = (e[0] as f32 / 32767.0).max(-1.0);
    let mut y = (e[1] as f32 / 32767.0).max(-1.0);
    let z = 1.0 - x.abs() - y.abs();
    if z < 0.0 {
        (x, y) = (
            (1.0 - y.abs()) * sign_not_zero(x),
            (1.0 - x.abs()) * sign_not_zero(y),
        );
    }
    let l = (x * x + y * y + z * z).sqrt();
    [x / l, y / l, z / l]
}
