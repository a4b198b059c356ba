//! The buckets' records on disk (the bucketed construction's step 2): buffers per bucket,
//! spilled fullest first as runs into one unnamed temporary file, read back bucket by bucket.
//! Records are delta-coded (`location_codec.rs`), each run from a zero state, so a run
//! decodes on its own.

use std::fs::File;
use std::io::{self, Seek, SeekFrom, Write};
use std::os::unix::fs::FileExt;

use super::barycentres::RECORD_BYTES;
use super::bucketed::BucketBudget;
use super::location_codec::Delta;

/// The buckets' records on disk: one unnamed temporary file of runs, each run a piece of one
/// bucket's records in input order; a bucket's runs in the order they were written.
pub(super) struct BucketStore {
    pub(super) file: File,
    pub(super) end: u64,
    /// The file's bytes, in the build's temporary totals.
    pub(super) charge: crate::external::temp_usage::Charge,
    /// Per bucket: (offset, bytes) of its runs.
    pub(super) runs: Vec<Vec<(u64, u64)>>,
    pub(super) counts: Vec<u64>,
    pub(super) buffers: Vec<Vec<u8>>,
    /// Each buffer's coding state (reset when it is written as a run).
    pub(super) deltas: Vec<Delta>,
    pub(super) buffered: usize,
    /// Spill buffers when together they pass this.
    pub(super) limit: usize,
}

impl BucketStore {
    pub(super) fn new(budget: &BucketBudget, buckets: usize) -> io::Result<BucketStore> {
        let file = tempfile::tempfile_in(&budget.temp_dir)?;
        Ok(BucketStore {
            file,
            end: 0,
            charge: crate::external::temp_usage::Charge::new(
                crate::external::temp_usage::TempKind::Buckets,
            ),
            runs: vec![Vec::new(); buckets],
            counts: vec![0; buckets],
            buffers: vec![Vec::new(); buckets],
            deltas: vec![Delta::default(); buckets],
            buffered: 0,
            limit: budget.buffer_bytes.max(RECORD_BYTES),
        })
    }

    pub(super) fn push(&mut self, bucket: usize, t: u32, q: [f64; 3]) -> io::Result<()> {
        let buffer = &mut self.buffers[bucket];
        let before = buffer.len();
        self.deltas[bucket].encode(buffer, t, q, true);
        self.counts[bucket] += 1;
        self.buffered += buffer.len() - before;
        if self.buffered >= self.limit {
            self.spill(self.limit / 2)?;
        }
        Ok(())
    }

    /// Writes buffers as runs, fullest first, until at most `keep_buffered` bytes stay
    /// buffered (fullest first: fewer, longer runs than writing every buffer each time). A
    /// written buffer keeps at most an even share of the limit allocated.
    pub(super) fn spill(&mut self, keep_buffered: usize) -> io::Result<()> {
        let mut order: Vec<usize> = (0..self.buffers.len())
            .filter(|&b| !self.buffers[b].is_empty())
            .collect();
        order.sort_unstable_by_key(|&b| std::cmp::Reverse(self.buffers[b].len()));
        let keep = self.limit / self.buffers.len().max(1);
        self.file.seek(SeekFrom::Start(self.end))?;
        let mut out = io::BufWriter::with_capacity(1 << 16, &mut self.file);
        for b in order {
            if self.buffered <= keep_buffered {
                break;
            }
            let buffer = &mut self.buffers[b];
            out.write_all(buffer)?;
            self.runs[b].push((self.end, buffer.len() as u64));
            self.end += buffer.len() as u64;
            self.charge.grow(buffer.len() as u64);
            self.buffered -= buffer.len();
            buffer.clear();
            self.deltas[b] = Delta::default();
            if buffer.capacity() > keep {
                *buffer = Vec::new();
            }
        }
        out.flush()?;
        Ok(())
    }

    /// Writes every buffer.
    pub(super) fn flush(&mut self) -> io::Result<()> {
        self.spill(0)
    }

    /// Calls `f` for each of a bucket's records, in input order, a run at a time (read with
    /// `pread`, so several buckets may be read at once).
    pub(super) fn for_each(
        &self,
        bucket: usize,
        mut f: impl FnMut(u32, [f64; 3]),
    ) -> io::Result<()> {
        let mut bytes = Vec::new();
        for &(offset, len) in &self.runs[bucket] {
            bytes.resize(len as usize, 0);
            self.file.read_exact_at(&mut bytes, offset)?;
            let (mut at, mut delta) = (0, Delta::default());
            while at < bytes.len() {
                let (t, q) = delta.decode(&bytes, &mut at, true)?;
                f(t, q);
            }
        }
        Ok(())
    }

    /// A bucket's records, in input order.
    pub(super) fn load(&self, bucket: usize) -> io::Result<Vec<(u32, [f64; 3])>> {
        let mut records = Vec::with_capacity(self.counts[bucket] as usize);
        self.for_each(bucket, |t, q| records.push((t, q)))?;
        Ok(records)
    }
}
