//! The out-of-core weld keeps no wedges yet (`mesh.rs`): where the in-memory weld would keep
//! corners at one position apart because their attributes differ (texture seams, creases,
//! per-face colours), a staged import is refused with [`refused`] rather than welded into
//! different bytes than `tessera build` without `--memory` gives.

use std::io;
use std::path::Path;

use super::fallible::check;
use super::sort::sort_external;
use super::staged::{RecordFile, VertexAttributes};

/// What a refused staged import says (exit 2 at the CLI).
pub const SEAMS_NOT_STAGED: &str = "corners at one position differ in normal, colour or \
    texture coordinate (texture seams or creases, kept as wedges by the in-memory build): the \
    out-of-core build (--memory) does not keep wedges yet; build without --memory";

/// The error of a refused staged import.
pub fn refused() -> io::Error {
    io::Error::new(io::ErrorKind::Unsupported, SEAMS_NOT_STAGED)
}

/// Fails with [`refused`] where two raw vertices of one position group (`representative`: each
/// raw vertex's group's first vertex, in raw order) carry different attributes, used by a
/// triangle or not: the out-of-core weld keeps the group's first vertex's attributes, the
/// in-memory weld its first used corner's, so an unused first vertex with other attributes
/// would give other bytes (a proptest regression seed, `proptest-regressions/`). The check may
/// refuse what the in-memory weld would weld, never the reverse. One external sort of (group,
/// attribute bits) of the raw vertices, within about `budget` bytes.
pub(crate) fn refuse_seams(
    representative: &RecordFile<u32>,
    attributes: &VertexAttributes,
    budget: usize,
    dir: &Path,
) -> io::Result<()> {
    let a = attributes;
    if a.normals.is_none() && a.colors.is_none() && a.uvs.is_none() {
        return Ok(());
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
            return Err(refused());
        }
        previous = Some(record);
    }
    Ok(())
}
