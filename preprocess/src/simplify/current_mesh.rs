//! The current mesh (DESIGN.md): the input with every processed diamond merged, kept as use
//! counts per vertex, and merged a whole batch of diamonds at a time.
//!
//! Edge counts are not kept here: the few the build needs (edges between vertices that a
//! diamond shares with the rest of the mesh, whose count another diamond can also change) are
//! counted when asked, by a census of the current mesh's patches (`edge_census.rs`), so memory
//! does not grow with the mesh's edges and the counts need no global table. The one exception
//! is the input's own non-manifold edges (more than two triangles), which are few and whose
//! counts are tracked here, so that every diamond can protect their sheets before simplifying.
//!
//! Connectivity is the vertices' (`mesh.rs`): counts, edges and the lock rule are by vertex id
//! (a wedge's `canonical`), never by wedge, so a texture seam or a crease is an inner edge like
//! any other, and a locked vertex locks all its wedges. The current mesh keeps the wedges'
//! `VertexStarts` for the whole build.
//!
//! The vertex counts are split into shards by ranges of vertex ids. A merge is a commutative
//! sum of count changes, so every shard applies the changes that fall in its range
//! independently and in parallel, and the final counts do not depend on the order or the
//! number of threads. Welded vertex ids follow the input's order, which scans keep spatially
//! coherent, so one diamond touches few shards.

use std::borrow::Cow;
use std::convert::Infallible;

use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;

use super::input_edges::{nonmanifold_edges_within, TriangleChunks, TrianglePasses};
use crate::external::RecordFile;
use crate::mesh::{InputMesh, VertexStarts};

/// Ranges of shards the input's use counts are counted in side by side (`count_uses`).
const USE_COUNT_RANGES: usize = 64;

/// Triangles a pass of `input_edges.rs` reads at a time (12 bytes each).
const EDGE_PASS_TRIANGLES: usize = 1 << 18;

/// Triangles whose corners `count_uses` sorts out at a time (12 bytes each).
const USE_COUNT_CHUNK: usize = 1 << 18;

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

/// Count changes of one merge.
pub(super) struct CountChanges {
    /// (vertex, change of its use count), non-zero changes only, sorted by shard.
    pub vertices: Vec<(u32, i32)>,
    /// (edge key, change of its use count) of the input's non-manifold edges, non-zero only.
    pub tracked_edges: Vec<(u64, i32)>,
}

impl CountChanges {
    /// Sorts the vertex changes by shard, as `CurrentMesh::merge` needs.
    pub fn sort_by_shard(&mut self) {
        self.vertices
            .sort_unstable_by_key(|&(v, _)| vertex_shard(v));
    }
}

/// Use counts of the current mesh's vertices, by shard, and of the input's non-manifold edges.
pub struct CurrentMesh {
    shards: Vec<Shard>,
    /// Current counts of the edges with more than two triangles in the input. The build never
    /// raises an edge's count above two (see `simplify_hierarchy`), so only these can have
    /// more in the current mesh.
    nonmanifold: HashMap<u64, u32>,
    /// Which wedges start a vertex: every count and edge here is by vertex (`canonical`).
    starts: VertexStarts,
}

impl CurrentMesh {
    /// The input mesh's counts.
    pub fn new(mesh: &InputMesh) -> Self {
        let starts = mesh.vertex_starts();
        let nonmanifold = nonmanifold_edges(&mesh.triangles, &starts);
        Self::with_edges(mesh, nonmanifold, starts)
    }

    /// The input mesh's counts, its non-manifold edges found by sorting its edge keys within
    /// `budget` bytes (`input_edges.rs`; temporary files in `temp_dir`): the same counts as
    /// `new`.
    pub fn new_within(
        mesh: &InputMesh,
        budget: usize,
        temp_dir: &std::path::Path,
    ) -> std::io::Result<Self> {
        let starts = mesh.vertex_starts();
        let nonmanifold = nonmanifold_edges_within(
            mesh.positions.len(),
            &InMemory(&mesh.triangles, &starts),
            budget,
            temp_dir,
        )?;
        Ok(Self::with_edges(mesh, nonmanifold, starts))
    }

    /// The counts of a mesh on disk (`new_within`'s, never loading it), whose wedges start
    /// vertices as `starts` says (`StagedMesh::vertex_starts`).
    pub fn from_staged(
        staged: &crate::external::StagedMesh,
        starts: VertexStarts,
        budget: usize,
        temp_dir: &std::path::Path,
    ) -> std::io::Result<Self> {
        let vertex_count = staged.positions.len() as usize;
        let triangles = Staged(&staged.triangles, &starts);
        let nonmanifold = nonmanifold_edges_within(vertex_count, &triangles, budget, temp_dir)?;
        let map = starts.clone();
        let mut current = Self::zeroed(vertex_count, nonmanifold, starts);
        let by_vertex = |t: std::io::Result<[u32; 3]>| t.map(|t| t.map(|w| map.canonical(w)));
        current.count_uses(staged.triangles.read()?.map(by_vertex))?;
        Ok(current)
    }

    fn with_edges(mesh: &InputMesh, nonmanifold: HashMap<u64, u32>, starts: VertexStarts) -> Self {
        // A copy (a bit a wedge, nothing without seams) to map the corners while counting.
        let map = starts.clone();
        let mut current = Self::zeroed(mesh.positions.len(), nonmanifold, starts);
        let triangles = mesh.triangles.iter();
        let Ok(()) = current
            .count_uses(triangles.map(|&t| Ok::<_, Infallible>(t.map(|w| map.canonical(w)))));
        current
    }

    /// Which wedges start a vertex.
    pub fn vertex_starts(&self) -> &VertexStarts {
        &self.starts
    }

    /// The vertex of wedge `w`.
    #[inline]
    pub fn canonical(&self, w: u32) -> u32 {
        self.starts.canonical(w)
    }

    /// Triangles of wedges as triangles of vertices (borrowed as they are without seams).
    pub(super) fn vertex_triangles<'t>(&self, t: Cow<'t, [[u32; 3]]>) -> Cow<'t, [[u32; 3]]> {
        match self.starts.is_identity() {
            true => t,
            false => Cow::Owned(t.iter().map(|&t| self.starts_of(t)).collect()),
        }
    }

    /// A triangle of wedges as a triangle of vertices.
    #[inline]
    pub fn starts_of(&self, t: [u32; 3]) -> [u32; 3] {
        t.map(|w| self.starts.canonical(w))
    }

    /// Adds a use for each corner of `triangles`, a chunk of triangles at a time: the chunk's
    /// corners sorted out by ranges of shards (a counting sort into one buffer), each range
    /// counted on its own, in parallel (a sum: the same counts in any order). Counting corner
    /// by corner jumped all over the counts (25 MB at 50 M vertices): a 100 M-triangle build
    /// spent some 10 s on it. (A buffer a range would keep, once each range has taken a
    /// whole chunk — a grid's triangles name nearby vertices —, a chunk's corners for every
    /// range: 256 MB at a 4097² height field.)
    fn count_uses<E>(
        &mut self,
        triangles: impl Iterator<Item = Result<[u32; 3], E>>,
    ) -> Result<(), E> {
        let per_range = self.shards.len().div_ceil(USE_COUNT_RANGES).max(1);
        let ranges = self.shards.len().div_ceil(per_range);
        let range_of = |v: u32| vertex_shard(v) as usize / per_range;
        let mut corners: Vec<u32> = Vec::with_capacity(3 * USE_COUNT_CHUNK);
        let mut sorted: Vec<u32> = Vec::with_capacity(3 * USE_COUNT_CHUNK);
        let mut triangles = triangles.peekable();
        while triangles.peek().is_some() {
            corners.clear();
            for t in triangles.by_ref().take(USE_COUNT_CHUNK) {
                corners.extend(t?);
            }
            // Where each range's corners start in `sorted`, then the corners put there.
            let mut starts = vec![0usize; ranges + 1];
            for &v in &corners {
                starts[range_of(v) + 1] += 1;
            }
            for r in 0..ranges {
                starts[r + 1] += starts[r];
            }
            let mut next = starts.clone();
            sorted.clear();
            sorted.resize(corners.len(), 0);
            for &v in &corners {
                let r = range_of(v);
                sorted[next[r]] = v;
                next[r] += 1;
            }
            self.shards
                .par_chunks_mut(per_range)
                .zip(starts.par_windows(2))
                .for_each(|(shards, range)| {
                    for &v in &sorted[range[0]..range[1]] {
                        let shard = &mut shards[vertex_shard(v) as usize % per_range];
                        let at = offset(v);
                        shard.set(at, shard.get(at) + 1);
                    }
                });
        }
        Ok(())
    }

    /// Zero counts for `vertex_count` vertices, straight in their shards (never a whole-mesh
    /// array beside them: at 50 M vertices that copy alone was 200 MB).
    fn zeroed(vertex_count: usize, nonmanifold: HashMap<u64, u32>, starts: VertexStarts) -> Self {
        let shards = (0..shard_count(vertex_count))
            .map(|i| Shard::zeroed(shard_len(vertex_count, i)))
            .collect();
        CurrentMesh {
            shards,
            nonmanifold,
            starts,
        }
    }

    /// The counts, for a build's checkpoint (`decode` reads them back).
    pub(crate) fn encode(&self, e: &mut crate::checkpoint::Enc) {
        // Each shard's counts as varints (after `Enc::list`'s own count of shards): a byte a
        // vertex where four were (the counts are written at every level's commit, and two
        // generations of them are on disk while one is committed).
        e.list(&self.shards, |e, shard| {
            (0..shard.len()).for_each(|at| e.varint(shard.get(at) as u64));
        });
        let mut edges: Vec<(u64, u32)> = self.nonmanifold.iter().map(|(&k, &n)| (k, n)).collect();
        edges.sort_unstable();
        e.list(&edges, |e, &(k, n)| {
            e.u64(k);
            e.u32(n);
        });
        e.list(self.starts.words(), |e, &w| e.u64(w));
    }

    /// The counts `encode` wrote for `vertex_count` vertices.
    pub(crate) fn decode(
        d: &mut crate::checkpoint::Dec,
        vertex_count: usize,
    ) -> std::io::Result<Self> {
        let damaged = || std::io::Error::new(std::io::ErrorKind::InvalidData, "use counts");
        let mut i = 0;
        let shards = d.list(0, |d| {
            let mut shard = Shard::zeroed(shard_len(vertex_count, i));
            for at in 0..shard.len() {
                let n = u32::try_from(d.varint()?).map_err(|_| damaged())?;
                shard.set(at, n);
            }
            i += 1;
            Ok(shard)
        })?;
        if shards.len() != shard_count(vertex_count) {
            return Err(damaged());
        }
        let nonmanifold = d
            .list(12, |d| Ok((d.u64()?, d.u32()?)))?
            .into_iter()
            .collect();
        let words = d.list(8, |d| d.u64())?;
        if !words.is_empty() && words.len() != vertex_count.div_ceil(64) {
            return Err(damaged());
        }
        Ok(CurrentMesh {
            shards,
            nonmanifold,
            starts: VertexStarts::from_words(words),
        })
    }

    /// Triangles of the current mesh using vertex `v`.
    #[inline]
    pub(super) fn use_count(&self, v: u32) -> u32 {
        self.shards[vertex_shard(v) as usize].get(offset(v))
    }

    /// Whether `key` is one of the input's non-manifold edges, whose counts are tracked.
    #[inline]
    pub(super) fn is_tracked(&self, key: u64) -> bool {
        !self.nonmanifold.is_empty() && self.nonmanifold.contains_key(&key)
    }

    /// Whether edge `key` has more than two triangles in the current mesh.
    #[inline]
    pub(super) fn is_nonmanifold(&self, key: u64) -> bool {
        self.nonmanifold.get(&key).is_some_and(|&n| n > 2)
    }

    /// Whether any edge may have more than two triangles (false: nothing to protect).
    pub(super) fn may_have_nonmanifold(&self) -> bool {
        !self.nonmanifold.is_empty()
    }

    /// Merges a batch of diamonds: adds every change (in parallel, by shard). The result is
    /// the same for any order of the batch.
    pub(super) fn merge<'a>(&mut self, batch: impl Iterator<Item = &'a CountChanges> + Clone) {
        for merge in batch.clone() {
            for &(e, d) in &merge.tracked_edges {
                let n = self.nonmanifold.get_mut(&e).expect("a tracked edge");
                *n = n.checked_add_signed(d).expect(NEGATIVE);
            }
        }
        // The runs of every merge's list that fall in one shard, by shard and in batch order
        // within a shard (a stable sort). Only the shards touched are visited: a list a shard
        // (12 k of them at 50 M vertices) made every merge cost the whole mesh.
        let mut runs: Vec<(u32, VertexRun)> = Vec::new();
        let mut changes = 0;
        for merge in batch {
            changes += merge.vertices.len();
            let mut vertices = &merge.vertices[..];
            while let Some(&(first, _)) = vertices.first() {
                let shard = vertex_shard(first);
                let n = vertices.partition_point(|&(v, _)| vertex_shard(v) == shard);
                runs.push((shard, &vertices[..n]));
                vertices = &vertices[n..];
            }
        }
        runs.sort_by_key(|&(shard, _)| shard);
        let mut touched: Vec<(&mut Shard, &[(u32, VertexRun)])> = Vec::new();
        let mut rest = &runs[..];
        for (i, shard) in self.shards.iter_mut().enumerate() {
            let Some(&(next, _)) = rest.first() else {
                break;
            };
            if next as usize == i {
                let n = rest.partition_point(|&(s, _)| s == next);
                touched.push((shard, &rest[..n]));
                rest = &rest[n..];
            }
        }
        let apply = |(shard, runs): (&mut Shard, &[(u32, VertexRun)])| {
            for &(v, d) in runs.iter().flat_map(|&(_, run)| run) {
                let at = offset(v);
                shard.set(at, shard.get(at).checked_add_signed(d).expect(NEGATIVE));
            }
        };
        // Small batches (the re-simplified stragglers) are not worth waking the workers for.
        if changes < PARALLEL_MIN_CHANGES {
            touched.into_iter().for_each(apply);
        } else {
            touched.into_par_iter().for_each(apply);
        }
    }
}

/// An input's triangles in memory, as triangles of vertices, passed over a chunk at a time.
struct InMemory<'a>(&'a [[u32; 3]], &'a VertexStarts);

impl InMemory<'_> {
    fn chunk<'c>(&self, c: &'c [[u32; 3]]) -> Cow<'c, [[u32; 3]]> {
        match self.1.is_identity() {
            true => Cow::Borrowed(c),
            false => Cow::Owned(c.iter().map(|t| t.map(|w| self.1.canonical(w))).collect()),
        }
    }
}

impl TrianglePasses for InMemory<'_> {
    fn triangle_count(&self) -> u64 {
        self.0.len() as u64
    }

    fn for_each_chunk(&self, f: &mut dyn FnMut(&[[u32; 3]])) -> std::io::Result<()> {
        self.0
            .chunks(EDGE_PASS_TRIANGLES)
            .for_each(|c| f(&self.chunk(c)));
        Ok(())
    }

    fn chunks(&self) -> std::io::Result<TriangleChunks<'_>> {
        Ok(Box::new(
            self.0
                .chunks(EDGE_PASS_TRIANGLES)
                .map(|c| Ok(self.chunk(c))),
        ))
    }
}

/// The staged triangles, read a chunk at a time, as triangles of vertices.
struct Staged<'a>(&'a RecordFile<[u32; 3]>, &'a VertexStarts);

impl Staged<'_> {
    fn by_vertex(&self, chunk: &mut [[u32; 3]]) {
        if !self.1.is_identity() {
            chunk
                .iter_mut()
                .for_each(|t| *t = t.map(|w| self.1.canonical(w)));
        }
    }
}

impl TrianglePasses for Staged<'_> {
    fn triangle_count(&self) -> u64 {
        self.0.len()
    }

    fn for_each_chunk(&self, f: &mut dyn FnMut(&[[u32; 3]])) -> std::io::Result<()> {
        let (mut reader, mut chunk) = (self.0.read_chunks(EDGE_PASS_TRIANGLES)?, Vec::new());
        while reader.read_into(&mut chunk)? {
            self.by_vertex(&mut chunk);
            f(&chunk);
        }
        Ok(())
    }

    fn chunks(&self) -> std::io::Result<TriangleChunks<'_>> {
        let mut reader = self.0.read_chunks(EDGE_PASS_TRIANGLES)?;
        Ok(Box::new(std::iter::from_fn(move || {
            let mut chunk = Vec::new();
            match reader.read_into(&mut chunk) {
                Ok(true) => {
                    self.by_vertex(&mut chunk);
                    Some(Ok(Cow::Owned(chunk)))
                }
                Ok(false) => None,
                Err(e) => Some(Err(e)),
            }
        })))
    }
}

/// The edges (by vertex) with more than two of `triangles` (wedges), with their counts:
/// every edge key sorted (in parallel) and counted in runs.
fn nonmanifold_edges(triangles: &[[u32; 3]], starts: &VertexStarts) -> HashMap<u64, u32> {
    let mut keys: Vec<u64> = triangles
        .par_iter()
        .flat_map_iter(|t| {
            let t = t.map(|w| starts.canonical(w));
            triangle_edges(&t).map(|(a, b)| edge_key(a, b))
        })
        .collect();
    keys.par_sort_unstable();
    keys.chunk_by(|a, b| a == b)
        .filter(|run| run.len() > 2)
        .map(|run| (run[0], run.len() as u32))
        .collect()
}

/// Shards of `vertex_count` vertices (at least one).
fn shard_count(vertex_count: usize) -> usize {
    vertex_count.div_ceil(1 << SHARD_BITS).max(1)
}

/// Vertices of shard `i`.
fn shard_len(vertex_count: usize, i: usize) -> usize {
    (vertex_count.saturating_sub(i << SHARD_BITS)).min(1 << SHARD_BITS)
}

/// Vertex `v`'s place in its shard.
#[inline]
fn offset(v: u32) -> usize {
    (v & ((1 << SHARD_BITS) - 1)) as usize
}

/// One shard's use counts: four bits a vertex, two vertices a byte (at 50 M vertices 25 MB,
/// not 200; most vertices of a mesh are used by about six triangles), the few counts of
/// [`NIBBLE_ESCAPE`] and more (fans, a coarse level's hubs) beside them.
#[derive(Clone, Debug)]
struct Shard {
    nibbles: Vec<u8>,
    len: usize,
    large: HashMap<u16, u32>,
}

/// The nibble that says a vertex's count is in `Shard::large`.
const NIBBLE_ESCAPE: u8 = 15;

impl Shard {
    fn zeroed(len: usize) -> Shard {
        Shard {
            nibbles: vec![0; len.div_ceil(2)],
            len,
            large: HashMap::default(),
        }
    }

    fn len(&self) -> usize {
        self.len
    }

    /// Vertex `at`'s nibble: the low half of its byte for even `at`.
    #[inline]
    fn nibble(&self, at: usize) -> u8 {
        debug_assert!(at < self.len, "vertex {at} of a shard of {}", self.len);
        (self.nibbles[at / 2] >> (4 * (at % 2))) & 0xf
    }

    #[inline]
    fn set_nibble(&mut self, at: usize, n: u8) {
        let shift = 4 * (at % 2);
        let byte = &mut self.nibbles[at / 2];
        *byte = (*byte & !(0xf << shift)) | (n << shift);
    }

    #[inline]
    fn get(&self, at: usize) -> u32 {
        match self.nibble(at) {
            NIBBLE_ESCAPE => self.large[&(at as u16)],
            n => n as u32,
        }
    }

    #[inline]
    fn set(&mut self, at: usize, n: u32) {
        if n < NIBBLE_ESCAPE as u32 {
            if self.nibble(at) == NIBBLE_ESCAPE {
                self.large.remove(&(at as u16));
            }
            self.set_nibble(at, n as u8);
        } else {
            self.set_nibble(at, NIBBLE_ESCAPE);
            self.large.insert(at as u16, n);
        }
    }
}

/// The part of one merge's vertex changes that falls in one shard.
type VertexRun<'a> = &'a [(u32, i32)];

const NEGATIVE: &str = "a merge removed a triangle the current mesh does not have";

/// Batches with fewer count changes are merged on one thread.
const PARALLEL_MIN_CHANGES: usize = 1 << 14;

/// The three edges of a triangle as vertex pairs.
pub(super) fn triangle_edges(t: &[u32; 3]) -> [(u32, u32); 3] {
    [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]
}

#[cfg(test)]
#[path = "current_mesh_tests.rs"]
mod tests;
