//! Diamonds: the sets of simplices that share a refinement edge and must be split together to
//! keep the mesh conforming. A diamond is identified by the (integer) midpoint of that edge.
//!
//! The relations are computed from the lattice alone, with no stored mesh: the simplices of
//! diamond `m` are found by descending the (infinite) LEB hierarchy through every simplex
//! that contains `m`, until `m` is either the split point (collect) or a vertex (stop). The
//! simplex we descended from is the parent; the diamonds of the parents are the diamond's
//! parents, the diamonds of the children are its children (seed 001, table 1: phases 0/1/2 have
//! 6/4/8 simplices, 3/2/4 parents, 6/4/8 children in 3D; 2D: 2, 2, 4).

use std::collections::BTreeSet;

use super::predicates::LatticePoint;
use super::simplex::Simplex;

/// The lattice midpoint of a diamond's split edge (z = 0 in 2D).
pub type DiamondId = LatticePoint;

/// One diamond with its simplices and DAG neighbours, in a deterministic order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diamond {
    pub id: DiamondId,
    pub dim: u8,
    /// Level of every simplex of the diamond (they always agree).
    pub level: u16,
    /// Simplices sharing the split edge, sorted by key.
    pub simplices: Vec<Simplex>,
    /// Diamonds whose split creates this diamond's simplices (empty for the root diamond).
    pub parents: Vec<DiamondId>,
    /// Diamonds of the simplices created by splitting this one.
    pub children: Vec<DiamondId>,
}

impl Diamond {
    /// Phase in the period-`dim` cycle of simplex shapes (3D: 0 = cube diagonal, 6 simplices;
    /// 1 = face diagonal, 4; 2 = axis edge, 8).
    pub fn phase(&self) -> u8 {
        (self.level % self.dim as u16) as u8
    }

    /// Finds diamond `id` in the hierarchy over `[0, 2^bits]^dim`. Returns None when `id` is not
    /// the split point of any simplex (outside the cube or below the lattice resolution).
    pub fn find(dim: u8, bits: u32, id: DiamondId) -> Option<Diamond> {
        let side = 1i64 << bits;
        let inside = (0..dim as usize).all(|i| (0..=side).contains(&(id[i] as i64)));
        if !inside || (dim == 2 && id[2] != 0) {
            return None;
        }
        let mut simplices = Vec::new();
        let mut parents = BTreeSet::new();
        let mut stack: Vec<(Simplex, Option<Simplex>)> = Simplex::roots(dim, bits)
            .into_iter()
            .filter(|r| r.contains_lattice_point(id))
            .map(|r| (r, None))
            .collect();
        while let Some((s, parent)) = stack.pop() {
            if s.split_point() == id && s.can_split() {
                simplices.push(s);
                if let Some(p) = parent {
                    parents.insert(p.split_point());
                }
                continue;
            }
            if s.has_vertex(id) || !s.can_split() {
                continue;
            }
            for c in s.children() {
                if c.contains_lattice_point(id) {
                    stack.push((c, Some(s)));
                }
            }
        }
        if simplices.is_empty() {
            return None;
        }
        simplices.sort_by_key(|s| s.key);
        let level = simplices[0].level();
        debug_assert!(simplices.iter().all(|s| s.level() == level));
        let children: BTreeSet<DiamondId> = simplices
            .iter()
            .filter(|s| s.key.level + 1 < super::simplex::MAX_LEVEL)
            .flat_map(|s| s.children())
            .filter(|c| c.can_split())
            .map(|c| c.split_point())
            .collect();
        Some(Diamond {
            id,
            dim,
            level,
            simplices,
            parents: parents.into_iter().collect(),
            children: children.into_iter().collect(),
        })
    }

    /// The root diamond: the cube's main diagonal.
    pub fn root(dim: u8, bits: u32) -> Diamond {
        let id = Simplex::roots(dim, bits)[0].split_point();
        Diamond::find(dim, bits, id).expect("the cube centre is the root diamond")
    }

    /// True when the split edge is interior to the cube (midpoint strictly inside), so the
    /// diamond has its full set of simplices.
    pub fn is_interior(&self, bits: u32) -> bool {
        let side = 1i32 << bits;
        (0..self.dim as usize).all(|i| self.id[i] > 0 && self.id[i] < side)
    }
}
