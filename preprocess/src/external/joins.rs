//! What the build needs from a staged mesh without loading it (issue 12): the triangles'
//! barycentres, the simplifier's f32 positions where distinct vertices coincide, and the
//! leaves' patches with the vertices they carry. Each is an external sort joined with the
//! vertex files read in order, and each equals what the in-memory build computes from the
//! loaded mesh (the build gives the same bytes either way: `tools/tests/determinism.rs`).

use std::io;
use std::path::Path;

use rayon::prelude::*;
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};
use tessera_core::leb::SimplexKey;

use super::cursor::{in_passes, Cursor};
use super::fallible::{check, ok_values};
use super::position_file::{PositionBlocks, PositionCursor};
use super::sort::sort_external;
use super::staged::StagedMesh;
use crate::frame::LatticeFrame;
use crate::hierarchy::{BarycentreSource, LeafCorners};
use crate::vertex_table::{LivePatch, VertexTable};

/// The locations of a staged mesh's triangles, as `frame.location` of their corners (the
/// in-memory build's `MeshBarycentres`), a chunk of triangles at a time: the chunk's corners
/// sorted by vertex pick their positions in a pass over the positions file (up to the
/// chunk's largest id; a few passes side by side, each over its own range of vertices). No
/// temporary file; the positions file is read once a chunk (from the page cache, mostly). Costly all the same: read it once (`SpooledBarycentres`). Where the
/// positions file fits the budget it is read whole and indexed instead (no sort).
pub struct JoinedBarycentres<'a> {
    pub staged: &'a StagedMesh,
    pub frame: &'a LatticeFrame,
    /// Bytes a chunk may hold in memory (about 160 a triangle), or the positions read whole.
    pub budget: usize,
}

/// Bytes a triangle of a chunk takes besides its mapped result: its corners (12), their sort
/// keys (24), their positions (72) and places in sorted order (12). The result counts twice
/// (the chunk handed to `f` and the one made meanwhile): 168 bytes with a barycentre.
const JOIN_BYTES_PER_TRIANGLE: usize = 120;

impl BarycentreSource for JoinedBarycentres<'_> {
    fn for_each_barycentre(&self, f: &mut dyn FnMut(u32, [f64; 3])) -> io::Result<()> {
        let join = TriangleCorners {
            staged: self.staged,
            budget: self.budget,
        };
        join.for_each(&|_, corners| self.frame.location(corners), f)
    }
}

/// Each triangle of a staged mesh with its corners' positions, mapped by a function in
/// parallel and handed over in triangle order: positions that fit `budget` are read whole and
/// indexed; otherwise a chunk of triangles at a time, the chunk's corners sorted by vertex
/// pick their positions in a few passes over the positions file side by side (each over its
/// own range of vertices), the next chunk joined by the pool while this one is handed over.
pub struct TriangleCorners<'a> {
    pub staged: &'a StagedMesh,
    /// Bytes a chunk may hold in memory (`JOIN_BYTES_PER_TRIANGLE` a triangle, plus twice a
    /// mapped result), or the positions read whole.
    pub budget: usize,
}

impl TriangleCorners<'_> {
    /// Calls `f(t, map(vertices of t, their positions))` for every triangle `t`, in order.
    pub fn for_each<R: Send>(
        &self,
        map: &(dyn Fn([u32; 3], [[f64; 3]; 3]) -> R + Sync),
        f: &mut dyn FnMut(u32, R),
    ) -> io::Result<()> {
        // Positions that fit the budget are read once and indexed: no sort, one pass.
        if self.staged.positions.bytes() <= self.budget as u64 {
            let positions = self.staged.positions.read_all()?;
            let mut triangles = self.staged.triangles.read()?;
            let mut first = 0u32;
            loop {
                // Computed in parallel a block at a time, handed over in order.
                let part: Vec<[u32; 3]> = triangles
                    .by_ref()
                    .take(1 << 16)
                    .collect::<io::Result<_>>()?;
                if part.is_empty() {
                    return Ok(());
                }
                let at = |v: u32| positions.get(v as usize).copied();
                let mapped: Vec<Option<R>> = part
                    .par_iter()
                    .map(|t| match t.map(at) {
                        [Some(a), Some(b), Some(c)] => Some(map(*t, [a, b, c])),
                        _ => None,
                    })
                    .collect();
                for (i, r) in mapped.into_iter().enumerate() {
                    let t = first + i as u32;
                    let r = r.ok_or_else(|| {
                        io::Error::other(format!(
                            "triangle {t} of a staged mesh names a vertex past its {} positions",
                            positions.len()
                        ))
                    })?;
                    f(t, r);
                }
                first += part.len() as u32;
            }
        }
        let per_triangle = JOIN_BYTES_PER_TRIANGLE + 2 * std::mem::size_of::<R>();
        let chunk = (self.budget / per_triangle).max(1 << 12);
        let mut triangles = self.staged.triangles.read_chunks(chunk)?;
        let mut first = 0u32;
        // Buffers reused from chunk to chunk.
        let mut buffers = JoinBuffers::default();
        let mut produce = || self.join_chunk(&mut triangles, &mut buffers, map);
        let mut current = produce()?;
        while let Some(mapped) = current.take() {
            // The next chunk is joined by the pool while this one goes to `f` (a spool's
            // writes) on this thread.
            let mut next = None;
            rayon::in_place_scope(|scope| {
                scope.spawn(|_| next = Some(produce()));
                for r in mapped {
                    f(first, r);
                    first += 1;
                }
            });
            current = next.expect("the scope ran the join")?;
        }
        Ok(())
    }

    /// The next chunk's mapped triangles: its corners sorted by vertex, their positions read
    /// in a few passes over the positions file side by side (each over its own range of
    /// vertices, in order), then `map` applied, all in parallel.
    fn join_chunk<R: Send>(
        &self,
        triangles: &mut super::chunk_reader::ChunkReader<[u32; 3]>,
        buffers: &mut JoinBuffers,
        map: &(dyn Fn([u32; 3], [[f64; 3]; 3]) -> R + Sync),
    ) -> io::Result<Option<Vec<R>>> {
        let JoinBuffers {
            part,
            corners,
            positions,
            rank,
            blocks,
        } = buffers;
        if !triangles.read_into(part)? {
            return Ok(None);
        }
        // Filled in place: a collecting `par_extend` held the keys twice for a moment, more
        // than `JOIN_BYTES_PER_TRIANGLE` counts.
        corners.clear();
        corners.resize(3 * part.len(), 0);
        corners
            .par_chunks_mut(3)
            .zip(part.par_iter())
            .enumerate()
            .for_each(|(i, (keys, t))| {
                for k in 0..3 {
                    keys[k] = ((t[k] as u64) << 32) | (3 * i + k) as u64;
                }
            });
        corners.par_sort_unstable();
        positions.clear();
        positions.resize(corners.len(), [0.0; 3]);
        in_passes(corners, positions, blocks, |corners, out, blocks| {
            let mut cursor = PositionCursor::reusing(&self.staged.positions, blocks)?;
            for (p, &c) in out.iter_mut().zip(corners) {
                *p = cursor.at((c >> 32) as u32);
            }
            cursor.finish(blocks)
        })?;
        rank.clear();
        rank.resize(corners.len(), 0);
        for (i, &c) in corners.iter().enumerate() {
            rank[c as u32 as usize] = i as u32;
        }
        let mapped = rank
            .par_chunks_exact(3)
            .zip(part.par_iter())
            .with_min_len(1 << 12)
            .map(|(r, t)| {
                let at = |k: usize| positions[r[k] as usize];
                map(*t, [at(0), at(1), at(2)])
            })
            .collect();
        Ok(Some(mapped))
    }
}

/// A chunk join's buffers, kept from chunk to chunk (fresh ones each time cost page faults).
#[derive(Default)]
struct JoinBuffers {
    part: Vec<[u32; 3]>,
    /// (vertex, corner slot in the chunk), sorted.
    corners: Vec<u64>,
    /// The sorted corners' positions.
    positions: Vec<[f64; 3]>,
    /// Each corner slot's place among the sorted corners.
    rank: Vec<u32>,
    /// One per pass over the positions file (`in_passes`).
    blocks: Vec<PositionBlocks>,
}

/// The simplifier's f32 position of each vertex (`f32_of` of its input position) is moved
/// apart where distinct vertices coincide, exactly as `simplify::separate_coincident` does
/// over all positions in memory: returns the moved ones (rare: none in most meshes), by
/// vertex (a wedge takes its vertex's: `starts`, `mesh.rs`).
///
/// One sort by (f32 position, id) finds the duplicates; each walks the same sequence of
/// one-ulp steps as in memory, its first `steps` candidates checked against every position
/// in one more pass (the set of candidates is small); if a duplicate runs out, it starts over
/// with four times the steps.
pub fn coincident_nudges(
    staged: &StagedMesh,
    starts: &crate::mesh::VertexStarts,
    f32_of: &(dyn Fn([f64; 3]) -> [f32; 3] + Sync),
    budget: usize,
    temp_dir: &Path,
) -> io::Result<HashMap<u32, [f32; 3]>> {
    let key = |p: [f32; 3]| p.map(f32::to_bits);
    let mut error = None;
    let records = ok_values(staged.positions.read()?, &mut error)
        .enumerate()
        .filter(|&(v, _)| starts.canonical(v as u32) == v as u32)
        .map(|(v, p)| {
            let [x, y, z] = key(f32_of(p));
            [x, y, z, v as u32]
        });
    let sorted = sort_external(records, budget, temp_dir)?;
    check(error)?;
    let mut duplicates: Vec<(u32, [f32; 3])> = Vec::new();
    let mut previous: Option<[u32; 3]> = None;
    for record in sorted {
        let [x, y, z, v] = record?;
        if previous == Some([x, y, z]) {
            duplicates.push((v, [x, y, z].map(f32::from_bits)));
        }
        previous = Some([x, y, z]);
    }
    if duplicates.is_empty() {
        return Ok(HashMap::default());
    }
    let step = crate::simplify::ulp_step;
    let mut steps = 64;
    loop {
        let mut candidates: HashSet<[u32; 3]> = HashSet::default();
        for &(_, p) in &duplicates {
            let mut p = p;
            for k in 0..steps {
                step(&mut p, k);
                candidates.insert(key(p));
            }
        }
        // Candidates some vertex already has.
        let mut taken: HashSet<[u32; 3]> = HashSet::default();
        for p in staged.positions.read()? {
            let k = key(f32_of(p?));
            if candidates.contains(&k) {
                taken.insert(k);
            }
        }
        let mut moved = HashMap::default();
        let mut ran_out = false;
        for &(v, p) in &duplicates {
            let mut p = p;
            let free = (0..steps).find(|&k| {
                step(&mut p, k);
                taken.insert(key(p))
            });
            if free.is_none() {
                ran_out = true;
                break;
            }
            moved.insert(v, p);
        }
        if !ran_out {
            return Ok(moved);
        }
        steps *= 4;
    }
}

/// The leaves' patches, a group of leaves at a time (in key order, about `max_triangles`
/// triangles a group): each leaf's triangles (in the hierarchy's order, from `LeafCorners`)
/// and the vertices they use, with their input positions, simplifier positions
/// (`simplifier_of(id, position)`) and attributes. A group costs one pass over the vertex
/// files (up to its largest id): its (vertex, leaf) pairs are sorted in memory and joined
/// with the vertex files, so each leaf's table comes out sorted by id. Nothing is written to
/// disk. The staged mesh's triangle file is not read (it is gone by then).
pub struct LeafGroups<'a> {
    staged: &'a StagedMesh,
    /// Each leaf's triangles, on disk (read a group at a time); closed after the last group,
    /// so its file's space goes as soon as nothing else names it.
    lists: Option<LeafCorners>,
    simplifier_of: &'a (dyn Fn(u32, [f64; 3]) -> [f32; 3] + Sync),
    /// The next leaf, in the spool's key order.
    next: usize,
    max_triangles: usize,
}

impl<'a> LeafGroups<'a> {
    pub fn new(
        staged: &'a StagedMesh,
        lists: LeafCorners,
        simplifier_of: &'a (dyn Fn(u32, [f64; 3]) -> [f32; 3] + Sync),
        max_triangles: usize,
    ) -> Self {
        LeafGroups {
            staged,
            lists: Some(lists),
            simplifier_of,
            next: 0,
            max_triangles: max_triangles.max(1),
        }
    }

    /// The next group's patches; `None` after the last.
    pub fn next_group(&mut self) -> io::Result<Option<Vec<(SimplexKey, LivePatch)>>> {
        let Some(lists) = &self.lists else {
            return Ok(None);
        };
        let leaves = lists.leaves().len();
        if self.next == leaves {
            self.lists = None;
            return Ok(None);
        }
        let start = self.next;
        let mut keys = Vec::new();
        let mut triangles = 0;
        while start + keys.len() < leaves && (keys.is_empty() || triangles < self.max_triangles) {
            let (key, n) = lists.leaf(start + keys.len());
            keys.push(key);
            triangles += n;
        }
        self.next = start + keys.len();
        let attributes = &self.staged.attributes;
        let mut patches: Vec<LivePatch> = Vec::with_capacity(keys.len());
        // (vertex, leaf) once per leaf, by vertex: a leaf's ids come decoded, distinct.
        let mut pairs: Vec<u64> = Vec::new();
        for leaf in 0..keys.len() {
            let (triangles, ids) = lists.triangles_of(start + leaf)?;
            pairs.extend(ids.into_iter().map(|v| ((v as u64) << 32) | leaf as u64));
            patches.push(LivePatch {
                triangles,
                vertices: VertexTable {
                    normals: attributes.normals.is_some().then(Vec::new),
                    colors: attributes.colors.is_some().then(Vec::new),
                    uvs: attributes.uvs.is_some().then(Vec::new),
                    ..VertexTable::default()
                },
            });
        }
        pairs.sort_unstable();
        let mut positions = PositionCursor::new(&self.staged.positions)?;
        let mut normals = attributes.normals.as_ref().map(Cursor::new).transpose()?;
        let mut colors = attributes.colors.as_ref().map(Cursor::new).transpose()?;
        let mut uvs = attributes.uvs.as_ref().map(Cursor::new).transpose()?;
        for pair in pairs {
            let (v, leaf) = ((pair >> 32) as u32, pair as u32 as usize);
            let table = &mut patches[leaf].vertices;
            let p = positions.at(v);
            table.ids.push(v);
            table.positions.push(p);
            table.simplifier.push((self.simplifier_of)(v, p));
            if let (Some(column), Some(cursor)) = (&mut table.normals, &mut normals) {
                column.push(cursor.at(v));
            }
            if let (Some(column), Some(cursor)) = (&mut table.colors, &mut colors) {
                column.push(cursor.at(v));
            }
            if let (Some(column), Some(cursor)) = (&mut table.uvs, &mut uvs) {
                column.push(cursor.at(v));
            }
        }
        positions.finish(&mut PositionBlocks::default())?;
        for cursor_error in [
            normals.and_then(|mut c| c.error.take()),
            colors.and_then(|mut c| c.error.take()),
            uvs.and_then(|mut c| c.error.take()),
        ] {
            check(cursor_error)?;
        }
        Ok(Some(keys.iter().copied().zip(patches).collect()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hierarchy::MeshBarycentres;

    fn barycentres(source: &dyn BarycentreSource) -> Vec<(u32, [f64; 3])> {
        let mut out = Vec::new();
        source
            .for_each_barycentre(&mut |t, b| out.push((t, b)))
            .unwrap();
        out
    }

    #[test]
    fn joined_barycentres_equal_the_in_memory_ones_read_whole_or_in_chunks() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/bunny00.off");
        let report = crate::import::load_mesh(&path).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let mesh = report.mesh.clone();
        let staged = StagedMesh::from_report(report, dir.path()).unwrap();
        let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
        for p in &mesh.positions {
            for i in 0..3 {
                lo[i] = lo[i].min(p[i]);
                hi[i] = hi[i].max(p[i]);
            }
        }
        let frame = LatticeFrame::around_box(lo, hi, 20, 3);
        let expected = barycentres(&MeshBarycentres {
            frame: &frame,
            mesh: &mesh,
        });
        assert_eq!(expected.len(), mesh.triangles.len());
        // Budget 0: chunks of 4,096 triangles joined with the positions file; a budget above
        // the positions' bytes: the positions read once and indexed.
        for budget in [0, 1 << 30] {
            let joined = barycentres(&JoinedBarycentres {
                staged: &staged,
                frame: &frame,
                budget,
            });
            assert_eq!(joined, expected, "budget {budget}");
        }
    }
}
