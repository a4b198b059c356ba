//! Rays against the drawn cut, on the CPU: the surface point under the cursor (a double-click
//! sets the orbit's pivot there; the wheel zooms towards it), the distance ahead that scales
//! the fly speed, and the ground under a terrain's eye.
//!
//! The cut is the last frame's selection read back from the GPU (the patches drawn), so a ray
//! meets what the user sees. Each patch's bounding sphere (from the tet table, no patch read)
//! is tested first; the patches whose spheres the ray enters are read from the map nearest
//! first, and the search stops once the nearest hit is nearer than the next sphere.

use tessera_core::repository::format::dequantize_position;
use tessera_core::repository::reader::Repository;
use tessera_runtime::vec3::{dot, sub};

/// The nearest intersection of the ray `origin + t·dir` (t > 0, `dir` a unit vector) with the
/// triangles of the patches of `tets`: its distance t, or `None` (a missing or unreadable patch
/// is skipped: a pick is a convenience, the frame already showed what could be drawn).
pub fn ray_cast(repo: &Repository, tets: &[u32], origin: [f64; 3], dir: [f64; 3]) -> Option<f64> {
    let h = repo.header();
    let records = repo.tets();
    // Spheres the ray enters ahead of the origin, by entry distance.
    let mut candidates: Vec<(f64, u32)> = tets
        .iter()
        .filter_map(|&t| {
            let r = records.get(t as usize)?;
            if r.triangle_count == 0 {
                return None;
            }
            let centre = [0, 1, 2].map(|i| h.origin[i] + r.center[i] as f64);
            // The f32 centre and radius are rounded: widen by a relative margin.
            let radius = r.radius as f64 * (1.0 + 1e-5) + 1e-6 * length_of(centre.map(f64::abs));
            let oc = sub(centre, origin);
            let along = dot(oc, dir);
            let across2 = dot(oc, oc) - along * along;
            if across2 > radius * radius {
                return None;
            }
            let half = (radius * radius - across2).max(0.0).sqrt();
            (along + half >= 0.0).then_some(((along - half).max(0.0), t))
        })
        .collect();
    candidates.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut best: Option<f64> = None;
    for (enter, t) in candidates {
        if best.is_some_and(|b| b < enter) {
            break;
        }
        let Ok(patch) = repo.patch(t as usize) else {
            continue;
        };
        let view = patch.view();
        let position =
            |v: u32| dequantize_position(view.position(v as usize), h.bbox_min, h.position_step);
        for [a, b, c] in view.triangles() {
            if let Some(d) = ray_triangle(origin, dir, [position(a), position(b), position(c)]) {
                if best.is_none_or(|b| d < b) {
                    best = Some(d);
                }
            }
        }
    }
    best
}

fn length_of(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// The distance along the ray (in units of `dir`) to the triangle, either face, if it is hit
/// at t > 0.
fn ray_triangle(origin: [f64; 3], dir: [f64; 3], triangle: [[f64; 3]; 3]) -> Option<f64> {
    tessera_runtime::measure::visibility::ray_triangle(origin, dir, triangle).filter(|&t| t > 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ray_meets_a_triangle_at_its_distance_from_either_side() {
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let hit = ray_triangle([0.25, 0.25, 2.0], [0.0, 0.0, -1.0], tri);
        assert_eq!(hit, Some(2.0));
        let below = ray_triangle([0.25, 0.25, -3.0], [0.0, 0.0, 1.0], tri);
        assert_eq!(below, Some(3.0));
        assert_eq!(ray_triangle([0.9, 0.9, 2.0], [0.0, 0.0, -1.0], tri), None);
        assert_eq!(ray_triangle([0.25, 0.25, 2.0], [0.0, 0.0, 1.0], tri), None);
        assert_eq!(ray_triangle([0.25, 0.25, 2.0], [1.0, 0.0, 0.0], tri), None);
    }
}
