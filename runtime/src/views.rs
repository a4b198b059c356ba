//! Deterministic camera positions for checks and benchmarks: directions evenly spread on a
//! Fibonacci sphere, at several distances around the model and inside its bounding box, or all
//! outside its bounding sphere.

/// Direction `i` of `count` on a Fibonacci sphere (unit vector).
fn fibonacci_direction(i: usize, count: usize) -> [f64; 3] {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let t = (i as f64 + 0.5) / count as f64;
    let z = 1.0 - 2.0 * t;
    let r = (1.0 - z * z).sqrt();
    let phi = golden * i as f64;
    [r * phi.cos(), r * phi.sin(), z]
}

/// Centre and bounding radius (half the diagonal) of a box.
fn centre_and_radius(lo: [f64; 3], hi: [f64; 3]) -> ([f64; 3], f64) {
    let centre = [0, 1, 2].map(|i| 0.5 * (lo[i] + hi[i]));
    let half = [0, 1, 2].map(|i| 0.5 * (hi[i] - lo[i]));
    let radius = (half[0] * half[0] + half[1] * half[1] + half[2] * half[2])
        .sqrt()
        .max(1e-30);
    (centre, radius)
}

/// `count` eyes in model space for a model with bounding box `[lo, hi]`. About one in eight is
/// inside the box; the others orbit at 0.6 to 6 bounding radii from the centre.
pub fn check_views(lo: [f64; 3], hi: [f64; 3], count: usize) -> Vec<[f64; 3]> {
    let (centre, radius) = centre_and_radius(lo, hi);
    let half = [0, 1, 2].map(|i| 0.5 * (hi[i] - lo[i]));
    (0..count)
        .map(|i| {
            let dir = fibonacci_direction(i, count);
            if i % 8 == 7 {
                // Inside the box, off-centre.
                let s = 0.2 + 0.6 * ((i / 8) as f64 * 0.618_033_988_75).fract();
                [0, 1, 2].map(|k| centre[k] + dir[k] * half[k] * s)
            } else {
                let distance = radius * (0.6 + 5.4 * ((i as f64 * 0.754_877_666).fract()).powi(2));
                [0, 1, 2].map(|k| centre[k] + dir[k] * distance)
            }
        })
        .collect()
}

/// `count` eyes outside the bounding sphere of a box, at 1.3 to 4 bounding radii from its
/// centre (the pixel check: a closed model seen from outside shows no back face).
pub fn outside_views(lo: [f64; 3], hi: [f64; 3], count: usize) -> Vec<[f64; 3]> {
    let (centre, radius) = centre_and_radius(lo, hi);
    (0..count)
        .map(|i| {
            let dir = fibonacci_direction(i, count);
            let distance = radius * (1.3 + 2.7 * (i as f64 * 0.618_033_988_75).fract());
            [0, 1, 2].map(|k| centre[k] + dir[k] * distance)
        })
        .collect()
}

/// A camera position and direction for the terrain pixel check.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TerrainView {
    pub eye: [f64; 3],
    pub target: [f64; 3],
    /// Below the terrain, looking up (its underside faces the camera).
    pub from_below: bool,
}

/// `count` views of a height field with bounding box `[lo, hi]` (z up): half above its highest
/// point, half below its lowest, every eye over the grid's (x, y) rectangle (inset by 10 %),
/// looking down (up) at 25° to 90° from the horizontal, from 1 % to 50 % of the larger
/// horizontal extent above (below) the terrain. From there every ray meets the side of the
/// surface that faces the eye first, so a flag pixel is a hole: a crack, or a hole of the input.
pub fn terrain_views(lo: [f64; 3], hi: [f64; 3], count: usize) -> Vec<TerrainView> {
    let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-30);
    (0..count)
        .map(|i| {
            let from_below = i % 2 == 1;
            let j = (i / 2) as f64;
            // Low-discrepancy placements (golden-ratio and plastic-number sequences).
            let u = 0.1 + 0.8 * (j * 0.618_033_988_75 + 0.31).fract();
            let v = 0.1 + 0.8 * (j * 0.754_877_666 + 0.17).fract();
            let t = (j * 0.569_840_290_998 + 0.5).fract();
            let height = extent * 10f64.powf(-2.0 + 1.7 * t);
            let elevation = (25.0 + 65.0 * (j * 0.414_213_562 + 0.2).fract()).to_radians();
            let azimuth = (j * 137.507_764).to_radians();
            let sign = if from_below { -1.0 } else { 1.0 };
            let eye = [
                lo[0] + u * (hi[0] - lo[0]),
                lo[1] + v * (hi[1] - lo[1]),
                if from_below { lo[2] } else { hi[2] } + sign * height,
            ];
            let forward = [
                azimuth.cos() * elevation.cos(),
                azimuth.sin() * elevation.cos(),
                -sign * elevation.sin(),
            ];
            let target = [0, 1, 2].map(|k| eye[k] + forward[k] * height);
            TerrainView {
                eye,
                target,
                from_below,
            }
        })
        .collect()
}
