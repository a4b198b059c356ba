//! Per-face colours staged out of core (PLY `face` red/green/blue, OFF colours after a face's
//! indices): each coloured face's corners become raw vertices of the face's colour exactly as
//! the in-memory import's `FaceColored::finish` makes them (`import/sink.rs`), before the weld
//! keeps those that differ as wedges:
//!
//! - a vertex that no uncoloured face uses takes the colour of its first coloured corner
//!   itself (its corners of that colour stay on it);
//! - every other (vertex, colour) of a coloured corner is a copy of the vertex with that
//!   colour, appended after the file's vertices in the order of its first corner.
//!
//! External sorts of the coloured corners (by vertex, then by their pair's first corner, then
//! back by corner), within about the budget; a vertex's coloured corners at a time in memory.

use std::io;
use std::path::Path;

use super::cursor::Cursor;
use super::fallible::{check, ok_values};
use super::position_file::{PositionBlocks, PositionCursor, PositionFile};
use super::sort::sort_external;
use super::staged::{RawStaged, RecordFile, RecordWriter, VertexAttributes};
use super::weld::PASS_TRIANGLES;
use super::weld_keys::referenced_ids;

/// The colour of a vertex without one where faces have them (`FaceColored::finish`).
const WHITE: [u8; 4] = [255; 4];

/// `raw` with the face colours `colored` ((triangle, colour) ascending by triangle) on corners
/// of their own; temporary files in `dir`, sorts within about `budget` bytes.
pub(super) fn apply(
    raw: RawStaged,
    colored: RecordFile<[u32; 2]>,
    budget: usize,
    dir: &Path,
) -> io::Result<RawStaged> {
    let n = raw.positions.len();
    // 1. The vertices uncoloured faces use; the coloured corners as (vertex, serial, colour).
    let mut uncolored = RecordFile::<[u32; 3]>::create(dir)?;
    let mut corners = RecordFile::<[u32; 3]>::create(dir)?;
    let mut faces = colored.read()?.peekable();
    let (mut chunks, mut chunk) = (raw.triangles.read_chunks(PASS_TRIANGLES)?, Vec::new());
    let (mut t, mut serial) = (0u32, 0u32);
    while chunks.read_into(&mut chunk)? {
        for tri in &chunk {
            match faces.next_if(|f| f.as_ref().map_or(true, |f| f[0] == t)) {
                Some(face) => {
                    let color = face?[1];
                    for &v in tri {
                        corners.push(&[v, serial, color])?;
                        serial = serial
                            .checked_add(1)
                            .ok_or_else(|| io::Error::other("too many coloured corners"))?;
                    }
                }
                None => uncolored.push(tri)?,
            }
            t += 1;
        }
    }
    let shared = referenced_ids(&uncolored.finish()?, n, budget, dir)?;
    let corners = corners.finish()?;
    let mut error = None;
    let by_vertex = sort_external(ok_values(corners.read()?, &mut error), budget, dir)?;
    check(error.take())?;
    drop(corners);

    // 2. A vertex's coloured corners at a time: those that stay on it, and pairs to copy.
    let mut resolved = RecordFile::<[u32; 2]>::create(dir)?; // (serial, raw vertex)
    let mut pending = RecordFile::<[u32; 2]>::create(dir)?; // (pair's first serial, serial)
    let mut pairs = RecordFile::<[u32; 3]>::create(dir)?; // (first serial, vertex, colour)
    let mut recolor = RecordFile::<[u32; 2]>::create(dir)?; // (vertex, colour), ascending
    let mut shared = shared.read()?.peekable();
    let mut run: Vec<[u32; 3]> = Vec::new();
    let mut fan = |run: &[[u32; 3]]| -> io::Result<()> {
        let v = run[0][0];
        while shared
            .next_if(|s| s.as_ref().is_ok_and(|&s| s < v))
            .is_some()
        {}
        let own = !matches!(shared.peek(), Some(Ok(s)) if *s == v);
        if let Some(Err(_)) = shared.peek() {
            return Err(shared.next().expect("peeked").expect_err("an error"));
        }
        let c0 = own.then_some(run[0][2]);
        if let Some(c) = c0 {
            recolor.push(&[v, c])?;
        }
        // Each colour's first serial (serials ascend within the run).
        let mut firsts: Vec<[u32; 2]> = Vec::new();
        for &[_, s, c] in run {
            let first = match firsts.iter().find(|f| f[0] == c) {
                Some(f) => f[1],
                None => {
                    firsts.push([c, s]);
                    if Some(c) != c0 {
                        pairs.push(&[s, v, c])?;
                    }
                    s
                }
            };
            match Some(c) == c0 {
                true => resolved.push(&[s, v])?,
                false => pending.push(&[first, s])?,
            }
        }
        Ok(())
    };
    for record in by_vertex {
        let record = record?;
        if run.first().is_some_and(|r| r[0] != record[0]) {
            fan(&run)?;
            run.clear();
        }
        run.push(record);
    }
    if !run.is_empty() {
        fan(&run)?;
    }
    let (pairs, pending, recolor) = (pairs.finish()?, pending.finish()?, recolor.finish()?);

    // 3. Copies numbered from `n` in the order of their first corner; every corner resolved.
    let pairs = sort_external(ok_values(pairs.read()?, &mut error), budget / 2, dir)?;
    check(error.take())?;
    let mut copies = RecordFile::<[u32; 3]>::create(dir)?; // (vertex, copy, colour)
    let mut first_ids = RecordFile::<[u32; 2]>::create(dir)?; // (first serial, copy)
    for (id, pair) in (n..).zip(pairs) {
        let [first, v, c] = pair?;
        let copy =
            u32::try_from(id).map_err(|_| io::Error::other("too many face-coloured corners"))?;
        copies.push(&[v, copy, c])?;
        first_ids.push(&[first, copy])?;
    }
    let (copies, first_ids) = (copies.finish()?, first_ids.finish()?);
    let pending = sort_external(ok_values(pending.read()?, &mut error), budget / 2, dir)?;
    check(error.take())?;
    let mut ids = first_ids.read()?.peekable();
    for p in pending {
        let [first, s] = p?;
        while ids
            .next_if(|i| i.as_ref().is_ok_and(|i| i[0] < first))
            .is_some()
        {}
        match ids.peek() {
            Some(Ok([f, copy])) if *f == first => resolved.push(&[s, *copy])?,
            _ => return Err(io::Error::other("a coloured corner's pair is missing")),
        }
    }
    let resolved = resolved.finish()?;
    let resolved = sort_external(ok_values(resolved.read()?, &mut error), budget / 2, dir)?;
    check(error.take())?;

    // 4. The triangles, their coloured corners on their new vertices.
    let mut triangles = RecordFile::<[u32; 3]>::create(dir)?;
    let mut faces = colored.read()?.peekable();
    let mut resolved = resolved.map(|r| r.map(|[_, v]| v));
    let (mut chunks, mut t) = (raw.triangles.read_chunks(PASS_TRIANGLES)?, 0u32);
    while chunks.read_into(&mut chunk)? {
        for tri in chunk.iter_mut() {
            if faces
                .next_if(|f| f.as_ref().map_or(true, |f| f[0] == t))
                .transpose()?
                .is_some()
            {
                for v in tri.iter_mut() {
                    *v = resolved
                        .next()
                        .ok_or_else(|| io::Error::other("a coloured corner went missing"))??;
                }
            }
            t += 1;
        }
        triangles.push_all(&chunk)?;
    }

    // 5. The vertices: the file's (own ones recoloured), then the copies.
    let copies_by_vertex = sort_external(ok_values(copies.read()?, &mut error), budget / 2, dir)?;
    check(error.take())?;
    let mut positions = PositionCursor::new(&raw.positions)?;
    let a = &raw.attributes;
    let mut normals = a.normals.as_ref().map(Cursor::new).transpose()?;
    let mut uvs = a.uvs.as_ref().map(Cursor::new).transpose()?;
    // (copy, position bits, normal bits, uv bits) by copy.
    let picked = ok_values(copies_by_vertex, &mut error).map(|[v, copy, _]| {
        let p = positions.at(v).map(f64::to_bits);
        let mut r = [0u32; 12];
        r[0] = copy;
        for k in 0..3 {
            r[1 + 2 * k] = (p[k] >> 32) as u32;
            r[2 + 2 * k] = p[k] as u32;
        }
        if let Some(c) = normals.as_mut() {
            r[7..10].copy_from_slice(&c.at(v).map(f32::to_bits));
        }
        if let Some(c) = uvs.as_mut() {
            r[10..12].copy_from_slice(&c.at(v).map(f32::to_bits));
        }
        r
    });
    let picked = sort_external(picked, budget / 2, dir)?;
    check(error.take())?;
    positions.finish(&mut PositionBlocks::default())?;
    for e in [normals.and_then(|c| c.error), uvs.and_then(|c| c.error)] {
        check(e)?;
    }
    let mut out_positions = PositionFile::create(dir)?;
    for p in raw.positions.read()? {
        out_positions.push(&p?)?;
    }
    let mut out_normals = copy_of(a.normals.as_ref(), dir)?;
    let mut out_uvs = copy_of(a.uvs.as_ref(), dir)?;
    for r in picked {
        let r = r?;
        let bits = |k: usize| (r[1 + 2 * k] as u64) << 32 | r[2 + 2 * k] as u64;
        out_positions.push(&[0, 1, 2].map(|k| f64::from_bits(bits(k))))?;
        if let Some(f) = out_normals.as_mut() {
            f.push(&[r[7], r[8], r[9]].map(f32::from_bits))?;
        }
        if let Some(f) = out_uvs.as_mut() {
            f.push(&[r[10], r[11]].map(f32::from_bits))?;
        }
    }
    let mut colors = RecordFile::<[u8; 4]>::create(dir)?;
    let mut old = a.colors.as_ref().map(RecordFile::read).transpose()?;
    let mut recolor = recolor.read()?.peekable();
    for v in 0..n {
        let color = match old.as_mut().map(Iterator::next) {
            Some(Some(c)) => c?,
            Some(None) => return Err(io::Error::other("a vertex colour is missing")),
            None => WHITE,
        };
        let color = match recolor.next_if(|r| r.as_ref().map_or(true, |r| r[0] as u64 == v)) {
            Some(r) => r?[1].to_le_bytes(),
            None => color,
        };
        colors.push(&color)?;
    }
    for c in copies.read()? {
        colors.push(&c?[2].to_le_bytes())?;
    }
    Ok(RawStaged {
        positions: out_positions.finish()?,
        triangles: triangles.finish()?,
        attributes: VertexAttributes {
            normals: out_normals.map(RecordWriter::finish).transpose()?,
            colors: Some(colors.finish()?),
            uvs: out_uvs.map(RecordWriter::finish).transpose()?,
        },
        face_colors: None,
    })
}

/// A copy of `file` still open for more records, where there is one.
fn copy_of<T: bytemuck::Pod>(
    file: Option<&RecordFile<T>>,
    dir: &Path,
) -> io::Result<Option<RecordWriter<T>>> {
    let Some(file) = file else {
        return Ok(None);
    };
    let mut out = RecordFile::<T>::create(dir)?;
    let (mut chunks, mut chunk) = (file.read_chunks(1 << 16)?, Vec::new());
    while chunks.read_into(&mut chunk)? {
        out.push_all(&chunk)?;
    }
    Ok(Some(out))
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    /// An OFF with vertices from a small pool of positions (duplicates among them), triangles
    /// and quads (fanned: one face colour over two triangles), some faces coloured from a
    /// small palette and some not.
    fn off(n: usize, faces: usize, seed: u64) -> String {
        let mut state = seed | 1;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut text = format!("OFF\n{n} {faces} 0\n");
        for _ in 0..n {
            let p = [0; 3].map(|_| next() % 4);
            text += &format!("{} {} {}\n", p[0], p[1], p[2]);
        }
        for _ in 0..faces {
            let corners = 3 + (next() % 2) as usize;
            text += &corners.to_string();
            for _ in 0..corners {
                text += &format!(" {}", next() % n as u64);
            }
            match next() % 4 {
                0 => {}
                c => text += &format!(" {} {} 7", 60 * c, 255 - 60 * c),
            }
            text += "\n";
        }
        text
    }

    /// The staged import (face colours put on corners out of core, then welded) gives the
    /// in-memory import's mesh and counts.
    fn same_as_in_memory(text: &str, budget: usize) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("mesh.off");
        std::fs::write(&path, text).unwrap();
        let expected = crate::import::load_mesh(&path);
        let temp = dir.path().join("temp");
        std::fs::create_dir(&temp).unwrap();
        let staged = crate::import::stage_mesh(&path, &temp, budget);
        let (expected, staged) = match (expected, staged) {
            (Ok(e), Ok(s)) => (e, s),
            (Err(_), Err(_)) => return, // no triangle left either way
            (e, s) => panic!("{:?} against {:?}", e.err(), s.err()),
        };
        assert_eq!(staged.load().unwrap(), expected.mesh);
        assert_eq!(
            [staged.raw_vertices, staged.welded_vertices],
            [expected.raw_vertices, expected.welded_vertices].map(|n| n as u64)
        );
    }

    /// Two coloured faces and an uncoloured one around a shared edge: the shared vertices keep
    /// one wedge a colour (the uncoloured face's corners white).
    #[test]
    fn corners_of_differently_coloured_faces_are_wedges() {
        let text = "OFF\n5 3 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n0 0 1\n\
                    3 0 1 2 255 0 0\n3 2 1 3 0 255 0\n3 0 4 1\n";
        for budget in [0, 1 << 30] {
            same_as_in_memory(text, budget);
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("mesh.off");
        std::fs::write(&path, text).unwrap();
        let staged = crate::import::stage_mesh(&path, dir.path(), 0).unwrap();
        let mesh = staged.load().unwrap();
        // Vertex 0 (red, white), 1 (red, green, white), 2 (red, green), 3, 4: 9 wedges.
        assert_eq!(mesh.positions.len(), 9);
        assert_eq!(mesh.vertex_starts().vertex_count(9), 5);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        #[test]
        fn face_colours_staged_equal_the_in_memory_import(n in 3usize..60, faces in 1usize..120, seed in any::<u64>(), budget in prop_oneof![Just(0usize), Just(1 << 30)]) {
            same_as_in_memory(&off(n, faces, seed), budget);
        }
    }
}
