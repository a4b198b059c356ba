//! A conforming LEB mesh: the set of split diamonds (closed under parents) and its leaves.
//!
//! Splitting a simplex means splitting its whole diamond, which first needs every parent
//! diamond split (seed 001, Algorithm 4's recursive forced split). The mesh never holds a
//! hanging vertex: every leaf facet is shared by exactly one other leaf or lies on the cube.

use std::collections::{HashMap, HashSet};

use super::diamond::{Diamond, DiamondId};
use super::simplex::{Simplex, SimplexKey};

#[derive(Clone, Debug)]
pub struct ConformingMesh {
    dim: u8,
    bits: u32,
    roots: Vec<Simplex>,
    split: HashSet<DiamondId>,
    leaves: HashMap<SimplexKey, Simplex>,
}

impl ConformingMesh {
    /// The unrefined mesh: the Kuhn roots of `[0, 2^bits]^dim`.
    pub fn new(dim: u8, bits: u32) -> Self {
        let roots = Simplex::roots(dim, bits);
        let leaves = roots.iter().map(|r| (r.key, *r)).collect();
        ConformingMesh {
            dim,
            bits,
            roots,
            split: HashSet::new(),
            leaves,
        }
    }

    pub fn dim(&self) -> u8 {
        self.dim
    }

    pub fn bits(&self) -> u32 {
        self.bits
    }

    pub fn roots(&self) -> &[Simplex] {
        &self.roots
    }

    pub fn is_split(&self, id: DiamondId) -> bool {
        self.split.contains(&id)
    }

    pub fn split_count(&self) -> usize {
        self.split.len()
    }

    pub fn leaf_count(&self) -> usize {
        self.leaves.len()
    }

    pub fn leaves(&self) -> impl Iterator<Item = &Simplex> {
        self.leaves.values()
    }

    pub fn is_leaf(&self, key: SimplexKey) -> bool {
        self.leaves.contains_key(&key)
    }

    /// Splits diamond `id`, after forcing the splits of its ancestors that it needs.
    /// `on_split` sees every diamond actually split, parents before children, while its
    /// simplices are still leaves (so the caller can move their contents to the children).
    /// Returns false, changing nothing more, when a diamond on the way is below the lattice
    /// resolution.
    pub fn split(&mut self, id: DiamondId, on_split: &mut impl FnMut(&Diamond)) -> bool {
        if self.split.contains(&id) {
            return true;
        }
        let Some(diamond) = Diamond::find(self.dim, self.bits, id) else {
            return false;
        };
        for &parent in &diamond.parents {
            if !self.split(parent, on_split) {
                return false;
            }
        }
        assert!(
            diamond
                .simplices
                .iter()
                .all(|s| self.leaves.contains_key(&s.key)),
            "diamond {id:?}: a simplex is missing although every parent is split"
        );
        on_split(&diamond);
        for s in &diamond.simplices {
            self.leaves.remove(&s.key);
            for c in s.children() {
                self.leaves.insert(c.key, c);
            }
        }
        self.split.insert(id);
        true
    }

    /// The leaf holding `q` (lattice coordinates, inside the cube). Ties on shared facets are
    /// broken by fixed rules (root order, then "on the bisecting plane → child 0"), so every
    /// point has exactly one leaf.
    pub fn locate(&self, q: [f64; 3]) -> Simplex {
        let mut s = self.roots[Simplex::root_index_of(self.dim, q) as usize];
        while !self.leaves.contains_key(&s.key) {
            s = s.children()[s.child_index_of(q)];
        }
        s
    }
}
