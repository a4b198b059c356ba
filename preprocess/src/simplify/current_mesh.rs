//! The current mesh (DESIGN.md): the input with every processed diamond merged, kept as use
//! counts per vertex and per edge, and merged a whole batch of diamonds at a time.
//!
//! The counts are split into shards by ranges of vertex ids (an edge lives with its smaller
//! endpoint). A merge is a commutative sum of count changes, so every shard applies the changes
//! that fall in its range independently and in parallel, and the final counts do not depend on
//! the order or the number of threads. Welded vertex ids follow the input's order, which scans
//! keep spatially coherent, so one diamond touches few shards, and a shard's table (a few
//! hundred KiB) stays in cache while it applies its share.

use std::collections::hash_map::Entry;

use rayon::prelude::*;
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use crate::mesh::InputMesh;

/// log2 of the vertex ids per shard.
const SHARD_BITS: u32 = 12;

/// An edge by its endpoints' global ids, smaller id in the high half.
pub(super) fn edge_key(a: u32, b: u32) -> u64 {
    ((a.min(b) as u64) << 32) | a.max(b) as u64
}

/// The shard holding vertex `v`.
pub(super) fn vertex_shard(v: u32) -> u32 {
    v >> SHARD_BITS
}

/// The shard holding edge `key` (its smaller endpoint's).
pub(super) fn edge_shard(key: u64) -> u32 {
    vertex_shard((key >> 32) as u32)
}

/// Count changes of one merge, each list sorted by shard (see `vertex_shard`, `edge_shard`).
pub(super) struct CountChanges {
    /// (vertex, change of its use count), non-zero changes only.
    pub vertices: Vec<(u32, i32)>,
    /// (edge key, change of its use count), non-zero changes only.
    pub edges: Vec<(u64, i32)>,
}

impl CountChanges {
    /// Sorts both lists by shard, as `CurrentMesh::merge` needs.
    pub fn sort_by_shard(&mut self) {
        self.vertices
            .sort_unstable_by_key(|&(v, _)| vertex_shard(v));
        self.edges.sort_unstable_by_key(|&(e, _)| edge_shard(e));
    }
}

/// Use counts of the current mesh's vertices and edges, by shard.
pub struct CurrentMesh {
    shards: Vec<Shard>,
    /// Edges with more than two triangles in the input. The build never raises an edge's count
    /// above two (see `simplify_hierarchy`), so only these can have more in the current mesh.
    nonmanifold: HashSet<u64>,
}

/// The counts of shard `i`: of the vertices from `i << SHARD_BITS` on, and of the edges whose
/// smaller endpoint is one of them (absent edges have no triangle).
struct Shard {
    use_count: Vec<u32>,
    edges: HashMap<u64, u32>,
}

impl CurrentMesh {
    /// The input mesh's counts.
    pub fn new(mesh: &InputMesh) -> Self {
        let vertex_count = mesh.positions.len();
        let shard_count = vertex_count.div_ceil(1 << SHARD_BITS).max(1);
        let mut use_count = vec![0u32; vertex_count];
        let mut edge_uses = vec![0usize; shard_count];
        for t in &mesh.triangles {
            for &v in t {
                use_count[v as usize] += 1;
            }
            for (a, b) in triangle_edges(t) {
                edge_uses[vertex_shard(a.min(b)) as usize] += 1;
            }
        }
        // Interior edges have two uses: half the uses is about the number of edges.
        let mut shards: Vec<Shard> = use_count
            .chunks(1 << SHARD_BITS)
            .zip(&edge_uses)
            .map(|(counts, &uses)| Shard {
                use_count: counts.to_vec(),
                edges: HashMap::with_capacity_and_hasher(uses / 2 + 1, Default::default()),
            })
            .collect();
        shards.resize_with(shard_count, || Shard {
            use_count: Vec::new(),
            edges: HashMap::default(),
        });
        for t in &mesh.triangles {
            for (a, b) in triangle_edges(t) {
                let key = edge_key(a, b);
                *shards[edge_shard(key) as usize]
                    .edges
                    .entry(key)
                    .or_default() += 1;
            }
        }
        let nonmanifold = shards
            .iter()
            .flat_map(|s| s.edges.iter().filter(|&(_, &n)| n > 2).map(|(&e, _)| e))
            .collect();
        CurrentMesh {
            shards,
            nonmanifold,
        }
    }

    /// Triangles of the current mesh using vertex `v`.
    #[inline]
    pub(super) fn use_count(&self, v: u32) -> u32 {
        self.shards[vertex_shard(v) as usize].use_count[(v & ((1 << SHARD_BITS) - 1)) as usize]
    }

    /// Triangles of the current mesh using edge `key`.
    #[inline]
    pub(super) fn edge_count(&self, key: u64) -> u32 {
        self.shards[edge_shard(key) as usize]
            .edges
            .get(&key)
            .copied()
            .unwrap_or(0)
    }

    /// Whether edge `key` has more than two triangles in the current mesh.
    #[inline]
    pub(super) fn is_nonmanifold(&self, key: u64) -> bool {
        !self.nonmanifold.is_empty() && self.nonmanifold.contains(&key) && self.edge_count(key) > 2
    }

    /// Whether any edge may have more than two triangles (false: nothing to protect).
    pub(super) fn may_have_nonmanifold(&self) -> bool {
        !self.nonmanifold.is_empty()
    }

    /// Merges a batch of diamonds: adds every change (in parallel, by shard). The result is
    /// the same for any order of the batch.
    pub(super) fn merge<'a>(&mut self, batch: impl Iterator<Item = &'a CountChanges>) {
        // For each shard, the runs of every merge's lists that fall in it.
        let mut runs: Vec<Vec<ShardChanges>> = (0..self.shards.len()).map(|_| Vec::new()).collect();
        let mut changes = 0;
        for merge in batch {
            changes += merge.vertices.len() + merge.edges.len();
            let mut vertices = &merge.vertices[..];
            let mut edges = &merge.edges[..];
            while !vertices.is_empty() || !edges.is_empty() {
                let shard = vertices
                    .first()
                    .map(|&(v, _)| vertex_shard(v))
                    .into_iter()
                    .chain(edges.first().map(|&(e, _)| edge_shard(e)))
                    .min()
                    .expect("a list is non-empty");
                let v = vertices.partition_point(|&(v, _)| vertex_shard(v) == shard);
                let e = edges.partition_point(|&(e, _)| edge_shard(e) == shard);
                runs[shard as usize].push((&vertices[..v], &edges[..e]));
                vertices = &vertices[v..];
                edges = &edges[e..];
            }
        }
        let apply = |(shard, runs): (&mut Shard, Vec<ShardChanges>)| {
            let mask = (1 << SHARD_BITS) - 1;
            for (vertices, edges) in runs {
                for &(v, d) in vertices {
                    let n = &mut shard.use_count[(v & mask) as usize];
                    *n = n.checked_add_signed(d).expect(NEGATIVE);
                }
                for &(e, d) in edges {
                    match shard.edges.entry(e) {
                        Entry::Occupied(mut count) => {
                            let n = count.get().checked_add_signed(d).expect(NEGATIVE);
                            if n == 0 {
                                count.remove();
                            } else {
                                *count.get_mut() = n;
                            }
                        }
                        Entry::Vacant(slot) => {
                            slot.insert(u32::try_from(d).expect(NEGATIVE));
                        }
                    }
                }
            }
        };
        // Small batches (the re-simplified stragglers) are not worth waking the workers for.
        if changes < PARALLEL_MIN_CHANGES {
            self.shards.iter_mut().zip(runs).for_each(apply);
        } else {
            self.shards.par_iter_mut().zip(runs).for_each(apply);
        }
    }
}

/// The part of one merge's changes that falls in one shard: (vertices, edges).
type ShardChanges<'a> = (&'a [(u32, i32)], &'a [(u64, i32)]);

const NEGATIVE: &str = "a merge removed a triangle the current mesh does not have";

/// Batches with fewer count changes are merged on one thread.
const PARALLEL_MIN_CHANGES: usize = 1 << 14;

/// The three edges of a triangle as vertex pairs.
pub(super) fn triangle_edges(t: &[u32; 3]) -> [(u32, u32); 3] {
    [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]
}
