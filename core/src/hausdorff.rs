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

fn longest_edge(t: &[[f64; 3]; 3]) -> f64 {
    distance(t[0], t[1])
        .max(distance(t[1], t[2]))
        .max(distance(t[2], t[0]))
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
/// empty `to`) are weighed too.
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
                let nearest = search.nearest(p, hint);
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

/// A corner of a piece of triangle, with its exact distance to the target set and the target
/// triangle that attains it.
#[derive(Clone, Copy, Debug)]
struct Corner {
    point: [f64; 3],
    distance: f64,
    nearest: usize,
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
            let unit = |v: [f64; 3]| {
                let n = dot(v, v).sqrt();
                if n > 0.0 {
                    v.map(|x| x / n)
                } else {
                    v
                }
            };
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

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
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

/// Triangles binned into a uniform grid by their bounding boxes.
struct TriangleGrid<'t> {
    triangles: &'t [[[f64; 3]; 3]],
    /// Each triangle's bounding box (min, max): a cheap lower bound on its distance.
    boxes: Vec<([f64; 3], [f64; 3])>,
    min: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    /// Triangles of cell i: `items[starts[i]..starts[i + 1]]`.
    starts: Vec<usize>,
    items: Vec<u32>,
}

impl<'t> TriangleGrid<'t> {
    fn new(triangles: &'t [[[f64; 3]; 3]]) -> Self {
        let mut min = [f64::INFINITY; 3];
        let mut max = [f64::NEG_INFINITY; 3];
        let mut edge_sum = 0.0;
        for t in triangles {
            for p in t {
                for k in 0..3 {
                    min[k] = min[k].min(p[k]);
                    max[k] = max[k].max(p[k]);
                }
            }
            edge_sum += distance(t[0], t[1])
                .max(distance(t[1], t[2]))
                .max(distance(t[2], t[0]));
        }
        let extent = (0..3).map(|k| max[k] - min[k]).fold(0.0f64, f64::max);
        // Cells half a triangle wide, at most 256 along an axis and 32 a triangle (4 for large
        // sets, whose cell table would otherwise dwarf the triangles).
        let mut cell = (0.5 * edge_sum / triangles.len() as f64)
            .max(extent / 256.0)
            .max(f64::MIN_POSITIVE);
        let dims_for =
            |cell: f64| [0, 1, 2].map(|k| (((max[k] - min[k]) / cell) as usize).min(1 << 20) + 1);
        let per_triangle = if triangles.len() > 100_000 { 4 } else { 32 };
        while dims_for(cell).iter().product::<usize>() > per_triangle * triangles.len() + 64 {
            cell *= 1.5;
        }
        let dims = dims_for(cell);
        let boxes = triangles
            .iter()
            .map(|t| {
                (
                    [0, 1, 2].map(|k| t[0][k].min(t[1][k]).min(t[2][k])),
                    [0, 1, 2].map(|k| t[0][k].max(t[1][k]).max(t[2][k])),
                )
            })
            .collect();
        let mut grid = TriangleGrid {
            triangles,
            boxes,
            min,
            cell,
            dims,
            starts: Vec::new(),
            items: Vec::new(),
        };
        let cells = dims.iter().product::<usize>();
        let mut counts = vec![0usize; cells + 1];
        for t in triangles {
            grid.for_cells_of(t, |i| counts[i] += 1);
        }
        let mut at = 0;
        for c in counts.iter_mut() {
            let n = *c;
            *c = at;
            at += n;
        }
        let mut fill = counts.clone();
        let mut items = vec![0u32; at];
        for (index, t) in triangles.iter().enumerate() {
            grid.for_cells_of(t, |i| {
                items[fill[i]] = index as u32;
                fill[i] += 1;
            });
        }
        grid.starts = counts;
        grid.items = items;
        grid
    }

    fn cell_of(&self, p: [f64; 3]) -> [usize; 3] {
        [0, 1, 2].map(|k| {
            let c = ((p[k] - self.min[k]) / self.cell).floor();
            if c.is_nan() || c < 0.0 {
                0
            } else {
                (c as usize).min(self.dims[k] - 1)
            }
        })
    }

    fn index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    fn for_cells_of(&self, t: &[[f64; 3]; 3], mut visit: impl FnMut(usize)) {
        let lo = [0, 1, 2].map(|k| t[0][k].min(t[1][k]).min(t[2][k]));
        let hi = [0, 1, 2].map(|k| t[0][k].max(t[1][k]).max(t[2][k]));
        let (lo, hi) = (self.cell_of(lo), self.cell_of(hi));
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    visit(self.index([x, y, z]));
                }
            }
        }
    }
}

/// Nearest-triangle queries on one grid, with a visit stamp per triangle.
struct Search<'g, 't> {
    grid: &'g TriangleGrid<'t>,
    stamp: Vec<u32>,
    query: u32,
}

impl<'g, 't> Search<'g, 't> {
    fn new(grid: &'g TriangleGrid<'t>) -> Self {
        Search {
            grid,
            stamp: vec![0; grid.triangles.len()],
            query: 0,
        }
    }

    /// The exact nearest triangle to `p`, starting from `hint` (a triangle likely to be near).
    /// Cells are visited in growing Chebyshev rings around `p`'s (clamped) cell; a triangle
    /// not seen after ring r − 1 lies in cells at least r − 1 cells beyond `p`'s own along some
    /// axis, so at least (r − 1) × cell + `p`'s distance to its cell's nearest face away (that
    /// distance counts only for a `p` inside the grid), and the search ends once the best
    /// distance is no larger. A triangle whose box is farther than the best is not measured.
    fn nearest(&mut self, p: [f64; 3], hint: Option<usize>) -> Corner {
        self.query = self.query.wrapping_add(1);
        if self.query == 0 {
            self.stamp.fill(0);
            self.query = 1;
        }
        let grid = self.grid;
        let centre = grid.cell_of(p);
        let mut best = Corner {
            point: p,
            distance: f64::INFINITY,
            nearest: 0,
        };
        if let Some(t) = hint {
            self.stamp[t] = self.query;
            best.distance = point_triangle_distance(p, &grid.triangles[t]);
            best.nearest = t;
        }
        let inside = (0..3)
            .all(|k| p[k] >= grid.min[k] && p[k] <= grid.min[k] + grid.dims[k] as f64 * grid.cell);
        let gap = if inside {
            (0..3)
                .map(|k| {
                    let lo = grid.min[k] + centre[k] as f64 * grid.cell;
                    (p[k] - lo).min(lo + grid.cell - p[k]).max(0.0)
                })
                .fold(f64::INFINITY, f64::min)
        } else {
            0.0
        };
        let largest_ring = grid.dims.iter().copied().max().unwrap_or(1);
        for ring in 0..=largest_ring {
            if ring > 0 && best.distance <= (ring - 1) as f64 * grid.cell + gap {
                break;
            }
            let lo = centre.map(|c| c.saturating_sub(ring));
            let hi = [0, 1, 2].map(|k| (centre[k] + ring).min(grid.dims[k] - 1));
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    // Off the ring in y and z, only the two x ends of the row are on it.
                    let interior = z.abs_diff(centre[2]) < ring && y.abs_diff(centre[1]) < ring;
                    let step = if interior { (2 * ring).max(1) } else { 1 };
                    let first = if interior && centre[0] < ring {
                        centre[0] + ring
                    } else {
                        lo[0]
                    };
                    for x in (first..=hi[0]).step_by(step) {
                        if [x, y, z]
                            .iter()
                            .zip(&centre)
                            .all(|(&i, &c)| i.abs_diff(c) != ring)
                        {
                            continue;
                        }
                        let cell = grid.index([x, y, z]);
                        for &t in &grid.items[grid.starts[cell]..grid.starts[cell + 1]] {
                            let t = t as usize;
                            if self.stamp[t] == self.query {
                                continue;
                            }
                            self.stamp[t] = self.query;
                            let (lo, hi) = &grid.boxes[t];
                            let outside = (0..3)
                                .map(|k| (lo[k] - p[k]).max(p[k] - hi[k]).max(0.0))
                                .map(|d| d * d)
                                .sum::<f64>();
                            if outside >= best.distance * best.distance {
                                continue;
                            }
                            let d = point_triangle_distance(p, &grid.triangles[t]);
                            if d < best.distance {
                                best.distance = d;
                                best.nearest = t;
                            }
                        }
                    }
                }
            }
        }
        best
    }
}

#[cfg(test)]
#[path = "hausdorff_tests.rs"]
mod tests;
