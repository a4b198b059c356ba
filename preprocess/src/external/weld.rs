//! Welding and cleaning out of core: the same mesh, wedge and vertex ids and triangle order as
//! the in-memory `import::weld`, from a `RawStaged` mesh, with memory bounded by a budget
//! (external sorts and windows over the id maps) whatever the mesh's size and vertex order.
//! Where corners at one position differ in attributes (`wedge_check::has_seams`), step 4 is
//! `weld_wedges.rs`'s instead, from the raw corners of the triangles steps 2 and 3 kept.
//!
//! 1. Group bit-identical positions (`-0.0` as `0.0`): sort (position bits, index), a window
//!    of positions (split by a hash of their bits) at a time so the keys stay in memory
//!    (`weld_keys::representatives`); each run's first index is the group's *representative*. Groups numbered by first index order as
//!    representatives are, so representatives stand in for group numbers until the end.
//! 2. Map triangle corners to representatives, a window of the representative map at a time
//!    (windows ascending: a representative is at most its vertex's index, so a corner mapped
//!    in one window is never in a later one), dropping degenerate triangles in the last pass.
//! 3. Drop duplicates: sort (sorted corners, position); all but the first of each run go.
//! 4. Number the referenced representatives in order (a bitmap of the raw ids where it fits,
//!    else a sort of the corners), map the corners to those numbers a dense window of ids at
//!    a time (ascending again), and pick the kept vertices' positions and attributes in one
//!    pass over the raw files.
//!
//! The passes over the triangles read and write them in chunks and map each chunk in
//! parallel: with shuffled vertex ids every lookup misses the cache, and only many lookups
//! in flight at once hide that.

use std::io;
use std::path::Path;

use bytemuck::Pod;
use rayon::prelude::*;

use super::fallible::{check, ok_values};
use super::position_file::PositionFile;
use super::sort::sort_external;
use super::staged::{RawStaged, RecordFile, StagedMesh, VertexAttributes};
use super::weld_keys::{
    canonical_f32_bits, least_corner_windows, referenced_ids, representatives, DuplicateKey,
    NarrowPositionKey, PositionKey,
};
use crate::import::weld::canonical_bits;

/// The smallest window of an id map held in memory, whatever the budget.
const MIN_WINDOW: usize = if cfg!(test) { 16 } else { 1 << 16 };

/// Welds `raw` with about `budget` bytes of memory, temporary files in `dir`: in memory
/// (`import::weld`, then the result written out) where [`in_memory_weld_bytes`] fits the
/// budget, by external sorts otherwise. The same mesh, ids and counts either way; the
/// in-memory weld skips five sorts and as many rewrites of the triangle file.
pub fn weld_within_budget(raw: RawStaged, budget: usize, dir: &Path) -> io::Result<StagedMesh> {
    let raw = face_colored(raw, budget / 2, dir)?;
    if in_memory_weld_bytes(&raw) <= budget as u64 {
        weld_in_memory(raw, dir)
    } else {
        weld_external(raw, budget, dir)
    }
}

/// An upper estimate of what `import::weld` holds at its peak for `raw`, read into memory:
/// the raw mesh (24 B a position, 12 B a triangle, the attributes), its hash table (at most
/// 16 B a vertex), group maps and new ids (16 B a vertex), the mapped triangles and the
/// duplicate search (28 B a triangle), the welded positions and attributes (as raw).
pub fn in_memory_weld_bytes(raw: &RawStaged) -> u64 {
    let attributes = raw.attributes.normals.as_ref().map_or(0, RecordFile::bytes)
        + raw.attributes.colors.as_ref().map_or(0, RecordFile::bytes)
        + raw.attributes.uvs.as_ref().map_or(0, RecordFile::bytes);
    let (v, t) = (raw.positions.len(), raw.triangles.len());
    v * (24 + 16 + 16 + 24) + t * (12 + 28) + 2 * attributes
}

/// Welds `raw` in memory with `import::weld` and writes the result as a [`StagedMesh`] in
/// `dir` (the raw files are freed first).
pub fn weld_in_memory(raw: RawStaged, dir: &Path) -> io::Result<StagedMesh> {
    // (Its sorts then stay in memory: the mesh is read whole anyway.)
    let raw = face_colored(raw, 1 << 30, dir)?;
    let (normals, colors, uvs) = raw.attributes.read_all()?;
    let mesh = crate::import::RawMesh {
        positions: raw.positions.read_all()?,
        triangles: raw.triangles.read_all()?,
        normals,
        colors,
        uvs,
    };
    drop(raw);
    let report = crate::import::weld(mesh);
    StagedMesh::from_report(report, dir)
}

/// Welds `raw` by external sorts with about `budget` bytes of memory, temporary files in
/// `dir`.
pub fn weld_external(raw: RawStaged, budget: usize, dir: &Path) -> io::Result<StagedMesh> {
    let half = budget / 2;
    let raw = face_colored(raw, half, dir)?;
    let raw_vertices = raw.positions.len();
    let raw_triangles = raw.triangles.len();
    // The raw triangles are consumed by the first mapping pass (freed then); the positions
    // and attributes are read again at the end.
    let RawStaged {
        positions: raw_positions,
        triangles: raw_triangle_file,
        attributes,
        face_colors: _,
    } = raw;
    if raw_vertices > u32::MAX as u64 {
        return Err(io::Error::other(format!(
            "{raw_vertices} vertices: at most {} are supported",
            u32::MAX
        )));
    }

    // 1. Representatives: sort by position bits (a window of positions at a time), then pair
    //    each index with its run's first, sorted back into index order. Positions that are all f32 are sorted by their f32
    //    bits (16-byte keys, half the runs of f64 bits): the same groups, the same firsts.
    let by_index = match &raw_positions {
        PositionFile::Narrow(_) => {
            representatives(&raw_positions, half, dir, |p, index| NarrowPositionKey {
                bits: p.map(canonical_f32_bits),
                index: index as u32,
            })?
        }
        PositionFile::Wide(_) => {
            representatives(&raw_positions, half, dir, |p, index| PositionKey {
                bits: p.map(canonical_bits),
                index,
            })?
        }
    };
    let mut representative = RecordFile::<u32>::create(dir)?;
    let mut groups = 0u64;
    for pair in by_index {
        let pair = pair?;
        let (index, rep) = ((pair >> 32) as u32, pair as u32);
        groups += (index == rep) as u64;
        representative.push(&rep)?;
    }
    let representative = representative.finish()?;
    // Where corners at one position differ in attributes, the kept triangles' raw corners
    // are wedges (`weld_wedges.rs`): the raw triangles are copied (step 2 consumes them), and
    // steps 2 and 3 note which they drop.
    let seams = super::wedge_check::has_seams(&representative, &attributes, half, dir)?;
    let mut wedge_notes = match seams {
        true => Some(super::weld_wedges::WedgeNotes::new(
            &raw_triangle_file,
            dir,
        )?),
        false => None,
    };

    // 2. Corners to representatives, a window of the map at a time, in ascending windows (a
    //    corner's representative is at most its index, so a corner mapped in one window is
    //    never in a later one); degenerate triangles dropped in the last pass.
    let window = (half / 4).max(MIN_WINDOW);
    let windows = raw_vertices.div_ceil(window as u64).max(1);
    let mut triangles = raw_triangle_file;
    let mut reps = representative.read_chunks(window)?;
    let mut start = 0u64;
    for pass in 0..windows {
        let part = reps.next().transpose()?.unwrap_or_default();
        let end = start + part.len() as u64;
        let last = pass + 1 == windows;
        triangles = map_triangles(triangles, dir, |chunk| {
            chunk.par_iter_mut().for_each(|t| {
                for v in t.iter_mut() {
                    if (start..end).contains(&(*v as u64)) {
                        *v = part[(*v as u64 - start) as usize];
                    }
                }
            });
            if let (true, Some(notes)) = (last, &wedge_notes) {
                notes.note_degenerate(chunk)?;
            }
            if last {
                chunk.retain(|m| m[0] != m[1] && m[1] != m[2] && m[0] != m[2]);
            }
            Ok(())
        })?;
        start = end;
    }
    drop(reps);
    let proper = triangles;
    let degenerate = raw_triangles - proper.len();

    // 3. Duplicates: the first of each run of equal corner sets stays. Equal sets share their
    //    least corner, so the sort is split into windows of least corners, each window's keys
    //    within half the budget where the mesh allows (`least_corner_windows`): the keys, as
    //    large as the triangle file, then never go to disk beside it.
    let mut dropped_positions = RecordFile::<u32>::create(dir)?;
    for (low, high) in least_corner_windows(&proper, raw_vertices, half)? {
        // A chunk's keys made in parallel (made one by one, they were a tenth of a large
        // import, on one core).
        let mut error = None;
        let mut chunks = proper.read_chunks(PASS_TRIANGLES)?;
        let mut first = 0usize;
        let keys = std::iter::from_fn(|| {
            let mut chunk = Vec::new();
            match chunks.read_into(&mut chunk) {
                Ok(true) => {}
                Ok(false) => return None,
                Err(e) => {
                    error = Some(e);
                    return None;
                }
            }
            let at = first;
            first += chunk.len();
            let keys: Vec<DuplicateKey> = chunk
                .par_iter()
                .enumerate()
                .filter_map(|(i, t)| {
                    let mut sorted = *t;
                    sorted.sort_unstable();
                    (low..high)
                        .contains(&(sorted[0] as u64))
                        .then_some(DuplicateKey {
                            corners: sorted,
                            position: (at + i) as u32,
                        })
                })
                .collect();
            Some(keys)
        })
        .flatten();
        let sorted = sort_external(keys, half, dir)?;
        check(error)?;
        let mut previous: Option<[u32; 3]> = None;
        for key in sorted {
            let key: DuplicateKey = key?;
            if previous == Some(key.corners) {
                dropped_positions.push(&key.position)?;
            }
            previous = Some(key.corners);
        }
    }
    let dropped_positions = dropped_positions.finish()?;
    let mut error = None;
    let dropped = ok_values(dropped_positions.read()?, &mut error);
    let mut dropped = sort_external(dropped, half, dir)?.peekable();
    check(error)?;
    drop(dropped_positions);
    let mut kept = RecordFile::<[u32; 3]>::create(dir)?;
    let mut duplicate = 0u64;
    let (mut chunks, mut chunk) = (proper.consume_chunks(PASS_TRIANGLES)?, Vec::new());
    let mut i = 0usize;
    while chunks.read_into(&mut chunk)? {
        // The runs between dropped positions in one write each (duplicates are rare).
        let (base, mut from) = (i, 0usize);
        i += chunk.len();
        while let Some(Ok(d)) = dropped.peek() {
            let d = *d as usize;
            if d < base + from || d >= i {
                break;
            }
            kept.push_all(&chunk[from..d - base])?;
            from = d - base + 1;
            dropped.next();
            duplicate += 1;
            if let Some(notes) = &mut wedge_notes {
                notes.duplicates.push(&(d as u32))?;
            }
        }
        kept.push_all(&chunk[from..])?;
    }
    if let Some(Err(e)) = dropped.next() {
        return Err(e);
    }
    let kept = kept.finish()?;
    drop(chunks);

    if let Some(notes) = wedge_notes {
        drop(kept);
        let kept = notes.kept_raw_triangles(dir)?;
        let w = super::weld_wedges::weld_wedges(
            &raw_positions,
            kept,
            &representative,
            &attributes,
            half,
            dir,
        )?;
        return Ok(StagedMesh {
            positions: w.positions,
            triangles: w.triangles,
            attributes: w.attributes,
            raw_vertices,
            raw_triangles,
            welded_vertices: raw_vertices - groups,
            degenerate_triangles: degenerate,
            duplicate_triangles: duplicate,
            unreferenced_vertices: groups - w.vertices,
            textures: None,
            missing_textures: Vec::new(),
        });
    }
    drop(representative);

    // 4. Referenced representatives, numbered in order.
    let referenced = referenced_ids(&kept, raw_vertices, half, dir)?;
    // Corners to their numbers, a dense window of the id range at a time, ascending (a
    // number is at most its representative: a corner mapped once is never in a later window).
    let window = window.min(raw_vertices as usize).max(1);
    let mut dense = vec![u32::MAX; window];
    let mut ids = referenced.read()?.peekable();
    let mut number = 0u32;
    let mut triangles = kept;
    for pass in 0..raw_vertices.div_ceil(window as u64).max(1) {
        let (start, end) = (pass * window as u64, (pass + 1) * window as u64);
        dense.fill(u32::MAX);
        while let Some(id) = ids.next_if(|id| id.as_ref().map_or(true, |&id| (id as u64) < end)) {
            dense[(id? as u64 - start) as usize] = number;
            number += 1;
        }
        let dense = &dense;
        triangles = map_triangles(triangles, dir, |chunk| {
            chunk
                .par_iter_mut()
                .try_for_each(|t| {
                    for v in t.iter_mut() {
                        if (start..end).contains(&(*v as u64)) {
                            match dense[(*v as u64 - start) as usize] {
                                u32::MAX => return Err(()),
                                n => *v = n,
                            }
                        }
                    }
                    Ok(())
                })
                .map_err(|()| io::Error::other("a referenced vertex is missing from its own list"))
        })?;
    }
    drop(dense);
    let welded = triangles;

    // The kept vertices' positions and attributes, in one pass each.
    let a = &attributes;
    Ok(StagedMesh {
        positions: pick_positions(&raw_positions, &referenced, dir)?,
        triangles: welded,
        attributes: VertexAttributes {
            normals: a
                .normals
                .as_ref()
                .map(|f| pick(f, &referenced, dir))
                .transpose()?,
            colors: a
                .colors
                .as_ref()
                .map(|f| pick(f, &referenced, dir))
                .transpose()?,
            uvs: a
                .uvs
                .as_ref()
                .map(|f| pick(f, &referenced, dir))
                .transpose()?,
        },
        raw_vertices,
        raw_triangles,
        welded_vertices: raw_vertices - groups,
        degenerate_triangles: degenerate,
        duplicate_triangles: duplicate,
        unreferenced_vertices: groups - referenced.len(),
        textures: None,
        missing_textures: Vec::new(),
    })
}

/// `raw` with its face colours on corners of their own (`face_colors.rs`), where it has any.
fn face_colored(mut raw: RawStaged, budget: usize, dir: &Path) -> io::Result<RawStaged> {
    match raw.face_colors.take() {
        Some(colors) => super::face_colors::apply(raw, colors, budget, dir),
        None => Ok(raw),
    }
}

/// Triangles a pass reads and maps at once (768 KiB).
pub(super) const PASS_TRIANGLES: usize = 1 << 16;

/// A new file of `from`'s triangles, each chunk changed by `map` (in place, in parallel
/// where it likes; it may drop triangles). `from`'s disk space is given back as it is read,
/// so the two files together stay about one file's size.
pub(super) fn map_triangles(
    from: RecordFile<[u32; 3]>,
    dir: &Path,
    map: impl Fn(&mut Vec<[u32; 3]>) -> io::Result<()>,
) -> io::Result<RecordFile<[u32; 3]>> {
    let mut out = RecordFile::<[u32; 3]>::create(dir)?;
    let (mut chunks, mut chunk) = (from.consume_chunks(PASS_TRIANGLES)?, Vec::new());
    while chunks.read_into(&mut chunk)? {
        map(&mut chunk)?;
        out.push_all(&chunk)?;
    }
    out.finish()
}

/// The records of `from` whose index is in `indices` (ascending).
fn pick<T: Pod>(
    from: &RecordFile<T>,
    indices: &RecordFile<u32>,
    dir: &Path,
) -> io::Result<RecordFile<T>> {
    let mut out = RecordFile::<T>::create(dir)?;
    pick_each(from.read()?, indices, |r| out.push(r))?;
    out.finish()
}

/// `pick` of positions.
pub(super) fn pick_positions(
    from: &PositionFile,
    indices: &RecordFile<u32>,
    dir: &Path,
) -> io::Result<PositionFile> {
    let mut out = PositionFile::create(dir)?;
    pick_each(from.read()?, indices, |p| out.push(p))?;
    out.finish()
}

/// Hands `push` the records of `from` at `indices` (ascending, repeats allowed: a record
/// once an index), in order.
fn pick_each<T>(
    from: impl Iterator<Item = io::Result<T>>,
    indices: &RecordFile<u32>,
    mut push: impl FnMut(&T) -> io::Result<()>,
) -> io::Result<()> {
    let mut wanted = indices.read()?.peekable();
    for (i, record) in from.enumerate() {
        let record = record?;
        loop {
            match wanted.peek() {
                Some(Ok(w)) if *w as usize == i => {
                    push(&record)?;
                    wanted.next();
                }
                Some(Err(_)) => return Err(wanted.next().expect("peeked").expect_err("an error")),
                _ => break,
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::external::staged::RawStaged;
    use crate::import::{weld, RawMesh};
    use proptest::prelude::*;

    /// Stages `raw`, welds it out of core with `budget`, and checks it against `import::weld`.
    fn same_as_in_memory(raw: &RawMesh, budget: usize) {
        same_as_import_weld(raw, |stager, dir| weld_external(stager, budget, dir));
    }

    /// Stages `raw`, welds it with `welder`, and checks the staged result (mesh, counts, no
    /// file left in the directory) against `import::weld`.
    fn same_as_import_weld(
        raw: &RawMesh,
        welder: impl FnOnce(RawStaged, &Path) -> io::Result<StagedMesh>,
    ) {
        let dir = tempfile::tempdir().unwrap();
        let stager = RawStaged::from_raw(raw, dir.path()).unwrap();
        let expected = weld(raw.clone());
        let staged = welder(stager, dir.path()).unwrap();
        assert_eq!(staged.load().unwrap(), expected.mesh);
        let counts = |s: &StagedMesh| {
            [
                s.raw_vertices,
                s.raw_triangles,
                s.welded_vertices,
                s.degenerate_triangles,
                s.duplicate_triangles,
                s.unreferenced_vertices,
            ]
        };
        let e = &expected;
        let expected_counts = [
            e.raw_vertices,
            e.raw_triangles,
            e.welded_vertices,
            e.degenerate_triangles,
            e.duplicate_triangles,
            e.unreferenced_vertices,
        ]
        .map(|n| n as u64);
        assert_eq!(counts(&staged), expected_counts);
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "files left"
        );
    }

    fn raw_mesh() -> impl Strategy<Value = RawMesh> {
        // Positions from a small pool, so that many coincide; ±0.0 among them. Attributes by
        // index (so corners at one position differ: seams, a wedge a raw vertex), by position
        // (no seams), from a small pool with ±0.0 (seams whose wedges gather several raw
        // vertices, told apart by value, not bits), or by position and parity (two wedges at
        // most a vertex).
        let pool = [0.0, -0.0, 1.0, 2.5, -3.0];
        (1usize..300, 0usize..600, any::<u64>(), 0u8..32).prop_map(move |(n, t, seed, attrs)| {
            let mut state = seed | 1;
            let mut next = move || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                state
            };
            let positions: Vec<[f64; 3]> = (0..n)
                .map(|_| [0; 3].map(|_| pool[next() as usize % pool.len()]))
                .collect();
            let triangles: Vec<[u32; 3]> = (0..t)
                .map(|_| [0; 3].map(|_| (next() % n as u64) as u32))
                .collect();
            let by_position =
                |p: &[f64; 3]| (p[0].abs() + 2.0 * p[1].abs() + 4.0 * p[2].abs()) as f32;
            let keys: Vec<f32> = positions
                .iter()
                .enumerate()
                .map(|(i, p)| match attrs >> 3 {
                    0 => i as f32,
                    1 => by_position(p),
                    2 => [0.0, -0.0, 1.0][next() as usize % 3],
                    _ => by_position(p) + (i % 2) as f32 * 0.5,
                })
                .collect();
            RawMesh {
                normals: (attrs & 1 != 0).then(|| keys.iter().map(|&x| [x, 0.5, -1.0]).collect()),
                colors: (attrs & 2 != 0)
                    .then(|| keys.iter().map(|&x| [x as u8, 1, 2, 3]).collect()),
                uvs: (attrs & 4 != 0).then(|| keys.iter().map(|&x| [0.25, x]).collect()),
                positions,
                triangles,
            }
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn equals_the_in_memory_weld(raw in raw_mesh(), budget in prop_oneof![Just(0usize), Just(256), Just(1 << 20)]) {
            same_as_in_memory(&raw, budget);
        }

        #[test]
        fn the_budget_chooses_a_weld_that_gives_the_same_mesh(raw in raw_mesh(), budget in prop_oneof![Just(0usize), Just(1 << 30)]) {
            same_as_import_weld(&raw, |stager, dir| weld_within_budget(stager, budget, dir));
            same_as_import_weld(&raw, weld_in_memory);
        }
    }

    #[test]
    fn the_in_memory_estimate_decides_the_weld() {
        let dir = tempfile::tempdir().unwrap();
        let raw = RawMesh {
            positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            triangles: vec![[0, 1, 2]],
            normals: None,
            colors: Some(vec![[1, 2, 3, 4]; 3]),
            uvs: None,
        };
        let staged = RawStaged::from_raw(&raw, dir.path()).unwrap();
        // 3 vertices × 80 B, 1 triangle × 40 B, the colours twice.
        assert_eq!(in_memory_weld_bytes(&staged), 3 * 80 + 40 + 2 * 12);
    }

    #[test]
    fn equals_the_in_memory_weld_on_a_real_scan_with_spills() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/bunny00.off");
        let raw = crate::import::load_raw(&path).unwrap();
        // Budget 0: 1,024-record sort buffers and 16-entry windows, so every step spills and
        // every id map is applied in thousands of windows.
        for budget in [0, 1 << 16, 1 << 30] {
            same_as_in_memory(&raw, budget);
        }
    }
}
