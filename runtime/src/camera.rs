//! A perspective camera in f64 model space, and everything a frame derives from it in the
//! eye-relative f32 frame: the view-projection matrix, the culling volume and the error metric.
//!
//! Why eye-relative: the GPU subtracts the eye from each vertex before the rotation and
//! projection, on the position lattice (`FrameUniforms::eye_cell` / `eye_fraction`,
//! `tessera_core::eye_relative`: the lattice difference in exact integers), so a model 1e7
//! units from the world origin, or 4e7 units across, renders near the eye with the precision
//! of a small one at the origin. The matrix has no
//! translation; the projection is reverse-Z with an infinite far plane (depth = near / z), whose
//! f32 depth precision is relative and so holds from 1e-6 to 1e12 units.

use tessera_core::cull::ViewVolume;
use tessera_core::metric::{eye_local, ScreenSpaceMetric};

use crate::vec3::{cross, dot, length, normalize, sub};

/// Where the camera is and what it sees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position, model units.
    pub eye: [f64; 3],
    /// Point looked at (must differ from `eye`).
    pub target: [f64; 3],
    /// Approximate up direction (must not be parallel to target − eye; a fallback is used).
    pub up: [f64; 3],
    /// Vertical field of view, degrees.
    pub fov_y_degrees: f64,
    /// Viewport size in pixels.
    pub width: u32,
    pub height: u32,
    /// Near plane distance, model units (> 0).
    pub near: f64,
    /// Far plane distance for culling; infinite for none (the depth buffer needs none).
    pub far: f64,
}

/// Up along +y: scanned models (Stanford, CGAL), OBJ and glTF files.
pub const Y_UP: [f64; 3] = [0.0, 1.0, 0.0];
/// Up along +z: height fields (the height is z).
pub const Z_UP: [f64; 3] = [0.0, 0.0, 1.0];

/// The eye's orthonormal frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Basis {
    pub right: [f64; 3],
    pub up: [f64; 3],
    pub forward: [f64; 3],
}

impl Camera {
    /// Looking at the centre of a bounding box from azimuth/elevation (degrees) around the
    /// `up` axis (`Y_UP` or `Z_UP`, or any unit vector), at `distance` × the box's bounding
    /// radius from its centre.
    pub fn orbit(
        lo: [f64; 3],
        hi: [f64; 3],
        up: [f64; 3],
        azimuth_degrees: f64,
        elevation_degrees: f64,
        distance: f64,
    ) -> Camera {
        let centre = [0, 1, 2].map(|i| 0.5 * (lo[i] + hi[i]));
        let radius = bounding_radius(lo, hi);
        let dir = orbit_direction(up, azimuth_degrees, elevation_degrees);
        let up = normalize(up).unwrap_or(Z_UP);
        let eye = [0, 1, 2].map(|i| centre[i] + dir[i] * distance * radius);
        Camera {
            up,
            ..Camera::looking_at(eye, centre, radius)
        }
    }

    /// 1920 × 1080, 60°, z up, near plane 1e-5 of the model radius.
    pub fn looking_at(eye: [f64; 3], target: [f64; 3], model_radius: f64) -> Camera {
        Camera {
            eye,
            target,
            up: [0.0, 0.0, 1.0],
            fov_y_degrees: 60.0,
            width: 1920,
            height: 1080,
            near: (model_radius * 1e-5).max(f64::MIN_POSITIVE),
            far: f64::INFINITY,
        }
    }

    /// The eye's frame; `up` is replaced by another axis when parallel to the view direction.
    pub fn basis(&self) -> Basis {
        let forward = normalize(sub(self.target, self.eye)).unwrap_or([0.0, 1.0, 0.0]);
        let right = [self.up, [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]
            .into_iter()
            .find_map(|up| {
                let r = cross(forward, up);
                (length(r) > 1e-9 * length(up).max(1e-300))
                    .then(|| normalize(r))
                    .flatten()
            })
            .unwrap_or([1.0, 0.0, 0.0]);
        Basis {
            right,
            up: cross(right, forward),
            forward,
        }
    }

    pub fn aspect(&self) -> f64 {
        self.width as f64 / self.height.max(1) as f64
    }

    /// The eye in the repository's f32 frame (f64 subtraction, then rounding).
    pub fn eye_local(&self, origin: [f64; 3]) -> [f32; 3] {
        eye_local(self.eye, origin)
    }

    /// Eye-relative position → clip space: rows give x·sx, y·sy, near, depth along forward, so
    /// NDC depth = near / depth (reverse Z; 1 at the near plane, 0 at infinity). Column-major,
    /// as WGSL's mat4x4 expects.
    pub fn view_projection(&self) -> [[f32; 4]; 4] {
        let b = self.basis();
        let sy = 1.0 / (0.5 * self.fov_y_degrees.to_radians()).tan();
        let sx = sy / self.aspect();
        let rows: [[f64; 4]; 4] = [
            [sx * b.right[0], sx * b.right[1], sx * b.right[2], 0.0],
            [sy * b.up[0], sy * b.up[1], sy * b.up[2], 0.0],
            [0.0, 0.0, 0.0, self.near],
            [b.forward[0], b.forward[1], b.forward[2], 0.0],
        ];
        // Transpose into columns.
        [0, 1, 2, 3].map(|c| [0, 1, 2, 3].map(|r| rows[r][c] as f32))
    }

    /// The culling volume (the frustum widened by nothing: spheres test conservatively).
    pub fn view_volume(&self) -> ViewVolume {
        let b = self.basis();
        let tan_y = (0.5 * self.fov_y_degrees.to_radians()).tan();
        ViewVolume::new(
            b.right,
            b.up,
            b.forward,
            tan_y * self.aspect(),
            tan_y,
            self.near,
            self.far,
        )
    }

    /// ρ's projection constants for this viewport (τ is in pixels of this height).
    pub fn metric(&self) -> ScreenSpaceMetric {
        ScreenSpaceMetric::new(self.height, self.fov_y_degrees, self.near)
    }

    /// Pixel coordinates (x right, y down, origin top-left) of a model-space point, or `None`
    /// behind the eye.
    pub fn project(&self, p: [f64; 3]) -> Option<[f64; 2]> {
        let b = self.basis();
        let d = sub(p, self.eye);
        let depth = dot(d, b.forward);
        if depth <= 0.0 {
            return None;
        }
        let sy = 1.0 / (0.5 * self.fov_y_degrees.to_radians()).tan();
        let sx = sy / self.aspect();
        let ndc = [sx * dot(d, b.right) / depth, sy * dot(d, b.up) / depth];
        Some([
            (ndc[0] + 1.0) * 0.5 * self.width as f64,
            (1.0 - ndc[1]) * 0.5 * self.height as f64,
        ])
    }
}

/// The orbit's frame around `up` (normalised; z when zero): two horizontal axes, azimuth 0
/// along the first, and the up axis.
pub fn orbit_frame(up: [f64; 3]) -> [[f64; 3]; 3] {
    let up = normalize(up).unwrap_or(Z_UP);
    let first = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
        .into_iter()
        .find_map(|a| normalize(cross(up, cross(a, up))))
        .unwrap_or([1.0, 0.0, 0.0]);
    [first, cross(up, first), up]
}

/// The unit direction from an orbit's centre to its eye at azimuth and elevation (degrees).
pub fn orbit_direction(up: [f64; 3], azimuth_degrees: f64, elevation_degrees: f64) -> [f64; 3] {
    let [first, second, up] = orbit_frame(up);
    let (az, el) = (azimuth_degrees.to_radians(), elevation_degrees.to_radians());
    [0, 1, 2].map(|i| el.cos() * (az.cos() * first[i] + az.sin() * second[i]) + el.sin() * up[i])
}

/// Azimuth and elevation (degrees, azimuth in [0, 360)) of a direction from an orbit's centre
/// to its eye: the inverse of `orbit_direction` (`None` for a zero direction).
pub fn orbit_angles(up: [f64; 3], direction: [f64; 3]) -> Option<[f64; 2]> {
    let d = normalize(direction)?;
    let [first, second, up] = orbit_frame(up);
    let el = dot(d, up).clamp(-1.0, 1.0).asin().to_degrees();
    let az = dot(d, second)
        .atan2(dot(d, first))
        .to_degrees()
        .rem_euclid(360.0);
    Some([az, el])
}

/// Half the diagonal of a box.
pub fn bounding_radius(lo: [f64; 3], hi: [f64; 3]) -> f64 {
    0.5 * length(sub(hi, lo)).max(1e-300)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(m: [[f32; 4]; 4], p: [f32; 3]) -> [f32; 4] {
        [0, 1, 2, 3].map(|r| m[0][r] * p[0] + m[1][r] * p[1] + m[2][r] * p[2] + m[3][r])
    }

    #[test]
    fn projection_is_reverse_z_and_matches_project() {
        let cam = Camera::looking_at([10.0, 0.0, 0.0], [0.0, 0.0, 0.0], 1.0);
        let b = cam.basis();
        assert!((b.forward[0] + 1.0).abs() < 1e-12);
        assert!((b.up[2] - 1.0).abs() < 1e-12, "z up stays up");
        let m = cam.view_projection();
        // The target, 10 units ahead: centre of the screen, depth near / 10.
        let c = apply(m, [-10.0, 0.0, 0.0]);
        assert!(c[0].abs() < 1e-6 && c[1].abs() < 1e-6);
        assert!((c[2] / c[3] - (cam.near / 10.0) as f32).abs() < 1e-12);
        // A point up and to the right lands where `project` says.
        // Right is +y when looking down −x with z up.
        let p = [0.0, 1.0, 2.0];
        let clip = apply(m, [-10.0, 1.0, 2.0]);
        let px = cam.project(p).unwrap();
        let x = (clip[0] / clip[3] + 1.0) * 0.5 * 1920.0;
        let y = (1.0 - clip[1] / clip[3]) * 0.5 * 1080.0;
        assert!((x as f64 - px[0]).abs() < 1e-3 && (y as f64 - px[1]).abs() < 1e-3);
        assert!(
            px[0] > 960.0 && px[1] < 540.0,
            "right of and above the centre"
        );
        assert!(cam.project([20.0, 0.0, 0.0]).is_none());
    }

    #[test]
    fn looking_straight_down_keeps_a_basis() {
        let cam = Camera::looking_at([0.0, 0.0, 5.0], [0.0, 0.0, 0.0], 1.0);
        let b = cam.basis();
        for v in [b.right, b.up, b.forward] {
            assert!((length(v) - 1.0).abs() < 1e-12);
        }
        assert!(dot(b.right, b.forward).abs() < 1e-12 && dot(b.up, b.forward).abs() < 1e-12);
    }

    #[test]
    fn view_volume_contains_what_projects_inside() {
        let cam = Camera::orbit([-1.0; 3], [1.0; 3], Y_UP, 30.0, 20.0, 4.0);
        assert!(cam.eye[1] > 0.0, "20° above the horizon, y up");
        let volume = cam.view_volume();
        let eye = cam.eye_local([0.0; 3]);
        for p in [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [-1.0, 0.5, -1.0]] {
            let px = cam.project(p).unwrap();
            let inside = (0.0..1920.0).contains(&px[0]) && (0.0..1080.0).contains(&px[1]);
            let c = [0, 1, 2].map(|i| p[i] as f32 - eye[i]);
            assert_eq!(volume.sphere_visible(c, 0.0), inside, "{p:?} at {px:?}");
        }
        let behind = [0, 1, 2].map(|i| (2.0 * cam.eye[i]) as f32 - eye[i]);
        assert!(!volume.sphere_visible(behind, 0.1));
    }
}
