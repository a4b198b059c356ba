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
//! 4. **Final assignment**: the leaves step 3 wrote keep their lists unless a later bucket's
//!    forced split split them; a bucket step 3 did not load is streamed once more, run by run,
//!    and each record descended from the bucket's cell to its final leaf; a bucket with split
//!    leaves is streamed too, but only the records of those leaves' lists (read back from the
//!    spool, merged in input order) are descended, from their leaf. The mesh is final by then,
//!    so a few buckets at a time are located in parallel, their lists written in bucket order.
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

use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;

use tessera_core::leb::{ConformingMesh, Simplex, SimplexKey};

use super::barycentres::{BarycentreSource, InOrder, RECORD_BYTES};
use super::bucket_store::BucketStore;
use super::coarse_passes::{coarse_refine, LOCATE_CHUNK};
use super::leaf_lists::{LeafListSpool, LeafListWriter, ListSpan};
use super::locator::Locator;
use super::refine::{refine, Located, LocatedLists};
use super::{Construction, Hierarchy, SplitDiamond};
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
    /// Processed buckets some of whose leaves a later bucket's forced split split (those
    /// leaves' records located again in step 4).
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
    let triangle_bound: u64;
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
        // A chunk at a time: located in parallel, then stored in order.
        let mut chunk: Vec<(u32, [f64; 3])> = Vec::with_capacity(LOCATE_CHUNK);
        let mut leaves: Vec<u32> = Vec::new();
        let mut distribute = |chunk: &mut Vec<(u32, [f64; 3])>| -> io::Result<()> {
            chunk
                .par_iter()
                .with_min_len(1 << 10)
                .map(|&(_, b)| locator.locate_root(frame.dim, b))
                .collect_into_vec(&mut leaves);
            for (&(t, b), &leaf) in chunk.iter().zip(&leaves) {
                store.push(leaf_bucket[leaf as usize] as usize, t, b)?;
            }
            chunk.clear();
            Ok(())
        };
        source.for_each_barycentre_last(&mut |t, b| {
            if io_error.is_some() || !order.accept(t) {
                return;
            }
            chunk.push((t, b));
            if chunk.len() == LOCATE_CHUNK {
                if let Err(e) = distribute(&mut chunk) {
                    io_error = Some(e);
                }
            }
        })?;
        if let Some(e) = io_error {
            return Err(e);
        }
        distribute(&mut chunk)?;
        triangle_bound = order.finish(triangles)?;
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
    // Each leaf's list goes to the spool as soon as it is final. A processed bucket's leaf
    // stays final until a later bucket's forced split splits it: then its list is taken out
    // of the spool (the space it took stays unused) and its triangles are located again in
    // step 4, from that leaf down; the bucket's other leaves keep theirs.
    let mut spool = LeafListWriter::new(&budget.temp_dir)?;
    let mut processed = vec![false; buckets.len()];
    // Per bucket: its leaves split since their lists were written, with those lists' spans.
    let mut stale: Vec<Vec<(SimplexKey, ListSpan)>> = vec![Vec::new(); buckets.len()];
    for (b, cell) in buckets.iter().enumerate() {
        let count = store.counts[b] as usize;
        if !(cell.can_split() && criterion.needs_split(cell, count)) {
            continue; // no leaf of its cell needs a split (see `Criterion`)
        }
        stats.split_buckets += 1;
        stats.largest_split_bucket = stats.largest_split_bucket.max(count as u64);
        let records = store.load(b)?;
        let mut touched = Vec::new();
        let lists = split_bucket(
            &mut mesh,
            cell,
            records,
            &criterion,
            &mut diamonds,
            &mut |key| {
                stats.cross_splits += 1;
                let other = owner(key) as usize;
                if other != b && processed[other] {
                    touched.push((other, key));
                }
            },
        );
        // A touched key with no list is a child of a leaf already taken out.
        for (other, key) in touched {
            if let Some(span) = spool.take(key) {
                stats.dirty_buckets += usize::from(stale[other].is_empty());
                stale[other].push((key, span));
            }
        }
        for (key, list) in lists {
            spool.write(key, &list)?;
        }
        processed[b] = true;
    }

    // 4. Final assignment: the buckets never split in step 3 from their cells, and the
    // leaves split since step 3 wrote them from those leaves. The mesh no longer changes, so
    // a window of buckets is located in parallel and their lists written in bucket order, as
    // one at a time would write them.
    let remaining: Vec<(usize, Vec<(SimplexKey, ListSpan)>)> = stale
        .into_iter()
        .enumerate()
        .filter(|(b, stale)| !stale.is_empty() || (!processed[*b] && store.counts[*b] > 0))
        .collect();
    for window in assignment_windows(&remaining, &store.counts, cap) {
        // The window's stale lists, read back (each a part of its bucket's triangles).
        let mut starts: Vec<Vec<(Simplex, Vec<u32>)>> = Vec::with_capacity(window.len());
        for (_, stale) in window {
            let mut leaves = Vec::with_capacity(stale.len());
            for &(key, span) in stale {
                let leaf = mesh.simplex(key).expect("a split leaf stays in the mesh");
                leaves.push((leaf, spool.read(span, triangle_bound)?));
            }
            starts.push(leaves);
        }
        let assigned: Vec<io::Result<LeafLists>> = window
            .par_iter()
            .zip(&starts)
            .map(|((b, _), stale)| assign_bucket(&mesh, &buckets[*b], stale, &store, *b))
            .collect();
        for lists in assigned {
            for (key, list) in lists? {
                spool.write(key, &list)?;
            }
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

/// Step 4's windows of buckets located together: consecutive, at most
/// `ASSIGNMENT_WINDOW_CAPS` buckets' cap of triangles in all (their lists, 4 bytes a triangle,
/// are held together: well within the 70 bytes a triangle of the cap a split bucket takes),
/// a bucket over that alone.
fn assignment_windows<'a, T>(
    buckets: &'a [(usize, T)],
    counts: &'a [u64],
    cap: u64,
) -> impl Iterator<Item = &'a [(usize, T)]> + 'a {
    let most = cap.saturating_mul(ASSIGNMENT_WINDOW_CAPS);
    let mut rest = buckets;
    std::iter::from_fn(move || {
        let first = rest.first()?.0;
        let mut sum = counts[first];
        let mut end = 1;
        while end < rest.len() && sum + counts[rest[end].0] <= most {
            sum += counts[rest[end].0];
            end += 1;
        }
        let (window, after) = rest.split_at(end);
        rest = after;
        Some(window)
    })
}

/// Step 4's windows hold up to this many buckets' cap of triangles.
const ASSIGNMENT_WINDOW_CAPS: u64 = 4;

/// Step 4 for one bucket: with no `stale` leaves (a bucket step 3 did not split), each of
/// its records located from the bucket's cell; else only the records of the stale leaves'
/// lists (split since step 3 wrote them), each from its leaf. Returns the leaves found with
/// their triangles, in input order.
fn assign_bucket(
    mesh: &ConformingMesh,
    cell: &Simplex,
    stale: &[(Simplex, Vec<u32>)],
    store: &BucketStore,
    b: usize,
) -> io::Result<LeafLists> {
    if stale.is_empty() {
        let locator = Locator::new(mesh, std::slice::from_ref(cell));
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); locator.leaves.len()];
        store.for_each(b, |t, q| lists[locator.locate_from(0, q) as usize].push(t))?;
        return Ok(locator
            .leaves
            .iter()
            .map(|leaf| leaf.key)
            .zip(lists)
            .collect());
    }
    let starts: Vec<Simplex> = stale.iter().map(|(leaf, _)| *leaf).collect();
    let locator = Locator::new(mesh, &starts);
    // The stale lists merged, in input order (each triangle is in one of them at most).
    let mut wanted: Vec<(u32, u32)> = stale
        .iter()
        .enumerate()
        .flat_map(|(i, (_, list))| list.iter().map(move |&t| (t, i as u32)))
        .collect();
    wanted.sort_unstable();
    let mut lists: Vec<Vec<u32>> = vec![Vec::new(); locator.leaves.len()];
    let mut next = wanted.iter().peekable();
    let mut missing = false;
    store.for_each(b, |t, q| match next.peek() {
        Some(&&(w, start)) if w == t => {
            next.next();
            lists[locator.locate_from(start as usize, q) as usize].push(t);
        }
        Some(&&(w, _)) if w < t => missing = true,
        _ => {}
    })?;
    if missing || next.next().is_some() {
        return Err(io::Error::other(
            "bucketed hierarchy: a split leaf's triangle is missing from its bucket",
        ));
    }
    Ok(locator
        .leaves
        .iter()
        .map(|leaf| leaf.key)
        .zip(lists)
        .collect())
}

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
    let leaves: Vec<u32> = records
        .par_iter()
        .with_min_len(1 << 12)
        .map(|&(_, barycenter)| locator.locate_from(0, barycenter))
        .collect();
    for ((triangle, barycenter), leaf) in records.into_iter().zip(leaves) {
        lists[leaf as usize].push(Located {
            barycenter,
            triangle,
        });
    }
    let mut leaf_triangles: LocatedLists = HashMap::default();
    let mut queue = Vec::new();
    for (leaf, list) in locator.leaves.iter().zip(lists) {
        if leaf.can_split() && criterion.needs_split(leaf, list.len()) {
            queue.push(*leaf);
        }
        leaf_triangles.insert(leaf.key, list);
    }
    let needs_split = |s: &Simplex, n: usize| criterion.needs_split(s, n);
    refine(
        mesh,
        &mut leaf_triangles,
        queue,
        &needs_split,
        diamonds,
        touched,
    );
    leaf_triangles
        .into_iter()
        .map(|(key, list)| (key, list.iter().map(|l| l.triangle).collect()))
        .collect()
}

/// [`BucketBudget::new`]'s smallest distribution buffers in all (with many tiny buckets, runs
/// of a few records would make reading them back seek-bound).
const MIN_BUFFER_BYTES: usize = 8 << 20;
