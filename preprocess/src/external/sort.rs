//! External merge sort of fixed-size records under a memory budget.
//!
//! Records are read from an iterator into a buffer of at most the budget, each full buffer is
//! sorted (in parallel) and written as a run to an unnamed temporary file in the given
//! directory, and the runs are merged through a heap, several passes if there are more runs
//! than the budget can give read buffers to. Input that fits the budget never touches the disk.
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

use super::temp_usage::Charge;

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

/// Sorts `input` with at most `budget` bytes of records in memory, spilling runs to
/// `temp_dir`. The result streams the records in ascending order.
pub fn sort_external<T, I>(input: I, budget: usize, temp_dir: &Path) -> io::Result<Sorted<T>>
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
            runs.push(write_run(&buffer, temp_dir, &mut stats)?);
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
            let mut file = tempfile::tempfile_in(temp_dir)?;
            let mut writer = BufWriter::with_capacity(MERGE_BUFFER, &mut file);
            let mut records = 0;
            let charge = Charge::new();
            for record in Merge::<T>::new(group)? {
                writer.write_all(bytemuck::bytes_of(&record?))?;
                records += 1;
                charge.grow(size as u64);
            }
            writer.flush()?;
            drop(writer);
            stats.bytes_written += records * size as u64;
            merged.push(Run {
                file,
                records,
                charge,
            });
        }
        runs = merged;
    }
    if !runs.is_empty() {
        stats.passes += 1;
    }
    Ok(Sorted {
        source: Source::Disk(Merge::new(runs)?),
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

fn write_run<T: Pod>(records: &[T], temp_dir: &Path, stats: &mut SortStats) -> io::Result<Run> {
    let mut file = tempfile::tempfile_in(temp_dir)?;
    let bytes: &[u8] = bytemuck::cast_slice(records);
    file.write_all(bytes)?;
    stats.runs += 1;
    stats.bytes_written += bytes.len() as u64;
    let charge = Charge::new();
    charge.grow(bytes.len() as u64);
    Ok(Run {
        file,
        records: records.len() as u64,
        charge,
    })
}

/// A k-way merge of runs.
struct Merge<T: Pod + Ord> {
    readers: Vec<RunReader<T>>,
    heap: BinaryHeap<Reverse<(T, usize)>>,
    failed: bool,
}

impl<T: Pod + Ord> Merge<T> {
    fn new(runs: Vec<Run>) -> io::Result<Self> {
        let mut readers = Vec::with_capacity(runs.len());
        let mut heap = BinaryHeap::with_capacity(runs.len());
        for (i, run) in runs.into_iter().enumerate() {
            let mut reader = RunReader::new(run)?;
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

/// Reads a run front to back, freeing its disk behind it (`holes::punch`, every
/// `FREE_BEHIND` bytes), so a merge's runs shrink as its output grows.
struct RunReader<T> {
    file: File,
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
    fn new(mut run: Run) -> io::Result<Self> {
        run.file.seek(SeekFrom::Start(0))?;
        Ok(RunReader {
            file: run.file,
            block: Vec::new(),
            at: 0,
            left: run.records,
            read: 0,
            freed: 0,
            charge: run.charge,
        })
    }

    #[inline]
    fn next(&mut self) -> io::Result<Option<T>> {
        if self.at == self.block.len() {
            if self.left == 0 {
                return Ok(None);
            }
            let per_block = (MERGE_BUFFER / std::mem::size_of::<T>().max(1)).max(1);
            let n = self.left.min(per_block as u64) as usize;
            self.block.resize(n, T::zeroed());
            self.file
                .read_exact(bytemuck::cast_slice_mut(&mut self.block[..n]))
                .map_err(|e| io::Error::new(e.kind(), format!("reading a sort run back: {e}")))?;
            self.left -= n as u64;
            self.at = 0;
            self.read += (n * std::mem::size_of::<T>()) as u64;
            // The block just read is in memory: everything before it can go.
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
