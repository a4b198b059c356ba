//! Which samples the eye sees: a segment from the eye to the sample, cast through the BVH of
//! the surface the sample lies on; the sample is hidden when a triangle crosses the segment
//! before it.
//!
//! This is the depth test of a frame done exactly: no depth-buffer precision, no pixel
//! footprint, the same answer on every backend (the measurement must not depend on the
//! renderer it measures). A sample lies on a triangle of the surface it is tested against, so
//! its own triangle (and, near an edge, its neighbours) meet the segment at its very end:
//! a crossing counts only before `1 − HIDDEN_SLACK` of the segment. Triangles seen edge-on
//! (no area across the segment) hide nothing. Which triangles hide follows the frame's face
//! rule (`Faces`): with `Both` a surface's back is as opaque as its front; with `Front` only
//! triangles facing the eye are drawn, so only they hide.
//!
//! Cost: one any-hit descent per sample, O(log n) boxes when little lies between the eye and
//! the sample.

use obvhs::aabb::Aabb;

use super::nearest::ReferenceMesh;
use crate::faces::Faces;
use crate::vec3::{cross, dot, length, sub};

/// A crossing hides a sample only this far (relative to the eye–sample distance) in front of
/// it. Samples are exact barycentric points of f64 triangles, so their own triangle crosses
/// within a few ulps; a neighbour sharing an edge crosses within the sample's distance to
/// that edge times the fold, far below a pixel at 1e-6 of the viewing distance.
pub const HIDDEN_SLACK: f64 = 1e-6;

impl ReferenceMesh {
    /// Whether some triangle that `faces` draws crosses the segment from `eye` to `p` before
    /// `p` (both in the mesh's frame): `p` is hidden from `eye` by this mesh.
    pub fn hides(&self, eye: [f64; 3], p: [f64; 3], faces: Faces) -> bool {
        let d = sub(p, eye);
        let limit = 1.0 - HIDDEN_SLACK;
        let nodes = &self.bvh.nodes;
        if nodes.is_empty() {
            return false;
        }
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(index) = stack.pop() {
            let node = &nodes[index as usize];
            if !segment_meets_box(node.aabb(), eye, d, limit) {
                continue;
            }
            if node.prim_count > 0 {
                let first = node.first_index as usize;
                for &primitive in
                    &self.bvh.primitive_indices[first..first + node.prim_count as usize]
                {
                    let t = self.triangles[primitive as usize];
                    let corners = t.map(|v| self.positions[v as usize]);
                    if ray_triangle(eye, d, corners).is_some_and(|t| t > 0.0 && t < limit)
                        && faces.shows(eye, corners)
                    {
                        return true;
                    }
                }
            } else {
                stack.push(node.first_index);
                stack.push(node.first_index + 1);
            }
        }
        false
    }
}

/// Whether `eye + t·d`, t in [0, limit], meets the box (slab test in f64; the box's f32
/// corners are exact in f64).
fn segment_meets_box(aabb: &Aabb, eye: [f64; 3], d: [f64; 3], limit: f64) -> bool {
    let (lo, hi) = (aabb.min.to_array(), aabb.max.to_array());
    let (mut enter, mut leave) = (0.0f64, limit);
    for i in 0..3 {
        let (lo, hi) = (lo[i] as f64, hi[i] as f64);
        if d[i] == 0.0 {
            if eye[i] < lo || eye[i] > hi {
                return false;
            }
            continue;
        }
        let (a, b) = ((lo - eye[i]) / d[i], (hi - eye[i]) / d[i]);
        enter = enter.max(a.min(b));
        leave = leave.min(a.max(b));
        if enter > leave {
            return false;
        }
    }
    true
}

/// The parameter t at which the line `eye + t·d` crosses the triangle, either face
/// (Möller–Trumbore in f64, edges included, t of either sign); `None` when it misses or the
/// triangle is edge-on to the line. (The viewer's picking uses it too, with t > 0.)
pub fn ray_triangle(eye: [f64; 3], d: [f64; 3], [a, b, c]: [[f64; 3]; 3]) -> Option<f64> {
    let e1 = sub(b, a);
    let e2 = sub(c, a);
    let pvec = cross(d, e2);
    let det = dot(e1, pvec);
    let scale = length(d) * length(e1) * length(e2);
    // Edge-on (or NaN): no crossing.
    if det.abs().partial_cmp(&(1e-12 * scale)) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let inverse = 1.0 / det;
    let tvec = sub(eye, a);
    let u = dot(tvec, pvec) * inverse;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qvec = cross(tvec, e1);
    let v = dot(d, qvec) * inverse;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some(dot(e2, qvec) * inverse)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two unit squares facing +z, at z = 0 and z = -1, each two triangles.
    fn two_squares() -> ReferenceMesh {
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for z in [0.0, -1.0] {
            let base = positions.len() as u32;
            positions.extend([
                [-1.0, -1.0, z],
                [1.0, -1.0, z],
                [1.0, 1.0, z],
                [-1.0, 1.0, z],
            ]);
            triangles.push([base, base + 1, base + 2]);
            triangles.push([base, base + 2, base + 3]);
        }
        ReferenceMesh::new(positions, triangles).unwrap()
    }

    #[test]
    fn the_front_square_hides_the_back_one_and_not_itself() {
        let mesh = two_squares();
        let eye = [0.0, 0.0, 5.0];
        // On the front square, at a vertex, on the diagonal shared by its two triangles, inside.
        for p in [
            [0.3, -0.2, 0.0],
            [0.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.5, 0.5, 0.0],
        ] {
            assert!(
                !mesh.hides(eye, p, Faces::Both),
                "{p:?} is on the front square"
            );
        }
        assert!(
            mesh.hides(eye, [0.3, -0.2, -1.0], Faces::Both),
            "behind the front square"
        );
        // Seen from below, the back square hides the front one, unless back faces are not
        // drawn (both squares face +z).
        assert!(mesh.hides([0.0, 0.0, -5.0], [0.3, -0.2, 0.0], Faces::Both));
        assert!(!mesh.hides([0.0, 0.0, -5.0], [0.3, -0.2, 0.0], Faces::Front));
        assert!(!mesh.hides([0.0, 0.0, -5.0], [0.3, -0.2, -1.0], Faces::Both));
        // From above the front square faces the eye: it hides with either rule.
        assert!(mesh.hides(eye, [0.3, -0.2, -1.0], Faces::Front));
        // Past the front square's edge the back square is in view.
        // (3, 0, 5) → (0.9, 0, −1) crosses z = 0 at x = 1.25, outside the front square.
        assert!(!mesh.hides([3.0, 0.0, 5.0], [0.9, 0.0, -1.0], Faces::Both));
    }

    #[test]
    fn an_edge_on_triangle_hides_nothing() {
        // A triangle in the plane y = 0, the segment along it.
        let mesh = ReferenceMesh::new(
            vec![[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 0.0, 1.0]],
            vec![[0, 1, 2]],
        )
        .unwrap();
        assert!(!mesh.hides([0.0, 0.0, 5.0], [0.0, 0.0, -5.0], Faces::Both));
        assert!(mesh.hides([0.0, 1.0, 0.0], [0.0, -1.0, 0.0], Faces::Both));
    }

    /// The BVH descent answers what a scan of every triangle answers.
    #[test]
    fn descent_matches_brute_force() {
        let mut state = 11u64;
        let mut r = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let positions: Vec<[f64; 3]> = (0..300).map(|_| [r(), r(), r()]).collect();
        let triangles: Vec<[u32; 3]> = (0..200)
            .map(|_| [0, 1, 2].map(|_| (r() * 300.0) as u32))
            .collect();
        let mesh = ReferenceMesh::new(positions.clone(), triangles.clone()).unwrap();
        let mut hidden = 0;
        for _ in 0..500 {
            let eye = [r() * 4.0 - 1.5, r() * 4.0 - 1.5, 3.0];
            let p = [r(), r(), r()];
            let d = sub(p, eye);
            let brute = triangles.iter().any(|t| {
                ray_triangle(eye, d, t.map(|v| positions[v as usize]))
                    .is_some_and(|t| t > 0.0 && t < 1.0 - HIDDEN_SLACK)
            });
            assert_eq!(mesh.hides(eye, p, Faces::Both), brute, "{eye:?} → {p:?}");
            hidden += brute as usize;
        }
        assert!(
            hidden > 50 && hidden < 450,
            "both answers exercised: {hidden}"
        );
    }
}
