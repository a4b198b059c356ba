//! Where the exact crack check (`geometric_check.rs`) reads the patches' triangles: decoded
//! once and held (a slice, as the tests and small models do), or decoded from the mapped
//! repository as each cut reaches them (`RepositoryPatches`: the check of a 100 M-triangle
//! build holds one cut's triangles, not the 200 M triangles of every level). Passes over every
//! patch (the input's edges, positions) are split by hash into as many passes as keep each
//! within `PASS_BYTES`.

use rayon::prelude::*;
use tessera_core::repository::reader::Repository;
use tessera_core::repository::RepositoryError;

/// Bytes of keys one pass over every patch may gather (the input's edges, the stored
/// positions): with the cut's own triangles, what bounds the check's memory.
pub const PASS_BYTES: usize = 128 << 20;

/// A long pass lets go of the map's pages whenever it has read this many bytes of patches
/// (the map's pages count in the resident set until then: a whole 1.6 GB repository).
const RELEASE_BYTES: u64 = 64 << 20;

/// A simplex's triangles by global vertex id, for the check.
pub trait CutPatches: Sync {
    /// The triangles of the simplex in row `tet` of the tet table.
    fn triangles(&self, tet: usize) -> Vec<[u32; 3]>;
    /// Called after a pass over many patches: lets go of what reading them mapped in.
    fn release(&self) {}
}

impl CutPatches for [Vec<[u32; 3]>] {
    fn triangles(&self, tet: usize) -> Vec<[u32; 3]> {
        self[tet].clone()
    }
}

impl CutPatches for Vec<Vec<[u32; 3]>> {
    fn triangles(&self, tet: usize) -> Vec<[u32; 3]> {
        self.as_slice().triangles(tet)
    }
}

/// The repository's patches, decoded when asked; every patch decoded once by `new`, so that
/// a damaged one is an error there and never a panic in the middle of the check.
pub struct RepositoryPatches<'r> {
    repo: &'r Repository,
    pacer: Pacer<'r>,
}

impl<'r> RepositoryPatches<'r> {
    /// Checks that every patch decodes (then lets go of the pages that read).
    pub fn new(repo: &'r Repository) -> Result<Self, RepositoryError> {
        let pacer = Pacer::new(repo);
        let chunks: Vec<usize> = (0..repo.tets().len()).step_by(4096).collect();
        let result = chunks.par_iter().try_for_each(|&start| {
            for i in start..(start + 4096).min(repo.tets().len()) {
                decode(repo, i)?;
                pacer.read(i);
            }
            Ok(())
        });
        repo.release_pages();
        result.map(|()| RepositoryPatches { repo, pacer })
    }
}

impl CutPatches for RepositoryPatches<'_> {
    fn triangles(&self, tet: usize) -> Vec<[u32; 3]> {
        let triangles = decode(self.repo, tet).expect("every patch decoded when the check began");
        self.pacer.read(tet);
        triangles
    }

    fn release(&self) {
        self.repo.release_pages();
    }
}

/// Lets go of the map's pages every `RELEASE_BYTES` of patches read (from any thread).
pub(crate) struct Pacer<'r> {
    repo: &'r Repository,
    read: std::sync::atomic::AtomicU64,
}

impl<'r> Pacer<'r> {
    pub(crate) fn new(repo: &'r Repository) -> Self {
        Pacer {
            repo,
            read: Default::default(),
        }
    }

    /// Patch `tet` was read.
    pub(crate) fn read(&self, tet: usize) {
        use std::sync::atomic::Ordering::Relaxed;
        let t = &self.repo.tets()[tet];
        let bytes = t.patch_bytes as u64 + t.id_bytes as u64;
        if self.read.fetch_add(bytes, Relaxed) + bytes >= RELEASE_BYTES {
            self.read.store(0, Relaxed);
            self.repo.release_pages();
        }
    }
}

/// A patch's triangles by global vertex id.
pub fn decode(repo: &Repository, tet: usize) -> Result<Vec<[u32; 3]>, RepositoryError> {
    let patch = repo.patch(tet)?;
    let patch = patch.view();
    let ids: Vec<u32> = patch.global_ids().collect();
    Ok(patch
        .triangles()
        .map(|t| t.map(|l| ids[l as usize]))
        .collect())
}

/// Sorted (key, how many times) runs of the keys of several sorted lists, merged.
pub(crate) fn merged_runs(lists: &[Vec<u64>], mut run: impl FnMut(u64, u32)) {
    use std::cmp::Reverse;
    let mut heads: std::collections::BinaryHeap<Reverse<(u64, usize)>> = lists
        .iter()
        .enumerate()
        .filter(|(_, l)| !l.is_empty())
        .map(|(i, l)| Reverse((l[0], i)))
        .collect();
    let mut at = vec![0usize; lists.len()];
    let mut current: Option<(u64, u32)> = None;
    while let Some(Reverse((key, i))) = heads.pop() {
        at[i] += 1;
        if let Some(&next) = lists[i].get(at[i]) {
            heads.push(Reverse((next, i)));
        }
        current = match current {
            Some((k, n)) if k == key => Some((k, n + 1)),
            Some((k, n)) => {
                run(k, n);
                Some((key, 1))
            }
            None => Some((key, 1)),
        };
    }
    if let Some((k, n)) = current {
        run(k, n);
    }
}

/// Passes that keep `items` keys of `item_bytes` each within `pass_bytes` a pass.
pub(crate) fn passes(items: u64, item_bytes: usize, pass_bytes: usize) -> u64 {
    (items.saturating_mul(item_bytes as u64))
        .div_ceil(pass_bytes.max(1) as u64)
        .max(1)
}

/// The pass (of `passes`) that handles `key`: a multiplicative hash, so that keys of one
/// pass are spread over the whole key range.
#[inline]
pub(crate) fn pass_of(key: u64, passes: u64) -> u64 {
    if passes == 1 {
        return 0;
    }
    (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32) % passes
}
