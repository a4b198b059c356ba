//! A diamond's gathered set by vertex: its local mesh of wedges (what meshopt simplifies and
//! the patches draw) with the wedges of one vertex made one (what connectivity sees: use
//! counts, the lock rule, edge counts, the conformity assertion, flaps). `mesh.rs` says what
//! wedges and vertices are.

use rustc_hash::FxHashMap as HashMap;

use super::CurrentMesh;
use crate::local_mesh::LocalMesh;

/// The vertex view of a local mesh of wedges that has a seam (two wedges of one vertex).
pub(super) struct ByVertex {
    /// The local mesh by vertex: local vertices in order of first use, their global ids the
    /// vertices' (`canonical`), uses summed over their wedges.
    pub mesh: LocalMesh,
    /// The local vertex of each local wedge.
    pub vertex_of: Vec<u32>,
}

impl ByVertex {
    /// The vertex view of `wedges`, or `None` where every wedge is its own vertex (then the
    /// wedges' local mesh is the vertices': the common case, free).
    pub fn of(wedges: &LocalMesh, current: &CurrentMesh) -> Option<ByVertex> {
        // Every wedge its vertex's first: distinct wedges are distinct vertices.
        if current.vertex_starts().is_identity()
            || wedges.global_of.iter().all(|&g| current.canonical(g) == g)
        {
            return None;
        }
        let mut local_of: HashMap<u32, u32> = HashMap::default();
        let mut global_of = Vec::new();
        let mut uses: Vec<u32> = Vec::new();
        let vertex_of: Vec<u32> = wedges
            .global_of
            .iter()
            .zip(&wedges.uses)
            .map(|(&g, &n)| {
                let c = current.canonical(g);
                let next = global_of.len() as u32;
                let l = *local_of.entry(c).or_insert(next);
                if l == next {
                    global_of.push(c);
                    uses.push(0);
                }
                uses[l as usize] += n;
                l
            })
            .collect();
        // Wedges are numbered by first use, so their vertices are too.
        let indices = wedges
            .indices
            .iter()
            .map(|&w| vertex_of[w as usize])
            .collect();
        Some(ByVertex {
            mesh: LocalMesh {
                indices,
                global_of,
                uses,
            },
            vertex_of,
        })
    }

    /// `indices` (local wedges) as local vertices.
    pub fn vertices(&self, indices: &[u32]) -> Vec<u32> {
        indices
            .iter()
            .map(|&w| self.vertex_of[w as usize])
            .collect()
    }

    /// Drops the triangles of `indices` (local wedges) with two corners on one vertex: meshopt
    /// may join two wedges of a vertex in a triangle of zero area. Such a triangle uses its one
    /// real edge twice, so dropping it keeps every edge's parity.
    pub fn drop_degenerate(&self, indices: &mut Vec<u32>) {
        let v = |w: u32| self.vertex_of[w as usize];
        let mut kept = Vec::with_capacity(indices.len());
        for t in indices.chunks_exact(3) {
            if v(t[0]) != v(t[1]) && v(t[1]) != v(t[2]) && v(t[0]) != v(t[2]) {
                kept.extend_from_slice(t);
            }
        }
        *indices = kept;
    }
}
