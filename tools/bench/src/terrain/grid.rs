//! The terrain baselines' view of a height field: a square of (2^k + 1)² samples over the
//! grid (ROAM and RUSTiC are defined on such squares), the right triangles of its bintree, and
//! the vertical error of any triangulation against the full grid.
//!
//! Coordinates: a *sample point* is `[column, row]` in the grid (i32); the square covers
//! columns and rows `0..=side`, the real grid `0..columns` × `0..rows`. Samples outside the real
//! grid (padding) and missing samples take the height of the nearest real sample of their row,
//! then column (clamping), so the baselines never see a hole; the benchmark grids (ETOPO20,
//! Jacksboro) have none. World positions are those of `HeightGrid::to_mesh` (metres), so the
//! baselines, tessera and the full grid are measured in one frame.

use tessera_preprocess::dem::{HeightGrid, TerrainOptions};

/// A height field padded to a (2^k + 1)² square.
pub struct BinGrid {
    /// Side of the square in cells: 2^k, k ≥ 1.
    pub side: i32,
    /// Real grid samples per row and rows.
    pub columns: usize,
    pub rows: usize,
    /// World x, y of sample [0, 0] and the world step per column and per row (metres).
    pub origin: [f64; 2],
    pub spacing: [f64; 2],
    /// Heights of the real grid (world z, exaggeration applied), row by row; NaN = missing.
    real: Vec<f32>,
    /// Heights of the whole square, (side + 1)², row by row; padded and filled.
    square: Vec<f32>,
}

impl BinGrid {
    pub fn new(grid: &HeightGrid, options: &TerrainOptions) -> BinGrid {
        let (origin, spacing) = grid.placement(options);
        let (columns, rows) = (grid.columns, grid.rows);
        let cells = (columns.max(rows) - 1).max(2);
        let side = cells.next_power_of_two() as i32;
        let exaggeration = options.vertical_exaggeration as f32;
        let real: Vec<f32> = grid.heights.iter().map(|h| h * exaggeration).collect();
        // Fill missing samples along rows, then columns (nearest valid in the row, else the
        // nearest filled row), then clamp the padding to the grid's edge.
        let mut filled = real.clone();
        for r in 0..rows {
            let row = &mut filled[r * columns..(r + 1) * columns];
            fill_nearest(row);
        }
        let valid_rows: Vec<usize> = (0..rows)
            .filter(|&r| !filled[r * columns].is_nan())
            .collect();
        for r in 0..rows {
            if filled[r * columns].is_nan() {
                let nearest = *valid_rows
                    .iter()
                    .min_by_key(|&&v| v.abs_diff(r))
                    .expect("a validated grid has a valid sample");
                let (src, dst) = (nearest * columns, r * columns);
                filled.copy_within(src..src + columns, dst);
            }
        }
        let n = side as usize + 1;
        let mut square = vec![0.0f32; n * n];
        for r in 0..n {
            for c in 0..n {
                square[r * n + c] = filled[r.min(rows - 1) * columns + c.min(columns - 1)];
            }
        }
        BinGrid {
            side,
            columns,
            rows,
            origin,
            spacing,
            real,
            square,
        }
    }

    /// Bintree levels below a root down to the finest triangles (legs of one cell): 2·log2(side).
    pub fn finest_level(&self) -> u32 {
        2 * self.side.trailing_zeros()
    }

    /// Height at a sample point of the square (padded, filled).
    pub fn height(&self, p: [i32; 2]) -> f32 {
        let n = self.side as usize + 1;
        self.square[p[1] as usize * n + p[0] as usize]
    }

    /// World position of a sample point (the positions of `HeightGrid::to_mesh`).
    pub fn world(&self, p: [i32; 2]) -> [f64; 3] {
        [
            self.origin[0] + p[0] as f64 * self.spacing[0],
            self.origin[1] + p[1] as f64 * self.spacing[1],
            self.height(p) as f64,
        ]
    }

    /// Whether a sample point is a sample of the real grid.
    pub fn in_grid(&self, p: [i32; 2]) -> bool {
        p[0] >= 0 && p[1] >= 0 && (p[0] as usize) < self.columns && (p[1] as usize) < self.rows
    }

    /// Height of the real grid at a sample (NaN where missing or outside).
    pub fn real_height(&self, p: [i32; 2]) -> f32 {
        if self.in_grid(p) {
            self.real[p[1] as usize * self.columns + p[0] as usize]
        } else {
            f32::NAN
        }
    }

    /// Whether a bintree triangle overlaps the real grid's rectangle (with positive area):
    /// the triangles a baseline draws and counts (`0..columns − 1` × `0..rows − 1`).
    pub fn overlaps_grid(&self, t: &BinTri) -> bool {
        let xs = [t.apex[0], t.left[0], t.right[0]];
        let ys = [t.apex[1], t.left[1], t.right[1]];
        let (x0, x1) = (*xs.iter().min().unwrap(), *xs.iter().max().unwrap());
        let (y0, y1) = (*ys.iter().min().unwrap(), *ys.iter().max().unwrap());
        // By bounding box: conservative only for triangles that clip a corner of the grid.
        x0 < self.columns as i32 - 1 && y0 < self.rows as i32 - 1 && x1 > 0 && y1 > 0
    }

    /// The two root triangles of the square (`roots_of_side`).
    pub fn roots(&self) -> [BinTri; 2] {
        roots_of_side(self.side)
    }

    /// The world box of the real grid's samples.
    #[cfg(test)]
    pub fn world_bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for r in 0..self.rows as i32 {
            for c in 0..self.columns as i32 {
                let p = self.world([c, r]);
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        (lo, hi)
    }
}

/// The two root triangles of a square of `side` cells (hypotenuse on the diagonal
/// (0, 0)–(side, side)).
pub fn roots_of_side(s: i32) -> [BinTri; 2] {
    [
        BinTri {
            apex: [s, 0],
            left: [s, s],
            right: [0, 0],
            id: 2,
        },
        BinTri {
            apex: [0, s],
            left: [0, 0],
            right: [s, s],
            id: 3,
        },
    ]
}

/// A grid of `columns` × `rows` unit-spaced samples, heights `f(row, column)` (tests).
#[cfg(test)]
pub fn test_grid(columns: usize, rows: usize, f: impl Fn(usize, usize) -> f32) -> BinGrid {
    let heights = (0..rows)
        .flat_map(|r| (0..columns).map(move |c| (r, c)))
        .map(|(r, c)| f(r, c))
        .collect();
    BinGrid::new(
        &HeightGrid::unit(columns, rows, heights),
        &TerrainOptions::default(),
    )
}

/// Fills NaNs of a row with the nearest non-NaN value (ties: the left one); an all-NaN row stays.
fn fill_nearest(row: &mut [f32]) {
    let valid: Vec<usize> = (0..row.len()).filter(|&i| !row[i].is_nan()).collect();
    if valid.is_empty() || valid.len() == row.len() {
        return;
    }
    let mut next = 0;
    for i in 0..row.len() {
        while next + 1 < valid.len() && valid[next + 1] <= i {
            next += 1;
        }
        let mut best = valid[next];
        if next + 1 < valid.len() && valid[next + 1].abs_diff(i) < best.abs_diff(i) {
            best = valid[next + 1];
        }
        row[i] = row[best];
    }
}

/// A right isosceles triangle of the bintree: `apex` at the right angle, hypotenuse from `left`
/// to `right`; `corners` gives them counter-clockwise.
/// `id` is the heap index: roots 2 and 3, children of `id` are `2·id` (left) and `2·id + 1`
/// (right); the level below the roots is `63 − leading_zeros(id) − 1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BinTri {
    pub apex: [i32; 2],
    pub left: [i32; 2],
    pub right: [i32; 2],
    pub id: u64,
}

impl BinTri {
    /// Level below the roots (roots: 0).
    pub fn level(&self) -> u32 {
        63 - self.id.leading_zeros() - 1
    }

    /// Midpoint of the hypotenuse: the apex of both children. Integer while the legs are longer
    /// than one cell.
    pub fn split_point(&self) -> [i32; 2] {
        [
            (self.left[0] + self.right[0]) / 2,
            (self.left[1] + self.right[1]) / 2,
        ]
    }

    /// Whether the triangle can split on the lattice (its hypotenuse has an integer midpoint
    /// distinct from its ends).
    pub fn can_split(&self) -> bool {
        let d = [self.right[0] - self.left[0], self.right[1] - self.left[1]];
        d[0].abs() + d[1].abs() >= 2 && d[0] % 2 == 0 && d[1] % 2 == 0
    }

    /// The two children: left child on the `left` end of the hypotenuse, right on the `right`.
    pub fn children(&self) -> [BinTri; 2] {
        let m = self.split_point();
        [
            BinTri {
                apex: m,
                left: self.apex,
                right: self.left,
                id: 2 * self.id,
            },
            BinTri {
                apex: m,
                left: self.right,
                right: self.apex,
                id: 2 * self.id + 1,
            },
        ]
    }

    /// Corners in one orientation for every triangle of the bintree (counter-clockwise in
    /// (column, row) coordinates).
    pub fn corners(&self) -> [[i32; 2]; 3] {
        let c = [self.apex, self.left, self.right];
        let area = (c[1][0] - c[0][0]) as i64 * (c[2][1] - c[0][1]) as i64
            - (c[1][1] - c[0][1]) as i64 * (c[2][0] - c[0][0]) as i64;
        if area >= 0 {
            c
        } else {
            [c[0], c[2], c[1]]
        }
    }
}

/// Vertical error of a triangulation against the full grid, over the real grid's valid samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VerticalError {
    /// Largest |surface − sample height| (world units, metres).
    pub max: f64,
    /// Mean over the covered samples.
    pub mean: f64,
    /// Valid samples some triangle covers (their errors count).
    pub covered: usize,
    /// Valid samples no triangle covers (holes in the triangulation; 0 for a full cover).
    pub uncovered: usize,
}

/// The vertical error of `triangles` (corners in sample coordinates: column, row, world
/// height) against the grid: each valid sample takes the surface height of the first triangle
/// that contains it (on edges every conforming triangulation agrees). Samples are rasterised
/// per triangle over its bounding box, so the cost is the triangles' total area in samples.
pub fn vertical_error(grid: &BinGrid, triangles: &[[[f64; 3]; 3]]) -> VerticalError {
    let (columns, rows) = (grid.columns, grid.rows);
    let mut surface = vec![f32::NAN; columns * rows];
    for t in triangles {
        let [a, b, c] = *t;
        let det = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if det == 0.0 || !det.is_finite() {
            continue;
        }
        let lo = |k: usize| a[k].min(b[k]).min(c[k]);
        let hi = |k: usize| a[k].max(b[k]).max(c[k]);
        let c0 = (lo(0).ceil().max(0.0)) as usize;
        let r0 = (lo(1).ceil().max(0.0)) as usize;
        let c1 = (hi(0).floor()).min(columns as f64 - 1.0);
        let r1 = (hi(1).floor()).min(rows as f64 - 1.0);
        if c1 < 0.0 || r1 < 0.0 {
            continue;
        }
        let eps = 1e-9 * det.abs();
        for r in r0..=r1 as usize {
            for col in c0..=c1 as usize {
                let slot = &mut surface[r * columns + col];
                if !slot.is_nan() {
                    continue;
                }
                let (x, y) = (col as f64, r as f64);
                // Barycentric weights of b and c.
                let wb = ((x - a[0]) * (c[1] - a[1]) - (y - a[1]) * (c[0] - a[0])) / det;
                let wc = ((b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0])) / det;
                let wa = 1.0 - wb - wc;
                let e = eps / det.abs();
                if wa >= -e && wb >= -e && wc >= -e {
                    *slot = (wa * a[2] + wb * b[2] + wc * c[2]) as f32;
                }
            }
        }
    }
    let mut out = VerticalError::default();
    let mut sum = 0.0;
    for r in 0..rows {
        for col in 0..columns {
            let h = grid.real[r * columns + col];
            if h.is_nan() {
                continue;
            }
            let s = surface[r * columns + col];
            if s.is_nan() {
                out.uncovered += 1;
            } else {
                let e = (s as f64 - h as f64).abs();
                out.max = out.max.max(e);
                sum += e;
                out.covered += 1;
            }
        }
    }
    out.mean = if out.covered > 0 {
        sum / out.covered as f64
    } else {
        0.0
    };
    out
}

/// A bintree triangle's corners as `vertical_error` takes them.
pub fn sample_triangle(grid: &BinGrid, corners: [[i32; 2]; 3]) -> [[f64; 3]; 3] {
    corners.map(|p| [p[0] as f64, p[1] as f64, grid.height(p) as f64])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leaves(t: BinTri, level: u32, out: &mut Vec<BinTri>) {
        if t.level() == level {
            out.push(t);
        } else {
            for c in t.children() {
                leaves(c, level, out);
            }
        }
    }

    #[test]
    fn the_square_covers_the_grid_and_pads_by_clamping() {
        let g = test_grid(5, 3, |r, c| (10 * r + c) as f32);
        assert_eq!(g.side, 4);
        assert_eq!(g.finest_level(), 4);
        assert_eq!(g.height([4, 2]), 24.0);
        assert_eq!(g.height([4, 4]), 24.0, "padding clamps to the last row");
        assert!(g.real_height([4, 3]).is_nan());
        let g = test_grid(6, 2, |_, c| c as f32);
        assert_eq!(g.side, 8);
        assert_eq!(g.height([7, 1]), 5.0);
    }

    #[test]
    fn children_tile_the_parent_and_the_finest_level_is_one_cell() {
        let g = test_grid(9, 9, |_, _| 0.0);
        let mut all = Vec::new();
        for root in g.roots() {
            leaves(root, g.finest_level(), &mut all);
        }
        assert_eq!(all.len(), 2 * 8 * 8, "two triangles per cell");
        let area2: i64 = all
            .iter()
            .map(|t| {
                let [a, b, c] = t.corners();
                (b[0] - a[0]) as i64 * (c[1] - a[1]) as i64
                    - (b[1] - a[1]) as i64 * (c[0] - a[0]) as i64
            })
            .sum();
        assert_eq!(
            area2,
            2 * 64,
            "corners are counter-clockwise and tile the square"
        );
        assert!(all.iter().all(|t| !t.can_split()));
        assert!(all.iter().all(|t| t.level() == 6));
    }

    #[test]
    fn vertical_error_is_zero_for_the_finest_level_and_exact_for_a_coarse_one() {
        let g = test_grid(9, 9, |r, c| ((r * 7 + c * 3) % 5) as f32);
        let mut fine = Vec::new();
        for root in g.roots() {
            leaves(root, g.finest_level(), &mut fine);
        }
        let tris: Vec<_> = fine
            .iter()
            .map(|t| sample_triangle(&g, t.corners()))
            .collect();
        let e = vertical_error(&g, &tris);
        assert_eq!((e.max, e.uncovered, e.covered), (0.0, 0, 81));
        // A flat grid with one bump: the two roots miss it by its height.
        let g = test_grid(9, 9, |r, c| if (r, c) == (3, 5) { 4.0 } else { 0.0 });
        let tris: Vec<_> = g
            .roots()
            .iter()
            .map(|t| sample_triangle(&g, t.corners()))
            .collect();
        let e = vertical_error(&g, &tris);
        assert_eq!(e.max, 4.0);
        assert!((e.mean - 4.0 / 81.0).abs() < 1e-12);
    }
}
