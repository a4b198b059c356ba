//! The input's non-manifold edges (more than two triangles) under a memory budget, found in
//! windows of the edges' smaller endpoint: each window's edge keys are made from a pass over
//! the triangles (a chunk at a time, in parallel), sorted, and counted in runs. An edge's key
//! falls in one window, so the windows' findings together are the whole mesh's.
//!
//! One external sort of every edge key did this before: its runs went to disk and came back
//! through one merge, which at 100 M triangles kept one core busy for about 12 s while the
//! other waited. A window that fits the budget is sorted in memory (in parallel) and never
//! touches the disk; the windows are at most `MAX_WINDOWS` passes over the triangles (read
//! from the page cache where they are staged), and one larger than the budget (a tiny budget,
//! or a vertex in millions of triangles) spills runs as the sort always did.

use std::borrow::Cow;
use std::io;
use std::path::Path;

use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;

use super::current_mesh::{edge_key, triangle_edges};
use crate::external::sort::{sort_external_with, RunCodec};

/// The triangles, a chunk at a time (each call starts a new pass).
pub(super) type TriangleChunks<'a> = Box<dyn Iterator<Item = io::Result<Cow<'a, [[u32; 3]]>>> + 'a>;

/// Where the triangles are: passes over them, a chunk at a time.
pub(super) trait TrianglePasses {
    fn triangle_count(&self) -> u64;
    /// Hands `f` every triangle, a chunk at a time, in order (one buffer for every chunk:
    /// a new one a chunk was faulted in and zeroed again, most of a pass's time).
    fn for_each_chunk(&self, f: &mut dyn FnMut(&[[u32; 3]])) -> io::Result<()>;
    /// The same chunks as an iterator (for the external sort of a window over the budget).
    fn chunks(&self) -> io::Result<TriangleChunks<'_>>;
}

/// Bins of the smaller endpoint's range the windows are made of.
const BINS: u64 = 4096;

/// Passes over the triangles at most (beyond, windows hold more than the budget and spill).
const MAX_WINDOWS: u64 = 16;

/// The edges used by more than two triangles of `vertex_count` vertices' triangles
/// (`chunks()` streams them), with their counts, sorting within about `budget` bytes
/// (temporary runs in `temp_dir` only where a window exceeds it). The same as sorting every
/// key at once.
pub(super) fn nonmanifold_edges_within(
    vertex_count: usize,
    triangles: &dyn TrianglePasses,
    budget: usize,
    temp_dir: &Path,
) -> io::Result<HashMap<u64, u32>> {
    let mut nonmanifold = HashMap::default();
    let fits = (budget / 8) as u64;
    // One allocation for every window that fits (a new one a window faulted its pages in again).
    let mut keys: Vec<u64> = Vec::new();
    for (low, high, count) in windows(vertex_count, triangles, budget)? {
        if count <= fits {
            keys.clear();
            keys.reserve(count as usize);
            triangles
                .for_each_chunk(&mut |chunk| keys.par_extend(window_keys(chunk, low, high)))?;
            keys.par_sort_unstable();
            let runs = keys.chunk_by(|a, b| a == b).filter(|run| run.len() > 2);
            nonmanifold.extend(runs.map(|run| (run[0], run.len() as u32)));
            continue;
        }
        let mut error = None;
        let mut pass = triangles.chunks()?;
        let keys = std::iter::from_fn(|| match pass.next()? {
            Ok(chunk) => Some(window_keys(&chunk, low, high).collect::<Vec<u64>>()),
            Err(e) => {
                error = Some(e);
                None
            }
        })
        .flatten();
        // Delta-coded runs: the keys take less than half the disk.
        let sorted = sort_external_with(keys, budget, temp_dir, RunCodec::delta_u64())?;
        if let Some(e) = error {
            return Err(e);
        }
        let mut run: Option<(u64, u32)> = None;
        for key in sorted {
            let key = key?;
            run = match run {
                Some((k, n)) if k == key => Some((k, n + 1)),
                Some((k, n)) => {
                    if n > 2 {
                        nonmanifold.insert(k, n);
                    }
                    Some((key, 1))
                }
                None => Some((key, 1)),
            };
        }
        if let Some((k, n)) = run.filter(|&(_, n)| n > 2) {
            nonmanifold.insert(k, n);
        }
    }
    Ok(nonmanifold)
}

/// The keys of `chunk`'s edges whose smaller endpoint is in `low..high`, made in parallel.
fn window_keys(chunk: &[[u32; 3]], low: u64, high: u64) -> impl ParallelIterator<Item = u64> + '_ {
    chunk.par_iter().flat_map_iter(move |t| {
        triangle_edges(t)
            .into_iter()
            .filter(move |&(a, b)| (low..high).contains(&(a.min(b) as u64)))
            .map(|(a, b)| edge_key(a, b))
    })
}

/// Ranges of the smaller endpoint splitting the edges into windows of at most `budget / 8`
/// keys (or a sixteenth of them, if that is more; a bin holding more is a window of its own),
/// with each window's keys, from a histogram of `BINS` bins made in one pass; one window, with
/// no pass, where every key fits.
fn windows(
    vertex_count: usize,
    triangles: &dyn TrianglePasses,
    budget: usize,
) -> io::Result<Vec<(u64, u64, u64)>> {
    let edges = 3 * triangles.triangle_count();
    let capacity = ((budget / 8) as u64)
        .max(edges.div_ceil(MAX_WINDOWS))
        .max(1);
    if edges <= capacity {
        return Ok(vec![(0, u64::MAX, edges)]);
    }
    let width = (vertex_count as u64).div_ceil(BINS).max(1);
    let bin = |v: u32| ((v as u64 / width).min(BINS)) as usize;
    let mut counts = vec![0u64; BINS as usize + 1];
    triangles.for_each_chunk(&mut |chunk| {
        let part = chunk
            .par_chunks(1 << 14)
            .map(|part| {
                let mut counts = vec![0u64; BINS as usize + 1];
                for t in part {
                    for (a, b) in triangle_edges(t) {
                        counts[bin(a.min(b))] += 1;
                    }
                }
                counts
            })
            .reduce(
                || vec![0u64; BINS as usize + 1],
                |mut x, y| {
                    x.iter_mut().zip(&y).for_each(|(x, y)| *x += y);
                    x
                },
            );
        counts.iter_mut().zip(&part).for_each(|(x, y)| *x += y);
    })?;
    let mut windows = Vec::new();
    let (mut start, mut held) = (0u64, 0u64);
    for (b, &n) in counts.iter().enumerate() {
        if held > 0 && held + n > capacity {
            windows.push((start, b as u64 * width, held));
            (start, held) = (b as u64 * width, 0);
        }
        held += n;
    }
    windows.push((start, u64::MAX, held));
    Ok(windows)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Triangles in memory, in chunks of `size`, the last pass failing where `fail`.
    struct Chunked<'a> {
        triangles: &'a [[u32; 3]],
        size: usize,
        fail: bool,
    }

    impl TrianglePasses for Chunked<'_> {
        fn triangle_count(&self) -> u64 {
            self.triangles.len() as u64
        }

        fn for_each_chunk(&self, f: &mut dyn FnMut(&[[u32; 3]])) -> io::Result<()> {
            self.triangles.chunks(self.size).for_each(f);
            match self.fail {
                true => Err(io::Error::other("disk gone")),
                false => Ok(()),
            }
        }

        fn chunks(&self) -> io::Result<TriangleChunks<'_>> {
            let failure = self.fail.then(|| Err(io::Error::other("disk gone")));
            Ok(Box::new(
                self.triangles
                    .chunks(self.size)
                    .map(|c| Ok(Cow::Borrowed(c)))
                    .chain(failure),
            ))
        }
    }

    #[test]
    fn windows_find_what_one_sort_finds_at_any_budget() {
        // A strip of quads with fins: every fifth edge of the spine has 3 to 5 triangles.
        let mut triangles = Vec::new();
        let n = 3000u32;
        for i in 0..n {
            triangles.push([i, i + 1, n + 10 + i]);
            triangles.push([i + 1, n + 11 + i, n + 10 + i]);
            if i % 5 == 0 {
                for f in 0..(1 + i % 3) {
                    triangles.push([i, i + 1, 3 * n + 20 + 3 * i + f]);
                }
            }
        }
        // A vertex in very many triangles (its bin alone over the budget).
        for j in 0..2000 {
            triangles.push([7, 3 * n + 20 + 10_000 + j, 3 * n + 20 + 10_001 + j]);
        }
        let vertex_count = (3 * n + 20 + 13_000) as usize;
        let mut expected: HashMap<u64, u32> = HashMap::default();
        for t in &triangles {
            for (a, b) in triangle_edges(t) {
                *expected.entry(edge_key(a, b)).or_default() += 1;
            }
        }
        expected.retain(|_, n| *n > 2);
        assert!(expected.len() > 300);
        let dir = tempfile::tempdir().unwrap();
        // One window; windows that fit (but the one of vertex 7); windows that spill.
        for budget in [8 << 20, 8 * 4000, 8 * 2500, 4096, 8 * 64, 8] {
            for size in [1, 7, 4096] {
                let passes = Chunked {
                    triangles: &triangles,
                    size,
                    fail: false,
                };
                let found =
                    nonmanifold_edges_within(vertex_count, &passes, budget, dir.path()).unwrap();
                assert_eq!(found, expected, "budget {budget}, chunks of {size}");
            }
        }
    }

    #[test]
    fn a_failed_read_is_an_error_not_fewer_edges() {
        let triangles = vec![[0, 1, 2]; 10];
        let passes = Chunked {
            triangles: &triangles,
            size: 3,
            fail: true,
        };
        let dir = tempfile::tempdir().unwrap();
        // One window that fits; windows after a histogram; windows over the budget.
        for budget in [1 << 20, 80, 8] {
            let e = nonmanifold_edges_within(3, &passes, budget, dir.path()).unwrap_err();
            assert_eq!(e.to_string(), "disk gone");
        }
    }
}
