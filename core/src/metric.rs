//! The screen-space error metric, evaluated identically (in f32) by the CPU reference and GPU.
//!
//! ρ(D) = err(D) · K / max(|centre(D) − eye| − radius(D), near),  K = height / (2·tan(fovy/2)).
//! Saturation (err(parent) ≥ err(child)·(1+margin), sphere(parent) ⊇ sphere(child) + margin)
//! makes ρ(parent) ≥ ρ(child) for every eye, after f32 rounding too.

/// Projection constants of a view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenSpaceMetric {
    /// Pixels per model unit at distance 1: viewport_height / (2·tan(fovy/2)).
    pub k: f32,
    /// Distances below this (model units) are clamped, so ρ stays finite inside a sphere.
    pub near: f32,
}

impl ScreenSpaceMetric {
    pub fn new(viewport_height: u32, fovy_degrees: f64, near: f64) -> Self {
        let k = viewport_height as f64 / (2.0 * (fovy_degrees.to_radians() * 0.5).tan());
        ScreenSpaceMetric {
            k: k as f32,
            near: near as f32,
        }
    }

    /// ρ in pixels of an error bounded by a sphere at `center_minus_eye` (f32, eye-relative).
    #[inline]
    pub fn rho(&self, error: f32, center_minus_eye: [f32; 3], radius: f32) -> f32 {
        let [x, y, z] = center_minus_eye;
        let distance = (x * x + y * y + z * z).sqrt();
        error * self.k / (distance - radius).max(self.near)
    }
}

/// The eye in the repository's f32 frame: `(eye − origin)` computed in f64, then rounded.
/// Every sphere centre is stored relative to `origin`, so `centre − eye_local` stays small and
/// exact enough even when the model sits 1e8 units from the world origin.
pub fn eye_local(eye: [f64; 3], origin: [f64; 3]) -> [f32; 3] {
    [0, 1, 2].map(|i| (eye[i] - origin[i]) as f32)
}

/// `centre − eye_local` in f32, the exact operation the GPU performs.
#[inline]
pub fn center_minus_eye(center: [f32; 3], eye_local: [f32; 3]) -> [f32; 3] {
    [
        center[0] - eye_local[0],
        center[1] - eye_local[1],
        center[2] - eye_local[2],
    ]
}
