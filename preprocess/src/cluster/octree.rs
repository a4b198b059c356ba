//! The octree over the model's cube (seed 004 section 4.3): a node splits while it holds
//! more than T triangles and its depth is below D; its end nodes hold the triangles. A
//! triangle belongs to the node holding its barycentre, so no triangle is stored twice.
//!
//! The soup is sorted by the Morton key of its barycentres on the 2^21 grid, so every node
//! is a contiguous range of it, and the tree is found in one pass over the sorted keys: a
//! node's count is known when its prefix ends, and it is a leaf exactly when its parent
//! split. Nodes are listed in post-order (children before their parent, siblings in key
//! order): the order the simplification goes bottom-up in, and in which any cut's nodes
//! come in key order.

use super::layout::KEY_BITS;
use super::node::Cube;

/// An octree node.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Node {
    pub depth: u8,
    /// The key's top 3 × depth bits.
    pub prefix: u64,
    /// Its triangles (its subtree's, for an internal node): a range of the sorted soup.
    pub first: u64,
    pub count: u64,
    pub leaf: bool,
    /// Index of the parent (`u32::MAX` for the root).
    pub parent: u32,
    /// 0 for a leaf, else 1 + the largest of its children's.
    pub height: u8,
}

impl Node {
    /// Its cube, relative to the model box's minimum, in a model cube of side `side`.
    pub fn cube(&self, side: f64) -> Cube {
        let cell = super::layout::unmorton(self.prefix << (3 * (KEY_BITS - self.depth as u32)));
        let step = side / (1u64 << KEY_BITS) as f64;
        Cube {
            min: cell.map(|c| c as f64 * step),
            side: side / (1u64 << self.depth) as f64,
        }
    }
}

/// The tree, in post-order, with each node's children.
pub struct Octree {
    pub nodes: Vec<Node>,
    /// Children of node i: `children[child_start[i]..child_start[i + 1]]`.
    pub child_start: Vec<u32>,
    pub children: Vec<u32>,
}

impl Octree {
    pub fn root(&self) -> usize {
        self.nodes.len() - 1
    }

    pub fn children_of(&self, i: usize) -> &[u32] {
        &self.children[self.child_start[i] as usize..self.child_start[i + 1] as usize]
    }

    pub fn leaves(&self) -> usize {
        self.nodes.iter().filter(|n| n.leaf).count()
    }
}

/// Builds the tree from the sorted keys: split while a node holds more than `max_triangles`
/// and is shallower than `max_depth` (at most 21).
pub fn build(
    keys: impl Iterator<Item = std::io::Result<u64>>,
    max_triangles: u64,
    max_depth: u8,
) -> std::io::Result<Octree> {
    let depth = max_depth.min(KEY_BITS as u8) as usize;
    // The open node of each depth: (prefix, first), and the decided subtrees of its closed
    // children, concatenated in post-order.
    let mut open: Vec<(u64, u64)> = vec![(0, 0); depth + 1];
    let mut pending: Vec<Vec<Node>> = vec![Vec::new(); depth + 1];
    let prefix = |key: u64, d: usize| key >> (3 * (KEY_BITS as usize - d));
    let close = |d: usize, end: u64, open: &[(u64, u64)], pending: &mut Vec<Vec<Node>>| {
        let (p, first) = open[d];
        let count = end - first;
        let split = d < depth && count > max_triangles;
        let node = Node {
            depth: d as u8,
            prefix: p,
            first,
            count,
            leaf: !split,
            parent: u32::MAX,
            height: 0,
        };
        let mut subtree = std::mem::take(&mut pending[d]);
        if !split {
            subtree.clear();
        }
        subtree.push(node);
        if d == 0 {
            pending[0] = subtree;
        } else {
            pending[d - 1].append(&mut subtree);
        }
    };
    let mut previous: Option<u64> = None;
    let mut index = 0u64;
    for key in keys {
        let key = key?;
        match previous {
            None => {
                for (d, o) in open.iter_mut().enumerate() {
                    *o = (prefix(key, d), 0);
                }
            }
            Some(p) if p != key => {
                let high = 63 - (p ^ key).leading_zeros() as usize;
                let shallowest = KEY_BITS as usize - high / 3;
                if shallowest <= depth {
                    for d in (shallowest..=depth).rev() {
                        close(d, index, &open, &mut pending);
                    }
                    for (d, o) in open.iter_mut().enumerate().skip(shallowest) {
                        *o = (prefix(key, d), index);
                    }
                }
            }
            _ => {}
        }
        previous = Some(key);
        index += 1;
    }
    if previous.is_none() {
        return Err(std::io::Error::other("the octree of an empty mesh"));
    }
    for d in (0..=depth).rev() {
        close(d, index, &open, &mut pending);
    }
    let nodes = std::mem::take(&mut pending[0]);
    Ok(link(nodes))
}

/// Parents, heights and child lists of a post-order list.
fn link(mut nodes: Vec<Node>) -> Octree {
    let mut stack: Vec<u32> = Vec::new();
    let mut counts = vec![0u32; nodes.len() + 1];
    for i in 0..nodes.len() {
        if !nodes[i].leaf {
            let d = nodes[i].depth;
            let mut height = 0;
            while let Some(&top) = stack.last() {
                if nodes[top as usize].depth != d + 1 {
                    break;
                }
                stack.pop();
                nodes[top as usize].parent = i as u32;
                height = height.max(nodes[top as usize].height + 1);
                counts[i] += 1;
            }
            nodes[i].height = height;
        }
        stack.push(i as u32);
    }
    let mut child_start = vec![0u32; nodes.len() + 1];
    for i in 0..nodes.len() {
        child_start[i + 1] = child_start[i] + counts[i];
    }
    let mut fill = child_start.clone();
    let mut children = vec![0u32; child_start[nodes.len()] as usize];
    for (i, n) in nodes.iter().enumerate() {
        if n.parent != u32::MAX {
            let p = n.parent as usize;
            children[fill[p] as usize] = i as u32;
            fill[p] += 1;
        }
    }
    Octree {
        nodes,
        child_start,
        children,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cluster::layout::morton;

    fn tree(points: &[[u32; 3]], t: u64, d: u8) -> Octree {
        let mut keys: Vec<u64> = points.iter().map(|&p| morton(p)).collect();
        keys.sort_unstable();
        build(keys.into_iter().map(Ok), t, d).unwrap()
    }

    #[test]
    fn nodes_split_while_over_t_and_above_d() {
        // 8 points in the low octant's low octant, one in each other top octant.
        let s = 1 << 18;
        let mut points: Vec<[u32; 3]> = (0..8).map(|i| [i, i, i]).collect();
        for o in 1..8u32 {
            points.push([
                (o & 1) * (1 << 20),
                (o >> 1 & 1) * (1 << 20),
                (o >> 2) * (1 << 20),
            ]);
        }
        points.push([s, s, s]);
        let octree = tree(&points, 4, 21);
        let root = &octree.nodes[octree.root()];
        assert_eq!((root.depth, root.count, root.leaf), (0, 16, false));
        // Every leaf holds at most 4 (or sits at depth 21), the leaves cover all 16, the
        // ranges follow each other in key order.
        let mut next = 0;
        for n in octree.nodes.iter().filter(|n| n.leaf) {
            assert!(n.count <= 4 || n.depth == 21);
            assert_eq!(n.first, next);
            next += n.count;
        }
        assert_eq!(next, 16);
        // The 8 points (i, i, i), i < 8, share the cells of side 8 (depth 18) and split
        // into two cells of side 4 (depth 19) holding 4 each.
        let deepest = octree.nodes.iter().map(|n| n.depth).max().unwrap();
        assert_eq!(deepest, 19);
        // Children lists and parents agree, heights grow upwards.
        for (i, n) in octree.nodes.iter().enumerate() {
            for &c in octree.children_of(i) {
                assert_eq!(octree.nodes[c as usize].parent, i as u32);
                assert!(octree.nodes[c as usize].height < n.height);
                assert!((c as usize) < i, "post-order");
            }
            assert_eq!(n.leaf, octree.children_of(i).is_empty());
        }
        // With D = 1 the root splits into its 8 octants only.
        let shallow = tree(&points, 4, 1);
        assert_eq!(shallow.nodes.len(), 9);
        assert_eq!(shallow.nodes[0].count, 9);
    }

    #[test]
    fn cubes_halve_with_depth() {
        let n = Node {
            depth: 1,
            prefix: 0b111,
            ..Node::default()
        };
        let c = n.cube(2.0);
        assert_eq!(c.min, [1.0, 1.0, 1.0]);
        assert_eq!(c.side, 1.0);
    }
}
