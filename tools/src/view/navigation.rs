//! The viewer's camera: an orbit around a pivot (azimuth, elevation, distance in bounding
//! radii, as `render --orbit`; the pivot starts at the model's centre and is moved by a pan,
//! a pick on the surface or a zoom towards the cursor), and a fly mode that turns the view
//! around the eye and moves eye and pivot together. Left drag orbits (fly mode: looks
//! around), right drag pans, the wheel zooms towards the cursor, `R` resets the view.

use tessera_runtime::camera::{bounding_radius, orbit_angles, orbit_direction, Camera};
use tessera_runtime::vec3::{add, dot, length, scale, sub};

/// Degrees of orbit per pixel dragged.
const DEGREES_PER_PIXEL: f64 = 0.3;
/// Degrees the view turns per pixel dragged in fly mode.
const LOOK_DEGREES_PER_PIXEL: f64 = 0.15;
/// Distance factor per wheel line (one notch).
const ZOOM_PER_LINE: f64 = 0.9;
/// The orbit distance's range, bounding radii.
const DISTANCE_RANGE: (f64, f64) = (1e-6, 1e4);
/// Largest elevation, degrees (the view never looks straight along `up`).
const MAX_ELEVATION: f64 = 89.0;

#[derive(Clone, Debug)]
pub struct Navigation {
    lo: [f64; 3],
    hi: [f64; 3],
    up: [f64; 3],
    fov_y_degrees: f64,
    initial: [f64; 3],
    /// Azimuth and elevation (degrees) of the direction from the pivot to the eye, distance
    /// (bounding radii).
    pub orbit: [f64; 3],
    /// The pivot's offset from the model's centre, model units (added to eye and target).
    pub pan: [f64; 3],
    /// Fly mode: a left drag turns the view around the eye instead of orbiting.
    pub fly: bool,
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
            fly: false,
        }
    }

    /// The same settings (field of view, initial orbit, fly mode) for another model, at its
    /// initial view.
    pub fn for_model(&self, lo: [f64; 3], hi: [f64; 3], up: [f64; 3]) -> Navigation {
        Navigation {
            fly: self.fly,
            ..Navigation::new(lo, hi, up, self.fov_y_degrees, self.initial)
        }
    }

    /// The model's bounding radius (the orbit distance's unit).
    pub fn radius(&self) -> f64 {
        bounding_radius(self.lo, self.hi)
    }

    /// The up direction.
    pub fn up(&self) -> [f64; 3] {
        self.up
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

    /// The point the orbit turns around, model units.
    pub fn pivot(&self) -> [f64; 3] {
        let centre = [0, 1, 2].map(|i| 0.5 * (self.lo[i] + self.hi[i]));
        add(centre, self.pan)
    }

    /// The eye, model units.
    pub fn eye(&self) -> [f64; 3] {
        let dir = orbit_direction(self.up, self.orbit[0], self.orbit[1]);
        add(self.pivot(), scale(dir, self.orbit[2] * self.radius()))
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

    /// Eye and pivot placed exactly (the orbit's angles and distance follow; the distance
    /// clamped to its range along the same direction); nothing for coincident points.
    pub fn set_eye_and_pivot(&mut self, eye: [f64; 3], pivot: [f64; 3]) {
        let d = sub(eye, pivot);
        let Some([az, el]) = orbit_angles(self.up, d) else {
            return;
        };
        let el = el.clamp(-MAX_ELEVATION, MAX_ELEVATION);
        let dist = (length(d) / self.radius()).clamp(DISTANCE_RANGE.0, DISTANCE_RANGE.1);
        self.orbit = [az, el, dist];
        self.pan = sub(pivot, [0, 1, 2].map(|i| 0.5 * (self.lo[i] + self.hi[i])));
    }

    /// A new pivot (a point picked on the surface) with the eye where it is.
    pub fn set_pivot(&mut self, pivot: [f64; 3]) {
        self.set_eye_and_pivot(self.eye(), pivot);
    }

    /// Left drag by (dx, dy) pixels: orbit (elevation kept within ±89°), or in fly mode
    /// `look`.
    pub fn rotate(&mut self, dx: f64, dy: f64) {
        if self.fly {
            return self.look(dx, dy);
        }
        self.orbit[0] = (self.orbit[0] - dx * DEGREES_PER_PIXEL).rem_euclid(360.0);
        self.orbit[1] =
            (self.orbit[1] + dy * DEGREES_PER_PIXEL).clamp(-MAX_ELEVATION, MAX_ELEVATION);
    }

    /// Fly mode's left drag by (dx, dy) pixels: the view turns around the eye (right and
    /// down with the cursor), the pivot moving in front of it.
    pub fn look(&mut self, dx: f64, dy: f64) {
        let eye = self.eye();
        // The pivot→eye direction turns with the view (the eye stays, the pivot swings to
        // the other side); a view turning up is an eye sinking below the pivot.
        self.orbit[0] = (self.orbit[0] - dx * LOOK_DEGREES_PER_PIXEL).rem_euclid(360.0);
        self.orbit[1] =
            (self.orbit[1] + dy * LOOK_DEGREES_PER_PIXEL).clamp(-MAX_ELEVATION, MAX_ELEVATION);
        let dir = orbit_direction(self.up, self.orbit[0], self.orbit[1]);
        let pivot = sub(eye, scale(dir, self.orbit[2] * self.radius()));
        self.pan = sub(pivot, [0, 1, 2].map(|i| 0.5 * (self.lo[i] + self.hi[i])));
    }

    /// Eye and pivot moved together by `step` model units along the view's right, up and
    /// forward axes (`[right, up, forward]` components).
    pub fn fly(&mut self, step: [f64; 3]) {
        let b = self.camera(1, 1).basis();
        let d = add(
            add(scale(b.right, step[0]), scale(b.up, step[1])),
            scale(b.forward, step[2]),
        );
        self.pan = add(self.pan, d);
    }

    /// Eye and pivot moved together by `d`, model units.
    pub fn translate(&mut self, d: [f64; 3]) {
        self.pan = add(self.pan, d);
    }

    /// Right drag by (dx, dy) pixels of a `height`-pixel view: the model follows the cursor
    /// at the pivot's depth.
    pub fn pan_by(&mut self, dx: f64, dy: f64, height: u32) {
        let camera = self.camera(1, height.max(1));
        let basis = camera.basis();
        let distance = self.orbit[2] * self.radius();
        let per_pixel =
            2.0 * distance * (self.fov_y_degrees.to_radians() / 2.0).tan() / height.max(1) as f64;
        for i in 0..3 {
            self.pan[i] += (-dx * basis.right[i] + dy * basis.up[i]) * per_pixel;
        }
    }

    /// Wheel by `lines` notches (positive: towards the model) towards the pivot.
    pub fn zoom(&mut self, lines: f64) {
        self.orbit[2] =
            (self.orbit[2] * ZOOM_PER_LINE.powf(lines)).clamp(DISTANCE_RANGE.0, DISTANCE_RANGE.1);
    }

    /// Wheel by `lines` notches towards `point` (the surface under the cursor): eye and pivot
    /// both move towards it by the zoom's factor, so the point stays under the cursor.
    pub fn zoom_towards(&mut self, point: [f64; 3], lines: f64) {
        let wanted = self.orbit[2] * ZOOM_PER_LINE.powf(lines);
        let f = wanted.clamp(DISTANCE_RANGE.0, DISTANCE_RANGE.1) / self.orbit[2];
        let toward = |p: [f64; 3]| add(point, scale(sub(p, point), f));
        let (eye, pivot) = (toward(self.eye()), toward(self.pivot()));
        self.set_eye_and_pivot(eye, pivot);
    }

    /// The unit ray from the eye through pixel (x, y) of a `width` × `height` image (x right,
    /// y down, pixel centres at +0.5).
    pub fn ray(&self, x: f64, y: f64, width: u32, height: u32) -> [f64; 3] {
        let c = self.camera(width, height);
        let b = c.basis();
        let tan_y = (0.5 * c.fov_y_degrees.to_radians()).tan();
        let nx = 2.0 * x / width.max(1) as f64 - 1.0;
        let ny = 1.0 - 2.0 * y / height.max(1) as f64;
        let d = add(
            b.forward,
            add(
                scale(b.right, nx * tan_y * c.aspect()),
                scale(b.up, ny * tan_y),
            ),
        );
        scale(d, 1.0 / length(d))
    }

    /// Eye and pivot lifted along `up` so that the eye is at least `clearance` above
    /// `ground` (the surface under it); whether they moved.
    pub fn keep_above(&mut self, ground: [f64; 3], clearance: f64) -> bool {
        let height = self.height_above(ground);
        if height >= clearance {
            return false;
        }
        let up = scale(self.up, 1.0 / length(self.up).max(1e-300));
        self.translate(scale(up, clearance - height));
        true
    }

    /// Height of the eye above a point along `up`.
    pub fn height_above(&self, point: [f64; 3]) -> f64 {
        let up = scale(self.up, 1.0 / length(self.up).max(1e-300));
        dot(sub(self.eye(), point), up)
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

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() < 1e-9)
    }

    #[test]
    fn a_new_pivot_keeps_the_eye_and_looks_at_the_pivot() {
        let mut n = nav();
        let eye = n.eye();
        assert!(close(eye, n.camera(64, 64).eye));
        n.set_pivot([0.3, -0.2, 0.5]);
        let c = n.camera(64, 64);
        assert!(close(c.eye, eye), "{:?} {:?}", c.eye, eye);
        assert!(close(c.target, [0.3, -0.2, 0.5]));
    }

    #[test]
    fn zoom_towards_a_point_keeps_it_on_its_ray_and_looking_keeps_the_eye() {
        let mut n = nav();
        let p = [0.2, 0.1, -0.3];
        let before = n.camera(64, 64);
        let dir = |c: &Camera| {
            let d = sub(p, c.eye);
            scale(d, 1.0 / length(d))
        };
        n.zoom_towards(p, 4.0);
        let after = n.camera(64, 64);
        assert!(
            close(dir(&before), dir(&after)),
            "the point stays under the cursor"
        );
        assert!(length(sub(p, after.eye)) < length(sub(p, before.eye)));
        assert!(close(before.basis().forward, after.basis().forward));
        let eye = after.eye;
        n.look(40.0, -25.0);
        assert!(close(n.eye(), eye));
        let turned = n.camera(64, 64).basis().forward;
        let b = after.basis();
        assert!(
            dot(turned, b.right) > 0.05,
            "a drag to the right turns the view right"
        );
        assert!(
            dot(turned, b.up) > 0.03,
            "a drag up turns the view up: {}",
            dot(turned, b.up)
        );
        n.fly([0.0, 0.0, 0.5]);
        let moved = n.camera(64, 64);
        assert!(
            close(sub(moved.eye, eye), scale(turned, 0.5)),
            "forward by 0.5"
        );
    }

    #[test]
    fn keep_above_lifts_an_eye_below_the_clearance_only() {
        let mut n = Navigation::new(
            [0.0; 3],
            [10.0, 10.0, 2.0],
            [0.0, 0.0, 1.0],
            60.0,
            [0.0, 10.0, 0.5],
        );
        let eye = n.eye();
        let ground = [eye[0], eye[1], eye[2] + 0.3]; // the eye is 0.3 below the ground
        assert!(n.keep_above(ground, 0.05));
        assert!((n.eye()[2] - (ground[2] + 0.05)).abs() < 1e-12);
        assert!(close([n.eye()[0], n.eye()[1], 0.0], [eye[0], eye[1], 0.0]));
        let lifted = n.eye();
        assert!(!n.keep_above(ground, 0.05), "already clear");
        assert_eq!(n.eye(), lifted);
    }

    #[test]
    fn the_centre_ray_is_the_view_direction() {
        let n = nav();
        let c = n.camera(640, 480);
        assert!(close(n.ray(320.0, 240.0, 640, 480), c.basis().forward));
        let r = n.ray(0.0, 0.0, 640, 480);
        assert!(dot(r, c.basis().up) > 0.0 && dot(r, c.basis().right) < 0.0);
    }
}
