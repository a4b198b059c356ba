//! Exact point–segment and point–triangle distances in f64.

use crate::vec3::{cross, dot, length, sub};

pub(super) fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    length(sub(a, b))
}

pub(super) fn longest_edge(t: &[[f64; 3]; 3]) -> f64 {
    distance(t[0], t[1])
        .max(distance(t[1], t[2]))
        .max(distance(t[2], t[0]))
}

/// Distance from `p` to the closest point of segment `ab`.
fn point_segment_distance(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let ab = sub(b, a);
    let len2 = dot(ab, ab);
    let t = if len2 > 0.0 {
        (dot(sub(p, a), ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    distance(p, [a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]])
}

/// Exact distance from `p` to the triangle `t` (closed, degenerate ones included): the
/// closest point by Voronoi regions (Ericson, "Real-Time Collision Detection", 5.1.5), or
/// the nearest edge of a triangle without area. Never below the true distance: every branch
/// measures to a point of the triangle.
pub fn point_triangle_distance(p: [f64; 3], t: &[[f64; 3]; 3]) -> f64 {
    let [a, b, c] = *t;
    let ab = sub(b, a);
    let ac = sub(c, a);
    let normal = cross(ab, ac);
    if dot(normal, normal) <= 1e-20 * dot(ab, ab) * dot(ac, ac) {
        // Degenerate (a segment or a point): the regions below assume an area, so the
        // nearest of the three edges.
        return point_segment_distance(p, a, b)
            .min(point_segment_distance(p, b, c))
            .min(point_segment_distance(p, c, a));
    }
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return distance(p, a);
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return distance(p, b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return point_segment_distance(p, a, b);
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return distance(p, c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return point_segment_distance(p, a, c);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return point_segment_distance(p, b, c);
    }
    let denominator = va + vb + vc;
    if denominator.is_finite() && denominator > 0.0 {
        let v = vb / denominator;
        let w = vc / denominator;
        let q = [0, 1, 2].map(|k| a[k] + ab[k] * v + ac[k] * w);
        let inside = distance(p, q);
        if inside.is_finite() {
            return inside;
        }
    }
    // Degenerate (or overflowing) triangle: the nearest of its three edges.
    point_segment_distance(p, a, b)
        .min(point_segment_distance(p, b, c))
        .min(point_segment_distance(p, c, a))
}
