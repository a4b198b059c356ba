//! What a frame's priorities depend on, and the priority itself: an upper bound, in pixels,
//! of how far a triangle's surface may be from the terrain on screen.
//!
//! The paper projects the wedgie's thickness exactly (its screen-space bound depends on the
//! view direction); we use the simpler isotropic bound e(T) · pixels per radian / distance to
//! the wedgie's bounding box. Because nested wedgies have nested boxes, the distance only grows
//! and the thickness only shrinks from parent to child, so the priority is monotone — the
//! property ROAM's queues need (`Roam` clamps it anyway, for errors that are not nested).

use tessera_runtime::camera::Camera;

use super::WedgieErrors;
use crate::terrain::grid::{BinGrid, BinTri};

/// What a frame's priorities depend on.
#[derive(Clone, Copy, Debug)]
pub struct RoamView {
    /// World metres (the frame of `BinGrid::world`).
    pub eye: [f64; 3],
    /// height_px / (2 tan(fov_y / 2)).
    pub pixels_per_radian: f64,
    /// World planes, inside where a·x + b·y + c·z + d ≥ 0.
    pub frustum: [[f64; 4]; 6],
}

impl RoamView {
    /// The camera's eye, its pixel scale and its six planes (left, right, bottom, top through
    /// the eye, then near and far; an infinite far plane becomes one that accepts everything),
    /// in f64 world coordinates so that ETOPO's 10⁷-metre extents keep their precision.
    pub fn from_camera(camera: &Camera) -> RoamView {
        let b = camera.basis();
        let tan_y = (0.5 * camera.fov_y_degrees.to_radians()).tan();
        let tan_x = tan_y * camera.aspect();
        let eye = camera.eye;
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        // Inward normal of a side plane through the eye: it contains the edge direction
        // forward ∓ tan·side, and forward itself is inside.
        let side = |axis: [f64; 3], sign: f64, tan: f64| {
            let n = [0, 1, 2].map(|i| sign * axis[i] + tan * b.forward[i]);
            let l = dot(n, n).sqrt();
            let n = n.map(|x| x / l);
            [n[0], n[1], n[2], -dot(n, eye)]
        };
        let f = b.forward;
        let near = [f[0], f[1], f[2], -(dot(f, eye) + camera.near)];
        let far = if camera.far.is_finite() {
            [-f[0], -f[1], -f[2], dot(f, eye) + camera.far]
        } else {
            [0.0, 0.0, 0.0, 1.0]
        };
        RoamView {
            eye,
            pixels_per_radian: camera.height as f64 / (2.0 * tan_y),
            frustum: [
                side(b.right, 1.0, tan_x),
                side(b.right, -1.0, tan_x),
                side(b.up, 1.0, tan_y),
                side(b.up, -1.0, tan_y),
                near,
                far,
            ],
        }
    }

    /// Whether an axis-aligned box may have a point inside every plane (the corner farthest
    /// along each plane's normal decides).
    pub fn box_visible(&self, lo: [f64; 3], hi: [f64; 3]) -> bool {
        self.frustum.iter().all(|p| {
            let x = if p[0] >= 0.0 { hi[0] } else { lo[0] };
            let y = if p[1] >= 0.0 { hi[1] } else { lo[1] };
            let z = if p[2] >= 0.0 { hi[2] } else { lo[2] };
            p[0] * x + p[1] * y + p[2] * z + p[3] >= 0.0
        })
    }
}

/// The split priority of a triangle in pixels: its wedgie thickness seen from the nearest
/// point of the wedgie's bounding box. 0 (never split for its own sake) when the wedgie is
/// flat, outside the frustum, or the triangle does not overlap the real grid.
pub fn priority(grid: &BinGrid, errors: &WedgieErrors, view: &RoamView, t: &BinTri) -> f32 {
    let e = errors.get(t) as f64;
    if e <= 0.0 || !grid.overlaps_grid(t) {
        return 0.0;
    }
    let corners = [grid.world(t.apex), grid.world(t.left), grid.world(t.right)];
    let mut lo = corners[0];
    let mut hi = corners[0];
    for c in &corners[1..] {
        for k in 0..3 {
            lo[k] = lo[k].min(c[k]);
            hi[k] = hi[k].max(c[k]);
        }
    }
    lo[2] -= e;
    hi[2] += e;
    if !view.box_visible(lo, hi) {
        return 0.0;
    }
    let mut d2 = 0.0;
    for k in 0..3 {
        let gap = (lo[k] - view.eye[k]).max(view.eye[k] - hi[k]).max(0.0);
        d2 += gap * gap;
    }
    // An eye inside the box would divide by 0: a thousandth of a cell stands for "here".
    let nearest = 1e-3 * grid.spacing[0].abs().min(grid.spacing[1].abs());
    let p = (e * view.pixels_per_radian / d2.sqrt().max(nearest)) as f32;
    if p >= 0.0 {
        p
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tessera_runtime::camera::Camera;

    #[test]
    fn the_planes_keep_what_the_camera_projects_and_cut_what_it_does_not() {
        let mut cam = Camera::looking_at([0.0, -50.0, 20.0], [0.0, 0.0, 0.0], 10.0);
        cam.far = 500.0;
        let v = RoamView::from_camera(&cam);
        assert!((v.pixels_per_radian - 1080.0 / (2.0 * 30f64.to_radians().tan())).abs() < 1e-9);
        let inside = |p: [f64; 3]| {
            v.frustum
                .iter()
                .all(|q| q[0] * p[0] + q[1] * p[1] + q[2] * p[2] + q[3] >= 0.0)
        };
        let mut rng = 12345u64;
        let mut next = || {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut hits, mut misses) = (0, 0);
        for _ in 0..20_000 {
            let p = [0, 1, 2].map(|_| (next() - 0.5) * 200.0);
            let on_screen = cam.project(p).is_some_and(|px| {
                (0.0..=1920.0).contains(&px[0]) && (0.0..=1080.0).contains(&px[1])
            });
            let depth = {
                let b = cam.basis();
                (0..3)
                    .map(|i| (p[i] - cam.eye[i]) * b.forward[i])
                    .sum::<f64>()
            };
            let expected = on_screen && depth >= cam.near && depth <= cam.far;
            // Points within a hair of a plane may go either way.
            let margin = v
                .frustum
                .iter()
                .map(|q| (q[0] * p[0] + q[1] * p[1] + q[2] * p[2] + q[3]).abs());
            if margin.fold(f64::INFINITY, f64::min) < 1e-6 {
                continue;
            }
            assert_eq!(inside(p), expected, "{p:?}");
            if expected {
                hits += 1;
            } else {
                misses += 1;
            }
        }
        assert!(hits > 100 && misses > 100, "{hits} {misses}");
        // Boxes: one around the target is seen, one behind the eye is not.
        assert!(v.box_visible([-1.0; 3], [1.0; 3]));
        assert!(!v.box_visible([-1.0, -80.0, 19.0], [1.0, -70.0, 21.0]));
    }
}
