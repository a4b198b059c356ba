//! Every octree node simplified, bottom-up (seed 004 sections 3.5.3 and 4.4.2): the end
//! nodes from their triangles in the sorted soup, each internal node again from its
//! children's simplified triangles; every node's output appended to one file. A cut of the
//! tree (nodes none of which contains another, covering the model) is a mesh: the seed's
//! level k is the cut of the nodes of height k (or leaves below them); `target_cut` picks a
//! cut of a given size.
//!
//! Memory: the node table (about 60 bytes a node), a batch of end nodes simplified in
//! parallel (bounded by the budget), and the children's outputs of the nodes on the path
//! from the root being worked on (fans: as many triangles as their boundary edges).

use std::collections::BinaryHeap;
use std::io;
use std::path::Path;

use rayon::prelude::*;

use super::layout::Layout;
use super::node::{self, Frame, Outcome};
use super::octree::Octree;
use super::soup::Soup;
use crate::external::staged::RecordWriter;
use crate::external::RecordFile;

/// How the nodes were simplified.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NodeStats {
    pub fanned: u64,
    pub centred: u64,
    pub kept: u64,
    /// Nodes whose boundary was not one simple loop (fanned all the same).
    pub irregular: u64,
}

/// What is done with a simplified node: its output recorded, written, and kept for its
/// parent.
type Finish<'a, L> = dyn FnMut(
        usize,
        node::Simplified<L>,
        &mut Vec<Vec<<L as Layout>::Rec>>,
        &mut RecordWriter<<L as Layout>::Rec>,
    ) -> io::Result<()>
    + 'a;

/// The simplified tree.
pub struct Hierarchy<L: Layout> {
    pub octree: Octree,
    /// Every node's output triangles, in post-order.
    pub outputs: RecordFile<L::Rec>,
    pub out_first: Vec<u64>,
    pub out_count: Vec<u32>,
    /// The quadric error of each node's vertex (0 where kept).
    pub error: Vec<f32>,
    pub stats: NodeStats,
}

/// Simplifies every node of `octree` over `soup`, holding at most about `budget` bytes of
/// end-node triangles at once.
pub fn simplify_all<L: Layout>(
    soup: &Soup<L>,
    octree: Octree,
    budget: usize,
    dir: &Path,
) -> io::Result<Hierarchy<L>> {
    let n = octree.nodes.len();
    if soup.vertices + n as u64 > u32::MAX as u64 {
        return Err(io::Error::other(format!(
            "{} vertices and {n} octree nodes: more than 32-bit vertex ids can name",
            soup.vertices
        )));
    }
    let frame = Frame {
        attributes: soup.attributes,
        min: soup.min,
        extent: soup.extent,
    };
    let record = std::mem::size_of::<L::Rec>();
    let batch_limit = (budget / (3 * record)).max(1 << 12);
    let mut reader = soup.sorted.read()?;
    let mut writer: RecordWriter<L::Rec> = RecordFile::create(dir)?;
    let mut out_first = vec![0u64; n];
    let mut out_count = vec![0u32; n];
    let mut error = vec![0f32; n];
    let mut stats = NodeStats::default();
    // Outputs waiting for their parent, in post-order.
    let mut waiting: Vec<Vec<L::Rec>> = Vec::new();
    // End nodes read but not yet simplified: (node, its triangles).
    let mut batch: Vec<(usize, Vec<L::Rec>)> = Vec::new();
    let mut batched = 0usize;
    let root = octree.root();
    let simplify_one = |i: usize, input: &[L::Rec]| {
        let nd = &octree.nodes[i];
        node::simplify::<L>(
            input,
            nd.cube(soup.extent),
            (soup.vertices + i as u64) as u32,
            i as u64,
            &frame,
        )
    };
    let mut done = |i: usize,
                    s: node::Simplified<L>,
                    waiting: &mut Vec<Vec<L::Rec>>,
                    writer: &mut RecordWriter<L::Rec>|
     -> io::Result<()> {
        out_first[i] = writer.len();
        out_count[i] = s.triangles.len() as u32;
        error[i] = s.error as f32;
        match s.outcome {
            Outcome::Fanned => stats.fanned += 1,
            Outcome::Centred => stats.centred += 1,
            Outcome::Kept => stats.kept += 1,
        }
        stats.irregular += s.irregular as u64;
        writer.push_all(&s.triangles)?;
        if i != root {
            waiting.push(s.triangles);
        }
        Ok(())
    };
    let flush = |batch: &mut Vec<(usize, Vec<L::Rec>)>,
                 waiting: &mut Vec<Vec<L::Rec>>,
                 writer: &mut RecordWriter<L::Rec>,
                 done: &mut Finish<L>|
     -> io::Result<()> {
        let results: Vec<node::Simplified<L>> = batch
            .par_iter()
            .map(|(i, input)| simplify_one(*i, input))
            .collect();
        for ((i, _), s) in batch.drain(..).zip(results) {
            done(i, s, waiting, writer)?;
        }
        Ok(())
    };
    for i in 0..n {
        let nd = octree.nodes[i];
        if nd.leaf {
            let input: Vec<L::Rec> = reader
                .by_ref()
                .take(nd.count as usize)
                .collect::<io::Result<_>>()?;
            if input.len() as u64 != nd.count {
                return Err(io::Error::other("the sorted soup ends early"));
            }
            batched += input.len();
            batch.push((i, input));
            if batched >= batch_limit {
                flush(&mut batch, &mut waiting, &mut writer, &mut done)?;
                batched = 0;
            }
            continue;
        }
        flush(&mut batch, &mut waiting, &mut writer, &mut done)?;
        batched = 0;
        let k = octree.children_of(i).len();
        let input: Vec<L::Rec> = waiting.drain(waiting.len() - k..).flatten().collect();
        let s = simplify_one(i, &input);
        done(i, s, &mut waiting, &mut writer)?;
    }
    flush(&mut batch, &mut waiting, &mut writer, &mut done)?;
    Ok(Hierarchy {
        octree,
        outputs: writer.finish()?,
        out_first,
        out_count,
        error,
        stats,
    })
}

impl<L: Layout> Hierarchy<L> {
    /// Triangles of a cut.
    pub fn triangles(&self, cut: &[u32]) -> u64 {
        cut.iter().map(|&i| self.out_count[i as usize] as u64).sum()
    }

    /// The highest level: the root's height.
    pub fn top_level(&self) -> u8 {
        self.octree.nodes[self.octree.root()].height
    }

    /// The seed's level k: every node of height at most k whose parent's height is above k
    /// (the root where k reaches it), in post-order.
    pub fn level_cut(&self, k: u8) -> Vec<u32> {
        let nodes = &self.octree.nodes;
        (0..nodes.len() as u32)
            .filter(|&i| {
                let n = &nodes[i as usize];
                n.height <= k && (n.parent == u32::MAX || nodes[n.parent as usize].height > k)
            })
            .collect()
    }

    /// A cut of about `target` triangles: from the root, the node of the cut with the largest
    /// quadric error is replaced by its children while the cut has fewer than `target`,
    /// unless that would take the cut past `target` + 10 % (near the root one split can
    /// multiply the count: such a node stays whole and the next is tried). Falls short only
    /// when the end nodes together have too few.
    pub fn target_cut(&self, target: u64) -> Vec<u32> {
        let nodes = &self.octree.nodes;
        let root = self.octree.root();
        let mut in_cut = vec![false; nodes.len()];
        in_cut[root] = true;
        let mut total = self.out_count[root] as u64;
        let ceiling = target + target / 10;
        let mut heap: BinaryHeap<(u32, u32)> = BinaryHeap::new();
        let push = |heap: &mut BinaryHeap<(u32, u32)>, i: usize| {
            if !nodes[i].leaf {
                heap.push((self.error[i].max(0.0).to_bits(), i as u32));
            }
        };
        push(&mut heap, root);
        while total < target {
            let Some((_, i)) = heap.pop() else { break };
            let i = i as usize;
            let children = self.octree.children_of(i);
            let after = total - self.out_count[i] as u64
                + children
                    .iter()
                    .map(|&c| self.out_count[c as usize] as u64)
                    .sum::<u64>();
            if after > ceiling {
                continue;
            }
            in_cut[i] = false;
            total = after;
            for &c in children {
                in_cut[c as usize] = true;
                push(&mut heap, c as usize);
            }
        }
        (0..nodes.len() as u32)
            .filter(|&i| in_cut[i as usize])
            .collect()
    }
}
