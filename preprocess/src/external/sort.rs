//! External merge sort of fixed-size records under a memory budget.
//!
//! Records are read from an iterator into a buffer of at most the budget, each full buffer is
//! sorted (in parallel) and written as a run to an unnamed temporary file in the given
//! directory, and the runs are merged through a heap, several passes if there are more runs
//! than the budget can give read buffers to. Input that fits the budget never touches the disk.
//! A run is written a frame at a time by a `RunCodec` (the records' bytes, or for sorted u64
//! keys their differences in LEB128), and a merge frees each run's disk behind its reader, so
//! the runs and a merge pass's output are not on disk whole together.
//!
//! Records are compared whole (`Ord`), so equal records are interchangeable and the output
//! does not depend on the budget; callers that need a stable order put the record's index in
//! it. Temporary files are unnamed (`tempfile::tempfile_in`): the kernel frees them when the
//! sort ends, fails, or the process is killed.

use std::cmp::Reverse;
use std::collections::binary_heap::PeekMut;
use std::collections::BinaryHeap;
use std::fs::File;
use std::io::{self, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::Path;

use bytemuck::Pod;
use rayon::prelude::*;

use super::temp_usage::{Charge, TempKind};

/// Bytes of read buffer given to each run while merging (a smaller budget merges in more
/// passes).
const MERGE_BUFFER: usize = 64 * 1024;

/// The smallest number of records a buffer holds, whatever the budget.
const MIN_RECORDS: usize = 1024;

/// What a sort did, for the build's statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SortStats {
    pub records: u64,
    /// Runs written to disk (0: the input fitted the budget).
    pub runs: usize,
    /// Merge passes over the disk (0 or more).
    pub passes: usize,
    /// Bytes written to temporary files, all passes.
    pub bytes_written: u64,
}

/// How a run's records are written: a frame at a time (at most `frame_records(T)` records),
/// each frame its payload's length and record count (u32 each) then the payload.
pub struct RunCodec<T> {
    /// Appends the payload of a frame of sorted records.
    pub encode: fn(&[T], &mut Vec<u8>),
    /// Appends the `count` records of a frame's payload.
    pub decode: fn(&[u8], usize, &mut Vec<T>) -> io::Result<()>,
}

impl<T: Pod> RunCodec<T> {
    /// The records' own bytes.
    pub fn raw() -> Self {
        RunCodec {
            encode: |records, out| out.extend_from_slice(bytemuck::cast_slice(records)),
            decode: |bytes, count, out| {
                if bytes.len() != count * std::mem::size_of::<T>() {
                    return Err(damaged_frame());
                }
                out.extend(bytemuck::pod_collect_to_vec::<u8, T>(bytes));
                Ok(())
            },
        }
    }
}

impl RunCodec<u64> {
    /// Sorted keys as the differences between neighbours, LEB128 (the first from 0): edge
    /// keys (two vertex ids) take about 3.5 bytes instead of 8.
    pub fn delta_u64() -> Self {
        RunCodec {
            encode: |records, out| {
                let mut previous = 0u64;
                for &r in records {
                    let mut d = r - previous;
                    previous = r;
                    while d >= 0x80 {
                        out.push(d as u8 | 0x80);
                        d >>= 7;
                    }
                    out.push(d as u8);
                }
            },
            decode: |bytes, count, out| {
                let (mut previous, mut at) = (0u64, 0usize);
                for _ in 0..count {
                    let (mut d, mut shift) = (0u64, 0u32);
                    loop {
                        let b = *bytes.get(at).ok_or_else(damaged_frame)?;
                        at += 1;
                        if shift > 63 {
                            return Err(damaged_frame());
                        }
                        d |= ((b & 0x7f) as u64) << shift;
                        shift += 7;
                        if b & 0x80 == 0 {
                            break;
                        }
                    }
                    previous = previous.checked_add(d).ok_or_else(damaged_frame)?;
                    out.push(previous);
                }
                if at != bytes.len() {
                    return Err(damaged_frame());
                }
                Ok(())
            },
        }
    }
}

fn damaged_frame() -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        "a sort run's frame does not decode",
    )
}

/// Records in a run's frame: a reader holds a frame's payload and its records, together
/// within `MERGE_BUFFER` (raw records; a delta-coded payload is smaller).
fn frame_records<T>() -> usize {
    (MERGE_BUFFER / 2 / std::mem::size_of::<T>().max(1)).max(1)
}

/// Sorts `input` with at most `budget` bytes of records in memory, spilling runs to
/// `temp_dir`. The result streams the records in ascending order.
pub fn sort_external<T, I>(input: I, budget: usize, temp_dir: &Path) -> io::Result<Sorted<T>>
where
    T: Pod + Ord + Send,
    I: IntoIterator<Item = T>,
{
    sort_external_with(input, budget, temp_dir, RunCodec::raw())
}

/// `sort_external` with runs written by `codec`.
pub fn sort_external_with<T, I>(
    input: I,
    budget: usize,
    temp_dir: &Path,
    codec: RunCodec<T>,
) -> io::Result<Sorted<T>>
where
    T: Pod + Ord + Send,
    I: IntoIterator<Item = T>,
{
    let size = std::mem::size_of::<T>().max(1);
    let capacity = (budget / size).max(MIN_RECORDS);
    let mut stats = SortStats::default();
    let mut runs: Vec<Run> = Vec::new();
    let mut buffer: Vec<T> = Vec::new();
    let mut input = input.into_iter();
    loop {
        buffer.clear();
        buffer.extend(input.by_ref().take(capacity));
        let last = buffer.len() < capacity;
        stats.records += buffer.len() as u64;
        buffer.par_sort_unstable();
        if last && runs.is_empty() {
            return Ok(Sorted {
                source: Source::Memory(std::mem::take(&mut buffer).into_iter()),
                stats,
            });
        }
        if !buffer.is_empty() {
            runs.push(write_run(&buffer, temp_dir, &codec, &mut stats)?);
        }
        if last {
            break;
        }
    }
    drop(buffer);
    // Merge passes until the runs fit one heap within the budget.
    let fan_in = (budget / MERGE_BUFFER).max(2);
    while runs.len() > fan_in {
        stats.passes += 1;
        let mut merged = Vec::with_capacity(runs.len().div_ceil(fan_in));
        let mut left = runs.into_iter();
        loop {
            // The group's runs are the merge's to read and free as it goes.
            let group: Vec<Run> = left.by_ref().take(fan_in).collect();
            if group.is_empty() {
                break;
            }
            let mut writer = RunWriter::new(temp_dir, &codec)?;
            let mut frame = Vec::with_capacity(frame_records::<T>());
            for record in Merge::<T>::new(group, &codec)? {
                frame.push(record?);
                if frame.len() == frame_records::<T>() {
                    writer.write_frame(&frame)?;
                    frame.clear();
                }
            }
            writer.write_frame(&frame)?;
            merged.push(writer.finish(&mut stats)?);
        }
        runs = merged;
    }
    if !runs.is_empty() {
        stats.passes += 1;
    }
    Ok(Sorted {
        source: Source::Disk(Merge::new(runs, &codec)?),
        stats,
    })
}

/// Sorted records, streamed.
pub struct Sorted<T: Pod + Ord> {
    source: Source<T>,
    stats: SortStats,
}

impl<T: Pod + Ord> Sorted<T> {
    /// What the sort did.
    pub fn stats(&self) -> SortStats {
        self.stats
    }
}

enum Source<T: Pod + Ord> {
    Memory(std::vec::IntoIter<T>),
    Disk(Merge<T>),
}

impl<T: Pod + Ord> Iterator for Sorted<T> {
    type Item = io::Result<T>;

    fn next(&mut self) -> Option<io::Result<T>> {
        match &mut self.source {
            Source::Memory(records) => records.next().map(Ok),
            Source::Disk(merge) => merge.next(),
        }
    }
}

/// A sorted run in an unnamed temporary file (its bytes charged to the temporary totals
/// while the owning `Run` lives).
struct Run {
    file: File,
    records: u64,
    charge: Charge,
}

/// Writes a run a frame at a time.
struct RunWriter<'c, T> {
    writer: BufWriter<File>,
    codec: &'c RunCodec<T>,
    payload: Vec<u8>,
    records: u64,
    bytes: u64,
    charge: Charge,
}

impl<'c, T: Pod> RunWriter<'c, T> {
    fn new(temp_dir: &Path, codec: &'c RunCodec<T>) -> io::Result<Self> {
        Ok(RunWriter {
            writer: BufWriter::with_capacity(MERGE_BUFFER, tempfile::tempfile_in(temp_dir)?),
            codec,
            payload: Vec::new(),
            records: 0,
            bytes: 0,
            charge: Charge::new(TempKind::SortRuns),
        })
    }

    fn write_frame(&mut self, records: &[T]) -> io::Result<()> {
        if records.is_empty() {
            return Ok(());
        }
        self.payload.clear();
        (self.codec.encode)(records, &mut self.payload);
        self.writer
            .write_all(&(self.payload.len() as u32).to_le_bytes())?;
        self.writer
            .write_all(&(records.len() as u32).to_le_bytes())?;
        self.writer.write_all(&self.payload)?;
        let bytes = 8 + self.payload.len() as u64;
        self.records += records.len() as u64;
        self.bytes += bytes;
        self.charge.grow(bytes);
        Ok(())
    }

    fn finish(self, stats: &mut SortStats) -> io::Result<Run> {
        let file = self.writer.into_inner().map_err(|e| e.into_error())?;
        stats.bytes_written += self.bytes;
        Ok(Run {
            file,
            records: self.records,
            charge: self.charge,
        })
    }
}

fn write_run<T: Pod>(
    records: &[T],
    temp_dir: &Path,
    codec: &RunCodec<T>,
    stats: &mut SortStats,
) -> io::Result<Run> {
    let mut writer = RunWriter::new(temp_dir, codec)?;
    for frame in records.chunks(frame_records::<T>()) {
        writer.write_frame(frame)?;
    }
    stats.runs += 1;
    writer.finish(stats)
}

/// A k-way merge of runs.
struct Merge<T: Pod + Ord> {
    readers: Vec<RunReader<T>>,
    heap: BinaryHeap<Reverse<(T, usize)>>,
    failed: bool,
}

impl<T: Pod + Ord> Merge<T> {
    fn new(runs: Vec<Run>, codec: &RunCodec<T>) -> io::Result<Self> {
        let mut readers = Vec::with_capacity(runs.len());
        let mut heap = BinaryHeap::with_capacity(runs.len());
        for (i, run) in runs.into_iter().enumerate() {
            let mut reader = RunReader::new(run, codec.decode)?;
            if let Some(first) = reader.next()? {
                heap.push(Reverse((first, i)));
            }
            readers.push(reader);
        }
        Ok(Merge {
            readers,
            heap,
            failed: false,
        })
    }
}

impl<T: Pod + Ord> Iterator for Merge<T> {
    type Item = io::Result<T>;

    fn next(&mut self) -> Option<io::Result<T>> {
        if self.failed {
            return None;
        }
        // The smallest head is replaced by its run's next record in place (one sift down),
        // or popped when its run is done.
        let mut top = self.heap.peek_mut()?;
        let Reverse((record, i)) = *top;
        match self.readers[i].next() {
            Ok(Some(next)) => *top = Reverse((next, i)),
            Ok(None) => {
                PeekMut::pop(top);
            }
            Err(e) => {
                self.failed = true;
                return Some(Err(e));
            }
        }
        Some(Ok(record))
    }
}

/// Reads a run front to back a frame at a time, freeing its disk behind it
/// (`holes::punch`, every `FREE_BEHIND` bytes), so a merge's runs shrink as its output grows.
struct RunReader<T> {
    file: File,
    decode: fn(&[u8], usize, &mut Vec<T>) -> io::Result<()>,
    payload: Vec<u8>,
    /// Records read ahead, served from `at`.
    block: Vec<T>,
    at: usize,
    /// Records of the run not yet in `block`.
    left: u64,
    /// Bytes read, and freed.
    read: u64,
    freed: u64,
    /// The run's bytes still held.
    charge: Charge,
}

/// Bytes a run reader reads between two holes it punches.
const FREE_BEHIND: u64 = 1 << 20;

impl<T: Pod> RunReader<T> {
    fn new(
        mut run: Run,
        decode: fn(&[u8], usize, &mut Vec<T>) -> io::Result<()>,
    ) -> io::Result<Self> {
        run.file.seek(SeekFrom::Start(0))?;
        Ok(RunReader {
            file: run.file,
            decode,
            payload: Vec::new(),
            block: Vec::new(),
            at: 0,
            left: run.records,
            read: 0,
            freed: 0,
            charge: run.charge,
        })
    }

    fn read_frame(&mut self) -> io::Result<()> {
        let mut head = [0u8; 8];
        self.file.read_exact(&mut head)?;
        let bytes = u32::from_le_bytes(head[..4].try_into().expect("4 bytes")) as usize;
        let count = u32::from_le_bytes(head[4..].try_into().expect("4 bytes")) as u64;
        if count == 0 || count > self.left || count as usize > frame_records::<T>() {
            return Err(damaged_frame());
        }
        self.payload.resize(bytes, 0);
        self.file.read_exact(&mut self.payload)?;
        self.block.clear();
        (self.decode)(&self.payload, count as usize, &mut self.block)?;
        self.left -= count;
        self.at = 0;
        self.read += 8 + bytes as u64;
        Ok(())
    }

    #[inline]
    fn next(&mut self) -> io::Result<Option<T>> {
        if self.at == self.block.len() {
            if self.left == 0 {
                return Ok(None);
            }
            self.read_frame()
                .map_err(|e| io::Error::new(e.kind(), format!("reading a sort run back: {e}")))?;
            // The frame just read is in memory: everything before it can go.
            if self.read - self.freed >= FREE_BEHIND || self.left == 0 {
                let freed = super::holes::punch(&self.file, self.freed, self.read);
                self.charge.shrink(freed);
                self.freed = self.read / 4096 * 4096;
            }
        }
        self.at += 1;
        Ok(Some(self.block[self.at - 1]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn sorted_with(values: &[u64], budget: usize) -> (Vec<u64>, SortStats) {
        let dir = tempfile::tempdir().unwrap();
        let sorted = sort_external(values.iter().copied(), budget, dir.path()).unwrap();
        let stats = sorted.stats();
        let out: Vec<u64> = sorted.map(Result::unwrap).collect();
        // Unnamed temporaries leave nothing behind.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        (out, stats)
    }

    #[test]
    fn delta_coded_runs_give_the_same_order_in_fewer_bytes() {
        // Edge-like keys (two ids), duplicates, and the extremes; a budget that spills and
        // merges in several passes.
        let mut values: Vec<u64> = (0..60_000u64)
            .map(|i| (((i * 7_919) % 5_003) << 32) | ((i * 104_729) % 5_003))
            .collect();
        values.extend([0, 0, u64::MAX, u64::MAX, 1]);
        let mut expected = values.clone();
        expected.sort_unstable();
        let dir = tempfile::tempdir().unwrap();
        let raw = sort_external(values.iter().copied(), 8 << 10, dir.path()).unwrap();
        let raw_stats = raw.stats();
        assert_eq!(raw.map(Result::unwrap).collect::<Vec<_>>(), expected);
        let delta = sort_external_with(
            values.iter().copied(),
            8 << 10,
            dir.path(),
            RunCodec::delta_u64(),
        )
        .unwrap();
        let delta_stats = delta.stats();
        assert_eq!(delta.map(Result::unwrap).collect::<Vec<_>>(), expected);
        assert!(delta_stats.passes > 1, "{delta_stats:?}");
        assert_eq!(delta_stats.runs, raw_stats.runs);
        assert!(
            delta_stats.bytes_written * 2 < raw_stats.bytes_written,
            "{delta_stats:?} against {raw_stats:?}"
        );
    }

    #[test]
    fn a_damaged_delta_frame_is_an_error() {
        let codec = RunCodec::delta_u64();
        let mut payload = Vec::new();
        (codec.encode)(&[3, 300, 70_000], &mut payload);
        let mut out = Vec::new();
        (codec.decode)(&payload, 3, &mut out).unwrap();
        assert_eq!(out, [3, 300, 70_000]);
        for (bytes, count) in [
            (&payload[..payload.len() - 1], 3),
            (&payload[..], 2),
            (&payload[..], 4),
        ] {
            assert!((codec.decode)(bytes, count, &mut Vec::new()).is_err());
        }
        assert!((codec.decode)(&[0xff; 11], 1, &mut Vec::new()).is_err());
    }

    #[test]
    fn small_input_stays_in_memory() {
        let (out, stats) = sorted_with(&[5, 3, 9, 1], 1 << 20);
        assert_eq!(out, vec![1, 3, 5, 9]);
        assert_eq!(stats.runs, 0);
        assert_eq!(stats.bytes_written, 0);
    }

    #[test]
    fn spills_and_merges_in_several_passes() {
        // 1,024-record buffers (the minimum) and a fan-in of 2: 50 runs, ⌈log2 50⌉ passes.
        let values: Vec<u64> = (0..51_000u64).map(|i| (i * 7_919) % 10_007).collect();
        let (out, stats) = sorted_with(&values, 0);
        let mut expected = values.clone();
        expected.sort_unstable();
        assert_eq!(out, expected);
        assert_eq!(stats.runs, 50);
        assert_eq!(stats.passes, 6);
        assert_eq!(stats.records, 51_000);
    }

    proptest! {
        #[test]
        fn the_same_as_an_in_memory_sort(
            values in proptest::collection::vec(any::<u32>(), 0..5_000),
            budget in 0usize..40_000,
        ) {
            let records: Vec<(u32, u32)> = values.iter().enumerate().map(|(i, &v)| (v % 97, i as u32)).collect();
            let flat: Vec<u64> = records.iter().map(|&(k, i)| (k as u64) << 32 | i as u64).collect();
            let (out, _) = sorted_with(&flat, budget);
            let mut expected = flat.clone();
            expected.sort_unstable();
            prop_assert_eq!(out, expected);
        }
    }
}
