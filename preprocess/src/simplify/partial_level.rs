//! A level's simplification results written into the build's checkpoint as they are made, so
//! that a build killed inside a level resumes with the diamonds already simplified instead of
//! simplifying the whole level again (issue 12: resuming after a kill at 75 % of a build takes
//! at most 40 % of a build; the deepest levels take several seconds each at 10 M triangles).
//!
//! Every diamond of a level is simplified against the state the previous level left, which
//! nothing changes until the level merges, so a result made before a kill is the one a resumed
//! build would make: the merge, and the bytes, are the uninterrupted build's. A part holds
//! results in the level's order; the parts of a level, read in order, are a prefix of it.
//! A saved result's payload is then read from its part (`Held::InPart`) and the level's spill
//! gives its copy back, so the parts add no temporary disk; a resumed build reads a part's
//! fields a record at a time and leaves the payloads in the file.

use std::fs::File;
use std::io::{self, BufReader, Read};
use std::path::Path;
use std::sync::Arc;

use super::attribute_error::AttributeError;
use super::batches::MergeEffect;
use super::conformity::BorderBreak;
use super::current_mesh::CountChanges;
use super::result_spill::{Held, ResultSpill};
use super::DiamondResult;
use crate::checkpoint::Enc;

/// Writes `results` (their payloads copied from `spill`) and returns where each payload is
/// in the written bytes: (offset, length).
pub(super) fn encode_results(
    results: &[&DiamondResult],
    spill: &ResultSpill,
    e: &mut Enc,
) -> io::Result<Vec<(u64, u64)>> {
    let mut spans = Vec::with_capacity(results.len());
    e.u64(results.len() as u64);
    for r in results {
        e.u64(r.diamond as u64);
        let payload = spill.bytes_of(&r.payload)?;
        e.u64(payload.len() as u64);
        spans.push((e.position(), payload.len() as u64));
        e.bytes(&payload);
        e.f32(r.error);
        for x in [
            r.attribute_error.colour,
            r.attribute_error.normal_degrees,
            r.attribute_error.uv,
        ] {
            e.f32(x);
        }
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
    Ok(spans)
}

fn border(e: &mut Enc, b: &BorderBreak) {
    e.u32(b.a);
    e.u32(b.b);
    e.u32(b.gathered_uses);
    e.u32(b.output_uses);
}

fn invalid(what: &str) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!("a level's part: {what}"),
    )
}

/// A part file read a field at a time, every read and count checked against its length.
struct PartReader {
    reader: BufReader<File>,
    at: u64,
    len: u64,
}

impl PartReader {
    fn bytes<const N: usize>(&mut self) -> io::Result<[u8; N]> {
        if self.len - self.at < N as u64 {
            return Err(invalid("cut short"));
        }
        let mut out = [0u8; N];
        self.reader.read_exact(&mut out)?;
        self.at += N as u64;
        Ok(out)
    }
    fn u32(&mut self) -> io::Result<u32> {
        Ok(u32::from_le_bytes(self.bytes()?))
    }
    fn i32(&mut self) -> io::Result<i32> {
        Ok(i32::from_le_bytes(self.bytes()?))
    }
    fn u64(&mut self) -> io::Result<u64> {
        Ok(u64::from_le_bytes(self.bytes()?))
    }
    fn f32(&mut self) -> io::Result<f32> {
        Ok(f32::from_bits(self.u32()?))
    }
    /// Skips `n` bytes (a payload left in the file).
    fn skip(&mut self, n: u64) -> io::Result<()> {
        if self.len - self.at < n {
            return Err(invalid("a payload past the end"));
        }
        self.reader.seek_relative(n as i64)?;
        self.at += n;
        Ok(())
    }
    /// A list `Enc::list` wrote, each item at least `min_item_bytes`.
    fn list<T>(
        &mut self,
        min_item_bytes: u64,
        mut f: impl FnMut(&mut Self) -> io::Result<T>,
    ) -> io::Result<Vec<T>> {
        let n = self.u64()?;
        if n.saturating_mul(min_item_bytes) > self.len - self.at {
            return Err(invalid("a count larger than the file"));
        }
        (0..n).map(|_| f(self)).collect()
    }
    fn border(&mut self) -> io::Result<BorderBreak> {
        Ok(BorderBreak {
            a: self.u32()?,
            b: self.u32()?,
            gathered_uses: self.u32()?,
            output_uses: self.u32()?,
        })
    }
}

/// Opens a part file for reading its payloads and, once the level merges and the
/// checkpoint no longer names it, punching them out as they are taken (which needs write
/// access: `holes::punch`).
pub(super) fn open_part(path: &Path) -> io::Result<File> {
    std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(path)
}

/// The results of the part file at `path`, their payloads left in it (`Held::InPart`).
pub(super) fn decode_results(path: &Path) -> io::Result<Vec<DiamondResult>> {
    let file = open_part(path)?;
    let len = file.metadata()?.len();
    let shared = Arc::new(file.try_clone()?);
    let mut r = PartReader {
        reader: BufReader::new(file),
        at: 0,
        len,
    };
    // A result takes at least 76 bytes (its fixed fields and empty lists).
    let n = r.u64()?;
    if n.saturating_mul(88) > len {
        return Err(invalid("more results than bytes"));
    }
    let mut results = Vec::with_capacity(n as usize);
    for _ in 0..n {
        let diamond = usize::try_from(r.u64()?).map_err(|_| invalid("a diamond index"))?;
        let bytes = r.u64()?;
        let payload = Held::InPart {
            file: shared.clone(),
            at: r.at,
            bytes,
        };
        r.skip(bytes)?;
        let error = r.f32()?;
        let attribute_error = AttributeError {
            colour: r.f32()?,
            normal_degrees: r.f32()?,
            uv: r.f32()?,
        };
        let locked = r.u64()? as usize;
        let tracked_edges = r.list(12, |r| Ok((r.u64()?, r.i32()?)))?;
        let local_conflicts = r.list(8, |r| r.u64())?;
        let shared_growth = r.list(12, |r| Ok((r.u64()?, r.i32()?)))?;
        let conflicts = r.list(8, |r| r.u64())?;
        let mut border_break = r.list(16, PartReader::border)?;
        if border_break.len() > 1 {
            return Err(invalid("two border breaks"));
        }
        let border_break_if_used_outside = r.list(16, PartReader::border)?;
        results.push(DiamondResult {
            diamond,
            payload,
            error,
            attribute_error,
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
    if r.at != len {
        return Err(invalid("trailing bytes"));
    }
    Ok(results)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simplify::live_record::tests::scale;
    use crate::simplify::result_spill::Payload;
    use crate::vertex_table::{LivePatch, VertexTable};
    use tessera_core::leb::Simplex;

    fn payload(seed: u32) -> Payload {
        let root = Simplex::roots(3, 10)[seed as usize % 6];
        let ids = vec![seed, seed + 1, seed + 2];
        Payload {
            patches: vec![(
                root.children()[1].key,
                LivePatch {
                    triangles: vec![[seed, seed + 1, seed + 2]],
                    vertices: VertexTable {
                        positions: ids.iter().map(|&g| [g as f64, 1.0, 2.0]).collect(),
                        simplifier: ids.iter().map(|&g| [g as f32, 0.0, 0.5]).collect(),
                        normals: None,
                        colors: None,
                        uvs: None,
                        ids,
                    },
                },
            )],
            vertices: vec![(seed, -3), (seed + 7, 2)],
        }
    }

    fn result(diamond: usize, payload: Held) -> DiamondResult {
        let d = diamond as u32;
        let border = |k: u32| BorderBreak {
            a: d + k,
            b: d + k + 1,
            gathered_uses: 1,
            output_uses: 2,
        };
        DiamondResult {
            diamond,
            payload,
            error: 0.25 * diamond as f32,
            attribute_error: AttributeError {
                colour: diamond as f32,
                normal_degrees: 0.5,
                uv: 0.125 * diamond as f32,
            },
            locked: 3 * diamond,
            effect: MergeEffect {
                changes: CountChanges {
                    vertices: Vec::new(),
                    tracked_edges: vec![(u64::MAX - diamond as u64, -2)],
                },
                local_conflicts: vec![7, 9],
                shared_growth: (0..diamond as u64).map(|e| (e, 1)).collect(),
                conflicts: vec![],
            },
            border_break: diamond.is_multiple_of(2).then(|| border(0)),
            border_break_if_used_outside: vec![border(5); diamond % 3],
        }
    }

    /// Everything but the payload, for comparing.
    fn fields(r: &DiamondResult) -> String {
        let e = &r.effect;
        format!(
            "{} {} {:?} {} {:?} {:?} {:?} {:?} {:?} {:?}",
            r.diamond,
            r.error,
            r.attribute_error,
            r.locked,
            e.changes.tracked_edges,
            e.local_conflicts,
            e.shared_growth,
            e.conflicts,
            r.border_break,
            r.border_break_if_used_outside
        )
    }

    #[test]
    fn a_part_comes_back_with_its_payloads_read_from_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let spill = ResultSpill::new(Some(dir.path()), scale()).unwrap();
        // Payloads spilled, and in memory (as a build without a spill directory holds them).
        let results: Vec<DiamondResult> = (0..6u32)
            .map(|i| {
                let held = match i % 2 {
                    0 => spill.hold(payload(10 * i)).unwrap(),
                    _ => Held::Memory(payload(10 * i)),
                };
                result(i as usize, held)
            })
            .collect();
        let path = dir.path().join("part.bin");
        let list: Vec<&DiamondResult> = results.iter().collect();
        let mut spans = Vec::new();
        crate::checkpoint::write_atomic_with(&path, |e| {
            spans = encode_results(&list, &spill, e)?;
            Ok(())
        })
        .unwrap();
        let back = decode_results(&path).unwrap();
        assert_eq!(back.len(), results.len());
        for ((b, r), span) in back.into_iter().zip(&results).zip(&spans) {
            assert_eq!(fields(&b), fields(r));
            match &b.payload {
                Held::InPart { at, bytes, .. } => assert_eq!((*at, *bytes), *span),
                other => panic!("{other:?}"),
            }
            let p = spill.take(b.payload).unwrap();
            assert_eq!(p, payload(10 * r.diamond as u32));
        }
        // Cut anywhere, or with a byte more, the part is refused (an error, no panic).
        let bytes = std::fs::read(&path).unwrap();
        for end in [0, 7, 8, 40, bytes.len() / 2, bytes.len() - 1] {
            std::fs::write(&path, &bytes[..end]).unwrap();
            assert!(decode_results(&path).is_err(), "cut at {end}");
        }
        std::fs::write(&path, [bytes.as_slice(), &[0]].concat()).unwrap();
        assert!(decode_results(&path).is_err());
    }
}
