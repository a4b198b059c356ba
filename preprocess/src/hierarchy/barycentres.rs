//! Where the bucketed construction reads its triangles from: every triangle's barycentre
//! (index, lattice coordinates), streamed as often as asked — from memory, computed from an
//! in-memory mesh, or spooled once to an unnamed file — and the 28-byte record the buckets
//! and the spool store them as.

use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom, Write};

use crate::frame::LatticeFrame;
use crate::mesh::InputMesh;

/// Streams every input triangle's barycentre (lattice coordinates), as often as asked.
pub trait BarycentreSource {
    /// Calls `f(index, barycentre)` for every triangle, with indices 0, 1, 2, … in order and
    /// the same barycentres on every call.
    fn for_each_barycentre(&self, f: &mut dyn FnMut(u32, [f64; 3])) -> io::Result<()>;

    /// The last pass a construction makes: `for_each_barycentre`, after which the source may
    /// have given back what it held (a spool frees its disk as it is read) and cannot stream
    /// again.
    fn for_each_barycentre_last(&self, f: &mut dyn FnMut(u32, [f64; 3])) -> io::Result<()> {
        self.for_each_barycentre(f)
    }
}

/// Barycentres held in memory (tests, small inputs).
impl BarycentreSource for [[f64; 3]] {
    fn for_each_barycentre(&self, f: &mut dyn FnMut(u32, [f64; 3])) -> io::Result<()> {
        for (t, b) in self.iter().enumerate() {
            f(t as u32, *b);
        }
        Ok(())
    }
}

/// The barycentres of an in-memory mesh's triangles, computed on the fly as the build computes
/// them (`frame.barycentre` of the three corners), so nothing per triangle is kept.
pub struct MeshBarycentres<'a> {
    pub frame: &'a LatticeFrame,
    pub mesh: &'a InputMesh,
}

impl BarycentreSource for MeshBarycentres<'_> {
    fn for_each_barycentre(&self, f: &mut dyn FnMut(u32, [f64; 3])) -> io::Result<()> {
        let positions = &self.mesh.positions;
        for (t, tri) in self.mesh.triangles.iter().enumerate() {
            f(
                t as u32,
                self.frame.barycentre(tri.map(|v| positions[v as usize])),
            );
        }
        Ok(())
    }
}

/// A source's barycentres written once, in order, to an unnamed temporary file and streamed
/// back from it sequentially as often as asked (24 bytes a triangle, the barycentre alone: the
/// index is the record's place; the file is gone when
/// this is dropped, or if the process dies). For sources that are costly to stream again, such
/// as a mesh whose vertices are not in memory or not in triangle order: the bucketed
/// construction then reads the source once.
pub struct SpooledBarycentres {
    file: File,
    triangles: u64,
    charge: crate::external::temp_usage::Charge,
    /// Set by the last pass, which frees the file.
    consumed: std::sync::atomic::AtomicBool,
}

/// Bytes the last pass reads between two holes it punches behind itself.
const CONSUME_BLOCK: usize = 1 << 20;

/// Bytes of a spooled barycentre (3 × f64, little-endian).
const SPOOL_RECORD: usize = 24;

fn write_spooled(out: &mut impl Write, q: [f64; 3]) -> io::Result<()> {
    let mut record = [0u8; SPOOL_RECORD];
    for (i, x) in q.iter().enumerate() {
        record[8 * i..8 * i + 8].copy_from_slice(&x.to_le_bytes());
    }
    out.write_all(&record)
}

fn read_spooled(r: &[u8]) -> [f64; 3] {
    [0, 1, 2].map(|i| f64::from_le_bytes(r[8 * i..8 * i + 8].try_into().unwrap()))
}

impl SpooledBarycentres {
    /// Streams `source` once into a temporary file in `temp_dir`.
    pub fn new(
        source: &(impl BarycentreSource + ?Sized),
        temp_dir: &std::path::Path,
    ) -> io::Result<SpooledBarycentres> {
        let mut file = tempfile::tempfile_in(temp_dir)?;
        let mut order = InOrder::default();
        let mut io_error = None;
        // Charged as it is written (a block of records at a time), not once written: other
        // temporary files grow beside it.
        const CHARGE_EVERY: u64 = 1 << 15;
        let charge = crate::external::temp_usage::Charge::new(
            crate::external::temp_usage::TempKind::Barycentres,
        );
        {
            let mut out = io::BufWriter::with_capacity(1 << 20, &mut file);
            let mut written = 0u64;
            source.for_each_barycentre(&mut |t, q| {
                if io_error.is_some() || !order.accept(t) {
                    return;
                }
                if let Err(e) = write_spooled(&mut out, q) {
                    io_error = Some(e);
                }
                written += 1;
                if written.is_multiple_of(CHARGE_EVERY) {
                    charge.grow(CHARGE_EVERY * SPOOL_RECORD as u64);
                }
            })?;
            if let Some(e) = io_error {
                return Err(e);
            }
            out.flush()?;
        }
        let triangles = order.finish(None)?;
        charge.grow(triangles * SPOOL_RECORD as u64 - charge.bytes());
        Ok(SpooledBarycentres {
            file,
            triangles,
            charge,
            consumed: Default::default(),
        })
    }

    /// Triangles spooled.
    pub fn len(&self) -> u64 {
        self.triangles
    }

    pub fn is_empty(&self) -> bool {
        self.triangles == 0
    }
}

impl SpooledBarycentres {
    fn check_not_consumed(&self) -> io::Result<()> {
        if self.consumed.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(io::Error::other(
                "spooled barycentres streamed after their last pass",
            ));
        }
        Ok(())
    }
}

impl BarycentreSource for SpooledBarycentres {
    fn for_each_barycentre(&self, f: &mut dyn FnMut(u32, [f64; 3])) -> io::Result<()> {
        self.check_not_consumed()?;
        let mut file = &self.file;
        file.seek(SeekFrom::Start(0))?;
        let mut input = io::BufReader::with_capacity(1 << 20, file);
        let mut record = [0u8; SPOOL_RECORD];
        for t in 0..self.triangles {
            input.read_exact(&mut record)?;
            f(t as u32, read_spooled(&record));
        }
        Ok(())
    }

    /// Reads a block at a time and punches a hole behind each block read, so that the
    /// spool's disk shrinks as whatever this pass writes grows; the file is emptied at the end.
    fn for_each_barycentre_last(&self, f: &mut dyn FnMut(u32, [f64; 3])) -> io::Result<()> {
        use crate::external::holes::punch;
        self.check_not_consumed()?;
        self.consumed
            .store(true, std::sync::atomic::Ordering::Relaxed);
        let mut file = &self.file;
        file.seek(SeekFrom::Start(0))?;
        let block_records = CONSUME_BLOCK / SPOOL_RECORD;
        let mut block = vec![0u8; block_records * SPOOL_RECORD];
        let (mut read, mut freed_to) = (0u64, 0u64);
        while read < self.triangles {
            let records = (self.triangles - read).min(block_records as u64) as usize;
            let bytes = &mut block[..records * SPOOL_RECORD];
            file.read_exact(bytes)?;
            for (i, record) in bytes.chunks_exact(SPOOL_RECORD).enumerate() {
                f((read + i as u64) as u32, read_spooled(record));
            }
            read += records as u64;
            let end = read * SPOOL_RECORD as u64;
            self.charge.shrink(punch(&self.file, freed_to, end));
            freed_to = end / 4096 * 4096;
        }
        self.file.set_len(0)?;
        self.charge.release();
        Ok(())
    }
}

/// Checks that a source streams 0, 1, 2, … and counts it.
#[derive(Default)]
pub(super) struct InOrder {
    next: u64,
    broken: bool,
}

impl InOrder {
    pub(super) fn accept(&mut self, t: u32) -> bool {
        if self.broken || t as u64 != self.next {
            self.broken = true;
            return false;
        }
        self.next += 1;
        true
    }

    pub(super) fn finish(&self, expected: Option<u64>) -> io::Result<u64> {
        if self.broken || expected.is_some_and(|n| n != self.next) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                "bucketed hierarchy: the triangle source must stream indices 0, 1, 2, … in \
                 order, the same triangles on every pass",
            ));
        }
        Ok(self.next)
    }
}

/// Bytes of one record: index (u32) and barycentre (3 × f64), little-endian.
pub(super) const RECORD_BYTES: usize = 4 + 3 * 8;

pub(super) fn write_record(out: &mut impl Write, t: u32, q: [f64; 3]) -> io::Result<()> {
    let mut record = [0u8; RECORD_BYTES];
    record[0..4].copy_from_slice(&t.to_le_bytes());
    for (i, x) in q.iter().enumerate() {
        record[4 + 8 * i..12 + 8 * i].copy_from_slice(&x.to_le_bytes());
    }
    out.write_all(&record)
}

pub(super) fn read_record(r: &[u8]) -> (u32, [f64; 3]) {
    let t = u32::from_le_bytes(r[0..4].try_into().unwrap());
    let q = [0, 1, 2].map(|i| f64::from_le_bytes(r[4 + 8 * i..12 + 8 * i].try_into().unwrap()));
    (t, q)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn collect(
        f: impl FnOnce(&mut dyn FnMut(u32, [f64; 3])) -> io::Result<()>,
    ) -> Vec<(u32, [f64; 3])> {
        let mut out = Vec::new();
        f(&mut |t, q| out.push((t, q))).unwrap();
        out
    }

    #[test]
    fn a_spool_streams_the_same_until_its_last_pass_frees_it() {
        let dir = tempfile::tempdir().unwrap();
        // More than one of the last pass's blocks.
        let source: Vec<[f64; 3]> = (0..100_000)
            .map(|i| [i as f64 / 7.0, -(i as f64), 1e-300 * i as f64])
            .collect();
        let spool = SpooledBarycentres::new(&source[..], dir.path()).unwrap();
        let expected: Vec<(u32, [f64; 3])> = source
            .iter()
            .enumerate()
            .map(|(t, q)| (t as u32, *q))
            .collect();
        assert_eq!(collect(|f| spool.for_each_barycentre(f)), expected);
        assert_eq!(collect(|f| spool.for_each_barycentre(f)), expected);
        assert_eq!(collect(|f| spool.for_each_barycentre_last(f)), expected);
        assert_eq!(spool.file.metadata().unwrap().len(), 0);
        assert_eq!(spool.charge.bytes(), 0);
        assert!(spool.for_each_barycentre(&mut |_, _| {}).is_err());
        assert!(spool.for_each_barycentre_last(&mut |_, _| {}).is_err());
    }
}
