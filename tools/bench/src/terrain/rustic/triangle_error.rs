//! The vertical error of every bintree triangle, drawn flat, against the real grid samples it
//! covers: the adaptive merge's priority (a merge replaces four triangles by two, whose
//! errors are these) and, as a maximum over a cluster's sub-triangles, the cluster's error.
//!
//! Stored per diamond centre (the triangle's hypotenuse midpoint), one slot per side of the
//! hypotenuse, so the table is two floats per sample point. The finest triangles (half a cell)
//! cover only their corners and have error 0. Computed exactly as `grid::vertical_error` does
//! (same corner order, barycentric formula and f32 rounding of the surface), so a cluster's
//! error is the same number `vertical_error` reports for its triangles.

use super::diamond::in_square;
use crate::terrain::grid::{BinGrid, BinTri};

pub struct TriangleErrors {
    side: i32,
    /// Per sample point (row by row), the errors of the diamond's two triangles.
    values: Vec<[f32; 2]>,
}

impl TriangleErrors {
    /// Rasterises every splittable bintree triangle over its bounding box clipped to the real
    /// grid: about 2 · (side + 1)² sample visits per level.
    pub fn compute(grid: &BinGrid) -> TriangleErrors {
        let side = grid.side;
        let n = (side + 1) as usize;
        let mut values = vec![[0.0f32; 2]; n * n];
        let mut stack: Vec<BinTri> = grid.roots().to_vec();
        while let Some(t) = stack.pop() {
            if !t.can_split() {
                continue;
            }
            let (point, slot) = slot_of(side, &t);
            values[point][slot] = triangle_error(grid, &t);
            stack.extend(t.children());
        }
        TriangleErrors { side, values }
    }

    /// The error of a bintree triangle (0 for the finest ones).
    pub fn get(&self, t: &BinTri) -> f32 {
        if !t.can_split() {
            return 0.0;
        }
        let (point, slot) = slot_of(self.side, t);
        self.values[point][slot]
    }

    /// The larger error of the (one or two) triangles of the diamond centred at `p`: the
    /// error a merge of that diamond introduces.
    pub fn diamond(&self, p: [i32; 2]) -> f32 {
        let [a, b] = self.values[(p[1] * (self.side + 1) + p[0]) as usize];
        a.max(b)
    }
}

/// Index of a splittable triangle's hypotenuse midpoint and the slot of its side: 0 when the
/// apex is lexicographically after the midpoint.
fn slot_of(side: i32, t: &BinTri) -> (usize, usize) {
    let c = t.split_point();
    debug_assert!(in_square(side, c));
    let slot = usize::from((t.apex[0], t.apex[1]) <= (c[0], c[1]));
    ((c[1] * (side + 1) + c[0]) as usize, slot)
}

/// Largest |flat triangle − real sample| over the real samples in the closed triangle.
fn triangle_error(grid: &BinGrid, t: &BinTri) -> f32 {
    let corners = t.corners();
    let [a, b, c] = corners.map(|p| [p[0] as f64, p[1] as f64, grid.height(p) as f64]);
    let lo = |k: usize| corners.iter().map(|p| p[k]).min().unwrap();
    let hi = |k: usize| corners.iter().map(|p| p[k]).max().unwrap();
    let (c0, r0) = (lo(0).max(0), lo(1).max(0));
    let c1 = hi(0).min(grid.columns as i32 - 1);
    let r1 = hi(1).min(grid.rows as i32 - 1);
    let det = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    // Exact integer edge functions decide inside; corners are counter-clockwise.
    let [pa, pb, pc] = corners;
    let edge = |p: [i32; 2], q: [i32; 2], x: i32, y: i32| {
        (q[0] - p[0]) as i64 * (y - p[1]) as i64 - (q[1] - p[1]) as i64 * (x - p[0]) as i64
    };
    let mut worst = 0.0f64;
    for r in r0..=r1 {
        for col in c0..=c1 {
            if edge(pa, pb, col, r) < 0 || edge(pb, pc, col, r) < 0 || edge(pc, pa, col, r) < 0 {
                continue;
            }
            let h = grid.real_height([col, r]);
            if h.is_nan() {
                continue;
            }
            let (x, y) = (col as f64, r as f64);
            let wb = ((x - a[0]) * (c[1] - a[1]) - (y - a[1]) * (c[0] - a[0])) / det;
            let wc = ((b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0])) / det;
            let wa = 1.0 - wb - wc;
            let surface = (wa * a[2] + wb * b[2] + wc * c[2]) as f32;
            worst = worst.max((surface as f64 - h as f64).abs());
        }
    }
    worst as f32
}
