//! The finished patches' records (what the tet table needs of each: sphere, cone, counts,
//! checksum, where its bytes are), by row in the order the patches finished: in memory, or
//! under a memory budget in a file of fixed-size records, each with its key, so that a
//! checkpoint's index is rebuilt by reading the file once (`checkpoint.rs`).

use std::io;
use std::os::unix::fs::FileExt;

use tessera_core::bounds::{NormalCone, Sphere};

use super::{FinishedPatch, Spill};
use crate::packed_key::PackedKey;

/// A record on disk: the key's four words, the sphere (four f64), the cone (four f32), six
/// u32 counts and two u64 offsets, little-endian.
pub(super) const RECORD_BYTES: usize = 16 + 32 + 16 + 24 + 16;

pub(super) enum Records {
    Memory(Vec<FinishedPatch>),
    Disk(Spill),
}

impl Records {
    pub(super) fn len(&self) -> usize {
        match self {
            Records::Memory(records) => records.len(),
            Records::Disk(spill) => (spill.bytes / RECORD_BYTES as u64) as usize,
        }
    }

    pub(super) fn reserve(&mut self, records: usize) {
        if let Records::Memory(all) = self {
            all.reserve_exact(records.saturating_sub(all.len()));
        }
    }

    /// Appends `patch`'s record; returns its row.
    pub(super) fn push(&mut self, key: PackedKey, patch: &FinishedPatch) -> io::Result<u32> {
        let row = u32::try_from(self.len()).expect("under 2^32 simplices");
        match self {
            Records::Memory(records) => records.push(*patch),
            Records::Disk(spill) => {
                spill.append(&encode(key, patch))?;
            }
        }
        Ok(row)
    }

    /// Makes every appended record readable by [`Self::get`].
    pub(super) fn flush(&mut self) -> io::Result<()> {
        match self {
            Records::Memory(_) => Ok(()),
            Records::Disk(spill) => io::Write::flush(&mut spill.writer),
        }
    }

    /// The record of `row` (appended and flushed).
    pub(super) fn get(&self, row: u32) -> io::Result<FinishedPatch> {
        match self {
            Records::Memory(records) => Ok(records[row as usize]),
            Records::Disk(spill) => {
                if !spill.writer.buffer().is_empty() {
                    return Err(io::Error::other("a finished record read before a flush"));
                }
                let mut bytes = [0u8; RECORD_BYTES];
                let at = row as u64 * RECORD_BYTES as u64;
                spill.writer.get_ref().read_exact_at(&mut bytes, at)?;
                Ok(decode(&bytes).1)
            }
        }
    }
}

pub(super) fn encode(key: PackedKey, p: &FinishedPatch) -> [u8; RECORD_BYTES] {
    let mut out = [0u8; RECORD_BYTES];
    let mut at = 0;
    let mut put = |bytes: &[u8]| {
        out[at..at + bytes.len()].copy_from_slice(bytes);
        at += bytes.len();
    };
    key.0.iter().for_each(|w| put(&w.to_le_bytes()));
    p.sphere.center.iter().for_each(|x| put(&x.to_le_bytes()));
    put(&p.sphere.radius.to_le_bytes());
    p.cone.axis.iter().for_each(|x| put(&x.to_le_bytes()));
    put(&p.cone.cos.to_le_bytes());
    for x in [
        p.vertex_count,
        p.strip_index_count,
        p.triangle_count,
        p.patch_bytes,
        p.id_bytes,
        p.patch_checksum,
    ] {
        put(&x.to_le_bytes());
    }
    put(&p.patch_at.to_le_bytes());
    put(&p.id_at.to_le_bytes());
    debug_assert_eq!(at, RECORD_BYTES);
    out
}

/// The key's words (not checked) and the record.
pub(super) fn decode(bytes: &[u8; RECORD_BYTES]) -> ([u32; 4], FinishedPatch) {
    let mut at = 0;
    let mut take = |n: usize| {
        at += n;
        &bytes[at - n..at]
    };
    let mut u32_ = || u32::from_le_bytes(take(4).try_into().expect("4 bytes"));
    let key = [u32_(), u32_(), u32_(), u32_()];
    let mut f64_ = || f64::from_le_bytes(take(8).try_into().expect("8 bytes"));
    let (center, radius) = ([f64_(), f64_(), f64_()], f64_());
    let mut f32_ = || f32::from_le_bytes(take(4).try_into().expect("4 bytes"));
    let (axis, cos) = ([f32_(), f32_(), f32_()], f32_());
    let mut u32_ = || u32::from_le_bytes(take(4).try_into().expect("4 bytes"));
    let counts = [u32_(), u32_(), u32_(), u32_(), u32_(), u32_()];
    let mut u64_ = || u64::from_le_bytes(take(8).try_into().expect("8 bytes"));
    let (patch_at, id_at) = (u64_(), u64_());
    let patch = FinishedPatch {
        sphere: Sphere { center, radius },
        cone: NormalCone { axis, cos },
        vertex_count: counts[0],
        strip_index_count: counts[1],
        triangle_count: counts[2],
        patch_bytes: counts[3],
        id_bytes: counts[4],
        patch_checksum: counts[5],
        patch_at,
        id_at,
    };
    (key, patch)
}
