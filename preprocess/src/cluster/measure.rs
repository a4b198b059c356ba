//! The error of a written cut, out of core: the one-sided distance from the output to the
//! input, sampled. Each output triangle is sampled on a barycentric lattice (`STEPS` steps a
//! side: corners, edge points, interior points), and each sample's distance is taken to the
//! input triangles of its own node (a range of the sorted soup, read in blocks within the
//! budget, each block binned in a uniform grid and searched exactly with
//! `hausdorff::point_triangle_distance`). The input's other triangles could only
//! be nearer, so each figure is an upper bound of the sampled distance to the whole input;
//! a fan stays over its own node's surface, so the two rarely differ.

use std::io;

use tessera_core::hausdorff::point_triangle_distance;

use super::layout::{self, Layout};
use super::levels::Hierarchy;
use super::soup::Soup;

/// Lattice steps a side on each output triangle (10 samples a triangle).
pub const STEPS: usize = 3;

/// The sampled one-sided distance from a cut to the input.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Distance {
    /// Largest sample distance, model units.
    pub max: f64,
    /// Area-weighted mean of the sample distances, model units.
    pub mean: f64,
    pub samples: u64,
}

/// Measures the cut `cut` (post-order, ascending) of `hierarchy` against `soup`, holding at
/// most about `budget` bytes of input triangles at once.
pub fn measure<L: Layout>(
    soup: &Soup<L>,
    hierarchy: &Hierarchy<L>,
    cut: &[u32],
    budget: usize,
) -> io::Result<Distance> {
    let block = (budget / (2 * std::mem::size_of::<L::Rec>() + 160)).max(1 << 10);
    let mut input = soup.sorted.read()?;
    let mut input_at = 0u64;
    let mut outputs = hierarchy.outputs.read()?;
    let mut output_at = 0u64;
    let (mut max, mut weighted, mut area_sum, mut samples) = (0.0f64, 0.0f64, 0.0f64, 0u64);
    let ends = || io::Error::other("a file of the simplifier ends early");
    for &i in cut {
        let node = &hierarchy.octree.nodes[i as usize];
        // This node's output triangles, as sample points with their weights.
        let first = hierarchy.out_first[i as usize];
        while output_at < first {
            outputs.next().ok_or_else(ends)??;
            output_at += 1;
        }
        let mut points: Vec<[f64; 3]> = Vec::new();
        let mut weights: Vec<f64> = Vec::new();
        for _ in 0..hierarchy.out_count[i as usize] {
            let r = outputs.next().ok_or_else(ends)??;
            output_at += 1;
            let t = corners::<L>(&r);
            let a = super::node::area(&t[0], &t[1], &t[2]);
            let per = (STEPS + 1) * (STEPS + 2) / 2;
            for u in 0..=STEPS {
                for v in 0..=STEPS - u {
                    let (fu, fv) = (u as f64 / STEPS as f64, v as f64 / STEPS as f64);
                    let fw = 1.0 - fu - fv;
                    points.push([0, 1, 2].map(|k| fu * t[0][k] + fv * t[1][k] + fw * t[2][k]));
                    weights.push(a / per as f64);
                }
            }
        }
        // The node's input, a block at a time.
        while input_at < node.first {
            input.next().ok_or_else(ends)??;
            input_at += 1;
        }
        let mut nearest = vec![f64::INFINITY; points.len()];
        let mut left = node.count;
        while left > 0 {
            let take = left.min(block as u64);
            let mut triangles = Vec::with_capacity(take as usize);
            for _ in 0..take {
                let r = input.next().ok_or_else(ends)??;
                triangles.push(corners::<L>(&r));
            }
            input_at += take;
            left -= take;
            if points.is_empty() {
                continue;
            }
            let grid = Grid::new(&triangles);
            for (p, d) in points.iter().zip(nearest.iter_mut()) {
                *d = d.min(grid.nearest(*p, *d));
            }
        }
        for (d, w) in nearest.iter().zip(&weights) {
            max = max.max(*d);
            weighted += d * w;
            area_sum += w;
        }
        samples += points.len() as u64;
    }
    Ok(Distance {
        max,
        mean: if area_sum > 0.0 {
            weighted / area_sum
        } else {
            0.0
        },
        samples,
    })
}

/// A record's corners, as f64.
fn corners<L: Layout>(r: &L::Rec) -> [[f64; 3]; 3] {
    [0, 1, 2].map(|k| layout::position(layout::corner::<L>(r, k)).map(f64::from))
}

/// Triangles binned into a uniform grid by their bounding boxes.
struct Grid<'t> {
    triangles: &'t [[[f64; 3]; 3]],
    origin: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl<'t> Grid<'t> {
    fn new(triangles: &'t [[[f64; 3]; 3]]) -> Grid<'t> {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for t in triangles {
            for p in t {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        let size = (0..3)
            .map(|k| hi[k] - lo[k])
            .fold(0.0f64, f64::max)
            .max(1e-30);
        // About one triangle a cell along a surface (√n cells along the largest side), and
        // never more cells than triangles in a volume.
        let n = triangles.len().max(1) as f64;
        let per_side = (n.sqrt().ceil() as usize).clamp(1, 256);
        let volume: f64 = (0..3).map(|k| hi[k] - lo[k]).product();
        let cell = (size / per_side as f64).max((volume / n).cbrt());
        let dims = [0, 1, 2].map(|k| (((hi[k] - lo[k]) / cell) as usize + 1).min(per_side + 1));
        let index = |p: [f64; 3]| -> [usize; 3] {
            [0, 1, 2].map(|k| (((p[k] - lo[k]) / cell).max(0.0) as usize).min(dims[k] - 1))
        };
        let cells = dims[0] * dims[1] * dims[2];
        let mut counts = vec![0u32; cells + 1];
        let each = |f: &mut dyn FnMut(usize, u32)| {
            for (i, t) in triangles.iter().enumerate() {
                let a = index([0, 1, 2].map(|k| t[0][k].min(t[1][k]).min(t[2][k])));
                let b = index([0, 1, 2].map(|k| t[0][k].max(t[1][k]).max(t[2][k])));
                for x in a[0]..=b[0] {
                    for y in a[1]..=b[1] {
                        for z in a[2]..=b[2] {
                            f((z * dims[1] + y) * dims[0] + x, i as u32);
                        }
                    }
                }
            }
        };
        each(&mut |c, _| counts[c + 1] += 1);
        for c in 0..cells {
            counts[c + 1] += counts[c];
        }
        let mut fill = counts.clone();
        let mut items = vec![0u32; counts[cells] as usize];
        each(&mut |c, i| {
            items[fill[c] as usize] = i;
            fill[c] += 1;
        });
        Grid {
            triangles,
            origin: lo,
            cell,
            dims,
            start: counts,
            items,
        }
    }

    /// The distance from `p` to the nearest triangle, or `bound` if none is nearer.
    fn nearest(&self, p: [f64; 3], bound: f64) -> f64 {
        let c = [0, 1, 2].map(|k| {
            (((p[k] - self.origin[k]) / self.cell).floor().max(0.0) as usize).min(self.dims[k] - 1)
        });
        let mut best = bound;
        let largest = *self.dims.iter().max().unwrap();
        for r in 0..=largest {
            let lo = [0, 1, 2].map(|k| c[k].saturating_sub(r));
            let hi = [0, 1, 2].map(|k| (c[k] + r).min(self.dims[k] - 1));
            // Ring r's cells: whole rows where y or z is on the ring, else its two ends in x.
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    let whole = z.abs_diff(c[2]) == r || y.abs_diff(c[1]) == r;
                    let row = (z * self.dims[1] + y) * self.dims[0];
                    let mut visit = |x: usize| {
                        let cell = row + x;
                        let items =
                            &self.items[self.start[cell] as usize..self.start[cell + 1] as usize];
                        for &t in items {
                            best =
                                best.min(point_triangle_distance(p, &self.triangles[t as usize]));
                        }
                    };
                    if whole {
                        (lo[0]..=hi[0]).for_each(&mut visit);
                    } else {
                        if c[0] >= r {
                            visit(c[0] - r);
                        }
                        if r > 0 && c[0] + r < self.dims[0] {
                            visit(c[0] + r);
                        }
                    }
                }
            }
            // The cells not yet visited lie beyond a wall of the box of rings up to r that has
            // cells behind it: none nearer than p's distance to such a wall (0 once p is past
            // it). With no such wall every cell has been visited.
            let mut wall = f64::INFINITY;
            for k in 0..3 {
                if lo[k] > 0 {
                    let low = self.origin[k] + lo[k] as f64 * self.cell;
                    wall = wall.min((p[k] - low).max(0.0));
                }
                if hi[k] + 1 < self.dims[k] {
                    let high = self.origin[k] + (hi[k] + 1) as f64 * self.cell;
                    wall = wall.min((high - p[k]).max(0.0));
                }
            }
            if best <= wall {
                break;
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_finds_the_nearest_triangle_exactly() {
        // A strip of triangles along x at z = 0, and queries above and beside it.
        let mut triangles = Vec::new();
        for i in 0..50 {
            let x = i as f64 * 0.1;
            triangles.push([[x, 0.0, 0.0], [x + 0.1, 0.0, 0.0], [x, 0.1, 0.0]]);
            triangles.push([[x + 0.1, 0.0, 0.0], [x + 0.1, 0.1, 0.0], [x, 0.1, 0.0]]);
        }
        let grid = Grid::new(&triangles);
        for p in [
            [2.5, 0.05, 0.3],
            [-1.0, 0.05, 0.0],
            [6.0, 2.0, 0.0],
            [1.234, 0.02, 0.0],
        ] {
            let brute = triangles
                .iter()
                .map(|t| point_triangle_distance(p, t))
                .fold(f64::INFINITY, f64::min);
            assert!(
                (grid.nearest(p, f64::INFINITY) - brute).abs() < 1e-12,
                "{p:?}"
            );
        }
    }
}
