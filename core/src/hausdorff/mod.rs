//! Upper bounds on the Hausdorff distance between two triangle sets, rigorous rather than
//! sampled: what makes a stored error a bound (issue 13).
//!
//! The directed distance h(A→B) = max over x in A of d(x, B) is bounded triangle by triangle
//! of A. For a triangle T and any one triangle t of B, x ↦ d(x, t) is convex (the distance to
//! a convex set), so its maximum over T is reached at a corner:
//! max over x in T of d(x, B) ≤ max over corners v of d(v, t). That is the bound used, with t
//! the nearest triangle of B to a corner or to the centre; where it is loose (T faces several
//! triangles of B), T is split in four at its edge midpoints, down to `MAX_DEPTH`, where the
//! covering bound takes over (every point of a triangle lies within L/√3 of a corner, L its
//! longest edge, and d(·, B) is 1-Lipschitz). A branch stops as soon as its bound cannot raise
//! the largest corner distance found so far by more than `SLACK`, or is below `RESOLUTION`
//! of the triangles' size: the result is never below the true maximum, and above it by at
//! most those margins (or the covering bound's L/√3 at the deepest split).
//!
//! Triangles present in both sets (same three vertex indices) are at distance 0 and skipped.
//! Nearest-triangle queries go through a uniform grid and are exact (rings of cells are
//! visited until no unvisited cell can hold anything nearer).

use std::collections::HashSet;

use crate::vec3::{cross, dot, normalize, sub};
use distance::longest_edge;
pub use distance::point_triangle_distance;
use grid::{Corner, Search, TriangleGrid};

mod distance;
mod grid;

/// Deepest four-way split of a triangle (4^6 = 4,096 pieces at most).
const MAX_DEPTH: u32 = 6;
/// A branch stops when its bound is within this fraction of the largest distance found...
const SLACK: f64 = 0.02;
/// ... or below this fraction of the mean longest edge of the measured triangles (where the
/// two sets nearly coincide, a finer split buys nothing the error can use).
const RESOLUTION: f64 = 0.01;

/// An upper bound on the two-sided Hausdorff distance between the triangles `a` and `b`
/// (flat lists of vertex indices into `positions`). Infinite when exactly one of them is
/// empty; 0 when both are.
pub fn two_sided_bound(positions: &[[f64; 3]], a: &[u32], b: &[u32]) -> f64 {
    let forward = directed_bound(positions, a, b, 0.0);
    directed_bound(positions, b, a, forward)
}

/// An upper bound on max(`floor`, h(from→to)), h(from→to) = max over points x of `from` of
/// d(x, `to`). The floor (a bound already known for something else) lets every piece whose
/// bound is below it stop at once.
pub fn directed_bound(positions: &[[f64; 3]], from: &[u32], to: &[u32], floor: f64) -> f64 {
    let sorted = |t: &[u32]| {
        let mut k = [t[0], t[1], t[2]];
        k.sort_unstable();
        k
    };
    let shared: HashSet<[u32; 3]> = to.chunks_exact(3).map(sorted).collect();
    let remaining: Vec<&[u32]> = from
        .chunks_exact(3)
        .filter(|t| !shared.contains(&sorted(t)))
        .collect();
    if remaining.is_empty() {
        return floor;
    }
    let targets = corner_positions(positions, to);
    if targets.is_empty() {
        return f64::INFINITY;
    }
    let grid = TriangleGrid::new(&targets);
    let mut search = Search::new(&grid);
    // Each corner once: a vertex of a target triangle is at distance 0 from it, any other
    // is queried (vertices are shared by about six triangles).
    let mut corner_of: Vec<Option<Corner>> = vec![None; positions.len()];
    for (index, t) in to.chunks_exact(3).enumerate() {
        for &v in t {
            corner_of[v as usize] = Some(Corner {
                point: positions[v as usize],
                distance: 0.0,
                nearest: index,
            });
        }
    }
    let mut hint = None;
    let mut corner = |v: u32, search: &mut Search| {
        *corner_of[v as usize].get_or_insert_with(|| {
            let c = search.nearest(positions[v as usize], hint);
            hint = Some(c.nearest);
            c
        })
    };
    // First every corner, so that the largest corner distance (a lower bound on the answer)
    // prunes from the start; then the triangles farthest away first.
    let mut pieces: Vec<[Corner; 3]> = remaining
        .iter()
        .map(|t| [0, 1, 2].map(|k| corner(t[k], &mut search)))
        .collect();
    let farthest = |c: &[Corner; 3]| c.iter().map(|c| c.distance).fold(0.0f64, f64::max);
    let mut found = pieces.iter().map(farthest).fold(0.0f64, f64::max);
    pieces.sort_by(|a, b| farthest(b).total_cmp(&farthest(a)));
    let remaining: Vec<[[f64; 3]; 3]> = remaining
        .iter()
        .map(|t| [0, 1, 2].map(|k| positions[t[k] as usize]))
        .collect();
    let mean_edge = remaining.iter().map(longest_edge).sum::<f64>() / remaining.len() as f64;
    let resolution = (RESOLUTION * mean_edge).max(floor);
    let mut bound = 0.0f64; // the largest accepted piece bound (the upper bound)
    let mut stack: Vec<(Corner, Corner, Corner, u32)> = Vec::new();
    for [a, b, c] in pieces {
        stack.push((a, b, c, 0));
        while let Some((a, b, c, depth)) = stack.pop() {
            found = found.max(a.distance).max(b.distance).max(c.distance);
            let enough = (found * (1.0 + SLACK)).max(resolution);
            let piece = piece_bound(&grid, &mut search, [&a, &b, &c], enough);
            if piece <= enough || depth == MAX_DEPTH {
                bound = bound.max(piece);
                continue;
            }
            let ab = search.nearest(midpoint(a.point, b.point), Some(a.nearest));
            let bc = search.nearest(midpoint(b.point, c.point), Some(b.nearest));
            let ca = search.nearest(midpoint(c.point, a.point), Some(c.nearest));
            stack.push((a, ab, ca, depth + 1));
            stack.push((ab, b, bc, depth + 1));
            stack.push((ca, bc, c, depth + 1));
            stack.push((ab, bc, ca, depth + 1));
        }
    }
    bound.max(found).max(floor)
}

/// A lower bound on h(from→to) by sampling: the largest exact distance to `to` of the points
/// of a barycentric lattice with `steps` steps a side on each triangle of `from` (corners and
/// edges included). What a measurement independent of the bound uses: it can only show a
/// bound false, never prove it. Infinite when `to` is empty and `from` is not.
pub fn sampled_directed(positions: &[[f64; 3]], from: &[u32], to: &[u32], steps: usize) -> f64 {
    sampled_directed_weighted(positions, from, to, steps, |_, d| d)
}

/// `sampled_directed` with each sample's distance d at point p turned into `weigh(p, d)`
/// first (a projection to pixels, say); the largest weighed value. Infinite distances (an
/// empty `to`) are weighed too. `weigh` must not decrease as d grows (for each p): the search
/// of a sample ends as soon as a triangle is found whose distance (an upper bound of the
/// sample's) weighs no more than the largest so far, since the sample cannot raise it. The
/// result is that of searching every sample to the end, about twice as fast on the cuts of
/// `check --errors` (most samples at distance 0, or well below the largest).
pub fn sampled_directed_weighted(
    positions: &[[f64; 3]],
    from: &[u32],
    to: &[u32],
    steps: usize,
    weigh: impl Fn([f64; 3], f64) -> f64,
) -> f64 {
    if from.len() < 3 {
        return 0.0;
    }
    let targets = corner_positions(positions, to);
    if targets.is_empty() {
        return from
            .chunks_exact(3)
            .map(|t| weigh(positions[t[0] as usize], f64::INFINITY))
            .fold(0.0, f64::max);
    }
    let grid = TriangleGrid::new(&targets);
    let mut search = Search::new(&grid);
    let steps = steps.max(1);
    let mut largest = 0.0f64;
    let mut hint = None;
    for t in from.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| positions[t[k] as usize]);
        for i in 0..=steps {
            for j in 0..=steps - i {
                let (u, v) = (i as f64 / steps as f64, j as f64 / steps as f64);
                let w = 1.0 - u - v;
                let p = [0, 1, 2].map(|k| u * a[k] + v * b[k] + w * c[k]);
                // Any triangle's distance bounds d, and `weigh` grows with d: once one found
                // weighs no more than the largest, the sample cannot raise it.
                let nearest = search.nearest_until(p, hint, |d| weigh(p, d) <= largest);
                hint = Some(nearest.nearest);
                largest = largest.max(weigh(p, nearest.distance));
            }
        }
    }
    largest
}

/// The corner positions of each triangle of a flat index list.
fn corner_positions(positions: &[[f64; 3]], indices: &[u32]) -> Vec<[[f64; 3]; 3]> {
    indices
        .chunks_exact(3)
        .map(|t| [0, 1, 2].map(|k| positions[t[k] as usize]))
        .collect()
}

/// A bound on max d(x, B) over the piece with these corners: the covering bound, or the
/// convexity bound through the nearest triangle of the piece's centre or of a corner,
/// whichever is least; stops at the first at or below `enough` (the caller accepts any such).
fn piece_bound(
    grid: &TriangleGrid,
    search: &mut Search,
    corners: [&Corner; 3],
    enough: f64,
) -> f64 {
    let points = corners.map(|c| c.point);
    let mut best = corners.iter().map(|c| c.distance).fold(0.0f64, f64::max)
        + longest_edge(&points) / 3f64.sqrt();
    if best <= enough {
        return best;
    }
    let centre = search.nearest(
        [0, 1, 2].map(|k| (points[0][k] + points[1][k] + points[2][k]) / 3.0),
        Some(corners[0].nearest),
    );
    let mut tried: [usize; 4] = [usize::MAX; 4];
    let candidates = std::iter::once(centre.nearest).chain(corners.iter().map(|c| c.nearest));
    for (slot, t) in candidates.enumerate() {
        if tried[..slot].contains(&t) {
            continue;
        }
        tried[slot] = t;
        // The largest corner distance to t, given up once it cannot improve on `best`.
        let mut through = 0.0f64;
        for c in corners {
            let d = match c.nearest == t {
                true => c.distance,
                false => point_triangle_distance(c.point, &grid.triangles[t]),
            };
            through = through.max(d);
            if through >= best {
                break;
            }
        }
        best = best.min(through);
        if best <= enough {
            return best;
        }
    }
    // A piece across the edge between two nearest triangles: split it by a plane, and bound
    // each side through its own triangle (`split_bound`).
    let distinct: Vec<usize> = tried.iter().copied().filter(|&t| t != usize::MAX).collect();
    for (i, &t1) in distinct.iter().enumerate() {
        for &t2 in &distinct[i + 1..] {
            best = best.min(split_bound(grid, &points, t1, t2, best));
            if best <= enough {
                return best;
            }
        }
    }
    best
}

/// For any plane π, max over the piece P of d(x, B) ≤ the larger of max over P ∩ π⁺ of
/// d(x, t1) and max over P ∩ π⁻ of d(x, t2); each side is convex, so its maximum is at a
/// corner of that side (P's corners there and where P's edges cross π). π goes through the
/// edge t1 and t2 share, halfway between their planes, or else halfway between their centres.
/// Gives up (returns `give_up`) once a corner reaches it.
fn split_bound(
    grid: &TriangleGrid,
    piece: &[[f64; 3]; 3],
    t1: usize,
    t2: usize,
    give_up: f64,
) -> f64 {
    let (a, b) = (&grid.triangles[t1], &grid.triangles[t2]);
    let centre = |t: &[[f64; 3]; 3]| [0, 1, 2].map(|k| (t[0][k] + t[1][k] + t[2][k]) / 3.0);
    let shared: Vec<[f64; 3]> = a.iter().filter(|p| b.contains(p)).copied().collect();
    let (origin, normal) = match shared.as_slice() {
        [p, q] => {
            let unit = |v: [f64; 3]| normalize(v).unwrap_or(v);
            let na = unit(cross(sub(a[1], a[0]), sub(a[2], a[0])));
            let nb = unit(cross(sub(b[1], b[0]), sub(b[2], b[0])));
            let mean = [na[0] + nb[0], na[1] + nb[1], na[2] + nb[2]];
            (*p, cross(sub(*q, *p), mean))
        }
        _ => {
            let (ca, cb) = (centre(a), centre(b));
            (midpoint(ca, cb), sub(ca, cb))
        }
    };
    // t1's side positive.
    let side = |x: [f64; 3]| dot(sub(x, origin), normal);
    let sign = if side(centre(a)) >= 0.0 { 1.0 } else { -1.0 };
    if dot(normal, normal) == 0.0 {
        return give_up;
    }
    let mut largest = 0.0f64;
    let mut measure = |x: [f64; 3], t: &[[f64; 3]; 3]| {
        largest = largest.max(point_triangle_distance(x, t));
        largest >= give_up
    };
    for i in 0..3 {
        let (p, q) = (piece[i], piece[(i + 1) % 3]);
        let (sp, sq) = (sign * side(p), sign * side(q));
        // A corner on π is a corner of both sides.
        let stop = match sp {
            s if s > 0.0 => measure(p, a),
            s if s < 0.0 => measure(p, b),
            _ => measure(p, a) || measure(p, b),
        };
        if stop {
            return give_up;
        }
        if (sp > 0.0 && sq < 0.0) || (sp < 0.0 && sq > 0.0) {
            let t = sp / (sp - sq);
            let x = [0, 1, 2].map(|k| p[k] + t * (q[k] - p[k]));
            // On π: a corner of both sides.
            if measure(x, a) || measure(x, b) {
                return give_up;
            }
        }
    }
    largest
}

fn midpoint(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|k| 0.5 * (a[k] + b[k]))
}

#[cfg(test)]
mod tests;
