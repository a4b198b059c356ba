//! The connectivity of `gen mesh`: a cube whose six faces are n × n grids sharing their edges
//! and corners, two triangles a cell, plus `k` cells whose diagonal is split (four triangles),
//! so that any even triangle count ≥ [`MIN_TRIANGLES`] is met exactly: 12n² + 2k.
//!
//! Every vertex's lattice point and every triangle's vertex indices are pure functions of an
//! index, computed in O(1) with no tables, so a mesh of any size streams in constant memory.
//!
//! Vertices: the 6n² + 2 lattice points on the surface of the cube [0, n]³, numbered layer by
//! layer along z (the full bottom grid, then one ring of 4n points per inner layer, then the
//! full top grid), then one vertex per split cell (the cell's centre). Triangles: 2 per cell,
//! cells numbered face by face (faces −x, +x, −y, +y, −z, +z), then the 2 extra triangles of
//! each split cell. Split cells lie evenly spread in a belt of 4 rows of cells around the
//! middle of the four faces around the z axis: there the density warp (see `surface.rs`)
//! makes triangles 4 times larger than at its densest, so the split cells' half-size
//! triangles never become the smallest ones.
//! Every triangle is counter-clockwise seen from outside; every edge is shared by exactly two
//! triangles (tested), so the surface is closed and 2-manifold, genus 0.
//!
//! Charted (`gen mesh --uv`): each face is a texture chart of its own, so a point on a cube
//! edge is one vertex of each face it lies on (same position, other texture coordinates: the
//! importer welds them into wedges of one vertex). Charted vertices: each face's (n + 1)²
//! grid points, face by face, u-major, then the split cells' centres; the same triangles.

/// Fewest triangles `gen mesh` makes (n = 4: every extra count fits in the belt).
pub const MIN_TRIANGLES: u64 = 192;
/// Rows of cells, around the middle of the faces around the z axis, that hold split cells.
const BELT_ROWS: u64 = 4;
/// Most triangles: vertex indices must fit the PLY's `int` (2^31 − 1).
pub const MAX_TRIANGLES: u64 = 4_000_000_000;

/// A vertex: a lattice point of the cube's surface, or the centre of a split cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CubeVertex {
    /// Integer point of [0, n]³ on the cube's surface.
    Lattice([u64; 3]),
    /// Centre of cell (u, v) of `face`.
    CellCentre { face: u64, u: u64, v: u64 },
}

/// The cube-sphere's connectivity for one triangle count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CubeSphere {
    /// Cells along a face edge.
    pub n: u64,
    /// Cells whose diagonal is split.
    pub splits: u64,
}

impl CubeSphere {
    /// The connectivity with exactly `triangles` triangles (an even number in
    /// [`MIN_TRIANGLES`, `MAX_TRIANGLES`]).
    pub fn with_triangles(triangles: u64) -> Result<CubeSphere, String> {
        if !triangles.is_multiple_of(2) {
            return Err(format!(
                "{triangles} triangles: a closed triangle mesh has an even number"
            ));
        }
        if !(MIN_TRIANGLES..=MAX_TRIANGLES).contains(&triangles) {
            return Err(format!(
                "{triangles} triangles: must be at least {MIN_TRIANGLES} and at most {MAX_TRIANGLES}"
            ));
        }
        let mut n = ((triangles / 12) as f64).sqrt() as u64;
        while 12 * (n + 1) * (n + 1) <= triangles {
            n += 1;
        }
        while 12 * n * n > triangles {
            n -= 1;
        }
        let splits = (triangles - 12 * n * n) / 2;
        // splits ≤ 12n + 5 ≤ 16n, the belt's cells.
        debug_assert!(splits <= BELT_ROWS * 4 * n);
        Ok(CubeSphere { n, splits })
    }

    pub fn vertex_count(&self) -> u64 {
        self.lattice_vertices() + self.splits
    }

    pub fn triangle_count(&self) -> u64 {
        12 * self.n * self.n + 2 * self.splits
    }

    fn lattice_vertices(&self) -> u64 {
        6 * self.n * self.n + 2
    }

    /// Cells where split cells may lie: the belt of [`BELT_ROWS`] rows of cells around the
    /// middle of the four faces around the z axis, 4n cells a row.
    fn belt_cells(&self) -> u64 {
        BELT_ROWS * 4 * self.n
    }

    /// The first row (in z) of the belt.
    fn belt_start(&self) -> u64 {
        (self.n - BELT_ROWS) / 2
    }

    /// (face, u, v) of a cell of face `f` < 4 from its z row and its other coordinate; the
    /// inverse of [`Self::z_row`].
    fn side_cell(&self, f: u64, z: u64, other: u64) -> (u64, u64) {
        // Face frames (see `face_point`): z is u on −x and +y, v on +x and −y.
        match f {
            1 | 2 => (other, z),
            _ => (z, other),
        }
    }

    /// The z row and the other coordinate of cell (u, v) of face `f` < 4.
    fn z_row(&self, f: u64, u: u64, v: u64) -> (u64, u64) {
        match f {
            1 | 2 => (v, u),
            _ => (u, v),
        }
    }

    /// The global cell index of split cell `j`: belt cell ⌊j · belt_cells / splits⌋.
    fn split_cell(&self, j: u64) -> u64 {
        let n = self.n;
        let b = (u128::from(j) * u128::from(self.belt_cells()) / u128::from(self.splits)) as u64;
        let (row, f, other) = (b / (4 * n), b / n % 4, b % n);
        let (u, v) = self.side_cell(f, self.belt_start() + row, other);
        f * n * n + u * n + v
    }

    /// `Some(j)` when cell `c` is split cell `j`.
    fn split_of(&self, c: u64) -> Option<u64> {
        let n = self.n;
        let (f, u, v) = (c / (n * n), c % (n * n) / n, c % n);
        if self.splits == 0 || f >= 4 {
            return None;
        }
        let (z, other) = self.z_row(f, u, v);
        let row = z
            .checked_sub(self.belt_start())
            .filter(|&r| r < BELT_ROWS)?;
        let b = (row * 4 + f) * n + other;
        let e = self.belt_cells();
        // The first j with ⌊j·e/splits⌋ ≥ b is ⌈b·splits/e⌉.
        let j = (u128::from(b) * u128::from(self.splits)).div_ceil(u128::from(e)) as u64;
        (j < self.splits && self.split_cell(j) == c).then_some(j)
    }

    /// The lattice point of face `f` (−x, +x, −y, +y, −z, +z) at grid coordinates (u, v); the
    /// face's (u, v) frame is right-handed around its outward normal.
    pub fn face_point(&self, f: u64, u: u64, v: u64) -> [u64; 3] {
        let a = (f / 2) as usize;
        let high = f % 2 == 1;
        let mut p = [0; 3];
        p[a] = if high { self.n } else { 0 };
        let (pu, pv) = if high { (u, v) } else { (v, u) };
        p[(a + 1) % 3] = pu;
        p[(a + 2) % 3] = pv;
        p
    }

    /// The index of a lattice point on the cube's surface.
    pub fn lattice_index(&self, [x, y, z]: [u64; 3]) -> u64 {
        let n = self.n;
        let full = (n + 1) * (n + 1);
        if z == 0 {
            x * (n + 1) + y
        } else if z == n {
            full + (n - 1) * 4 * n + x * (n + 1) + y
        } else {
            let ring = if y == 0 && x < n {
                x
            } else if x == n && y < n {
                n + y
            } else if y == n && x > 0 {
                3 * n - x
            } else {
                debug_assert!(x == 0 && y > 0, "({x}, {y}, {z}) is inside the cube");
                4 * n - y
            };
            full + (z - 1) * 4 * n + ring
        }
    }

    /// Vertex `i` (see the module docs).
    pub fn vertex(&self, i: u64) -> CubeVertex {
        let n = self.n;
        let full = (n + 1) * (n + 1);
        let rings = (n - 1) * 4 * n;
        if i < full {
            CubeVertex::Lattice([i / (n + 1), i % (n + 1), 0])
        } else if i < full + rings {
            let r = i - full;
            let (z, p) = (1 + r / (4 * n), r % (4 * n));
            let (x, y) = if p < n {
                (p, 0)
            } else if p < 2 * n {
                (n, p - n)
            } else if p < 3 * n {
                (3 * n - p, n)
            } else {
                (0, 4 * n - p)
            };
            CubeVertex::Lattice([x, y, z])
        } else if i < self.lattice_vertices() {
            let r = i - full - rings;
            CubeVertex::Lattice([r / (n + 1), r % (n + 1), n])
        } else {
            let c = self.split_cell(i - self.lattice_vertices());
            let nn = n * n;
            CubeVertex::CellCentre {
                face: c / nn,
                u: c % nn / n,
                v: c % n,
            }
        }
    }

    /// Vertices of the charted numbering (module docs).
    pub fn charted_vertex_count(&self) -> u64 {
        6 * (self.n + 1) * (self.n + 1) + self.splits
    }

    /// Charted vertex `i`: its point, its face and its chart coordinates in [0, 1]² (the
    /// face's u and v over n).
    pub fn charted_vertex(&self, i: u64) -> (CubeVertex, u64, [f64; 2]) {
        let (n, side) = (self.n, self.n + 1);
        let grid = 6 * side * side;
        if i < grid {
            let (f, u, v) = (i / (side * side), i % (side * side) / side, i % side);
            let chart = [u as f64 / n as f64, v as f64 / n as f64];
            return (CubeVertex::Lattice(self.face_point(f, u, v)), f, chart);
        }
        let c = self.split_cell(i - grid);
        let (face, u, v) = (c / (n * n), c % (n * n) / n, c % n);
        let chart = [(u as f64 + 0.5) / n as f64, (v as f64 + 0.5) / n as f64];
        (CubeVertex::CellCentre { face, u, v }, face, chart)
    }

    /// Triangle `t`'s charted vertex indices (the same triangle as [`Self::triangle`]).
    pub fn charted_triangle(&self, t: u64) -> [u64; 3] {
        let side = self.n + 1;
        let grid = 6 * side * side;
        self.triangle_with(t, |f, u, v| f * side * side + u * side + v, |j| grid + j)
    }

    /// Triangle `t`'s vertex indices, counter-clockwise seen from outside.
    pub fn triangle(&self, t: u64) -> [u64; 3] {
        let lattice = self.lattice_vertices();
        self.triangle_with(
            t,
            |f, u, v| self.lattice_index(self.face_point(f, u, v)),
            |j| lattice + j,
        )
    }

    /// Triangle `t` with the index of grid point (u, v) of face f given by `corner` and that
    /// of split cell j's centre by `centre`.
    fn triangle_with(
        &self,
        t: u64,
        corner: impl Fn(u64, u64, u64) -> u64,
        centre: impl Fn(u64) -> u64,
    ) -> [u64; 3] {
        let n = self.n;
        let regular = 12 * n * n;
        let (c, part) = if t < regular {
            (t / 2, t % 2)
        } else {
            let j = (t - regular) / 2;
            (self.split_cell(j), 2 + (t - regular) % 2)
        };
        let (f, u, v) = (c / (n * n), c % (n * n) / n, c % n);
        let corner = |du: u64, dv: u64| corner(f, u + du, v + dv);
        let (p00, p10, p11, p01) = (corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1));
        match self.split_of(c) {
            None => {
                if part == 0 {
                    [p00, p10, p11]
                } else {
                    [p00, p11, p01]
                }
            }
            Some(j) => {
                let m = centre(j);
                match part {
                    0 => [p00, p10, m],
                    1 => [p10, p11, m],
                    2 => [p11, p01, m],
                    _ => [p01, p00, m],
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::{HashMap, HashSet};

    fn counts_to_test() -> Vec<u64> {
        let mut v = vec![192, 194, 250, 300, 12 * 25 - 2, 12 * 25, 1000, 4242];
        v.extend((0..30).map(|i| 12 * 49 + 2 * i));
        v
    }

    #[test]
    fn exact_counts_and_limits() {
        for t in counts_to_test() {
            let c = CubeSphere::with_triangles(t).unwrap();
            assert_eq!(c.triangle_count(), t);
            assert!(c.n >= 4);
        }
        let c = CubeSphere::with_triangles(100_000_000).unwrap();
        assert_eq!((c.n, c.triangle_count()), (2886, 100_000_000));
        let big = CubeSphere::with_triangles(MAX_TRIANGLES).unwrap();
        assert!(big.vertex_count() < i32::MAX as u64);
        assert!(CubeSphere::with_triangles(191).is_err());
        assert!(CubeSphere::with_triangles(190).is_err());
        assert!(CubeSphere::with_triangles(1001).is_err());
        assert!(CubeSphere::with_triangles(MAX_TRIANGLES + 2).is_err());
    }

    /// Vertex numbering: a bijection between indices and surface points / split cells.
    #[test]
    fn vertex_numbering_is_a_bijection() {
        for t in [192, 300, 1000] {
            let c = CubeSphere::with_triangles(t).unwrap();
            let mut seen = HashSet::new();
            for i in 0..c.vertex_count() {
                let v = c.vertex(i);
                assert!(
                    seen.insert(format!("{v:?}")),
                    "{t}: vertex {i} repeats {v:?}"
                );
                if let CubeVertex::Lattice(p) = v {
                    assert!(
                        p.iter().any(|&x| x == 0 || x == c.n),
                        "{p:?} not on the surface"
                    );
                    assert_eq!(c.lattice_index(p), i);
                }
            }
        }
    }

    /// Every directed edge once and its reverse once (closed, 2-manifold, oriented), every
    /// vertex used, no repeated corner, V − E + F = 2.
    #[test]
    fn closed_oriented_manifold_sphere() {
        for t in counts_to_test() {
            let c = CubeSphere::with_triangles(t).unwrap();
            let mut directed = HashMap::new();
            let mut used = HashSet::new();
            for i in 0..c.triangle_count() {
                let [a, b, d] = c.triangle(i);
                assert!(
                    a != b && b != d && d != a,
                    "{t}: triangle {i} repeats a corner"
                );
                for e in [(a, b), (b, d), (d, a)] {
                    assert!(directed.insert(e, i).is_none(), "{t}: edge {e:?} twice");
                }
                used.extend([a, b, d]);
            }
            for &(a, b) in directed.keys() {
                assert!(
                    directed.contains_key(&(b, a)),
                    "{t}: ({a}, {b}) is a border"
                );
            }
            assert_eq!(used.len() as u64, c.vertex_count());
            assert!(used.iter().all(|&v| v < c.vertex_count()));
            let (v, e, f) = (
                c.vertex_count(),
                directed.len() as u64 / 2,
                c.triangle_count(),
            );
            assert_eq!(v + f, e + 2, "{t}: Euler characteristic");
        }
    }
}
