//! Hierarchy construction (seed 001, section 4): a conforming LEB tetrahedral mesh whose leaves
//! hold the input triangles, each triangle in the leaf that contains its barycentre (rounded to
//! a sixteenth of a lattice unit: `LatticeFrame::location`).
//!
//! - by leaf size (Algorithms 3/4): split any leaf holding more than `max_triangles`; the
//!   conforming mesh forces the parent splits that this needs;
//! - by levels (Algorithm 1): split every leaf down to a fixed level.
//!
//! [`build_hierarchy_bucketed`] builds the same hierarchy out of core, through buckets on disk.

mod barycentres;
mod bucket_store;
mod bucketed;
mod coarse_passes;
mod leaf_lists;
mod location_codec;
mod locator;
mod refine;

pub use barycentres::{BarycentreSource, MeshBarycentres, SpooledBarycentres};
pub use bucketed::{
    build_hierarchy_bucketed, build_hierarchy_bucketed_spooled,
    build_hierarchy_bucketed_with_stats, BucketBudget, BucketStats,
};
pub(crate) use leaf_lists::{decode_corners, encode_corners};
pub use leaf_lists::{LeafCorners, LeafListSpool, LeafListWriter};

use rustc_hash::FxHashMap as HashMap;

use tessera_core::leb::{ConformingMesh, Diamond, DiamondId, Simplex, SimplexKey};

use refine::{refine, Located, LocatedLists};

use crate::frame::LatticeFrame;

/// How deep the hierarchy goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Construction {
    /// Adaptive: split leaves holding more than this many triangles.
    LeafTriangles(usize),
    /// Complete: every leaf at this level.
    Levels(u16),
}

/// The LEB hierarchy over a mesh, before simplification.
pub struct Hierarchy {
    pub frame: LatticeFrame,
    pub mesh: ConformingMesh,
    /// The split diamonds in (level, id) order, so parents before children. The order is
    /// canonical: it does not depend on the order the splits were made in, so a build that
    /// finds the same splits another way (by buckets, out of core) lists them alike, and the
    /// simplifier, which merges a level's diamonds in this order, gives the same bytes.
    /// Only ids and levels are kept: [`Hierarchy::diamond`] makes the rest.
    pub diamonds: Vec<SplitDiamond>,
    /// Input triangle indices held by each leaf (every leaf has an entry, maybe empty).
    pub leaf_triangles: HashMap<SimplexKey, Vec<u32>>,
}

/// A split diamond as the hierarchy keeps it: 16 bytes, where a [`Diamond`] with its
/// simplices, parents and children took about 800 (118 MB for the 148 k diamonds of a
/// 100 M-triangle build). All of them follow from the id ([`Diamond::find`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SplitDiamond {
    pub id: DiamondId,
    pub level: u16,
}

impl SplitDiamond {
    pub fn of(d: &Diamond) -> SplitDiamond {
        SplitDiamond {
            id: d.id,
            level: d.level,
        }
    }
}

impl Hierarchy {
    /// Diamond `i` of [`Self::diamonds`], whole: its simplices, parents and children.
    pub fn diamond(&self, i: usize) -> Diamond {
        let id = self.diamonds[i].id;
        Diamond::find(self.frame.dim, self.frame.bits, id)
            .expect("a split diamond of the hierarchy is in its lattice")
    }

    /// Deepest leaf level.
    pub fn depth(&self) -> u16 {
        self.mesh.leaves().map(|s| s.level()).max().unwrap_or(0)
    }
}

/// Builds the hierarchy. `barycenters` are the triangles' barycentres in lattice coordinates.
pub fn build_hierarchy(
    frame: LatticeFrame,
    barycenters: &[[f64; 3]],
    construction: Construction,
) -> Hierarchy {
    let mut mesh = ConformingMesh::new(frame.dim, frame.bits);
    // Each leaf's triangles, in input order, with their barycentres beside them: partitioning
    // then streams through memory instead of gathering barycentres from all over the input.
    let mut leaf_triangles: LocatedLists =
        mesh.roots().iter().map(|r| (r.key, Vec::new())).collect();
    let roots: Vec<Simplex> = mesh.roots().to_vec();
    for (t, b) in barycenters.iter().enumerate() {
        let root = roots[Simplex::root_index_of(frame.dim, *b) as usize];
        leaf_triangles.get_mut(&root.key).unwrap().push(Located {
            barycenter: *b,
            triangle: t as u32,
        });
    }
    let needs_split = |s: &Simplex, count: usize| match construction {
        Construction::LeafTriangles(max) => count > max,
        Construction::Levels(levels) => s.level() < levels,
    };
    let queue: Vec<Simplex> = roots
        .iter()
        .copied()
        .filter(|r| needs_split(r, leaf_triangles[&r.key].len()))
        .collect();
    let mut diamonds = Vec::new();
    refine(
        &mut mesh,
        &mut leaf_triangles,
        queue,
        &needs_split,
        &mut diamonds,
        &mut |key| unreachable!("every leaf holds a list, {key:?} too"),
    );
    diamonds.sort_unstable_by_key(|d| (d.level, d.id));
    Hierarchy {
        frame,
        mesh,
        diamonds,
        leaf_triangles: leaf_triangles
            .into_iter()
            .map(|(key, list)| (key, list.iter().map(|l| l.triangle).collect()))
            .collect(),
    }
}
