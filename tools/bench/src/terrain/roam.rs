//! ROAM (Duchaineau et al. 1997, "ROAMing Terrain: Real-time Optimally Adapting Meshes";
//! seed 002): a bintree triangulation of the padded square, refined and coarsened every frame
//! from the previous frame's by a split queue (leaves, most urgent first) and a merge queue
//! (mergeable diamonds, least urgent first).
//!
//! - `roam/wedgie.rs`: the nested wedgie thickness per bintree triangle;
//! - `roam/view.rs`: the view a frame depends on and the priority (projected thickness);
//! - `roam/bintree.rs`: the triangle pool, neighbour links, forced splits and merges;
//! - this file: the queues and the frame loop.
//!
//! # The frame loop
//! The paper's loop splits the top of the split queue while the mesh is too small, merges the
//! bottom of the merge queue while it is too large, and keeps swapping while the highest split
//! priority exceeds the lowest merge priority. Run literally with forced splits, that loop can
//! cycle (a split drags in forced splits, the overshoot merges something back, the same split
//! is chosen again), and a frame with an unchanged view need not be a fixed point. We keep its
//! queues and its end condition but drive them by a *tolerance* θ carried from frame to frame:
//! the triangulation is always the one whose leaves have priority ≤ θ and whose mergeable
//! diamonds have priority ≥ θ (with monotone priorities there is exactly one such conforming
//! triangulation per θ, up to ties: the closure of {T : p(T) > θ} under forced splits). A frame
//!
//! 1. recomputes the priorities of the current triangulation's leaves and of the triangles
//!    of its mergeable diamonds, and rebuilds both queues (the per-frame cost besides the
//!    edits: linear in the triangulation, nothing per grid sample);
//! 2. restores the invariant at the same θ for the new view: merges the diamonds that fell
//!    below θ, splits the leaves that rose above it (if that overflows the budget by more
//!    than the slack, θ is raised to the current top instead);
//! 3. raises θ to the lowest merge priority, merging, while the mesh has more than
//!    budget + slack triangles;
//! 4. lowers θ to the highest split priority, splitting one triangle at a time, while it has
//!    fewer than the budget.
//!
//! θ only rises in steps 2–3 and only falls in step 4, and each edit is one θ calls for, so
//! nothing is undone and redone within a frame and the frame ends. It ends with the highest
//! split priority ≤ θ ≤ the lowest merge priority (the paper's optimality condition), and a
//! frame with the same view finds nothing to do (frame-to-frame coherence: the edits are those
//! whose priorities crossed θ, plus what the budget asks).
//!
//! # The budget
//! The slack is 2 · `max_level`: one split from the queue splits at most one diamond per level
//! from its own up to the roots (the forced chain), two triangles each, each adding at most one
//! triangle overlapping the grid. So after a frame, `budget ≤ triangle_count ≤ budget +
//! 2 · max_level`, unless no leaf may split any more (every leaf is at `max_level`, flat,
//! unseen or off the grid), in which case the count is below the budget.

mod bintree;
mod view;
mod wedgie;

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::time::Instant;

pub use view::RoamView;
pub use wedgie::WedgieErrors;

use crate::terrain::grid::{BinGrid, BinTri};
use bintree::{Bintree, Changes, NONE};

/// What one `update` did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RoamFrameStats {
    /// Triangles split because the split queue chose them (each also splits its diamond
    /// partner).
    pub splits: usize,
    /// Diamonds merged.
    pub merges: usize,
    /// Coarser diamonds split only to keep the mesh conforming.
    pub forced_splits: usize,
    /// Triangles overlapping the grid after the frame.
    pub triangles: usize,
    /// Wall time of the call.
    pub cpu_ms: f64,
}

/// A ROAM triangulation and its queues, kept from frame to frame.
pub struct Roam {
    tree: Bintree,
    errors: WedgieErrors,
    /// Max-queue of leaves that may split: (priority key, node, node generation).
    splits: BinaryHeap<(u32, u32, u32)>,
    /// Min-queue of mergeable diamonds by canonical node.
    merges: BinaryHeap<Reverse<(u32, u32, u32)>>,
    /// The tolerance, as a priority key: leaves ≤ θ ≤ mergeable diamonds.
    theta: u32,
    changes: Changes,
    /// Frame number, stamping which priorities are current (0: none).
    frame: u32,
}

/// Priorities compare as their bits: they are never negative or NaN.
fn key(p: f32) -> u32 {
    debug_assert!(p >= 0.0);
    p.to_bits()
}

impl Roam {
    /// The triangulation starts as the two roots.
    pub fn new(grid: &BinGrid, errors: WedgieErrors) -> Roam {
        Roam {
            tree: Bintree::new(grid),
            errors,
            splits: BinaryHeap::new(),
            merges: BinaryHeap::new(),
            theta: key(f32::INFINITY),
            changes: Changes::default(),
            frame: 0,
        }
    }

    /// One frame: recompute priorities for `view`, then split/merge from the previous frame's
    /// triangulation until the triangles overlapping the grid number about `budget` (see the
    /// module comment for the bound) and the highest split priority ≤ the lowest merge
    /// priority. `cpu_ms` = wall time of this call.
    pub fn update(&mut self, grid: &BinGrid, view: &RoamView, budget: usize) -> RoamFrameStats {
        let start = Instant::now();
        let mut stats = RoamFrameStats::default();
        // 1. Priorities for this view.
        self.reprioritise(grid, view);
        let cap = budget.saturating_add(self.slack());
        // 2. The same tolerance under the new view.
        self.merge_below(grid, view, self.theta, &mut stats);
        while let Some((k, s)) = self.top_split() {
            if k <= self.theta {
                break;
            }
            if self.tree.count > cap {
                self.theta = k;
                self.merge_below(grid, view, self.theta, &mut stats);
                break;
            }
            self.split(grid, view, s, &mut stats);
        }
        // 3. Too many: coarsen.
        while self.tree.count > cap {
            let Some((k, m)) = self.bottom_merge() else {
                break;
            };
            self.theta = self.theta.max(k);
            self.merge(grid, view, m, &mut stats);
            self.merge_below(grid, view, self.theta, &mut stats);
        }
        // 4. Too few: refine, one queue split at a time.
        while self.tree.count < budget {
            let Some((k, s)) = self.top_split() else {
                break;
            };
            self.theta = k;
            self.split(grid, view, s, &mut stats);
        }
        stats.triangles = self.tree.count;
        stats.cpu_ms = start.elapsed().as_secs_f64() * 1e3;
        stats
    }

    /// The current triangles that overlap the grid (`BinGrid::overlaps_grid`) — what is
    /// drawn; in no particular order.
    pub fn leaves(&self) -> Vec<BinTri> {
        self.tree
            .leaves
            .iter()
            .map(|&n| self.tree.node(n))
            .filter(|n| n.overlaps)
            .map(|n| n.tri)
            .collect()
    }

    #[cfg(test)]
    /// Their number.
    pub fn triangle_count(&self) -> usize {
        self.tree.count
    }

    /// How far one queue split may overshoot the budget (module comment).
    pub fn slack(&self) -> usize {
        2 * self.errors.max_level() as usize
    }

    /// Priorities for the new view, then both queues rebuilt. Only the triangles the queues
    /// can reach next are evaluated now — the leaves and the triangles whose children are
    /// leaves (the mergeable diamonds' among them) — in one pass in pool order, for locality;
    /// any other triangle gets its priority when a merge exposes it (`key_of`).
    fn reprioritise(&mut self, grid: &BinGrid, view: &RoamView) {
        self.frame = self.frame.wrapping_add(1).max(1);
        let mut splits = std::mem::take(&mut self.splits).into_vec();
        splits.clear();
        for n in 0..self.tree.nodes.len() as u32 {
            let node = self.tree.node(n);
            let leaf = node.children == NONE;
            if !(leaf || node.leaf_pair) || !self.tree.alive(n) {
                continue;
            }
            self.key_of(grid, view, n);
            if leaf {
                splits.extend(self.split_entry(grid, view, n));
            }
        }
        self.splits = BinaryHeap::from(splits);
        let mut merges = std::mem::take(&mut self.merges).into_vec();
        merges.clear();
        for i in 0..self.tree.mergeable.len() {
            let c = self.tree.mergeable[i];
            merges.push(self.merge_entry(grid, view, c));
        }
        self.merges = BinaryHeap::from(merges);
    }

    /// The priority key of node `n` in this frame, computed once per frame. Nested wedgies
    /// make priorities monotone down the tree by themselves; other errors are clamped to the
    /// parent's priority, which keeps the queues' invariant (a split never exposes a leaf more
    /// urgent than θ) for any values.
    fn key_of(&mut self, grid: &BinGrid, view: &RoamView, n: u32) -> u32 {
        let node = self.tree.node(n);
        if node.key_frame == self.frame {
            return node.key;
        }
        let parent = node.parent;
        let mut k = key(view::priority(grid, &self.errors, view, &node.tri));
        if !self.errors.nested() && parent != NONE {
            k = k.min(self.key_of(grid, view, parent));
        }
        let node = &mut self.tree.nodes[n as usize];
        node.key = k;
        node.key_frame = self.frame;
        k
    }

    /// A leaf's split-queue entry, if it may split at all.
    fn split_entry(&mut self, grid: &BinGrid, view: &RoamView, n: u32) -> Option<(u32, u32, u32)> {
        let k = self.key_of(grid, view, n);
        let node = self.tree.node(n);
        (k > 0 && node.tri.level() < self.errors.max_level() && node.tri.can_split())
            .then_some((k, n, node.gen))
    }

    /// A mergeable diamond's entry: the more urgent of its triangles.
    fn merge_entry(&mut self, grid: &BinGrid, view: &RoamView, c: u32) -> Reverse<(u32, u32, u32)> {
        let b = self.tree.node(c).base;
        let mut k = self.key_of(grid, view, c);
        if b != NONE {
            k = k.max(self.key_of(grid, view, b));
        }
        Reverse((k, c, self.tree.node(c).gen))
    }

    /// The most urgent leaf, stale entries dropped.
    fn top_split(&mut self) -> Option<(u32, u32)> {
        while let Some(&(k, n, gen)) = self.splits.peek() {
            let node = self.tree.node(n);
            if node.gen == gen && node.children == NONE {
                return Some((k, n));
            }
            self.splits.pop();
        }
        None
    }

    /// The least urgent mergeable diamond, stale entries dropped.
    fn bottom_merge(&mut self) -> Option<(u32, u32)> {
        while let Some(&Reverse((k, c, gen))) = self.merges.peek() {
            if self.tree.node(c).gen == gen && self.tree.is_mergeable(c) {
                return Some((k, c));
            }
            self.merges.pop();
        }
        None
    }

    /// Merges every diamond strictly below `theta`, including those that become mergeable on
    /// the way.
    fn merge_below(&mut self, grid: &BinGrid, view: &RoamView, theta: u32, s: &mut RoamFrameStats) {
        while let Some((k, m)) = self.bottom_merge() {
            if k >= theta {
                break;
            }
            self.merge(grid, view, m, s);
        }
    }

    fn split(&mut self, grid: &BinGrid, view: &RoamView, n: u32, s: &mut RoamFrameStats) {
        self.splits.pop();
        let mut changes = std::mem::take(&mut self.changes);
        changes.clear();
        self.tree.split(grid, n, &mut changes);
        s.splits += 1;
        s.forced_splits += changes.forced;
        self.enqueue(grid, view, &changes);
        self.changes = changes;
    }

    fn merge(&mut self, grid: &BinGrid, view: &RoamView, c: u32, s: &mut RoamFrameStats) {
        self.merges.pop();
        let mut changes = std::mem::take(&mut self.changes);
        changes.clear();
        self.tree.merge(c, &mut changes);
        s.merges += 1;
        self.enqueue(grid, view, &changes);
        self.changes = changes;
    }

    /// The new leaves and diamonds into the queues (priorities of created triangles are
    /// computed on the way, from their parents', which are current: a split only creates
    /// children of the leaves it splits).
    fn enqueue(&mut self, grid: &BinGrid, view: &RoamView, changes: &Changes) {
        for &n in &changes.new_leaves {
            if let Some(e) = self.split_entry(grid, view, n) {
                self.splits.push(e);
            }
        }
        for &c in &changes.new_mergeable {
            if self.tree.is_mergeable(c) {
                let e = self.merge_entry(grid, view, c);
                self.merges.push(e);
            }
        }
    }
}

#[cfg(test)]
mod tests;
