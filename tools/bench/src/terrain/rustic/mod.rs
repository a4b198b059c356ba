//! RUSTiC (seed 000): ROAM over pre-built *triangle clusters*, the clusters built by the
//! **adaptive merge** method (seed 000, section 3.3).
//!
//! Every bintree triangle from the roots down to the deepest cluster level `L` owns a cluster:
//! a set of finer bintree triangles tiling it. At run time ROAM triangulates with cluster
//! triangles and every ROAM triangle is replaced by its cluster (`renderer.rs`). The clusters
//! must obey the *edge constraint*: wherever a conforming ROAM triangulation can put two
//! cluster triangles side by side, their clusters subdivide the shared edge identically.
//!
//! Construction, one global conforming triangulation `M_l` of the whole square per cluster
//! level, the cluster of a level-`l` triangle being the part of `M_l` inside it:
//! 1. `M_L` is the uniform triangulation at the finest grid level: with 2^Q ≥ N (Q minimal),
//!    `L = finest − Q`, so every deepest cluster has 2^Q evenly sized triangles and the
//!    deepest clusters together are the full grid.
//! 2. Per *cluster diamond* of level `l` (a level-`l` triangle and its base neighbour, or a
//!    lone triangle on the square's boundary), interior diamonds of `M_l` are merged, smallest
//!    vertical error first (a merge's error is that of the two triangles it creates), until the
//!    cluster diamond holds 2N triangles (N for a half diamond), or no merge is left. A diamond
//!    whose hypotenuse lies on a *cluster diamond edge* — a leg of a level-`l` triangle, see
//!    `Diamond::on_cluster_edge` — is never merged at level `l`.
//! 3. `M_{l−1}` starts as a copy of `M_l` (the clusters keep their sub-triangles, only the
//!    cluster boundaries move: the former legs become interior) and is merged again, up to the
//!    roots.
//!
//! Why this is crack-free: in a conforming triangulation two neighbouring triangles share a
//! whole edge, and either have one level (their clusters come from one conforming `M_l`) or
//! levels `l` and `l + 1`, sharing a leg of the level-`l` triangle. `M_l` is `M_{l+1}` after
//! merges that never remove a vertex from a level-`l` leg (a vertex on such a leg at a level
//! below `l` belongs to a diamond whose hypotenuse lies along it), so both subdivide that edge
//! alike. The crack test below checks this on many random conforming triangulations and
//! checks that the check fails when the cluster edges are not kept.
//!
//! N (`cluster_size`): any N ≥ 1; a power of two makes the deepest clusters exactly N
//! (uniform), otherwise they start at 2^Q and are merged to N like the others. N = 1 is ROAM.
//! Merges remove two triangles (one on the square's boundary), so a cluster diamond ends at
//! 2N or 2N − 1 unless it runs out of merges; in practice the mean per cluster is within one
//! triangle of N below `L` on grids whose levels reach `L + Q`.
//!
//! Memory: the clusters are stored as their sub-triangles' corners, level by level (24 bytes
//! per sub-triangle, about 2 × the grid's triangles in all, since each level holds about N per
//! cluster and the deepest level is the full grid); the build holds one split flag per sample
//! point, a stamp per point and two triangle errors per point.

mod diamond;
mod renderer;
#[cfg(test)]
mod tests;
mod triangle_error;

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use self::diamond::{in_square, Diamond};
use self::triangle_error::TriangleErrors;
use super::grid::{BinGrid, BinTri};
use super::roam::WedgieErrors;

pub use self::renderer::{RusticFrame, RusticRenderer};

/// Triangle clusters for every bintree triangle down to the deepest cluster level.
pub struct Rustic {
    side: i32,
    max_level: u32,
    levels: Vec<ClusterLevel>,
    /// Mean sub-triangles per cluster over clusters whose triangle overlaps the grid.
    mean: f64,
}

/// The clusters of one level, indexed by `id − 2^(level + 1)`.
struct ClusterLevel {
    /// Cluster `i` is `triangles[offsets[i]..offsets[i + 1]]`.
    offsets: Vec<u32>,
    triangles: Vec<[[i32; 2]; 3]>,
    /// Per cluster: max vertical error of its sub-triangles against the real grid.
    errors: Vec<f32>,
    /// Over clusters whose triangle overlaps the grid: how many, and their sub-triangles.
    overlapping: usize,
    overlapping_triangles: usize,
}

impl Rustic {
    /// Clusters of about `cluster_size` triangles (any N ≥ 1; the benchmarks use 16, 32, 64,
    /// 128) for every bintree triangle from the roots down to the deepest cluster level, by
    /// adaptive merge (see the module comment).
    pub fn build(grid: &BinGrid, cluster_size: usize) -> Rustic {
        build_with(grid, cluster_size, true)
    }

    /// The cluster of a bintree triangle at a cluster level (≤ `max_level`): its sub-triangles,
    /// corners in sample coordinates, counter-clockwise like `BinTri::corners`.
    pub fn cluster(&self, t: &BinTri) -> &[[[i32; 2]; 3]] {
        let (level, i) = self.index(t);
        let level = &self.levels[level];
        let (a, b) = (level.offsets[i] as usize, level.offsets[i + 1] as usize);
        &level.triangles[a..b]
    }

    #[cfg(test)]
    /// The max vertical error of a cluster's sub-triangles against the real grid (before
    /// saturation).
    pub fn cluster_error(&self, t: &BinTri) -> f32 {
        let (level, i) = self.index(t);
        self.levels[level].errors[i]
    }

    fn index(&self, t: &BinTri) -> (usize, usize) {
        let level = t.level();
        assert!(
            level <= self.max_level,
            "no clusters below level {} (asked for level {level})",
            self.max_level
        );
        (level as usize, (t.id - (1u64 << (level + 1))) as usize)
    }

    #[cfg(test)]
    /// The deepest cluster level (ROAM over clusters never splits below it).
    pub fn max_level(&self) -> u32 {
        self.max_level
    }

    /// Per-triangle errors for ROAM over clusters: each cluster's max vertical error against
    /// the grid over its region, saturated by `WedgieErrors::from_values`.
    pub fn errors(&self) -> WedgieErrors {
        let mut values = vec![0.0f32; 1usize << (self.max_level + 2)];
        for (l, level) in self.levels.iter().enumerate() {
            let first = 1usize << (l + 1);
            values[first..first + level.errors.len()].copy_from_slice(&level.errors);
        }
        WedgieErrors::from_values(self.max_level, values)
    }

    /// Mean sub-triangles per cluster, over all cluster levels' clusters whose triangle
    /// overlaps the grid (the ones ROAM can draw).
    pub fn mean_cluster_triangles(&self) -> f64 {
        self.mean
    }

    #[cfg(test)]
    /// Mean sub-triangles per cluster at one level, over clusters overlapping the grid.
    pub fn level_mean(&self, level: u32) -> f64 {
        let l = &self.levels[level as usize];
        l.overlapping_triangles as f64 / l.overlapping.max(1) as f64
    }

    /// Bytes the clusters hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        self.levels
            .iter()
            .map(|l| {
                l.offsets.capacity() * 4
                    + l.triangles.capacity() * std::mem::size_of::<[[i32; 2]; 3]>()
                    + l.errors.capacity() * 4
            })
            .sum()
    }

    /// Side of the square the clusters tile.
    pub fn side(&self) -> i32 {
        self.side
    }
}

/// The build; `keep_cluster_edges = false` (tests only) also merges across cluster diamond
/// edges, which breaks the edge constraint — the crack test checks that it notices.
fn build_with(grid: &BinGrid, cluster_size: usize, keep_cluster_edges: bool) -> Rustic {
    assert!(cluster_size >= 1, "clusters need at least one triangle");
    let side = grid.side;
    let finest = grid.finest_level();
    let q = cluster_size.next_power_of_two().trailing_zeros();
    let max_level = finest.saturating_sub(q);
    let errors = TriangleErrors::compute(grid);
    let mut mesh = Mesh::uniform(side);
    let mut levels: Vec<ClusterLevel> = Vec::with_capacity(max_level as usize + 1);
    let mut scratch = MergeScratch::default();
    for level in (0..=max_level).rev() {
        let triangles = level_triangles(grid, level);
        let rules = MergeRules {
            level,
            size: cluster_size,
            keep_cluster_edges,
        };
        let mut kept = 0usize;
        for t in &triangles {
            let (slot, partner) = base_neighbour(side, t);
            if slot == 1 && partner.is_some() {
                continue; // merged with its partner (slot 0)
            }
            kept += mesh.merge_cluster_diamond(&rules, t, partner, &errors, &mut scratch);
        }
        levels.push(extract(grid, &mesh, &errors, &triangles, kept));
    }
    levels.reverse();
    let (clusters, subs) = levels.iter().fold((0, 0), |(c, s), l| {
        (c + l.overlapping, s + l.overlapping_triangles)
    });
    Rustic {
        side,
        max_level,
        levels,
        mean: subs as f64 / clusters.max(1) as f64,
    }
}

/// All bintree triangles of one level, in id order.
fn level_triangles(grid: &BinGrid, level: u32) -> Vec<BinTri> {
    let mut current = grid.roots().to_vec();
    for _ in 0..level {
        current = current.iter().flat_map(|t| t.children()).collect();
    }
    current
}

/// A triangle's slot in its diamond (0: apex lexicographically after the hypotenuse midpoint)
/// and its base neighbour's geometry (id 0: only the corners matter), if inside the square.
fn base_neighbour(side: i32, t: &BinTri) -> (usize, Option<BinTri>) {
    let c = [t.left[0] + t.right[0], t.left[1] + t.right[1]];
    let slot = usize::from((2 * t.apex[0], 2 * t.apex[1]) <= (c[0], c[1]));
    let apex = [c[0] - t.apex[0], c[1] - t.apex[1]];
    let partner = in_square(side, apex).then_some(BinTri {
        apex,
        left: t.right,
        right: t.left,
        id: 0,
    });
    (slot, partner)
}

/// A conforming bintree triangulation of the square: one split flag per diamond (sample
/// point), closed under parents.
struct Mesh {
    side: i32,
    split: Vec<bool>,
    /// Per point, the last cluster diamond that visited it (dedup of shared diamonds).
    stamp: Vec<u32>,
    clock: u32,
}

/// What the merges of one cluster level may do.
struct MergeRules {
    /// The cluster level: diamonds at this level or finer merge.
    level: u32,
    /// Target triangles per cluster.
    size: usize,
    /// Leave the cluster diamond edges alone (false only in the crack test's control).
    keep_cluster_edges: bool,
}

/// Buffers reused from one cluster diamond to the next.
#[derive(Default)]
struct MergeScratch {
    stack: Vec<BinTri>,
    /// Mergeable diamonds, smallest error first: (error bits, point index).
    heap: BinaryHeap<Reverse<(u32, u32)>>,
}

impl Mesh {
    /// Every diamond split: the finest triangulation.
    fn uniform(side: i32) -> Mesh {
        let n = (side + 1) as usize;
        let mut split = vec![true; n * n];
        for c in [[0, 0], [side, 0], [0, side], [side, side]] {
            split[(c[1] * (side + 1) + c[0]) as usize] = false;
        }
        Mesh {
            side,
            split,
            stamp: vec![0; n * n],
            clock: 0,
        }
    }

    fn index(&self, p: [i32; 2]) -> usize {
        (p[1] * (self.side + 1) + p[0]) as usize
    }

    fn is_split(&self, p: [i32; 2]) -> bool {
        self.split[self.index(p)]
    }

    /// Whether a triangle is split in the mesh.
    fn splits(&self, t: &BinTri) -> bool {
        t.can_split() && self.is_split(t.split_point())
    }

    /// Whether a split diamond can merge: none of its children is split.
    fn mergeable(&self, d: &Diamond) -> bool {
        d.children().is_none_or(|kids| {
            kids.iter()
                .all(|&k| !in_square(self.side, k) || !self.is_split(k))
        })
    }

    /// Whether the diamond at `p` may merge at the rules' cluster level: split, at the level
    /// or below, off the cluster diamond edges, and with no split child.
    fn candidate(&self, p: [i32; 2], rules: &MergeRules) -> bool {
        let Some(d) = Diamond::at(self.side, p) else {
            return false;
        };
        self.is_split(p)
            && d.level(self.side) >= rules.level
            && !(rules.keep_cluster_edges && d.on_cluster_edge(rules.level, self.side))
            && self.mergeable(&d)
    }

    /// Merges inside one cluster diamond (`t` and its base neighbour `partner`, both at the
    /// cluster level), smallest error first, until it holds the target size per cluster
    /// triangle or no merge is left. Returns the triangles left.
    ///
    /// Every candidate lies inside the cluster diamond: its triangles are at the cluster level
    /// or finer, so each lies in one cluster triangle, and two of them on either side of a
    /// cluster triangle's leg would have their hypotenuse on it (a cluster diamond edge).
    /// So cluster diamonds merge independently of each other.
    fn merge_cluster_diamond(
        &mut self,
        rules: &MergeRules,
        t: &BinTri,
        partner: Option<BinTri>,
        errors: &TriangleErrors,
        scratch: &mut MergeScratch,
    ) -> usize {
        self.clock += 1;
        let clock = self.clock;
        let target = rules.size * if partner.is_some() { 2 } else { 1 };
        scratch.stack.clear();
        scratch.stack.push(*t);
        scratch.stack.extend(partner);
        scratch.heap.clear();
        let mut count = 0usize;
        while let Some(s) = scratch.stack.pop() {
            if !self.splits(&s) {
                count += 1;
                continue;
            }
            scratch.stack.extend(s.children());
            let p = s.split_point();
            let i = self.index(p);
            if self.stamp[i] != clock {
                self.stamp[i] = clock;
                if self.candidate(p, rules) {
                    scratch
                        .heap
                        .push(Reverse((errors.diamond(p).to_bits(), i as u32)));
                }
            }
        }
        while count > target {
            let Some(Reverse((_, i))) = scratch.heap.pop() else {
                break;
            };
            if !self.split[i as usize] {
                continue; // defensive: each diamond is queued once, when it becomes mergeable
            }
            let n = self.side + 1;
            let p = [i as i32 % n, i as i32 / n];
            let d = Diamond::at(self.side, p).expect("candidates are diamonds");
            self.split[i as usize] = false;
            let apexes = d.apexes();
            // A diamond has two triangles inside the square, or one on its boundary.
            count -= apexes.iter().filter(|&&a| in_square(self.side, a)).count();
            for a in apexes {
                if in_square(self.side, a) && self.candidate(a, rules) {
                    let j = self.index(a) as u32;
                    scratch.heap.push(Reverse((errors.diamond(a).to_bits(), j)));
                }
            }
        }
        count
    }

    /// The leaves of the mesh inside `t`, pushed onto `out`; returns their max error.
    fn leaves(
        &self,
        t: &BinTri,
        errors: &TriangleErrors,
        stack: &mut Vec<BinTri>,
        out: &mut Vec<[[i32; 2]; 3]>,
    ) -> f32 {
        let mut worst = 0.0f32;
        stack.clear();
        stack.push(*t);
        while let Some(s) = stack.pop() {
            if self.splits(&s) {
                stack.extend(s.children());
            } else {
                worst = worst.max(errors.get(&s));
                out.push(s.corners());
            }
        }
        worst
    }
}

/// The clusters of one level from the level's merged mesh.
fn extract(
    grid: &BinGrid,
    mesh: &Mesh,
    errors: &TriangleErrors,
    triangles: &[BinTri],
    total: usize,
) -> ClusterLevel {
    let mut out = ClusterLevel {
        offsets: Vec::with_capacity(triangles.len() + 1),
        triangles: Vec::with_capacity(total),
        errors: Vec::with_capacity(triangles.len()),
        overlapping: 0,
        overlapping_triangles: 0,
    };
    out.offsets.push(0);
    let mut stack = Vec::new();
    for t in triangles {
        let before = out.triangles.len();
        let e = mesh.leaves(t, errors, &mut stack, &mut out.triangles);
        out.errors.push(e);
        let n = out.triangles.len();
        out.offsets
            .push(u32::try_from(n).expect("under 2^32 sub-triangles per level"));
        if grid.overlaps_grid(t) {
            out.overlapping += 1;
            out.overlapping_triangles += n - before;
        }
    }
    out
}
