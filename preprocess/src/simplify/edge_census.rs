//! Edge counts of the current mesh, counted when asked.
//!
//! A diamond knows the use counts of every edge with an interior endpoint (all its triangles
//! are in the diamond's gathered set). Only edges between two vertices it shares with the rest
//! of the mesh need the rest's counts: to know whether raising such an edge over-fills it, and
//! whether a border edge of its region is also used outside. The build asks for those edges,
//! a level (or a batch of re-simplified diamonds) at a time, and counts them here over the
//! current mesh's patches: one pass over the live patches, with a bitmap of the asked edges'
//! endpoints rejecting most triangles before any hashing.
//!
//! This replaces a global table of every edge's count (about a third of the in-core build's
//! memory), and it is the shape an out-of-core build needs: the census streams through the
//! patches wherever they are stored.

use rayon::prelude::*;
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};
use tessera_core::leb::SimplexKey;

use super::current_mesh::{edge_key, triangle_edges};
use crate::packed_key::PackedKey;
use std::borrow::Cow;
use std::io;

/// The number of triangles of the current mesh using each edge of `query` (sorted and
/// deduplicated edge keys), the current mesh being the patches of the `live` simplices.
/// Edges no triangle uses are absent. Counts are sums, so the result does not depend on the
/// order of `live` or on the number of threads.
/// A live simplex's patch triangles (none for a simplex that is not live).
pub(super) type TrianglesOf<'f, 's> =
    dyn Fn(&SimplexKey) -> io::Result<Option<Cow<'s, [[u32; 3]]>>> + Sync + 'f;

pub(super) fn count_edges<'s>(
    query: &[u64],
    live: &[PackedKey],
    triangles_of: &TrianglesOf<'_, 's>,
) -> io::Result<HashMap<u64, u32>> {
    if query.is_empty() {
        return Ok(HashMap::default());
    }
    let wanted: HashSet<u64> = query.iter().copied().collect();
    let endpoints = EndpointBitmap::new(query);
    live.par_iter()
        .try_fold(HashMap::default, |mut counts: HashMap<u64, u32>, key| {
            let triangles = triangles_of(&key.key())?;
            for t in triangles.as_deref().unwrap_or(&[]) {
                for (a, b) in triangle_edges(t) {
                    if endpoints.contains(a) && endpoints.contains(b) {
                        let e = edge_key(a, b);
                        if wanted.contains(&e) {
                            *counts.entry(e).or_default() += 1;
                        }
                    }
                }
            }
            Ok(counts)
        })
        .try_reduce(HashMap::default, |mut a, b| {
            for (e, n) in b {
                *a.entry(e).or_default() += n;
            }
            Ok(a)
        })
}

/// The vertices that are an endpoint of an asked edge, one bit each.
struct EndpointBitmap {
    words: Vec<u64>,
}

impl EndpointBitmap {
    fn new(query: &[u64]) -> Self {
        let largest = query.iter().map(|&e| e as u32).max().unwrap_or(0) as usize;
        let mut words = vec![0u64; largest / 64 + 1];
        for &e in query {
            for v in [(e >> 32) as u32, e as u32] {
                words[v as usize / 64] |= 1 << (v % 64);
            }
        }
        EndpointBitmap { words }
    }

    #[inline]
    fn contains(&self, v: u32) -> bool {
        self.words
            .get(v as usize / 64)
            .is_some_and(|w| w & (1 << (v % 64)) != 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tessera_core::leb::Simplex;

    #[test]
    fn counts_only_the_asked_edges_of_live_patches() {
        let roots = Simplex::roots(3, 10);
        let (a, b, c) = (roots[0].key, roots[1].key, roots[2].key);
        let patches: HashMap<SimplexKey, Vec<[u32; 3]>> = [
            (a, vec![[0, 1, 2], [2, 1, 3]]),
            (b, vec![[1, 2, 7], [100, 200, 300]]),
            (c, vec![[1, 2, 9]]), // not live
        ]
        .into_iter()
        .collect();
        let mut query = vec![
            edge_key(1, 2),
            edge_key(0, 1),
            edge_key(200, 300),
            edge_key(0, 3),
        ];
        query.sort_unstable();
        let triangles_of = |k: &SimplexKey| Ok(patches.get(k).map(|t| Cow::Borrowed(&t[..])));
        let live = [a, b].map(PackedKey::of_hierarchy);
        let counts = count_edges(&query, &live, &triangles_of).unwrap();
        assert_eq!(counts.get(&edge_key(1, 2)), Some(&3));
        assert_eq!(counts.get(&edge_key(0, 1)), Some(&1));
        assert_eq!(counts.get(&edge_key(200, 300)), Some(&1));
        assert_eq!(counts.get(&edge_key(0, 3)), None);
        // Edges not asked for are not counted, even between asked endpoints.
        assert_eq!(counts.get(&edge_key(1, 3)), None);
        assert_eq!(counts.len(), 3);
    }
}
