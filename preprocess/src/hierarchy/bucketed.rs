//! Hierarchy construction out of core: the same hierarchy as [`build_hierarchy`], built without
//! ever holding every triangle's barycentre in memory, through buckets on disk (issue 12, first
//! stage).
//!
//! 1. **Coarse passes** (`coarse_passes.rs`) find the *buckets*: the leaves of the least conforming refinement whose
//!    leaves hold at most `max_bucket_triangles` triangles (and that makes only splits the
//!    final hierarchy also makes). A pass streams the source once and counts, for every leaf
//!    still possibly over the cap, the triangles of each simplex of the complete subtree a few
//!    levels below it (a histogram), then splits every counted simplex over the cap, top
//!    down, with the forced splits the conforming mesh makes; so one pass advances several
//!    levels. A leaf created by a forced split inherits its parent's count as a bound and is
//!    counted in the next pass if that bound is over the cap.
//! 2. **One distribution pass** appends each triangle's record (index, location, delta-coded
//!    against the bucket's previous record) to its bucket: a buffer per bucket; when together
//!    they pass the budget, the fullest are written as runs into one unnamed temporary file
//!    until half the budget is left (memory stays bounded whatever the number of buckets; the
//!    file has no name, so it vanishes when closed, also when the process is killed). Only
//!    buckets that need splitting are ever loaded whole, and those hold at most the cap.
//! 3. **Per bucket** that needs a split, in key order: load its records (at most the cap) and run the in-core
//!    splitting on the leaves inside its cell against the shared mesh. A split inside may force
//!    splits in other buckets' cells: a bucket not yet processed sees them when it is; a
//!    processed one is marked for re-reading (a forced split makes children holding at most
//!    what their parent holds, so, the parent being within the criterion, they need no split).
//! 4. **Final assignment**: the leaves of processed, untouched buckets keep the lists found in
//!    step 3; every other bucket is streamed once more, run by run, and each record descended
//!    from the bucket's cell to its final leaf.
//!
//! Why the result is `build_hierarchy`'s exactly: with `LeafTriangles(max)`, the result of
//! both is the least conforming LEB refinement in which no splittable leaf holds more than
//! `max` triangles (conforming refinements are closed under intersection and a leaf of an
//! intersection is a leaf of one of them, so the least exists); both make only splits every
//! such refinement makes (a splittable leaf over the cap, or a split forced by one) and stop
//! when the criterion holds, so both reach that least one, in whatever order. `Levels(l)` is
//! the complete refinement to level `l`. The coarse criterion (over `max_bucket_triangles`
//! *and* over the final criterion) only makes splits the final one needs. Leaf lists are in
//! input order because the source streams in index order, each bucket's runs are read in
//! the order they were written, and partitioning keeps order. `Hierarchy::diamonds` is sorted
//! by (level, id). The tests compare both constructions on scans, a height field and
//! generated meshes of widely varying density, with caps that make many buckets.

use std::io;
use std::path::PathBuf;

use rustc_hash::FxHashMap as HashMap;

use tessera_core::leb::{ConformingMesh, Diamond, Simplex, SimplexKey};

use super::barycentres::{BarycentreSource, InOrder, RECORD_BYTES};
use super::bucket_store::BucketStore;
use super::coarse_passes::coarse_refine;
use super::leaf_lists::{LeafListSpool, LeafListWriter};
use super::locator::Locator;
use super::{partition, Construction, Hierarchy, Located, SplitDiamond};
use crate::frame::LatticeFrame;

/// How much of the input the bucketed construction may hold at once, and where its
/// temporary file goes.
#[derive(Clone, Debug)]
pub struct BucketBudget {
    /// Most triangles a bucket may hold (more only in a bucket that needs no split: where the
    /// final hierarchy has a leaf with more, one that cannot split or, when this is below the
    /// leaf cap, one within the cap; such a bucket is never loaded whole). The bucket being
    /// split takes about 70 bytes per triangle (its records and their per-leaf lists).
    pub max_bucket_triangles: usize,
    /// Bytes the distribution buffers may hold together.
    pub buffer_bytes: usize,
    /// Directory of the temporary file (a few bytes a triangle, delta-coded; gone on return).
    pub temp_dir: PathBuf,
}

impl BucketBudget {
    /// Buffers for as many records as a bucket holds, and at least 8 MiB.
    pub fn new(max_bucket_triangles: usize, temp_dir: impl Into<PathBuf>) -> BucketBudget {
        BucketBudget {
            max_bucket_triangles,
            buffer_bytes: (max_bucket_triangles.saturating_mul(RECORD_BYTES)).max(MIN_BUFFER_BYTES),
            temp_dir: temp_dir.into(),
        }
    }
}

/// What [`build_hierarchy_bucketed`] did, for reports and tests.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BucketStats {
    /// Coarse counting passes over the source.
    pub coarse_passes: usize,
    /// Buckets (leaves of the coarse mesh), empty ones included.
    pub buckets: usize,
    /// Triangles in the fullest bucket.
    pub largest_bucket: u64,
    /// Buckets loaded and split further (step 3).
    pub split_buckets: usize,
    /// Triangles in the fullest bucket loaded whole (at most `max_bucket_triangles`).
    pub largest_split_bucket: u64,
    /// Simplices split outside the bucket being split (forced across a cell's border).
    pub cross_splits: usize,
    /// Processed buckets that a later bucket's forced split touched (read again).
    pub dirty_buckets: usize,
    /// Runs written to the temporary file.
    pub runs: usize,
    /// Bytes written to the temporary file.
    pub temp_bytes: u64,
}

/// Builds the hierarchy [`build_hierarchy`] builds from the same barycentres, equal in every
/// field (split diamonds in (level, id) order with their simplices, parents and children; the
/// mesh's splits and leaves; each leaf's triangles in input order), without holding the
/// barycentres in memory. It holds at once: the records of one bucket being split (at most
/// `max_bucket_triangles`), or the distribution buffers (`buffer_bytes`), or the coarse
/// passes' counts (a few bytes per `max_bucket_triangles / 4` histogram nodes, at least
/// 16384 nodes); and the hierarchy it returns (a `u32` per triangle in `leaf_triangles`).
///
/// `source` is streamed `coarse_passes + 1` times ([`BucketStats`]): the coarse counting
/// passes, then the distribution into buckets on disk; buckets are read back from one
/// temporary file in `budget.temp_dir` (delta-coded records: `location_codec.rs`), which has
/// no name (created with `O_TMPFILE` where the file system allows it, else unlinked as soon as
/// created), so it is gone on return, on error, and when the process dies. To read a costly source once, wrap
/// it in [`SpooledBarycentres`]. Errors: the source's, the temporary file's, and
/// `InvalidData` when the source does not stream indices 0, 1, 2, … in order, the same count
/// on every pass.
pub fn build_hierarchy_bucketed(
    frame: LatticeFrame,
    source: &(impl BarycentreSource + ?Sized),
    construction: Construction,
    budget: &BucketBudget,
) -> io::Result<Hierarchy> {
    build_hierarchy_bucketed_with_stats(frame, source, construction, budget).map(|(h, _)| h)
}

/// [`build_hierarchy_bucketed`], also saying what it did.
pub fn build_hierarchy_bucketed_with_stats(
    frame: LatticeFrame,
    source: &(impl BarycentreSource + ?Sized),
    construction: Construction,
    budget: &BucketBudget,
) -> io::Result<(Hierarchy, BucketStats)> {
    let (mut hierarchy, lists, stats) =
        build_hierarchy_bucketed_spooled(frame, source, construction, budget)?;
    hierarchy.leaf_triangles = lists.into_map()?;
    Ok((hierarchy, stats))
}

/// [`build_hierarchy_bucketed_with_stats`] with the leaves' lists left on disk (in an unnamed
/// file in `budget.temp_dir`; `Hierarchy::leaf_triangles` is empty): what an out-of-core build
/// uses, holding a few dozen bytes per leaf instead of four per triangle.
pub fn build_hierarchy_bucketed_spooled(
    frame: LatticeFrame,
    source: &(impl BarycentreSource + ?Sized),
    construction: Construction,
    budget: &BucketBudget,
) -> io::Result<(Hierarchy, LeafListSpool, BucketStats)> {
    let cap = budget.max_bucket_triangles.max(1) as u64;
    let criterion = Criterion(construction);
    let mut stats = BucketStats::default();
    let mut mesh = ConformingMesh::new(frame.dim, frame.bits);
    let mut diamonds: Vec<SplitDiamond> = Vec::new();

    // 1. Coarse passes.
    let triangles: Option<u64> = coarse_refine(
        &frame,
        source,
        &criterion,
        cap,
        &mut mesh,
        &mut diamonds,
        &mut stats,
    )?;

    // 2. Distribution.
    let mut buckets: Vec<Simplex> = mesh.leaves().collect();
    buckets.sort_unstable_by_key(|s| s.key);
    stats.buckets = buckets.len();
    let mut store = BucketStore::new(budget, buckets.len())?;
    {
        let locator = Locator::new(&mesh, mesh.roots());
        let leaf_bucket: Vec<u32> = {
            let index: HashMap<SimplexKey, u32> = buckets
                .iter()
                .enumerate()
                .map(|(i, s)| (s.key, i as u32))
                .collect();
            locator.leaves.iter().map(|s| index[&s.key]).collect()
        };
        let mut io_error = None;
        let mut order = InOrder::default();
        source.for_each_barycentre_last(&mut |t, b| {
            if io_error.is_some() || !order.accept(t) {
                return;
            }
            let leaf = locator.locate_root(frame.dim, b);
            if let Err(e) = store.push(leaf_bucket[leaf as usize] as usize, t, b) {
                io_error = Some(e);
            }
        })?;
        if let Some(e) = io_error {
            return Err(e);
        }
        order.finish(triangles)?;
        store.flush()?;
    }
    stats.largest_bucket = store.counts.iter().copied().max().unwrap_or(0);
    stats.runs = store.runs.iter().map(Vec::len).sum();
    stats.temp_bytes = store.end;

    // 3. Per bucket: split inside its cell.
    let bucket_of: HashMap<SimplexKey, u32> = buckets
        .iter()
        .enumerate()
        .map(|(i, s)| (s.key, i as u32))
        .collect();
    let mut bucket_levels: Vec<u16> = buckets.iter().map(|s| s.level()).collect();
    bucket_levels.sort_unstable();
    bucket_levels.dedup();
    let owner = |key: SimplexKey| -> u32 {
        bucket_levels
            .iter()
            .take_while(|&&l| l <= key.level)
            .find_map(|&l| bucket_of.get(&key.ancestor(l)).copied())
            .expect("every leaf lies in a bucket's cell")
    };
    // Each leaf's list goes to the spool as soon as it is final. A processed bucket's leaves
    // are final until a later bucket's forced split touches the bucket: then they are
    // forgotten (the space they took stays unused) and assigned again in step 4.
    let mut spool = LeafListWriter::new(&budget.temp_dir)?;
    let mut done: Vec<Option<Vec<SimplexKey>>> = vec![None; buckets.len()];
    let mut processed = vec![false; buckets.len()];
    for (b, cell) in buckets.iter().enumerate() {
        let count = store.counts[b] as usize;
        if !(cell.can_split() && criterion.needs_split(cell, count)) {
            continue; // no leaf of its cell needs a split (see `Criterion`)
        }
        stats.split_buckets += 1;
        stats.largest_split_bucket = stats.largest_split_bucket.max(count as u64);
        let records = store.load(b)?;
        let mut dirty = Vec::new();
        let lists = split_bucket(
            &mut mesh,
            cell,
            records,
            &criterion,
            &mut diamonds,
            &mut |key| {
                stats.cross_splits += 1;
                let other = owner(key) as usize;
                if other != b && processed[other] && done[other].is_some() {
                    dirty.push(other);
                }
            },
        );
        for other in dirty {
            if let Some(keys) = done[other].take() {
                stats.dirty_buckets += 1;
                keys.into_iter().for_each(|k| spool.forget(k));
            }
        }
        let mut keys = Vec::with_capacity(lists.len());
        for (key, list) in lists {
            spool.write(key, &list)?;
            keys.push(key);
        }
        processed[b] = true;
        done[b] = Some(keys);
    }

    // 4. Final assignment.
    for (b, cell) in buckets.iter().enumerate() {
        if done[b].is_some() || store.counts[b] == 0 {
            continue;
        }
        let locator = Locator::new(&mesh, std::slice::from_ref(cell));
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); locator.leaves.len()];
        store.for_each(b, |t, q| lists[locator.locate_from(0, q) as usize].push(t))?;
        for (leaf, list) in locator.leaves.iter().zip(lists) {
            spool.write(leaf.key, &list)?;
        }
    }
    drop(store);
    let lists = spool.finish(mesh.leaves().map(|s| s.key))?;

    // The criterion holds everywhere (a bug otherwise, not an input problem).
    let mut leaves: Vec<Simplex> = mesh.leaves().collect();
    leaves.sort_unstable_by_key(|s| s.key);
    for (leaf, (key, n)) in leaves.into_iter().zip(lists.leaves()) {
        debug_assert_eq!(leaf.key, key);
        assert!(
            !(leaf.can_split() && criterion.needs_split(&leaf, n)),
            "bucketed hierarchy: leaf {key:?} with {n} triangles was left unsplit"
        );
    }
    diamonds.sort_unstable_by_key(|d| (d.level, d.id));
    Ok((
        Hierarchy {
            frame,
            mesh,
            diamonds,
            leaf_triangles: Default::default(),
        },
        lists,
        stats,
    ))
}

/// The final hierarchy's split criterion, `build_hierarchy`'s `needs_split`. For both
/// constructions a leaf that does not need a split has no descendant that does (children hold
/// at most their parent's triangles and are deeper), which is what lets whole buckets be
/// skipped and forced splits into finished buckets be left alone.
pub(super) struct Criterion(pub(super) Construction);

impl Criterion {
    pub(super) fn needs_split(&self, s: &Simplex, count: usize) -> bool {
        match self.0 {
            Construction::LeafTriangles(max) => count > max,
            Construction::Levels(levels) => s.level() < levels,
        }
    }

    /// A coarse split: over the bucket cap and needed by the final hierarchy.
    pub(super) fn coarse_split(&self, s: &Simplex, count: u64, cap: u64) -> bool {
        count > cap && s.can_split() && self.needs_split(s, count.min(usize::MAX as u64) as usize)
    }
}

/// Leaves with their triangles, in input order.
type LeafLists = Vec<(SimplexKey, Vec<u32>)>;

/// Step 3 for one bucket: `build_hierarchy`'s splitting, on the leaves inside `cell`.
/// `touched(key)` hears of every split simplex outside the cell (a forced split). Returns the
/// cell's leaves with their triangles.
fn split_bucket(
    mesh: &mut ConformingMesh,
    cell: &Simplex,
    records: Vec<(u32, [f64; 3])>,
    criterion: &Criterion,
    diamonds: &mut Vec<SplitDiamond>,
    touched: &mut dyn FnMut(SimplexKey),
) -> LeafLists {
    // Earlier buckets' forced splits may have split the cell already.
    let locator = Locator::new(mesh, std::slice::from_ref(cell));
    let mut lists: Vec<Vec<Located>> = vec![Vec::new(); locator.leaves.len()];
    for (triangle, barycenter) in records {
        lists[locator.locate_from(0, barycenter) as usize].push(Located {
            barycenter,
            triangle,
        });
    }
    let mut leaf_triangles: HashMap<SimplexKey, Vec<Located>> = HashMap::default();
    let mut queue = Vec::new();
    for (leaf, list) in locator.leaves.iter().zip(lists) {
        if leaf.can_split() && criterion.needs_split(leaf, list.len()) {
            queue.push(*leaf);
        }
        leaf_triangles.insert(leaf.key, list);
    }
    while let Some(s) = queue.pop() {
        if !mesh.contains_leaf(&s) || !s.can_split() {
            continue;
        }
        mesh.split(s.split_point(), &mut |d: &Diamond| {
            for t in &d.simplices {
                let Some(triangles) = leaf_triangles.remove(&t.key) else {
                    touched(t.key);
                    continue;
                };
                let children = t.children();
                let parts = partition(triangles, &t.bisector());
                for (c, part) in children.iter().zip(parts) {
                    if criterion.needs_split(c, part.len()) && c.can_split() {
                        queue.push(*c);
                    }
                    leaf_triangles.insert(c.key, part);
                }
            }
            diamonds.push(SplitDiamond::of(d));
        });
    }
    leaf_triangles
        .into_iter()
        .map(|(key, list)| (key, list.iter().map(|l| l.triangle).collect()))
        .collect()
}

/// [`BucketBudget::new`]'s smallest distribution buffers in all (with many tiny buckets, runs
/// of a few records would make reading them back seek-bound).
const MIN_BUFFER_BYTES: usize = 8 << 20;
