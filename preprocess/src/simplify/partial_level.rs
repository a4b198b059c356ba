//! A level's simplification results written into the build's checkpoint as they are made, so
//! that a build killed inside a level resumes with the diamonds already simplified instead of
//! simplifying the whole level again (issue 12: resuming after a kill at 75 % of a build takes
//! at most 40 % of a build; the deepest levels take several seconds each at 10 M triangles).
//!
//! Every diamond of a level is simplified against the state the previous level left, which
//! nothing changes until the level merges, so a result made before a kill is the one a resumed
//! build would make: the merge, and the bytes, are the uninterrupted build's. A part holds
//! results in the level's order; the parts of a level, read in order, are a prefix of it.

use std::io;

use super::batches::MergeEffect;
use super::conformity::BorderBreak;
use super::current_mesh::CountChanges;
use super::result_spill::ResultSpill;
use super::DiamondResult;
use crate::checkpoint::{Dec, Enc};

/// The bytes of `results` (their payloads copied from `spill`).
pub(super) fn encode_results(
    results: &[&DiamondResult],
    spill: &ResultSpill,
    e: &mut Enc,
) -> io::Result<()> {
    e.u64(results.len() as u64);
    for r in results {
        e.u64(r.diamond as u64);
        let payload = spill.bytes_of(&r.payload)?;
        e.u64(payload.len() as u64);
        e.bytes(&payload);
        e.f32(r.error);
        e.u64(r.locked as u64);
        let effect = &r.effect;
        e.list(&effect.changes.tracked_edges, |e, &(k, d)| {
            e.u64(k);
            e.i32(d);
        });
        e.list(&effect.local_conflicts, |e, &k| e.u64(k));
        e.list(&effect.shared_growth, |e, &(k, d)| {
            e.u64(k);
            e.i32(d);
        });
        e.list(&effect.conflicts, |e, &k| e.u64(k));
        e.list(r.border_break.as_slice(), border);
        e.list(&r.border_break_if_used_outside, border);
    }
    Ok(())
}

fn border(e: &mut Enc, b: &BorderBreak) {
    e.u32(b.a);
    e.u32(b.b);
    e.u32(b.gathered_uses);
    e.u32(b.output_uses);
}

fn border_of(d: &mut Dec) -> io::Result<BorderBreak> {
    Ok(BorderBreak {
        a: d.u32()?,
        b: d.u32()?,
        gathered_uses: d.u32()?,
        output_uses: d.u32()?,
    })
}

fn invalid(what: &str) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!("a level's part: {what}"),
    )
}

/// The results `encode_results` wrote, their payloads held by `spill`.
pub(super) fn decode_results(bytes: &[u8], spill: &ResultSpill) -> io::Result<Vec<DiamondResult>> {
    let mut d = Dec::new(bytes);
    let n = d.u64()?;
    if n > bytes.len() as u64 {
        return Err(invalid("more results than bytes"));
    }
    let mut results = Vec::with_capacity(n as usize);
    for _ in 0..n {
        let diamond = usize::try_from(d.u64()?).map_err(|_| invalid("a diamond index"))?;
        let len = usize::try_from(d.u64()?).map_err(|_| invalid("a payload length"))?;
        let payload = d.take_bytes(len)?;
        let payload = spill.hold_bytes(payload)?;
        let error = d.f32()?;
        let locked = d.u64()? as usize;
        let tracked_edges = d.list(12, |d| Ok((d.u64()?, d.i32()?)))?;
        let local_conflicts = d.list(8, |d| d.u64())?;
        let shared_growth = d.list(12, |d| Ok((d.u64()?, d.i32()?)))?;
        let conflicts = d.list(8, |d| d.u64())?;
        let mut border_break = d.list(16, border_of)?;
        if border_break.len() > 1 {
            return Err(invalid("two border breaks"));
        }
        let border_break_if_used_outside = d.list(16, border_of)?;
        results.push(DiamondResult {
            diamond,
            payload,
            error,
            locked,
            effect: MergeEffect {
                changes: CountChanges {
                    vertices: Vec::new(),
                    tracked_edges,
                },
                local_conflicts,
                shared_growth,
                conflicts,
            },
            border_break: border_break.pop(),
            border_break_if_used_outside,
        });
    }
    d.finish()?;
    Ok(results)
}
