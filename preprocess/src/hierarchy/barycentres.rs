//! Where the bucketed construction reads its triangles from: every triangle's barycentre
//! (index, lattice coordinates), streamed as often as asked — from memory, computed from an
//! in-memory mesh, or spooled once to an unnamed file, delta-coded (`location_codec.rs`).

use std::fs::File;
use std::io::{self, Write};

use super::location_codec::{Delta, MAX_RECORD_BYTES};

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
/// them (`frame.location` of the three corners), so nothing per triangle is kept.
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
                self.frame.location(tri.map(|v| positions[v as usize])),
            );
        }
        Ok(())
    }
}

/// A source's barycentres written once, in order, to an unnamed temporary file and streamed
/// back from it sequentially as often as asked (each delta-coded against the one before:
/// `location_codec.rs`, a few bytes a triangle where neighbours follow each other; the file
/// is gone when this is dropped, or if the process dies). For sources that are costly to
/// stream again, such as a mesh whose vertices are not in memory or not in triangle order:
/// the bucketed construction then reads the source once.
pub struct SpooledBarycentres {
    file: File,
    triangles: u64,
    /// The file's length.
    bytes: u64,
    charge: crate::external::temp_usage::Charge,
    /// Set by the last pass, which frees the file.
    consumed: std::sync::atomic::AtomicBool,
}

/// Bytes a pass reads at once; the last pass punches a hole behind each.
const CONSUME_BLOCK: usize = 1 << 20;

impl SpooledBarycentres {
    /// Streams `source` once into a temporary file in `temp_dir`.
    pub fn new(
        source: &(impl BarycentreSource + ?Sized),
        temp_dir: &std::path::Path,
    ) -> io::Result<SpooledBarycentres> {
        let mut file = tempfile::tempfile_in(temp_dir)?;
        let mut order = InOrder::default();
        let mut io_error = None;
        // Charged as it is written (a block at a time), not once written: other temporary
        // files grow beside it.
        let charge = crate::external::temp_usage::Charge::new(
            crate::external::temp_usage::TempKind::Barycentres,
        );
        // Coded a block at a time and written whole (the block is the write buffer).
        let mut block = Vec::with_capacity(CONSUME_BLOCK + MAX_RECORD_BYTES);
        let mut bytes = 0u64;
        let mut write = |block: &mut Vec<u8>| -> io::Result<()> {
            file.write_all(block)?;
            bytes += block.len() as u64;
            charge.grow(block.len() as u64);
            block.clear();
            Ok(())
        };
        let mut delta = Delta::default();
        source.for_each_barycentre(&mut |t, q| {
            if io_error.is_some() || !order.accept(t) {
                return;
            }
            delta.encode(&mut block, t, q, false);
            if block.len() >= CONSUME_BLOCK {
                if let Err(e) = write(&mut block) {
                    io_error = Some(e);
                }
            }
        })?;
        if let Some(e) = io_error {
            return Err(e);
        }
        write(&mut block)?;
        let triangles = order.finish(None)?;
        Ok(SpooledBarycentres {
            file,
            triangles,
            bytes,
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

    fn check_not_consumed(&self) -> io::Result<()> {
        if self.consumed.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(io::Error::other(
                "spooled barycentres streamed after their last pass",
            ));
        }
        Ok(())
    }

    /// Decodes every record in order, calling `behind(offset)` after each block with the
    /// offset below which the file has been read.
    fn stream(
        &self,
        f: &mut dyn FnMut(u32, [f64; 3]),
        behind: &mut dyn FnMut(u64),
    ) -> io::Result<()> {
        use std::os::unix::fs::FileExt;
        let mut buffer: Vec<u8> = Vec::with_capacity(CONSUME_BLOCK + MAX_RECORD_BYTES);
        let (mut at, mut offset) = (0usize, 0u64);
        let mut delta = Delta::default();
        for t in 0..self.triangles {
            if buffer.len() - at < MAX_RECORD_BYTES && offset < self.bytes {
                buffer.drain(..at);
                at = 0;
                behind(offset - buffer.len() as u64);
                let more = (CONSUME_BLOCK as u64).min(self.bytes - offset) as usize;
                let old = buffer.len();
                buffer.resize(old + more, 0);
                self.file.read_exact_at(&mut buffer[old..], offset)?;
                offset += more as u64;
            }
            let (_, q) = delta.decode(&buffer, &mut at, false)?;
            f(t as u32, q);
        }
        Ok(())
    }
}

impl BarycentreSource for SpooledBarycentres {
    fn for_each_barycentre(&self, f: &mut dyn FnMut(u32, [f64; 3])) -> io::Result<()> {
        self.check_not_consumed()?;
        self.stream(f, &mut |_| {})
    }

    /// Punches a hole behind each block read, so that the spool's disk shrinks as whatever
    /// this pass writes grows; the file is emptied at the end.
    fn for_each_barycentre_last(&self, f: &mut dyn FnMut(u32, [f64; 3])) -> io::Result<()> {
        use crate::external::holes::punch;
        self.check_not_consumed()?;
        self.consumed
            .store(true, std::sync::atomic::Ordering::Relaxed);
        let mut freed_to = 0u64;
        self.stream(f, &mut |read_to| {
            self.charge.shrink(punch(&self.file, freed_to, read_to));
            freed_to = freed_to.max(read_to / 4096 * 4096);
        })?;
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

/// Budget bytes a bucket's triangle is given in the distribution buffers (a record's size
/// before they were delta-coded: an index and three f64; a coded one takes less).
pub(super) const RECORD_BYTES: usize = 4 + 3 * 8;

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
