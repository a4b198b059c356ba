//! A level's simplification results under a memory budget: each diamond's new patches and
//! vertex count changes (the bulk of a result) go to an unnamed file as soon as the worker has
//! them, and come back one diamond at a time when its batch merges. What deciding the batches
//! needs (growth records, conflicts, border checks) stays in memory, so the batches, and the
//! bytes, are the ones the in-memory build decides. The file lives for one level.
//!
//! Workers append concurrently: each reserves its range with an atomic add and writes it with
//! `pwrite`, so the file's layout depends on timing but every result finds its own bytes.

use std::fs::File;
use std::io;
use std::os::unix::fs::FileExt;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

use tessera_core::leb::SimplexKey;

use super::live_record::{decode_patch, encode_patch};
use super::positions::SimplifierScale;
use crate::external::temp_usage::{Charge, TempKind};
use crate::vertex_table::LivePatch;

/// A diamond's new patches and vertex count changes (sorted by shard).
#[derive(Debug, Default, PartialEq)]
pub(super) struct Payload {
    pub patches: Vec<(SimplexKey, LivePatch)>,
    pub vertices: Vec<(u32, i32)>,
}

/// Where a result's payload is.
#[derive(Debug)]
pub(super) enum Held {
    Memory(Payload),
    Spilled {
        at: u64,
        bytes: u64,
    },
    /// In a part file of the build's checkpoint (`partial_level.rs`), which stays until the
    /// level is committed: the spill's copy is given back once the part is saved.
    InPart {
        file: std::sync::Arc<File>,
        at: u64,
        bytes: u64,
    },
}

/// The level's spill file, or none (results held in memory).
pub(super) struct ResultSpill {
    file: Option<File>,
    end: AtomicU64,
    charge: Charge,
    scale: SimplifierScale,
    /// Whether the level's part files (`Held::InPart`) are no longer named by the checkpoint
    /// (`adopt_parts`): their payloads' bytes are then given back as they are taken.
    parts_adopted: std::sync::atomic::AtomicBool,
}

impl ResultSpill {
    /// `scale`: as the live store's (`live_record.rs`).
    pub(super) fn new(dir: Option<&Path>, scale: SimplifierScale) -> io::Result<ResultSpill> {
        Ok(ResultSpill {
            file: dir.map(tempfile::tempfile_in).transpose()?,
            end: AtomicU64::new(0),
            charge: Charge::new(TempKind::ResultSpill),
            scale,
            parts_adopted: std::sync::atomic::AtomicBool::new(false),
        })
    }

    /// Keeps `payload` (in memory without a file).
    pub(super) fn hold(&self, payload: Payload) -> io::Result<Held> {
        let Some(file) = &self.file else {
            return Ok(Held::Memory(payload));
        };
        let bytes = encode(&payload, &self.scale);
        let at = self.end.fetch_add(bytes.len() as u64, Ordering::Relaxed);
        file.write_all_at(&bytes, at)?;
        self.charge.grow(bytes.len() as u64);
        Ok(Held::Spilled {
            at,
            bytes: bytes.len() as u64,
        })
    }

    /// The payload kept by `hold`; its bytes' disk space is given back (`release`).
    pub(super) fn take(&self, held: Held) -> io::Result<Payload> {
        match held {
            Held::Memory(payload) => Ok(payload),
            Held::Spilled { at, bytes } => {
                let file = self.file.as_ref().expect("spilled without a file");
                let mut buffer = vec![0u8; bytes as usize];
                file.read_exact_at(&mut buffer, at)?;
                self.release(&held);
                decode(&buffer, &self.scale)
            }
            Held::InPart {
                ref file,
                at,
                bytes,
            } => {
                let mut buffer = vec![0u8; bytes as usize];
                file.read_exact_at(&mut buffer, at)?;
                self.release(&held);
                decode(&buffer, &self.scale)
            }
        }
    }

    /// Takes over the level's part files once the checkpoint no longer names them (the level
    /// merges: `bytes` of them, still open, charged here), so that their payloads' disk space
    /// is given back as they are taken, as the spill's is.
    pub(super) fn adopt_parts(&self, bytes: u64) {
        self.charge.grow(bytes);
        self.parts_adopted.store(true, Ordering::Relaxed);
    }

    /// The bytes `encode` makes of a held payload, left held (a mid-level checkpoint copies
    /// them: `partial_level.rs`).
    pub(super) fn bytes_of(&self, held: &Held) -> io::Result<Vec<u8>> {
        match held {
            Held::Memory(payload) => Ok(encode(payload, &self.scale)),
            Held::Spilled { at, bytes } => {
                let file = self.file.as_ref().expect("spilled without a file");
                let mut buffer = vec![0u8; *bytes as usize];
                file.read_exact_at(&mut buffer, *at)?;
                Ok(buffer)
            }
            Held::InPart { file, at, bytes } => {
                let mut buffer = vec![0u8; *bytes as usize];
                file.read_exact_at(&mut buffer, *at)?;
                Ok(buffer)
            }
        }
    }

    /// Gives back the disk space of a payload that will not be taken again (taken, or
    /// replaced by a diamond's simplification again): the whole blocks inside its bytes, so
    /// the file holds about the results not yet merged rather than the whole level's.
    pub(super) fn release(&self, held: &Held) {
        let (file, at, bytes) = match held {
            Held::Spilled { at, bytes } => match &self.file {
                Some(file) => (file, *at, *bytes),
                None => return,
            },
            // Named by the checkpoint until adopted: left as it is.
            Held::InPart { file, at, bytes } if self.parts_adopted.load(Ordering::Relaxed) => {
                (&**file, *at, *bytes)
            }
            _ => return,
        };
        self.charge
            .shrink(crate::external::holes::punch(file, at, at + bytes));
    }
}

fn encode(payload: &Payload, scale: &SimplifierScale) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&(payload.patches.len() as u32).to_le_bytes());
    for (key, patch) in &payload.patches {
        out.push(key.root);
        out.extend_from_slice(&key.level.to_le_bytes());
        out.extend_from_slice(&key.path.to_le_bytes());
        let bytes = encode_patch(patch, scale);
        out.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
        out.extend_from_slice(&bytes);
    }
    out.extend_from_slice(&(payload.vertices.len() as u64).to_le_bytes());
    for &(v, d) in &payload.vertices {
        out.extend_from_slice(&v.to_le_bytes());
        out.extend_from_slice(&d.to_le_bytes());
    }
    out
}

fn decode(bytes: &[u8], scale: &SimplifierScale) -> std::io::Result<Payload> {
    // Read back from this build's spill file or from a checkpoint's part whose CRC-32 matched,
    // so a payload that does not decode is a bug or damage: an error, not a panic.
    let cut = || std::io::Error::new(std::io::ErrorKind::InvalidData, "a result payload is cut");
    let mut at = 0usize;
    let mut take = |n: usize| -> std::io::Result<&[u8]> {
        let end = at
            .checked_add(n)
            .filter(|&e| e <= bytes.len())
            .ok_or_else(cut)?;
        let part = &bytes[at..end];
        at = end;
        Ok(part)
    };
    let u32_of = |b: &[u8]| u32::from_le_bytes(b.try_into().expect("4 bytes"));
    let u64_of = |b: &[u8]| u64::from_le_bytes(b.try_into().expect("8 bytes"));
    let count = u32_of(take(4)?);
    // Each patch takes at least 27 bytes (key and length).
    let mut patches = Vec::with_capacity((count as usize).min(bytes.len() / 27));
    for _ in 0..count {
        let root = take(1)?[0];
        let level = u16::from_le_bytes(take(2)?.try_into().expect("2 bytes"));
        let path = u128::from_le_bytes(take(16)?.try_into().expect("16 bytes"));
        let n = usize::try_from(u64_of(take(8)?)).map_err(|_| cut())?;
        patches.push((
            SimplexKey { root, level, path },
            decode_patch(take(n)?, scale)?,
        ));
    }
    let n = usize::try_from(u64_of(take(8)?)).map_err(|_| cut())?;
    let mut vertices = Vec::with_capacity(n.min(bytes.len() / 8));
    for _ in 0..n {
        let v = u32_of(take(4)?);
        let d = i32::from_le_bytes(take(4)?.try_into().expect("4 bytes"));
        vertices.push((v, d));
    }
    Ok(Payload { patches, vertices })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simplify::live_record::tests::scale;
    use crate::vertex_table::VertexTable;
    use tessera_core::leb::Simplex;

    #[test]
    fn a_spilled_payload_comes_back_as_it_went() {
        let dir = tempfile::tempdir().unwrap();
        let roots = Simplex::roots(3, 10);
        let payload = |seed: u32| Payload {
            patches: roots
                .iter()
                .take(2)
                .map(|r| {
                    let [_, child] = r.children();
                    let ids = vec![seed, seed + 1, seed + 2];
                    (
                        child.key,
                        LivePatch {
                            triangles: vec![[seed, seed + 1, seed + 2]],
                            vertices: VertexTable {
                                positions: ids.iter().map(|&g| [g as f64, 1.0, 2.0]).collect(),
                                // Half the patches' simplifier positions are the scale's.
                                simplifier: ids
                                    .iter()
                                    .map(|&g| match seed % 20 {
                                        0 => scale().position([g as f64, 1.0, 2.0]),
                                        _ => [g as f32, 0.0, 0.5],
                                    })
                                    .collect(),
                                normals: Some(vec![[0.0, 0.0, 1.0]; 3]),
                                colors: None,
                                uvs: Some(vec![[0.5, 0.25]; 3]),
                                ids,
                            },
                        },
                    )
                })
                .collect(),
            vertices: vec![(seed, -3), (seed + 7, 2)],
        };
        let spill = ResultSpill::new(Some(dir.path()), scale()).unwrap();
        let held: Vec<Held> = (0..5)
            .map(|s| spill.hold(payload(s * 10)).unwrap())
            .collect();
        for (s, h) in held.into_iter().enumerate().rev() {
            assert!(matches!(h, Held::Spilled { .. }));
            assert_eq!(spill.take(h).unwrap(), payload(s as u32 * 10));
        }
        let memory = ResultSpill::new(None, scale()).unwrap();
        let h = memory.hold(payload(3)).unwrap();
        assert!(matches!(h, Held::Memory(_)));
        assert_eq!(memory.take(h).unwrap(), payload(3));
    }
}
