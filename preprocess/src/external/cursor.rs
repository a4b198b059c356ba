//! Reads a record file by ascending index, a block at a time (the joins' passes that pick
//! records of sorted ids).

use std::io;

use rayon::prelude::*;

use super::chunk_reader::ChunkReader;
use super::staged::{RecordFile, IO_BUFFER};

/// Reads a record file in order, answering `at(i)` for ascending (repeatable) indices: a
/// block of records at a time, blocks with no index asked skipped without reading.
pub(super) struct Cursor<T: bytemuck::Pod> {
    chunks: ChunkReader<T>,
    /// The block read last, and the index of its first record.
    pub(super) block: Vec<T>,
    start: u64,
    /// The first read error (`at` then answers zeroes; the caller checks).
    pub(super) error: Option<io::Error>,
}

impl<T: bytemuck::Pod> Cursor<T> {
    pub(super) fn new(file: &RecordFile<T>) -> io::Result<Self> {
        Cursor::reusing(file, Vec::new())
    }

    /// A cursor reading into `block`'s allocation (a caller that reads a file many times
    /// takes `block` back after each: a fresh block each time costs page faults).
    pub(super) fn reusing(file: &RecordFile<T>, mut block: Vec<T>) -> io::Result<Self> {
        let records = (IO_BUFFER / std::mem::size_of::<T>().max(1)).max(1);
        block.clear();
        Ok(Cursor {
            chunks: file.read_chunks(records)?,
            block,
            start: 0,
            error: None,
        })
    }

    pub(super) fn at(&mut self, index: u32) -> T {
        let index = index as u64;
        assert!(
            index >= self.start,
            "record {index} asked after record {}: indices must ascend",
            self.start
        );
        while index >= self.start + self.block.len() as u64 {
            self.start += self.block.len() as u64;
            let chunk = self.chunks.chunk_len() as u64;
            let whole = (index - self.start) / chunk * chunk;
            let next = self.chunks.skip_records(whole).and_then(|()| {
                self.start += whole;
                self.chunks.read_into(&mut self.block)
            });
            match next {
                Ok(true) => {}
                Err(e) => {
                    self.error.get_or_insert(e);
                    return T::zeroed();
                }
                Ok(false) => {
                    self.error.get_or_insert(io::Error::other(format!(
                        "record {index} asked past the end of a staged file"
                    )));
                    return T::zeroed();
                }
            }
        }
        self.block[(index - self.start) as usize]
    }
}

/// Runs `pass` over `indices` (ascending record indices) and `out` split alike into a few
/// pieces side by side (two a worker, each of at least `MIN_INDICES_A_PASS`): each piece's
/// pass reads its own range of the file with its own cursor, all in parallel. `states` (one
/// a piece, kept by the caller from call to call: a cursor's block, say) grows to the pieces.
pub(super) fn in_passes<I: Sync, T: Send, S: Send + Default>(
    indices: &[I],
    out: &mut [T],
    states: &mut Vec<S>,
    pass: impl Fn(&[I], &mut [T], &mut S) -> io::Result<()> + Sync,
) -> io::Result<()> {
    debug_assert_eq!(indices.len(), out.len());
    let passes = (2 * rayon::current_num_threads())
        .min(indices.len().div_ceil(MIN_INDICES_A_PASS))
        .max(1);
    let per_pass = indices.len().div_ceil(passes).max(1);
    if states.len() < passes {
        states.resize_with(passes, S::default);
    }
    out.par_chunks_mut(per_pass)
        .zip(indices.par_chunks(per_pass))
        .zip(states.par_iter_mut())
        .try_for_each(|((out, indices), state)| pass(indices, out, state))
}

/// Indices a pass of [`in_passes`] reads at least (fewer passes where there are few).
const MIN_INDICES_A_PASS: usize = 1 << 16;
