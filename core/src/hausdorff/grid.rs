//! Triangles binned into a uniform grid, and exact nearest-triangle queries on it.

use super::distance::{distance, point_triangle_distance};

/// A corner of a piece of triangle, with its exact distance to the target set and the target
/// triangle that attains it.
#[derive(Clone, Copy, Debug)]
pub(super) struct Corner {
    pub point: [f64; 3],
    pub distance: f64,
    pub nearest: usize,
}

/// Triangles binned into a uniform grid by their bounding boxes.
pub(super) struct TriangleGrid<'t> {
    pub triangles: &'t [[[f64; 3]; 3]],
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
    pub(super) fn new(triangles: &'t [[[f64; 3]; 3]]) -> Self {
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
pub(super) struct Search<'g, 't> {
    grid: &'g TriangleGrid<'t>,
    stamp: Vec<u32>,
    query: u32,
}

impl<'g, 't> Search<'g, 't> {
    pub(super) fn new(grid: &'g TriangleGrid<'t>) -> Self {
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
    pub(super) fn nearest(&mut self, p: [f64; 3], hint: Option<usize>) -> Corner {
        self.nearest_until(p, hint, |_| false)
    }

    /// `nearest`, ended early once `enough(distance)` holds for the best distance found (the
    /// hint's, or after a ring): the distance returned is then only an upper bound of the
    /// nearest (and `enough` of it holds). `sampled_directed_weighted` stops once a sample
    /// cannot raise the largest weighed value.
    pub(super) fn nearest_until(
        &mut self,
        p: [f64; 3],
        hint: Option<usize>,
        enough: impl Fn(f64) -> bool,
    ) -> Corner {
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
            if enough(best.distance) {
                return best;
            }
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
            if ring > 0
                && (best.distance <= (ring - 1) as f64 * grid.cell + gap || enough(best.distance))
            {
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
