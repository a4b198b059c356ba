//! The weld's sorts (`weld.rs`): the keys that group bit-identical positions (step 1) and
//! find duplicate triangles (step 3), and the windows that keep step 3's keys within the
//! budget, and the vertex ids a triangle file uses (step 4).

use std::io;
use std::path::Path;

use bytemuck::{Pod, Zeroable};

use super::fallible::{check, ok_values};
use super::position_file::PositionFile;
use super::sort::{sort_external, Sorted};
use super::staged::RecordFile;
use super::weld::PASS_TRIANGLES;

/// A vertex by its position's bits, then its index: sorting groups bit-identical positions
/// with their first vertex first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Pod, Zeroable)]
#[repr(C)]
pub(super) struct PositionKey {
    pub(super) bits: [u64; 3],
    pub(super) index: u64,
}

/// `PositionKey` of a position that is exactly an f32 (`-0.0` as `0.0`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Pod, Zeroable)]
#[repr(C)]
pub(super) struct NarrowPositionKey {
    pub(super) bits: [u32; 3],
    pub(super) index: u32,
}

pub(super) fn canonical_f32_bits(x: f64) -> u32 {
    let x = x as f32;
    if x == 0.0 {
        0
    } else {
        x.to_bits()
    }
}

/// What step 1 needs of a key: whether two keys hold the same position, the index, and a
/// hash of the position (equal positions, equal hashes) that spreads positions over windows.
pub(super) trait GroupKey: Pod + Ord + Send {
    fn same_position(&self, other: &Self) -> bool;
    fn index(&self) -> u64;
    fn position_hash(&self) -> u64;
}

/// A 64-bit mix of position bits (the multiplier of Fibonacci hashing after each word).
fn mix(words: impl IntoIterator<Item = u64>) -> u64 {
    words.into_iter().fold(0u64, |h, w| {
        (h.rotate_left(29) ^ w).wrapping_mul(0x9E37_79B9_7F4A_7C15)
    })
}

impl GroupKey for PositionKey {
    fn same_position(&self, other: &Self) -> bool {
        self.bits == other.bits
    }
    fn index(&self) -> u64 {
        self.index
    }
    fn position_hash(&self) -> u64 {
        mix(self.bits)
    }
}

impl GroupKey for NarrowPositionKey {
    fn same_position(&self, other: &Self) -> bool {
        self.bits == other.bits
    }
    fn index(&self) -> u64 {
        self.index as u64
    }
    fn position_hash(&self) -> u64 {
        mix(self.bits.map(u64::from))
    }
}

/// Step 1: `(index << 32) | representative` for every vertex, in index order.
///
/// The keys are sorted a window of positions at a time, each window the positions whose hash
/// falls in its share (so a group is never split), as many windows as the keys need to fit in
/// a quarter of the budget (`half / 2`; the pairs' sort holds the other quarter): each window
/// costs a pass over the positions, but no key goes to disk (a window larger than that — one
/// position repeated that often — spills as any sort does). The
/// windows' pairs go to one sort back into index order; the representatives are the same as
/// one sort of every key would give (a group's first index is its least).
pub(super) fn representatives<K: GroupKey>(
    positions: &PositionFile,
    half: usize,
    dir: &Path,
    key_of: impl Fn([f64; 3], u64) -> K,
) -> io::Result<Sorted<u64>> {
    // A window's keys and the pairs' sort are in memory together: half of `half` each.
    let quarter = half / 2;
    let key_bytes = positions
        .len()
        .saturating_mul(std::mem::size_of::<K>() as u64);
    // Each window costs a pass over the positions: at most `MAX_WINDOWS`, their keys spilled
    // in runs where the budget is smaller than that.
    const MAX_WINDOWS: u64 = 16;
    let windows = key_bytes
        .div_ceil(quarter.max(1) as u64)
        .clamp(1, MAX_WINDOWS);
    let mut pairs = WindowPairs {
        positions,
        budget: quarter,
        dir,
        key_of,
        windows,
        next_window: 0,
        sorted: None,
        run: None,
        error: None,
    };
    // Ascending: each delta is about 2^32, five bytes instead of eight.
    let codec = super::sort::RunCodec::delta_u64();
    let by_index = super::sort::sort_external_with(&mut pairs, quarter, dir, codec)?;
    check(pairs.error)?;
    Ok(by_index)
}

/// The `(index << 32) | representative` pairs of one window after another.
struct WindowPairs<'a, K: GroupKey, F> {
    positions: &'a PositionFile,
    /// Bytes a window's sort may hold.
    budget: usize,
    dir: &'a Path,
    key_of: F,
    windows: u64,
    next_window: u64,
    /// The current window's keys, sorted.
    sorted: Option<Sorted<K>>,
    /// The last key and its group's representative.
    run: Option<(K, u64)>,
    error: Option<io::Error>,
}

impl<K: GroupKey, F: Fn([f64; 3], u64) -> K> WindowPairs<'_, K, F> {
    /// The window's keys, sorted.
    fn sort_window(&self, window: u64) -> io::Result<Sorted<K>> {
        let windows = self.windows;
        let mut error = None;
        let keys = ok_values(self.positions.read()?, &mut error)
            .enumerate()
            .map(|(i, p)| (self.key_of)(p, i as u64))
            // The hash's share: its top bits scaled to the window count.
            .filter(|k| ((k.position_hash() >> 32) * windows) >> 32 == window);
        let sorted = sort_external(keys, self.budget, self.dir)?;
        check(error)?;
        Ok(sorted)
    }
}

impl<K: GroupKey, F: Fn([f64; 3], u64) -> K> Iterator for WindowPairs<'_, K, F> {
    type Item = u64;

    fn next(&mut self) -> Option<u64> {
        loop {
            if let Some(sorted) = &mut self.sorted {
                match sorted.next() {
                    Some(Ok(key)) => {
                        let rep = match self.run {
                            Some((first, rep)) if first.same_position(&key) => rep,
                            _ => key.index(),
                        };
                        self.run = Some((key, rep));
                        return Some((key.index() << 32) | rep);
                    }
                    Some(Err(e)) => {
                        self.error = Some(e);
                        return None;
                    }
                    None => self.sorted = None,
                }
            }
            if self.error.is_some() || self.next_window == self.windows {
                return None;
            }
            match self.sort_window(self.next_window) {
                Ok(sorted) => (self.sorted, self.run) = (Some(sorted), None),
                Err(e) => {
                    self.error = Some(e);
                    return None;
                }
            }
            self.next_window += 1;
        }
    }
}

/// A triangle by its sorted corners, then its position in the triangle list.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Pod, Zeroable)]
#[repr(C)]
pub(super) struct DuplicateKey {
    pub(super) corners: [u32; 3],
    pub(super) position: u32,
}

/// The vertex ids `triangles` use, ascending, each once: marked in a bitmap of the ids (below
/// `vertices`) where it fits `budget` (a bit a vertex), else found by a sort of the corners.
pub(super) fn referenced_ids(
    triangles: &RecordFile<[u32; 3]>,
    vertices: u64,
    budget: usize,
    dir: &Path,
) -> io::Result<RecordFile<u32>> {
    let mut referenced = RecordFile::<u32>::create(dir)?;
    if vertices.div_ceil(8) <= budget as u64 {
        let mut marked = vec![0u64; vertices.div_ceil(64) as usize];
        let (mut chunks, mut chunk) = (triangles.read_chunks(PASS_TRIANGLES)?, Vec::new());
        while chunks.read_into(&mut chunk)? {
            for &v in chunk.iter().flatten() {
                let word = marked.get_mut(v as usize / 64).ok_or_else(|| {
                    io::Error::other(format!("vertex index {v} past the {vertices} vertices"))
                })?;
                *word |= 1 << (v % 64);
            }
        }
        for (w, &bits) in marked.iter().enumerate() {
            let mut bits = bits;
            while bits != 0 {
                referenced.push(&(w as u32 * 64 + bits.trailing_zeros()))?;
                bits &= bits - 1;
            }
        }
    } else {
        let mut error = None;
        let corners = ok_values(triangles.read()?, &mut error).flat_map(|t| t.into_iter());
        let sorted = sort_external(corners, budget, dir)?;
        check(error)?;
        let mut last = None;
        for v in sorted {
            let v = v?;
            if last != Some(v) {
                referenced.push(&v)?;
                last = Some(v);
            }
        }
    }
    referenced.finish()
}

/// Ranges of least corners (of ids below `vertices`) that split `triangles` into windows of
/// at most `budget / 16` triangles (a `DuplicateKey` each; at most about 16 windows), from a
/// histogram of 4,096 bins (a bin holding more is a window of its own, sorted with runs on
/// disk).
pub(super) fn least_corner_windows(
    triangles: &RecordFile<[u32; 3]>,
    vertices: u64,
    budget: usize,
) -> io::Result<Vec<(u64, u64)>> {
    const BINS: u64 = 4096;
    // Each window costs a pass over the triangles: at most about `MAX_WINDOWS` of them, their
    // keys spilled in runs where the budget is that small.
    const MAX_WINDOWS: u64 = 16;
    let capacity = ((budget / std::mem::size_of::<DuplicateKey>()) as u64)
        .max(triangles.len().div_ceil(MAX_WINDOWS))
        .max(1);
    if triangles.len() <= capacity {
        return Ok(vec![(0, u64::MAX)]);
    }
    let width = vertices.div_ceil(BINS).max(1);
    let mut counts = vec![0u64; BINS as usize + 1];
    let (mut chunks, mut chunk) = (triangles.read_chunks(PASS_TRIANGLES)?, Vec::new());
    while chunks.read_into(&mut chunk)? {
        for t in &chunk {
            let least = t[0].min(t[1]).min(t[2]) as u64;
            counts[((least / width).min(BINS)) as usize] += 1;
        }
    }
    let mut windows = Vec::new();
    let (mut start, mut held) = (0u64, 0u64);
    for (bin, &n) in counts.iter().enumerate() {
        if held > 0 && held + n > capacity {
            windows.push((start, bin as u64 * width));
            (start, held) = (bin as u64 * width, 0);
        }
        held += n;
    }
    windows.push((start, u64::MAX));
    Ok(windows)
}
