//! Local vertex numbering: a diamond's gathered triangles, or a patch, renumbered `0..n` in
//! order of first use, as meshopt wants them.

use std::cell::RefCell;

use rustc_hash::FxHashMap as HashMap;

/// Largest mesh (in vertices) numbered through the per-thread table below (4 bytes per vertex
/// and worker thread); larger ones use a hash map per call.
const TABLE_MAX_VERTICES: usize = 1 << 24;

thread_local! {
    /// Per worker thread: the local id of every global vertex of the triangles being numbered
    /// (`u32::MAX` for all others between calls). Indexing beats hashing the ids.
    static LOCAL_OF: RefCell<Vec<u32>> = const { RefCell::new(Vec::new()) };
}

/// A triangle list on local vertex ids.
pub(crate) struct LocalMesh {
    /// Three local ids per triangle.
    pub indices: Vec<u32>,
    /// The global id of each local vertex, in order of first use.
    pub global_of: Vec<u32>,
    /// How many triangles use each local vertex.
    pub uses: Vec<u32>,
}

/// Numbers the vertices of `triangles` in order of first use. `table`: the input's vertex
/// count (every global id is below it) to number through a per-thread table of that many
/// entries, or `None` for a hash map per call (under a memory budget, where a table per
/// worker thread would not fit). Either way the same numbering.
pub(crate) fn local_mesh(triangles: &[[u32; 3]], table: Option<usize>) -> LocalMesh {
    let vertex_count = table.unwrap_or(usize::MAX);
    if vertex_count > TABLE_MAX_VERTICES {
        let mut local_of: HashMap<u32, u32> =
            HashMap::with_capacity_and_hasher(triangles.len(), Default::default());
        return number(triangles, |g, next| *local_of.entry(g).or_insert(next));
    }
    LOCAL_OF.with_borrow_mut(|local_of| {
        if local_of.len() < vertex_count {
            local_of.resize(vertex_count, u32::MAX);
        }
        let local = number(triangles, |g, next| {
            let l = &mut local_of[g as usize];
            if *l == u32::MAX {
                *l = next;
            }
            *l
        });
        for &g in &local.global_of {
            local_of[g as usize] = u32::MAX;
        }
        local
    })
}

/// Numbers with `local_id(global, next unused id)`, which returns the vertex's id, assigning
/// the next unused one on first sight.
fn number(triangles: &[[u32; 3]], mut local_id: impl FnMut(u32, u32) -> u32) -> LocalMesh {
    let mut global_of: Vec<u32> = Vec::with_capacity(triangles.len());
    let mut uses: Vec<u32> = Vec::with_capacity(triangles.len());
    let mut indices: Vec<u32> = Vec::with_capacity(triangles.len() * 3);
    for tri in triangles {
        for &g in tri {
            let l = local_id(g, global_of.len() as u32);
            if l as usize == global_of.len() {
                global_of.push(g);
                uses.push(0);
            }
            uses[l as usize] += 1;
            indices.push(l);
        }
    }
    LocalMesh {
        indices,
        global_of,
        uses,
    }
}
