//! Which staged imports need wedges (`mesh.rs`, `weld_wedges.rs`): [`has_seams`] tells the
//! out-of-core weld whether corners at one position may differ in attributes; [`refused`] is
//! what an import says where it still cannot keep wedges out of core (an OBJ's corners with
//! their own `vt` or `vn` indices) rather than build other bytes than `tessera build` without
//! `--memory` gives. Per-face colours are put on corners of their own before the weld
//! (`face_colors.rs`).

use std::io;
use std::path::Path;

use super::fallible::check;
use super::sort::sort_external;
use super::staged::{RecordFile, VertexAttributes};

/// What a refused staged import says (exit 2 at the CLI).
pub const SEAMS_NOT_STAGED: &str = "an OBJ whose face corners give one vertex other texture \
    coordinates or normals (texture seams or hard edges, kept as wedges by the in-memory \
    build): the out-of-core build (--memory) does not stage those corners yet; build without \
    --memory, or convert the mesh to PLY or glTF";

/// The error of a refused staged import.
pub fn refused() -> io::Error {
    io::Error::new(io::ErrorKind::Unsupported, SEAMS_NOT_STAGED)
}

/// Whether two raw vertices of one position group (`representative`: each raw vertex's
/// group's first vertex, in raw order) carry different attributes, used by a triangle or not:
/// then the weld numbers wedges (`weld_wedges.rs`), else it welds by position and takes each
/// group's first vertex's attributes, which are all its vertices' (an unused first vertex with
/// other attributes would have given other bytes: a proptest regression seed,
/// `proptest-regressions/`). One external sort of (group, attribute bits) of the raw vertices,
/// within about `budget` bytes.
pub(crate) fn has_seams(
    representative: &RecordFile<u32>,
    attributes: &VertexAttributes,
    budget: usize,
    dir: &Path,
) -> io::Result<bool> {
    let a = attributes;
    if a.normals.is_none() && a.colors.is_none() && a.uvs.is_none() {
        return Ok(false);
    }
    let vertices = representative.len() as usize;
    let bits = |x: f32| if x == 0.0 { 0 } else { x.to_bits() };
    let mut reps = representative.read()?;
    let mut normals = a.normals.as_ref().map(RecordFile::read).transpose()?;
    let mut colors = a.colors.as_ref().map(RecordFile::read).transpose()?;
    let mut uvs = a.uvs.as_ref().map(RecordFile::read).transpose()?;
    let mut error = None;
    let mut fail = |e: io::Error| {
        error.get_or_insert(e);
    };
    let records = (0..vertices).map(|_| {
        let mut record = [0u32; 7];
        match reps.next() {
            Some(Ok(r)) => record[0] = r,
            Some(Err(e)) => fail(e),
            None => fail(io::Error::other("a representative missing")),
        }
        if let Some(Some(n)) = normals.as_mut().map(Iterator::next) {
            n.map(|n| record[1..4].copy_from_slice(&n.map(bits)))
                .unwrap_or_else(&mut fail);
        }
        if let Some(Some(c)) = colors.as_mut().map(Iterator::next) {
            c.map(|c| record[4] = u32::from_le_bytes(c))
                .unwrap_or_else(&mut fail);
        }
        if let Some(Some(uv)) = uvs.as_mut().map(Iterator::next) {
            uv.map(|uv| record[5..7].copy_from_slice(&uv.map(bits)))
                .unwrap_or_else(&mut fail);
        }
        record
    });
    let sorted = sort_external(records, budget / 2, dir)?;
    check(error)?;
    let mut previous: Option<[u32; 7]> = None;
    for record in sorted {
        let record = record?;
        if previous.is_some_and(|p| p[0] == record[0] && p != record) {
            return Ok(true);
        }
        previous = Some(record);
    }
    Ok(false)
}
