//! The out-of-core weld's wedges (`weld.rs`; `mesh.rs` says what wedges are): where corners at
//! one position differ in normal, colour or texture coordinate, they stay apart as consecutive
//! wedges of one vertex, numbered exactly as `import::weld` numbers them, with memory bounded
//! by the budget (external sorts and windows of the id maps, never a table a vertex).
//!
//! The in-memory rule: vertices in the order of their position group's first raw vertex (its
//! *representative*), a vertex's wedges consecutive, each wedge a distinct attribute key
//! among the raw vertices the kept triangles use, in the order of that key's first used raw
//! vertex, whose attributes the wedge takes; every wedge takes the representative's position.
//!
//! 1. The used raw vertices (`weld::referenced_ids`), each with its representative and key,
//!    sorted by (representative, key, index): a run is a wedge, its first index the wedge's
//!    *first* raw vertex.
//! 2. Every used raw vertex as (representative, first, index), sorted: wedges come out in
//!    their order, numbered as they come; a raw vertex's wedge and a wedge's first raw vertex
//!    go to sorts of their own.
//! 3. Each wedge's position (the representative's, in one pass: representatives ascend with
//!    the wedges) and attributes (its first raw vertex's, picked in one pass and sorted back).
//! 4. The kept triangles' raw corners to wedges, a dense window of raw ids at a time (a
//!    mapped corner is marked, `MAPPED`, since a wedge number may lie in a later window).

use std::io;
use std::path::Path;

use rayon::prelude::*;

use super::cursor::Cursor;
use super::fallible::{check, ok_values};
use super::position_file::PositionFile;
use super::sort::sort_external;
use super::staged::RecordWriter;
use super::staged::{RecordFile, VertexAttributes};
use super::weld::{map_triangles, pick_positions, PASS_TRIANGLES};
use super::weld_keys::referenced_ids;

/// The mark of a corner already mapped to its wedge (wedge numbers stay below it).
const MAPPED: u32 = 1 << 31;

/// The smallest window of the raw-to-wedge map held in memory, whatever the budget.
const MIN_WINDOW: usize = if cfg!(test) { 16 } else { 1 << 16 };

/// A welded mesh's wedges: positions, triangles, attributes, and how many vertices they form.
pub(super) struct Wedges {
    pub positions: PositionFile,
    pub triangles: RecordFile<[u32; 3]>,
    pub attributes: VertexAttributes,
    pub vertices: u64,
}

/// The attribute bits that tell wedges apart (`import::weld`'s key: `-0.0` as `0.0`), with
/// the representative in front and the raw index behind: sorting groups a wedge's raw
/// vertices, its first in front.
type WedgeKey = [u32; 8];

/// Numbers the wedges of `kept` (the kept triangles, by raw vertex) and maps them: `raw_positions`
/// and `attributes` are the raw vertices', `representative` each raw vertex's group's first;
/// within about `budget` bytes, temporary files in `dir`.
pub(super) fn weld_wedges(
    raw_positions: &PositionFile,
    kept: RecordFile<[u32; 3]>,
    representative: &RecordFile<u32>,
    attributes: &VertexAttributes,
    budget: usize,
    dir: &Path,
) -> io::Result<Wedges> {
    let raw_vertices = raw_positions.len();
    if raw_vertices > MAPPED as u64 {
        return Err(io::Error::other(format!(
            "{raw_vertices} vertices with texture seams or creases: at most {MAPPED} are \
             supported out of core"
        )));
    }
    // 1. The used raw vertices by (representative, key, index).
    let used = referenced_ids(&kept, raw_vertices, budget, dir)?;
    let keyed = sorted_keys(&used, representative, attributes, budget, dir)?;
    drop(used);
    // 2. (representative, first, index) of every used raw vertex, in wedge order.
    let mut error = None;
    let mut first = 0u32;
    let mut previous: Option<[u32; 7]> = None;
    let by_wedge = ok_values(keyed, &mut error).map(|k: WedgeKey| {
        let key: [u32; 7] = k[..7].try_into().expect("seven words");
        if previous != Some(key) {
            (previous, first) = (Some(key), k[7]);
        }
        [k[0], first, k[7]]
    });
    let by_wedge = sort_external(by_wedge, budget, dir)?;
    check(error.take())?;
    // On disk until sorted: (raw index, wedge) of every used raw vertex, (first raw vertex,
    // wedge) and the representative of every wedge.
    let mut wedge_of_raw = RecordFile::<[u32; 2]>::create(dir)?;
    let mut firsts = RecordFile::<[u32; 2]>::create(dir)?;
    let mut reps = RecordFile::<u32>::create(dir)?;
    let (mut wedges, mut vertices) = (0u32, 0u64);
    let mut last: Option<[u32; 2]> = None;
    for record in by_wedge {
        let [rep, first, raw] = record?;
        if last != Some([rep, first]) {
            vertices += last.is_none_or(|[r, _]| r != rep) as u64;
            if last.is_some() {
                wedges += 1;
            }
            last = Some([rep, first]);
            reps.push(&rep)?;
            firsts.push(&[first, wedges])?;
        }
        wedge_of_raw.push(&[raw, wedges])?;
    }
    let (reps, firsts) = (reps.finish()?, firsts.finish()?);
    // 3. Positions (representatives ascend with the wedges) and attributes.
    let positions = pick_positions(raw_positions, &reps, dir)?;
    drop(reps);
    let attributes = pick_attributes(attributes, &firsts, budget, dir)?;
    drop(firsts);
    let wedge_of_raw = wedge_of_raw.finish()?;
    let sorted = sort_external(ok_values(wedge_of_raw.read()?, &mut error), budget / 2, dir)?;
    check(error.take())?;
    drop(wedge_of_raw);
    let wedge_of_raw = sorted;
    // 4. The corners, a dense window of raw ids at a time.
    let window = (budget / 8)
        .max(MIN_WINDOW)
        .min(raw_vertices.max(1) as usize);
    let windows = raw_vertices.div_ceil(window as u64).max(1);
    let mut dense = vec![u32::MAX; window];
    let mut pairs = wedge_of_raw.peekable();
    let mut triangles = kept;
    for pass in 0..windows {
        let (start, end) = (pass * window as u64, (pass + 1) * window as u64);
        dense.fill(u32::MAX);
        while let Some(pair) = pairs.next_if(|p| p.as_ref().map_or(true, |p| (p[0] as u64) < end)) {
            let [raw, wedge] = pair?;
            dense[(raw as u64 - start) as usize] = wedge;
        }
        let (dense, last) = (&dense, pass + 1 == windows);
        triangles = map_triangles(triangles, dir, |chunk| {
            chunk
                .par_iter_mut()
                .try_for_each(|t| {
                    for v in t.iter_mut() {
                        if *v & MAPPED == 0 && (start..end).contains(&(*v as u64)) {
                            match dense[(*v as u64 - start) as usize] {
                                u32::MAX => return Err(()),
                                w => *v = w | MAPPED,
                            }
                        }
                        if last {
                            *v &= !MAPPED;
                        }
                    }
                    Ok(())
                })
                .map_err(|()| io::Error::other("a used raw vertex has no wedge"))
        })?;
    }
    Ok(Wedges {
        positions,
        triangles,
        attributes,
        vertices,
    })
}

/// The used raw vertices (`used`, ascending) as wedge keys, sorted.
fn sorted_keys(
    used: &RecordFile<u32>,
    representative: &RecordFile<u32>,
    attributes: &VertexAttributes,
    budget: usize,
    dir: &Path,
) -> io::Result<super::sort::Sorted<WedgeKey>> {
    let a = attributes;
    let bits = |x: f32| if x == 0.0 { 0 } else { x.to_bits() };
    let mut reps = Cursor::new(representative)?;
    let mut normals = a.normals.as_ref().map(Cursor::new).transpose()?;
    let mut colors = a.colors.as_ref().map(Cursor::new).transpose()?;
    let mut uvs = a.uvs.as_ref().map(Cursor::new).transpose()?;
    let mut error = None;
    let keys = ok_values(used.read()?, &mut error).map(|i| {
        let mut key = [0u32; 8];
        key[0] = reps.at(i);
        if let Some(n) = normals.as_mut() {
            key[1..4].copy_from_slice(&n.at(i).map(bits));
        }
        if let Some(c) = colors.as_mut() {
            key[4] = u32::from_le_bytes(c.at(i));
        }
        if let Some(uv) = uvs.as_mut() {
            key[5..7].copy_from_slice(&uv.at(i).map(bits));
        }
        key[7] = i;
        key
    });
    let sorted = sort_external(keys, budget, dir)?;
    check(error)?;
    check(reps.error)?;
    for e in [
        normals.and_then(|c| c.error),
        colors.and_then(|c| c.error),
        uvs.and_then(|c| c.error),
    ] {
        check(e)?;
    }
    Ok(sorted)
}

/// Each wedge's attributes: its first raw vertex's (`firsts`: (first raw vertex, wedge), a
/// wedge each), picked in one pass over the raw files and sorted back into wedge order.
fn pick_attributes(
    raw: &VertexAttributes,
    firsts: &RecordFile<[u32; 2]>,
    budget: usize,
    dir: &Path,
) -> io::Result<VertexAttributes> {
    let mut error = None;
    let firsts = sort_external(ok_values(firsts.read()?, &mut error), budget / 2, dir)?;
    check(error.take())?;
    let mut normals = raw.normals.as_ref().map(Cursor::new).transpose()?;
    let mut colors = raw.colors.as_ref().map(Cursor::new).transpose()?;
    let mut uvs = raw.uvs.as_ref().map(Cursor::new).transpose()?;
    // (wedge, normal, colour, texture coordinate) as bits.
    let picked = ok_values(firsts, &mut error).map(|[first, wedge]| {
        let mut record = [0u32; 7];
        record[0] = wedge;
        if let Some(n) = normals.as_mut() {
            record[1..4].copy_from_slice(&n.at(first).map(f32::to_bits));
        }
        if let Some(c) = colors.as_mut() {
            record[4] = u32::from_le_bytes(c.at(first));
        }
        if let Some(uv) = uvs.as_mut() {
            record[5..7].copy_from_slice(&uv.at(first).map(f32::to_bits));
        }
        record
    });
    let picked = sort_external(picked, budget / 2, dir)?;
    check(error)?;
    for e in [
        normals.and_then(|c| c.error),
        colors.and_then(|c| c.error),
        uvs.and_then(|c| c.error),
    ] {
        check(e)?;
    }
    fn create<T: bytemuck::Pod>(
        present: bool,
        dir: &Path,
    ) -> io::Result<Option<super::staged::RecordWriter<T>>> {
        present.then(|| RecordFile::create(dir)).transpose()
    }
    let mut out_normals = create(raw.normals.is_some(), dir)?;
    let mut out_colors = create(raw.colors.is_some(), dir)?;
    let mut out_uvs = create(raw.uvs.is_some(), dir)?;
    for record in picked {
        let r = record?;
        if let Some(f) = out_normals.as_mut() {
            f.push(&[r[1], r[2], r[3]].map(f32::from_bits))?;
        }
        if let Some(f) = out_colors.as_mut() {
            f.push(&r[4].to_le_bytes())?;
        }
        if let Some(f) = out_uvs.as_mut() {
            f.push(&[r[5], r[6]].map(f32::from_bits))?;
        }
    }
    Ok(VertexAttributes {
        normals: out_normals.map(|f| f.finish()).transpose()?,
        colors: out_colors.map(|f| f.finish()).transpose()?,
        uvs: out_uvs.map(|f| f.finish()).transpose()?,
    })
}

/// What the wedges need of steps 2 and 3 (`weld_wedges.rs`): the raw triangles, and the
/// positions of those dropped as degenerate (among the raw ones) and as duplicates (among the
/// proper ones).
pub(super) struct WedgeNotes {
    raw: RecordFile<[u32; 3]>,
    degenerate: std::sync::Mutex<(RecordWriter<u32>, u64)>,
    pub(super) duplicates: RecordWriter<u32>,
}

impl WedgeNotes {
    pub(super) fn new(raw: &RecordFile<[u32; 3]>, dir: &Path) -> io::Result<WedgeNotes> {
        let mut copy = RecordFile::<[u32; 3]>::create(dir)?;
        let (mut chunks, mut chunk) = (raw.read_chunks(PASS_TRIANGLES)?, Vec::new());
        while chunks.read_into(&mut chunk)? {
            copy.push_all(&chunk)?;
        }
        Ok(WedgeNotes {
            raw: copy.finish()?,
            degenerate: std::sync::Mutex::new((RecordFile::create(dir)?, 0)),
            duplicates: RecordFile::create(dir)?,
        })
    }

    /// Notes the degenerate triangles of the next chunk of step 2's last pass.
    pub(super) fn note_degenerate(&self, chunk: &[[u32; 3]]) -> io::Result<()> {
        let mut guard = self.degenerate.lock().expect("not poisoned");
        let (file, first) = &mut *guard;
        for (i, m) in chunk.iter().enumerate() {
            if m[0] == m[1] || m[1] == m[2] || m[0] == m[2] {
                file.push(&((*first + i as u64) as u32))?;
            }
        }
        *first += chunk.len() as u64;
        Ok(())
    }

    /// The raw triangles that steps 2 and 3 kept, in order.
    pub(super) fn kept_raw_triangles(self, dir: &Path) -> io::Result<RecordFile<[u32; 3]>> {
        let degenerate = self
            .degenerate
            .into_inner()
            .expect("not poisoned")
            .0
            .finish()?;
        let duplicates = self.duplicates.finish()?;
        let (mut degenerate, mut duplicates) =
            (degenerate.read()?.peekable(), duplicates.read()?.peekable());
        let mut kept = RecordFile::<[u32; 3]>::create(dir)?;
        let (mut chunks, mut chunk) = (self.raw.consume_chunks(PASS_TRIANGLES)?, Vec::new());
        let (mut raw, mut proper) = (0u64, 0u64);
        while chunks.read_into(&mut chunk)? {
            for t in &chunk {
                let at = |next: Option<&io::Result<u32>>, i: u64| matches!(next, Some(Ok(d)) if *d as u64 == i);
                raw += 1;
                if at(degenerate.peek(), raw - 1) {
                    degenerate.next();
                    continue;
                }
                proper += 1;
                if at(duplicates.peek(), proper - 1) {
                    duplicates.next();
                    continue;
                }
                kept.push(t)?;
            }
        }
        for rest in [degenerate.next(), duplicates.next()] {
            match rest {
                None => {}
                Some(Err(e)) => return Err(e),
                Some(Ok(_)) => return Err(io::Error::other("a dropped triangle past the last")),
            }
        }
        kept.finish()
    }
}
