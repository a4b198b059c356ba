//! Visibility tests of a simplex's patch, evaluated identically (in f32, same operation order)
//! by the CPU reference traversal and the GPU traversal (`shaders/traverse.wgsl`):
//!
//! - frustum: the patch's bounding sphere against the four side planes (through the eye) and
//!   the near and far distances along the view direction;
//! - back faces: the patch's normal cone against the directions from the eye to its sphere.
//!
//! Both are conservative: a culled patch has no pixel on screen (frustum) or only back faces
//! (cone). Everything is in the eye-relative frame (`centre − eye_local`, see `metric.rs`).

use crate::metric::center_minus_eye;
use crate::repository::format::TetRecord;

/// Below this cone cosine (a half-angle over ~84°) the cone test never culls.
const MIN_CONE_COS: f32 = 0.1;
/// Added to the cone's angular bound (as a cosine margin) to absorb f32 rounding.
const CONE_MARGIN: f32 = 1e-4;

/// The culling planes of a view in the eye-relative frame, as the GPU receives them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewVolume {
    /// Inward unit normals of the left, right, bottom and top planes; each passes through the
    /// eye (the origin of the eye-relative frame), so a point p is inside iff dot(n, p) ≥ 0.
    pub side_planes: [[f32; 3]; 4],
    /// Unit view direction.
    pub forward: [f32; 3],
    /// Near distance along `forward` (model units, > 0).
    pub near: f32,
    /// Far distance along `forward`; `f32::INFINITY` for none.
    pub far: f32,
}

impl ViewVolume {
    /// The volume of a camera with orthonormal `right`, `up`, `forward` (f64, any frame
    /// orientation) and tangents of the half field of view.
    pub fn new(
        right: [f64; 3],
        up: [f64; 3],
        forward: [f64; 3],
        tan_half_x: f64,
        tan_half_y: f64,
        near: f64,
        far: f64,
    ) -> ViewVolume {
        let plane = |side: [f64; 3], sign: f64, tan: f64| {
            let n = [0, 1, 2].map(|i| sign * side[i] + tan * forward[i]);
            let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            n.map(|x| (x / l) as f32)
        };
        ViewVolume {
            side_planes: [
                plane(right, 1.0, tan_half_x),
                plane(right, -1.0, tan_half_x),
                plane(up, 1.0, tan_half_y),
                plane(up, -1.0, tan_half_y),
            ],
            forward: forward.map(|x| x as f32),
            near: near as f32,
            far: if far.is_finite() {
                far as f32
            } else {
                f32::INFINITY
            },
        }
    }

    /// Whether a sphere (centre relative to the eye) may have a point inside the volume.
    #[inline]
    pub fn sphere_visible(&self, c: [f32; 3], radius: f32) -> bool {
        for n in &self.side_planes {
            if dot(*n, c) < -radius {
                return false;
            }
        }
        let depth = dot(self.forward, c);
        depth + radius >= self.near && depth - radius <= self.far
    }
}

/// `a · b` as the shader writes it: ((a.x·b.x + a.y·b.y) + a.z·b.z).
#[inline]
pub fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// True when every triangle of a patch with this normal cone and bounding sphere (centre
/// relative to the eye) faces away from the eye, for every point of the sphere.
///
/// Normals lie within α of the axis (cos α = `cone_cos`) and directions from the eye to the
/// sphere within γ of its centre (sin γ = r / d); all faces point away when the angle between
/// the axis and the centre direction is below 90° − α − γ, i.e. its cosine exceeds sin(α + γ).
#[inline]
pub fn cone_backfacing(axis: [f32; 3], cone_cos: f32, c: [f32; 3], radius: f32) -> bool {
    if cone_cos <= MIN_CONE_COS {
        return false;
    }
    let distance = dot(c, c).sqrt();
    if distance <= radius {
        return false;
    }
    let sin_a = (1.0 - cone_cos * cone_cos).max(0.0).sqrt();
    let sin_g = radius / distance;
    let cos_g = (1.0 - sin_g * sin_g).max(0.0).sqrt();
    if cone_cos * cos_g - sin_a * sin_g <= 0.0 {
        return false; // α + γ ≥ 90°: some face may point at the eye
    }
    let sin_sum = sin_a * cos_g + cone_cos * sin_g;
    dot(axis, c) > (sin_sum + CONE_MARGIN) * distance
}

/// What the traversal tests besides the cut rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CullTests {
    /// The view volume, or `None` to keep everything the rule selects.
    pub frustum: Option<ViewVolume>,
    /// Back-face culling by normal cone. Off for the pixel crack check, which must see back
    /// faces through any crack.
    pub cones: bool,
}

impl CullTests {
    /// Everything the rule selects is drawn.
    pub const NONE: CullTests = CullTests {
        frustum: None,
        cones: false,
    };

    /// Whether the patch of `tet` survives the tests for an eye at `eye_local`.
    #[inline]
    pub fn keeps(&self, tet: &TetRecord, eye_local: [f32; 3]) -> bool {
        let c = center_minus_eye(tet.center, eye_local);
        if let Some(volume) = &self.frustum {
            if !volume.sphere_visible(c, tet.radius) {
                return false;
            }
        }
        !(self.cones && cone_backfacing(tet.cone_axis, tet.cone_cos, c, tet.radius))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn volume() -> ViewVolume {
        // Looking down −z with x right and y up, 90° × 90°.
        ViewVolume::new(
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, -1.0],
            1.0,
            1.0,
            0.1,
            100.0,
        )
    }

    #[test]
    fn spheres_inside_straddling_and_outside() {
        let v = volume();
        assert!(v.sphere_visible([0.0, 0.0, -5.0], 0.1));
        // Beside the 45° side plane: centre outside, sphere reaching in.
        assert!(v.sphere_visible([6.0, 0.0, -5.0], 1.0));
        assert!(!v.sphere_visible([6.0, 0.0, -5.0], 0.5));
        assert!(!v.sphere_visible([0.0, -7.0, -5.0], 1.0));
        // Behind the eye, before the near plane, past the far plane.
        assert!(!v.sphere_visible([0.0, 0.0, 5.0], 1.0));
        assert!(!v.sphere_visible([0.0, 0.0, -0.05], 0.01));
        assert!(v.sphere_visible([0.0, 0.0, -0.05], 0.06));
        assert!(!v.sphere_visible([0.0, 0.0, -102.0], 1.0));
        let endless = ViewVolume {
            far: f32::INFINITY,
            ..v
        };
        assert!(endless.sphere_visible([0.0, 0.0, -1e30], 1.0));
    }

    #[test]
    fn cones_cull_only_when_every_face_points_away() {
        // Normals along −z within ~25°, patch straight ahead at distance 10: faces point at
        // the eye (front), never culled.
        let cos = 25f32.to_radians().cos();
        assert!(!cone_backfacing(
            [0.0, 0.0, 1.0],
            cos,
            [0.0, 0.0, -10.0],
            1.0
        ));
        // Normals along −z seen from the other side: back faces.
        assert!(cone_backfacing(
            [0.0, 0.0, -1.0],
            cos,
            [0.0, 0.0, -10.0],
            1.0
        ));
        // Same, but the sphere is big enough to reach 90° − 25° off the axis: kept.
        assert!(!cone_backfacing(
            [0.0, 0.0, -1.0],
            cos,
            [0.0, 0.0, -10.0],
            9.5
        ));
        // Eye inside the sphere, or a wide cone: never culled.
        assert!(!cone_backfacing(
            [0.0, 0.0, -1.0],
            cos,
            [0.0, 0.0, -1.0],
            2.0
        ));
        assert!(!cone_backfacing(
            [0.0, 0.0, -1.0],
            -1.0,
            [0.0, 0.0, -10.0],
            1.0
        ));
        assert!(!cone_backfacing(
            [0.0, 0.0, -1.0],
            0.05,
            [0.0, 0.0, -10.0],
            1.0
        ));
    }

    /// Brute force: whenever the cone test culls, no sampled face of the cone and point of the
    /// sphere faces the eye.
    #[test]
    fn cone_test_is_conservative() {
        let mut seed = 12345u64;
        let mut rand = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 40) as f32) / (1u64 << 24) as f32
        };
        let mut culled = 0;
        for _ in 0..2000 {
            let axis = normalize([rand() - 0.5, rand() - 0.5, rand() - 0.5]);
            let cos = 0.1 + 0.9 * rand();
            let c = [
                20.0 * (rand() - 0.5),
                20.0 * (rand() - 0.5),
                20.0 * (rand() - 0.5),
            ];
            let r = 3.0 * rand();
            if !cone_backfacing(axis, cos, c, r) {
                continue;
            }
            culled += 1;
            for _ in 0..200 {
                // A normal in the cone and a point in the sphere.
                let n = loop {
                    let d = normalize([rand() - 0.5, rand() - 0.5, rand() - 0.5]);
                    if dot(d, axis) >= cos {
                        break d;
                    }
                };
                let p = loop {
                    let o = [2.0 * rand() - 1.0, 2.0 * rand() - 1.0, 2.0 * rand() - 1.0];
                    if dot(o, o) <= 1.0 {
                        break [c[0] + r * o[0], c[1] + r * o[1], c[2] + r * o[2]];
                    }
                };
                assert!(dot(n, p) > 0.0, "a front face in a culled patch");
            }
        }
        assert!(culled > 50, "the test culls something ({culled})");
    }

    fn normalize(v: [f32; 3]) -> [f32; 3] {
        let l = dot(v, v).sqrt();
        v.map(|x| x / l)
    }
}
