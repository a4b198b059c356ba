//! Point location in a fixed conforming mesh (the bucketed construction's distribution and
//! final assignment): descend prepared bisectors from a start simplex to the leaf holding a
//! point.

use tessera_core::leb::{Bisector, ConformingMesh, Simplex};

/// Point location in a fixed mesh from given starting simplices (the roots, or a bucket's
/// cell): the split simplices below them with their bisectors prepared, and their leaves.
pub(super) struct Locator {
    /// Per start: a node index, or a leaf index with `LEAF` set.
    starts: Vec<u32>,
    nodes: Vec<LocatorNode>,
    pub(super) leaves: Vec<Simplex>,
}

struct LocatorNode {
    bisector: Bisector,
    children: [u32; 2],
}

const LEAF: u32 = 1 << 31;

impl Locator {
    pub(super) fn new(mesh: &ConformingMesh, starts: &[Simplex]) -> Locator {
        let mut locator = Locator {
            starts: Vec::with_capacity(starts.len()),
            nodes: Vec::new(),
            leaves: Vec::new(),
        };
        for s in starts {
            let r = locator.add(mesh, *s);
            locator.starts.push(r);
        }
        locator
    }

    fn add(&mut self, mesh: &ConformingMesh, s: Simplex) -> u32 {
        if mesh.contains_leaf(&s) {
            self.leaves.push(s);
            return (self.leaves.len() - 1) as u32 | LEAF;
        }
        let i = self.nodes.len();
        self.nodes.push(LocatorNode {
            bisector: s.bisector(),
            children: [0, 0],
        });
        let [c0, c1] = s.children();
        let r0 = self.add(mesh, c0);
        let r1 = self.add(mesh, c1);
        self.nodes[i].children = [r0, r1];
        i as u32
    }

    /// The leaf holding `q`, from the roots (starts in root order).
    pub(super) fn locate_root(&self, dim: u8, q: [f64; 3]) -> u32 {
        self.locate_from(Simplex::root_index_of(dim, q) as usize, q)
    }

    pub(super) fn locate_from(&self, start: usize, q: [f64; 3]) -> u32 {
        let mut r = self.starts[start];
        while r & LEAF == 0 {
            let n = &self.nodes[r as usize];
            r = n.children[n.bisector.child_index_of(q)];
        }
        r & !LEAF
    }
}
