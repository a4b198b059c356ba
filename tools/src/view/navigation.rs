//! The viewer's camera: an orbit around the model's centre (azimuth, elevation, distance in
//! bounding radii, as `render --orbit`) shifted by a pan. Left drag orbits, right drag pans,
//! the wheel zooms, `R` resets to the initial view.

use tessera_runtime::camera::{bounding_radius, Camera};

/// Degrees of orbit per pixel dragged.
const DEGREES_PER_PIXEL: f64 = 0.3;
/// Distance factor per wheel line (one notch).
const ZOOM_PER_LINE: f64 = 0.9;

#[derive(Clone, Debug)]
pub struct Navigation {
    lo: [f64; 3],
    hi: [f64; 3],
    up: [f64; 3],
    fov_y_degrees: f64,
    initial: [f64; 3],
    /// Azimuth and elevation (degrees), distance (bounding radii).
    pub orbit: [f64; 3],
    /// Added to the eye and the target, model units.
    pub pan: [f64; 3],
}

impl Navigation {
    pub fn new(lo: [f64; 3], hi: [f64; 3], up: [f64; 3], fov: f64, orbit: [f64; 3]) -> Self {
        Navigation {
            lo,
            hi,
            up,
            fov_y_degrees: fov,
            initial: orbit,
            orbit,
            pan: [0.0; 3],
        }
    }

    /// The orbit `[az, el, dist]` around the centre, pan cleared.
    pub fn set_orbit(&mut self, orbit: [f64; 3]) {
        self.orbit = orbit;
        self.pan = [0.0; 3];
    }

    /// Back to the initial view.
    pub fn reset(&mut self) {
        self.set_orbit(self.initial);
    }

    /// The camera for a `width` × `height` image.
    pub fn camera(&self, width: u32, height: u32) -> Camera {
        let [az, el, dist] = self.orbit;
        let mut camera = Camera::orbit(self.lo, self.hi, self.up, az, el, dist);
        for i in 0..3 {
            camera.eye[i] += self.pan[i];
            camera.target[i] += self.pan[i];
        }
        camera.fov_y_degrees = self.fov_y_degrees;
        (camera.width, camera.height) = (width, height);
        camera
    }

    /// Left drag by (dx, dy) pixels: orbit (elevation kept within ±89°).
    pub fn rotate(&mut self, dx: f64, dy: f64) {
        self.orbit[0] = (self.orbit[0] - dx * DEGREES_PER_PIXEL).rem_euclid(360.0);
        self.orbit[1] = (self.orbit[1] + dy * DEGREES_PER_PIXEL).clamp(-89.0, 89.0);
    }

    /// Right drag by (dx, dy) pixels of a `height`-pixel view: the model follows the cursor
    /// at the target's depth.
    pub fn pan_by(&mut self, dx: f64, dy: f64, height: u32) {
        let camera = self.camera(1, height.max(1));
        let basis = camera.basis();
        let distance = self.orbit[2] * bounding_radius(self.lo, self.hi);
        let per_pixel =
            2.0 * distance * (self.fov_y_degrees.to_radians() / 2.0).tan() / height.max(1) as f64;
        for i in 0..3 {
            self.pan[i] += (-dx * basis.right[i] + dy * basis.up[i]) * per_pixel;
        }
    }

    /// Wheel by `lines` notches (positive: towards the model).
    pub fn zoom(&mut self, lines: f64) {
        self.orbit[2] = (self.orbit[2] * ZOOM_PER_LINE.powf(lines)).clamp(1e-4, 1e4);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nav() -> Navigation {
        Navigation::new(
            [-1.0; 3],
            [1.0; 3],
            [0.0, 1.0, 0.0],
            60.0,
            [30.0, 20.0, 2.5],
        )
    }

    #[test]
    fn the_initial_camera_is_renders_orbit() {
        let c = nav().camera(640, 480);
        let r = Camera::orbit([-1.0; 3], [1.0; 3], [0.0, 1.0, 0.0], 30.0, 20.0, 2.5);
        assert_eq!(
            (c.eye, c.target, c.width, c.height),
            (r.eye, r.target, 640, 480)
        );
    }

    #[test]
    fn navigation_moves_the_camera_and_reset_restores_it() {
        let mut n = nav();
        let before = n.camera(640, 480);
        n.rotate(100.0, 20.0);
        n.pan_by(50.0, -30.0, 480);
        n.zoom(3.0);
        let after = n.camera(640, 480);
        assert_ne!(before.eye, after.eye);
        assert_ne!(before.target, after.target);
        let d = |c: &Camera| {
            (0..3)
                .map(|i| (c.eye[i] - c.target[i]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        assert!(d(&after) < d(&before));
        n.reset();
        let reset = n.camera(640, 480);
        assert_eq!((reset.eye, reset.target), (before.eye, before.target));
    }
}
