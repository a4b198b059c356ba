//! The bucketed construction's step 1 (`bucketed.rs`): coarse counting passes that split the
//! mesh until no leaf holds more than a bucket may, each pass counting the triangles of a
//! complete subtree a few levels below every leaf still over the cap.

use std::io;

use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;

use tessera_core::leb::{Bisector, ConformingMesh, Diamond, Simplex, SimplexKey};

use super::barycentres::{BarycentreSource, InOrder};
use super::bucketed::{BucketStats, Criterion};
use super::locator::Locator;
use super::SplitDiamond;
use crate::frame::LatticeFrame;

/// Barycentres a pass descends together, in parallel.
pub(super) const LOCATE_CHUNK: usize = 1 << 16;

/// Deepest histogram below a counted leaf.
const MAX_HISTOGRAM_DEPTH: u32 = 12;

/// Step 1: splits `mesh` until no leaf needs a coarse split. Returns the triangle count, if
/// it made a pass.
pub(super) fn coarse_refine(
    frame: &LatticeFrame,
    source: &(impl BarycentreSource + ?Sized),
    criterion: &Criterion,
    cap: u64,
    mesh: &mut ConformingMesh,
    diamonds: &mut Vec<SplitDiamond>,
    stats: &mut BucketStats,
) -> io::Result<Option<u64>> {
    // An upper bound on every leaf's triangle count (exact once counted).
    let mut bounds: HashMap<SimplexKey, u64> =
        mesh.roots().iter().map(|r| (r.key, u64::MAX)).collect();
    let mut triangles = None;
    // Histogram nodes in all, a few bytes each: well under the bucket's records.
    let node_budget = (cap / 4).max(1 << 14);
    loop {
        let mut active: Vec<Simplex> = mesh
            .leaves()
            .filter(|s| criterion.coarse_split(s, bounds[&s.key], cap))
            .collect();
        if active.is_empty() {
            break;
        }
        active.sort_unstable_by_key(|s| s.key);
        // Depth: enough levels for the bound to fall under the cap if the triangles spread
        // evenly, plus a cycle of shapes for uneven ones; shallower if the nodes would not fit.
        let wanted: Vec<u32> = active
            .iter()
            .map(|s| {
                let ratio = bounds[&s.key] / cap;
                (64 - ratio.leading_zeros() + 3).min(MAX_HISTOGRAM_DEPTH)
            })
            .collect();
        let mut limit = MAX_HISTOGRAM_DEPTH;
        while limit > 1
            && wanted
                .iter()
                .map(|&d| (2u64 << d.min(limit)) - 1)
                .sum::<u64>()
                > node_budget
        {
            limit -= 1;
        }
        let mut histograms: Vec<Histogram> = active
            .iter()
            .zip(&wanted)
            .map(|(s, &d)| Histogram::new(*s, d.min(limit)))
            .collect();
        let locator = Locator::new(mesh, mesh.roots());
        let mut leaf_histogram = vec![u32::MAX; locator.leaves.len()];
        {
            let index: HashMap<SimplexKey, u32> = active
                .iter()
                .enumerate()
                .map(|(i, s)| (s.key, i as u32))
                .collect();
            for (l, s) in locator.leaves.iter().enumerate() {
                if let Some(&h) = index.get(&s.key) {
                    leaf_histogram[l] = h;
                }
            }
        }
        let mut order = InOrder::default();
        // A chunk of barycentres at a time, each descended in parallel to its deepest
        // histogram node; the hits are then counted in order (apart from the histograms,
        // which the descents read), and summed up each histogram once the pass is over.
        let mut hits: Vec<Vec<u64>> = histograms.iter().map(|h| vec![0; h.nodes.len()]).collect();
        let mut chunk: Vec<[f64; 3]> = Vec::with_capacity(LOCATE_CHUNK);
        let mut deepest: Vec<Option<(u32, u32)>> = Vec::new();
        let mut count = |chunk: &mut Vec<[f64; 3]>| {
            chunk
                .par_iter()
                .with_min_len(1 << 10)
                .map(|&q| {
                    let h = leaf_histogram[locator.locate_root(frame.dim, q) as usize];
                    (h != u32::MAX).then(|| (h, histograms[h as usize].deepest(q) as u32))
                })
                .collect_into_vec(&mut deepest);
            for &(h, node) in deepest.iter().flatten() {
                hits[h as usize][node as usize] += 1;
            }
            chunk.clear();
        };
        source.for_each_barycentre(&mut |t, q| {
            if !order.accept(t) {
                return;
            }
            chunk.push(q);
            if chunk.len() == LOCATE_CHUNK {
                count(&mut chunk);
            }
        })?;
        count(&mut chunk);
        for (h, hits) in histograms.iter_mut().zip(hits) {
            h.sum_up(hits);
        }
        triangles = Some(order.finish(triangles)?);
        stats.coarse_passes += 1;

        // Exact counts of every histogram simplex, then the splits, top down.
        let mut exact: HashMap<SimplexKey, u64> = HashMap::default();
        for h in &histograms {
            for n in h.nodes.iter().flatten() {
                exact.insert(n.simplex.key, n.count);
            }
            bounds.insert(h.nodes[0].as_ref().unwrap().simplex.key, h.count());
        }
        for h in &histograms {
            let mut stack = vec![0usize];
            while let Some(i) = stack.pop() {
                let Some(node) = &h.nodes[i] else { continue };
                if !criterion.coarse_split(&node.simplex, node.count, cap) {
                    continue;
                }
                let split = mesh.split(node.simplex.split_point(), &mut |d: &Diamond| {
                    for t in &d.simplices {
                        let bound = bounds.remove(&t.key).expect("every leaf has a bound");
                        for c in t.children() {
                            bounds.insert(c.key, exact.get(&c.key).copied().unwrap_or(bound));
                        }
                    }
                    diamonds.push(SplitDiamond::of(d));
                });
                assert!(split, "a splittable simplex's diamond splits");
                if node.bisector.is_some() {
                    stack.extend([2 * i + 1, 2 * i + 2]);
                }
            }
        }
    }
    Ok(triangles)
}

/// Triangle counts over the complete LEB subtree `depth` levels below a leaf, in heap order
/// (node `i`'s children are `2i + 1` and `2i + 2`; none below a simplex that cannot split).
struct Histogram {
    nodes: Vec<Option<HistogramNode>>,
}

struct HistogramNode {
    simplex: Simplex,
    /// None at the bottom and where the simplex cannot split.
    bisector: Option<Bisector>,
    count: u64,
}

impl Histogram {
    fn new(leaf: Simplex, depth: u32) -> Histogram {
        let len = (2usize << depth) - 1;
        let inner = (1usize << depth) - 1;
        let mut nodes: Vec<Option<HistogramNode>> = Vec::with_capacity(len);
        nodes.push(Some(HistogramNode {
            simplex: leaf,
            bisector: None,
            count: 0,
        }));
        for i in 0..len {
            if 2 * i + 2 >= len {
                break;
            }
            let children = match &mut nodes[i] {
                Some(n) if i < inner && n.simplex.can_split() => {
                    n.bisector = Some(n.simplex.bisector());
                    n.simplex.children().map(Some)
                }
                _ => [None, None],
            };
            for c in children {
                nodes.push(c.map(|simplex| HistogramNode {
                    simplex,
                    bisector: None,
                    count: 0,
                }));
            }
        }
        Histogram { nodes }
    }

    /// The deepest node holding `q`.
    fn deepest(&self, q: [f64; 3]) -> usize {
        let mut i = 0;
        while let Some(HistogramNode {
            bisector: Some(b), ..
        }) = &self.nodes[i]
        {
            i = 2 * i + 1 + b.child_index_of(q);
        }
        i
    }

    /// Sets each node's count from `hits` (each node's count of points it was the deepest
    /// node of): the points in its subtree.
    fn sum_up(&mut self, mut hits: Vec<u64>) {
        for i in (1..self.nodes.len()).rev() {
            hits[(i - 1) / 2] += hits[i];
        }
        for (node, n) in self.nodes.iter_mut().zip(hits) {
            if let Some(node) = node {
                node.count = n;
            }
        }
    }

    fn count(&self) -> u64 {
        self.nodes[0].as_ref().map_or(0, |n| n.count)
    }
}
