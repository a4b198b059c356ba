//! The splitting both constructions share: leaves over the criterion are split, with the
//! splits the conforming mesh forces, and each split simplex's triangles partitioned between
//! its children, a wave of splits at a time.
//!
//! A wave makes every queued split on the mesh first (serially: the mesh is shared, and a
//! split forces others), then partitions the triangles of every simplex split in the wave down
//! to the wave's new leaves: the subtrees below the split simplices that held lists are
//! independent, so they are partitioned in parallel. The hierarchy is the same whatever the
//! order the splits are made in (the least conforming refinement that meets the criterion:
//! see `bucketed.rs`), so waves give the same hierarchy as one split at a time.

use rayon::prelude::*;
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use tessera_core::leb::{Bisector, ConformingMesh, Diamond, Simplex, SimplexKey};

use super::SplitDiamond;

/// A triangle in a leaf under construction.
#[derive(Clone, Copy)]
pub(super) struct Located {
    pub(super) barycenter: [f64; 3],
    pub(super) triangle: u32,
}

/// Leaves' triangles under construction, by leaf.
pub(super) type LocatedLists = HashMap<SimplexKey, Vec<Located>>;

/// Splits the leaves in `queue`, and then every leaf `needs_split` says must split, until none
/// is left: `lists` keeps each leaf's triangles (in input order), `diamonds` gets each split
/// diamond. `touched` hears of every simplex split whose triangles are not in `lists` (a
/// bucket's construction holds only its cell's: those are the splits forced outside it).
pub(super) fn refine(
    mesh: &mut ConformingMesh,
    lists: &mut LocatedLists,
    mut queue: Vec<Simplex>,
    needs_split: &(impl Fn(&Simplex, usize) -> bool + Sync),
    diamonds: &mut Vec<SplitDiamond>,
    touched: &mut dyn FnMut(SimplexKey),
) {
    while !queue.is_empty() {
        // The wave's splits, forced ones included.
        let mut split: Vec<Simplex> = Vec::new();
        for s in queue.drain(..) {
            if !mesh.contains_leaf(&s) || !s.can_split() {
                continue;
            }
            mesh.split(s.split_point(), &mut |d: &Diamond| {
                split.extend(d.simplices.iter().copied());
                diamonds.push(SplitDiamond::of(d));
            });
        }
        // Parents before children: a split simplex holds a list, or its parent was split in
        // this wave and holds one (through its own parent...), or it lies outside `lists`.
        split.sort_unstable_by_key(|s| (s.key.level, s.key));
        let mut inside: HashSet<SimplexKey> = HashSet::default();
        let mut roots: Vec<(Simplex, Vec<Located>)> = Vec::new();
        for s in &split {
            let key = s.key;
            if let Some(list) = lists.remove(&key) {
                roots.push((*s, list));
                inside.insert(key);
            } else if key.level > 0 && inside.contains(&key.ancestor(key.level - 1)) {
                inside.insert(key);
            } else {
                touched(key);
            }
        }
        let leaves: Vec<Vec<(Simplex, Vec<Located>)>> = roots
            .into_par_iter()
            .map(|(s, list)| {
                let mut leaves = Vec::new();
                partition_down(s, list, &inside, &mut leaves);
                leaves
            })
            .collect();
        for (leaf, list) in leaves.into_iter().flatten() {
            if leaf.can_split() && needs_split(&leaf, list.len()) {
                queue.push(leaf);
            }
            lists.insert(leaf.key, list);
        }
    }
}

/// `list` (the triangles of `s`) partitioned down to the leaves below `s` that the wave made:
/// each simplex in `split` hands its triangles to its children.
fn partition_down(
    s: Simplex,
    list: Vec<Located>,
    split: &HashSet<SimplexKey>,
    leaves: &mut Vec<(Simplex, Vec<Located>)>,
) {
    if !split.contains(&s.key) {
        leaves.push((s, list));
        return;
    }
    let parts = partition(list, &s.bisector());
    for (child, part) in s.children().into_iter().zip(parts) {
        partition_down(child, part, split, leaves);
    }
}

/// Splits a leaf's triangles between its children (`bisector`'s tie rule), keeping their order
/// (and allocating each child's list at its size). Long lists take their sides in parallel
/// (the top levels of a construction, where one list holds most triangles).
pub(super) fn partition(triangles: Vec<Located>, bisector: &Bisector) -> [Vec<Located>; 2] {
    let side = |l: &Located| bisector.child_index_of(l.barycenter) as u8;
    let sides: Vec<u8> = if triangles.len() >= PARALLEL_PARTITION {
        triangles
            .par_iter()
            .with_min_len(1 << 12)
            .map(side)
            .collect()
    } else {
        triangles.iter().map(side).collect()
    };
    let ones = sides.iter().map(|&s| s as usize).sum::<usize>();
    let mut parts = [
        Vec::with_capacity(triangles.len() - ones),
        Vec::with_capacity(ones),
    ];
    for (l, side) in triangles.into_iter().zip(sides) {
        parts[side as usize].push(l);
    }
    parts
}

/// Lists at least this long are partitioned in parallel.
const PARALLEL_PARTITION: usize = 1 << 15;
