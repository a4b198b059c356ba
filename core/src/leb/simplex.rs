//! LEB simplices on an exact integer lattice: tetrahedra in 3D, right triangles in 2D.
//!
//! We follow Maubach's bisection ("Local bisection refinement for n-simplicial grids generated
//! by reflection", 1995), which for Kuhn simplices is exactly longest-edge bisection and yields
//! conforming meshes. A simplex is an ordered vertex list `(x0, .., xd)` with a tag `k` in 1..=d;
//! its refinement (longest) edge is `x0–xk`, bisected at `z = (x0 + xk) / 2`:
//!
//! ```text
//! child 0 = (x0, x1, .., x(k-1), z, x(k+1), .., xd)   — keeps x0
//! child 1 = (x1, x2, .., xk,     z, x(k+1), .., xd)   — keeps xk
//! tag'    = k - 1, or d when k = 1
//! ```
//!
//! Roots are the Kuhn simplices of the cube `[0, 2^bits]^d`: 6 tetrahedra (2 triangles) around
//! the main diagonal, all with tag d, so the root diamond is that diagonal.
//! The lattice side is a power of two, so every midpoint down to level `d·bits` is an integer:
//! diamonds are identified by that integer midpoint, with no float ties.

use super::plane::LatticePlane;
use super::predicates::{orient2d_exact, orient3d_exact, LatticePoint};

/// The plane that splits a simplex into its two children, prepared for classifying many points.
#[derive(Clone, Copy, Debug)]
pub struct Bisector {
    /// Through z and every vertex but x0 and xk.
    plane: LatticePlane,
    /// Side of x0 (child 0's own vertex).
    side_x0: i32,
}

impl Bisector {
    /// 0 or 1: the child holding `q`, exactly; points on the plane go to child 0.
    #[inline]
    pub fn child_index_of(&self, q: [f64; 3]) -> usize {
        let side = self.plane.side_of_point(q);
        if side == 0 || side == self.side_x0 {
            0
        } else {
            1
        }
    }
}

/// A simplex's facet planes, prepared for many containment tests.
#[derive(Clone, Copy, Debug)]
pub struct PreparedSimplex {
    facets: [Facet; 4],
    count: u8,
}

/// A facet's plane and the side its opposite vertex lies on.
#[derive(Clone, Copy, Debug)]
struct Facet {
    plane: LatticePlane,
    inner_side: i32,
}

impl PreparedSimplex {
    /// Closed containment of an f64 point in lattice coordinates (boundary included), exact.
    #[inline]
    pub fn contains_point(&self, q: [f64; 3]) -> bool {
        self.facets[..self.count as usize].iter().all(|f| {
            let s = f.plane.side_of_point(q);
            s == 0 || s == f.inner_side
        })
    }

    /// Open (strict interior) containment of an f64 point, exact.
    #[inline]
    pub fn strictly_contains_point(&self, q: [f64; 3]) -> bool {
        self.facets[..self.count as usize]
            .iter()
            .all(|f| f.plane.side_of_point(q) == f.inner_side)
    }
}

/// Identity of a simplex inside the hierarchy: its root and the child choices from that root.
/// Bit `i` of `path` is the child taken at level `i + 1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SimplexKey {
    pub root: u8,
    pub level: u16,
    pub path: u128,
}

impl SimplexKey {
    /// The key of this simplex's ancestor at `level` (which must be ≤ self.level).
    pub fn ancestor(self, level: u16) -> SimplexKey {
        debug_assert!(level <= self.level);
        let path = if level == 0 {
            0
        } else {
            self.path & (u128::MAX >> (128 - level as u32))
        };
        SimplexKey {
            root: self.root,
            level,
            path,
        }
    }
}

/// Deepest level a key can address (path is a u128).
pub const MAX_LEVEL: u16 = 127;

/// A simplex of the LEB hierarchy, in Maubach order. Only the first `dim + 1` vertices are used;
/// 2D simplices have z = 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Simplex {
    pub vertices: [LatticePoint; 4],
    pub dim: u8,
    pub tag: u8,
    pub key: SimplexKey,
}

impl Simplex {
    /// The Kuhn roots of the cube `[0, 2^bits]^dim`, in a fixed order (root index = position).
    pub fn roots(dim: u8, bits: u32) -> Vec<Simplex> {
        assert!(dim == 2 || dim == 3, "dimension must be 2 or 3");
        assert!((1..=30).contains(&bits), "lattice bits must be in 1..=30");
        let side = 1i32 << bits;
        let perms: &[[usize; 3]] = if dim == 3 {
            &[
                [0, 1, 2],
                [0, 2, 1],
                [1, 0, 2],
                [1, 2, 0],
                [2, 0, 1],
                [2, 1, 0],
            ]
        } else {
            &[[0, 1, 2], [1, 0, 2]]
        };
        perms
            .iter()
            .enumerate()
            .map(|(root, perm)| {
                let mut vertices = [[0; 3]; 4];
                for i in 1..=dim as usize {
                    vertices[i] = vertices[i - 1];
                    vertices[i][perm[i - 1]] = side;
                }
                Simplex {
                    vertices,
                    dim,
                    tag: dim,
                    key: SimplexKey {
                        root: root as u8,
                        level: 0,
                        path: 0,
                    },
                }
            })
            .collect()
    }

    /// Which root holds point `q` (lattice coordinates): root `π` is `{q[π0] ≥ q[π1] ≥ q[π2]}`;
    /// ties go to the first root in `roots()` order, so every point has exactly one root.
    pub fn root_index_of(dim: u8, q: [f64; 3]) -> u8 {
        if dim == 2 {
            return if q[0] >= q[1] { 0 } else { 1 };
        }
        let perms = [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ];
        perms
            .iter()
            .position(|p| q[p[0]] >= q[p[1]] && q[p[1]] >= q[p[2]])
            .unwrap_or(0) as u8 // NaN only; callers validate points first
    }

    pub fn level(&self) -> u16 {
        self.key.level
    }

    /// The refinement edge `(x0, xk)`.
    pub fn refinement_edge(&self) -> (LatticePoint, LatticePoint) {
        (self.vertices[0], self.vertices[self.tag as usize])
    }

    /// Whether the refinement edge can still be bisected on the lattice (integer midpoint and
    /// the level fits in a key).
    pub fn can_split(&self) -> bool {
        let (a, b) = self.refinement_edge();
        self.key.level < MAX_LEVEL && (0..3).all(|i| (a[i] - b[i]) % 2 == 0)
    }

    /// Midpoint of the refinement edge: the id of the diamond this simplex belongs to.
    pub fn split_point(&self) -> LatticePoint {
        let (a, b) = self.refinement_edge();
        [
            ((a[0] as i64 + b[0] as i64) / 2) as i32,
            ((a[1] as i64 + b[1] as i64) / 2) as i32,
            ((a[2] as i64 + b[2] as i64) / 2) as i32,
        ]
    }

    /// The two children (see the module comment). Panics if `!can_split()`.
    pub fn children(&self) -> [Simplex; 2] {
        assert!(
            self.can_split(),
            "simplex {:?} is at the lattice resolution",
            self.key
        );
        let d = self.dim as usize;
        let k = self.tag as usize;
        let z = self.split_point();
        let x = &self.vertices;
        let mut c0 = [[0; 3]; 4];
        let mut c1 = [[0; 3]; 4];
        for i in 0..=d {
            c0[i] = if i < k {
                x[i]
            } else if i == k {
                z
            } else {
                x[i]
            };
            c1[i] = if i < k {
                x[i + 1]
            } else if i == k {
                z
            } else {
                x[i]
            };
        }
        let tag = if k > 1 { k as u8 - 1 } else { self.dim };
        let level = self.key.level + 1;
        let child = |vertices, bit: u128| Simplex {
            vertices,
            dim: self.dim,
            tag,
            key: SimplexKey {
                root: self.key.root,
                level,
                path: self.key.path | (bit << self.key.level),
            },
        };
        [child(c0, 0), child(c1, 1)]
    }

    /// Which child holds `q`: side of the bisecting plane (through z and every vertex but x0 and
    /// xk). Points on the plane go to child 0 — the fixed tie rule that makes point location
    /// return exactly one leaf. To classify many points, use `bisector()` once.
    pub fn child_index_of(&self, q: [f64; 3]) -> usize {
        self.bisector().child_index_of(q)
    }

    /// The bisecting plane, prepared for classifying many points.
    pub fn bisector(&self) -> Bisector {
        let z = self.split_point();
        let k = self.tag as usize;
        let x = &self.vertices;
        let mut others = [[0; 3]; 2];
        for (m, i) in (1..=self.dim as usize).filter(|&i| i != k).enumerate() {
            others[m] = x[i];
        }
        let plane = LatticePlane::through(self.dim, z, others[0], others[1]);
        Bisector {
            plane,
            side_x0: plane.side_of_lattice_point(x[0]),
        }
    }

    /// The facet planes, prepared for testing many points.
    pub fn prepared(&self) -> PreparedSimplex {
        let n = self.dim as usize + 1;
        let mut facets = [Facet {
            plane: LatticePlane::through(self.dim, [0; 3], [0; 3], [0; 3]),
            inner_side: 0,
        }; 4];
        self.all_facets(|skip, face, opposite| {
            let plane = LatticePlane::through(self.dim, face[0], face[1], face[face.len() - 1]);
            facets[skip] = Facet {
                plane,
                inner_side: plane.side_of_lattice_point(opposite),
            };
            true
        });
        PreparedSimplex {
            facets,
            count: n as u8,
        }
    }

    /// Closed containment of a lattice point (boundary included), exact.
    pub fn contains_lattice_point(&self, p: LatticePoint) -> bool {
        self.all_facets(|_, face, opposite| {
            let s_p = self.orient_exact(face, p);
            let s_o = self.orient_exact(face, opposite);
            s_p == 0 || s_p == s_o
        })
    }

    /// Closed containment of an f64 point in lattice coordinates, exact. To test many points,
    /// use `prepared()` once.
    pub fn contains_point(&self, q: [f64; 3]) -> bool {
        self.prepared().contains_point(q)
    }

    /// Open (strict interior) containment of an f64 point.
    pub fn strictly_contains_point(&self, q: [f64; 3]) -> bool {
        self.prepared().strictly_contains_point(q)
    }

    /// Twice (2D) or six times (3D) the volume, exact.
    pub fn scaled_volume(&self) -> i128 {
        let x = &self.vertices;
        let v = |i: usize, j: usize| x[i][j] as i128 - x[0][j] as i128;
        if self.dim == 2 {
            (v(1, 0) * v(2, 1) - v(1, 1) * v(2, 0)).abs()
        } else {
            let det = v(1, 0) * (v(2, 1) * v(3, 2) - v(2, 2) * v(3, 1))
                - v(1, 1) * (v(2, 0) * v(3, 2) - v(2, 2) * v(3, 0))
                + v(1, 2) * (v(2, 0) * v(3, 1) - v(2, 1) * v(3, 0));
            det.abs()
        }
    }

    /// Whether `p` is one of this simplex's vertices.
    pub fn has_vertex(&self, p: LatticePoint) -> bool {
        self.vertices[..=self.dim as usize].contains(&p)
    }

    /// Calls `test(skipped index, face, opposite vertex)` for each facet in vertex order, until
    /// one returns false; true iff all return true.
    fn all_facets(
        &self,
        mut test: impl FnMut(usize, &[LatticePoint], LatticePoint) -> bool,
    ) -> bool {
        let n = self.dim as usize + 1;
        let mut face = [[0; 3]; 3];
        for skip in 0..n {
            let mut m = 0;
            for i in (0..n).filter(|&i| i != skip) {
                face[m] = self.vertices[i];
                m += 1;
            }
            if !test(skip, &face[..m], self.vertices[skip]) {
                return false;
            }
        }
        true
    }

    fn orient_exact(&self, face: &[LatticePoint], p: LatticePoint) -> i32 {
        if self.dim == 3 {
            orient3d_exact(face[0], face[1], face[2], p)
        } else {
            orient2d_exact(face[0], face[1], p)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roots_tile_the_cube() {
        // scaled_volume is 2·area in 2D and 6·volume in 3D.
        for (dim, cube) in [(2u8, 2i128 * 64 * 64), (3, 6 * 64 * 64 * 64)] {
            let roots = Simplex::roots(dim, 6);
            let total: i128 = roots.iter().map(|r| r.scaled_volume()).sum();
            assert_eq!(total, cube);
            assert!(roots
                .iter()
                .all(|r| r.split_point() == [32, 32, if dim == 3 { 32 } else { 0 }]));
        }
    }

    #[test]
    fn children_halve_the_volume_and_keep_the_key_path() {
        let r = Simplex::roots(3, 4)[3];
        let [a, b] = r.children();
        assert_eq!(a.scaled_volume() + b.scaled_volume(), r.scaled_volume());
        assert_eq!(a.scaled_volume(), b.scaled_volume());
        assert_eq!(b.key.ancestor(0), r.key);
        let [_, bb] = b.children();
        assert_eq!(bb.key.ancestor(1), b.key);
        assert_eq!(bb.key.path, 0b11);
    }

    #[test]
    fn refinement_edge_is_a_longest_edge() {
        let mut stack = Simplex::roots(3, 8);
        while let Some(s) = stack.pop() {
            let (a, b) = s.refinement_edge();
            let len = |p: LatticePoint, q: LatticePoint| {
                (0..3).map(|i| ((p[i] - q[i]) as i64).pow(2)).sum::<i64>()
            };
            let longest = (0..4)
                .flat_map(|i| (i + 1..4).map(move |j| (i, j)))
                .map(|(i, j)| len(s.vertices[i], s.vertices[j]))
                .max()
                .unwrap();
            assert_eq!(len(a, b), longest, "{s:?}");
            if s.level() < 9 {
                stack.extend(s.children());
            }
        }
    }
}
