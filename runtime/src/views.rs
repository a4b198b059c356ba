//! Deterministic camera positions for checks and benchmarks: around the model at several
//! distances (a Fibonacci sphere, so directions are evenly spread) and inside its bounding box.

/// `count` eyes in model space for a model with bounding box `[lo, hi]`. About one in eight is
/// inside the box; the others orbit at 0.6 to 6 bounding radii from the centre.
pub fn check_views(lo: [f64; 3], hi: [f64; 3], count: usize) -> Vec<[f64; 3]> {
    let centre = [0, 1, 2].map(|i| 0.5 * (lo[i] + hi[i]));
    let half = [0, 1, 2].map(|i| 0.5 * (hi[i] - lo[i]));
    let radius = (half[0] * half[0] + half[1] * half[1] + half[2] * half[2])
        .sqrt()
        .max(1e-30);
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count)
        .map(|i| {
            let t = (i as f64 + 0.5) / count as f64;
            let z = 1.0 - 2.0 * t;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            let dir = [r * phi.cos(), r * phi.sin(), z];
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
