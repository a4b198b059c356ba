//! How many bytes the build's temporary files hold, now and at most (`build --json`
//! `temp_bytes_peak`; issue 12 wants them under 1.5× the input). Every temporary file the
//! out-of-core stages make carries a [`Charge`] of a [`TempKind`]: it grows as the file is
//! written and is given back when the file is dropped (the files have no names, so dropping
//! frees them). What each kind held when the total peaked is kept too
//! ([`by_kind_at_peak`]), so a report can say which files make the peak.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// What a temporary file holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TempKind {
    /// The staged input: positions, triangles, attributes.
    StagedMesh,
    /// External sorts' runs (welding, joins, the use counts' edge keys).
    SortRuns,
    /// The triangles' barycentres spooled for the hierarchy's passes.
    Barycentres,
    /// The hierarchy's buckets.
    Buckets,
    /// Each leaf's triangle list.
    LeafLists,
    /// The simplifier's live patches.
    LiveStore,
    /// Level results spilled before they are merged.
    ResultSpill,
    /// Finished patches' bytes and records, until the repository is written.
    FinishedPatches,
    /// A checkpoint's own copies.
    Checkpoint,
}

impl TempKind {
    pub const ALL: [TempKind; 9] = [
        TempKind::StagedMesh,
        TempKind::SortRuns,
        TempKind::Barycentres,
        TempKind::Buckets,
        TempKind::LeafLists,
        TempKind::LiveStore,
        TempKind::ResultSpill,
        TempKind::FinishedPatches,
        TempKind::Checkpoint,
    ];

    /// Its name in JSON.
    pub fn name(self) -> &'static str {
        match self {
            TempKind::StagedMesh => "staged_mesh",
            TempKind::SortRuns => "sort_runs",
            TempKind::Barycentres => "barycentres",
            TempKind::Buckets => "buckets",
            TempKind::LeafLists => "leaf_lists",
            TempKind::LiveStore => "live_store",
            TempKind::ResultSpill => "result_spill",
            TempKind::FinishedPatches => "finished_patches",
            TempKind::Checkpoint => "checkpoint",
        }
    }
}

const KINDS: usize = TempKind::ALL.len();

static CURRENT: AtomicU64 = AtomicU64::new(0);
static PEAK: AtomicU64 = AtomicU64::new(0);
static STAGE_PEAK: AtomicU64 = AtomicU64::new(0);
static BY_KIND: [AtomicU64; KINDS] = [const { AtomicU64::new(0) }; KINDS];
/// `BY_KIND` when `PEAK` was last raised.
static AT_PEAK: Mutex<[u64; KINDS]> = Mutex::new([0; KINDS]);
/// `BY_KIND` when `STAGE_PEAK` was last raised.
static AT_STAGE_PEAK: Mutex<[u64; KINDS]> = Mutex::new([0; KINDS]);
/// The totals at which `AT_PEAK` and `AT_STAGE_PEAK` were last taken.
static PEAK_TAKEN: AtomicU64 = AtomicU64::new(0);
static STAGE_PEAK_TAKEN: AtomicU64 = AtomicU64::new(0);
/// A snapshot is taken when a peak passes the last one by this much: files that grow a record
/// at a time (the staged mesh's 12-byte records) would otherwise take the lock on every
/// record. So the parts at a peak may lag it by less than this.
const SNAPSHOT_GRAIN: u64 = 1 << 20;

/// Bytes the temporary files alive hold.
pub fn current() -> u64 {
    CURRENT.load(Ordering::Relaxed)
}

/// The most they held since the last `reset_peak`.
pub fn peak() -> u64 {
    PEAK.load(Ordering::Relaxed)
}

/// The most they held since the last `start_stage` (or `reset_peak`).
pub fn stage_peak() -> u64 {
    STAGE_PEAK.load(Ordering::Relaxed)
}

/// Starts a new peak from what is held now.
pub fn reset_peak() {
    PEAK.store(current(), Ordering::Relaxed);
    PEAK_TAKEN.store(current(), Ordering::Relaxed);
    *lock(&AT_PEAK) = snapshot();
    start_stage();
}

/// Starts a new stage's peak from what is held now (the overall peak goes on).
pub fn start_stage() {
    STAGE_PEAK.store(current(), Ordering::Relaxed);
    STAGE_PEAK_TAKEN.store(current(), Ordering::Relaxed);
    *lock(&AT_STAGE_PEAK) = snapshot();
}

/// What each kind held when the total last reached its peak, in [`TempKind::ALL`]'s order.
/// Taken as the peak is raised (every `SNAPSHOT_GRAIN`), while other threads may be writing:
/// the parts can be off from the peak by less than the grain and what those threads wrote
/// meanwhile (a buffer or two).
pub fn by_kind_at_peak() -> Vec<(TempKind, u64)> {
    by_kind(&AT_PEAK)
}

/// [`by_kind_at_peak`] for the stage's peak ([`stage_peak`]).
pub fn by_kind_at_stage_peak() -> Vec<(TempKind, u64)> {
    by_kind(&AT_STAGE_PEAK)
}

fn by_kind(at: &'static Mutex<[u64; KINDS]>) -> Vec<(TempKind, u64)> {
    let at = *lock(at);
    TempKind::ALL.into_iter().zip(at).collect()
}

fn lock(at: &'static Mutex<[u64; KINDS]>) -> std::sync::MutexGuard<'static, [u64; KINDS]> {
    at.lock().unwrap_or_else(|e| e.into_inner())
}

/// `at` := the parts now, if the new peak `now` passed the last one taken by the grain.
fn take(taken: &AtomicU64, at: &'static Mutex<[u64; KINDS]>, now: u64) {
    if now >= taken.load(Ordering::Relaxed).saturating_add(SNAPSHOT_GRAIN) {
        taken.store(now, Ordering::Relaxed);
        *lock(at) = snapshot();
    }
}

fn snapshot() -> [u64; KINDS] {
    std::array::from_fn(|k| BY_KIND[k].load(Ordering::Relaxed))
}

/// The bytes one temporary file holds, counted in the totals until dropped or released.
#[derive(Debug)]
pub struct Charge {
    bytes: AtomicU64,
    kind: TempKind,
}

impl Charge {
    pub fn new(kind: TempKind) -> Charge {
        Charge {
            bytes: AtomicU64::new(0),
            kind,
        }
    }

    /// The file grew by `bytes`.
    pub fn grow(&self, bytes: u64) {
        self.bytes.fetch_add(bytes, Ordering::Relaxed);
        BY_KIND[self.kind as usize].fetch_add(bytes, Ordering::Relaxed);
        let now = CURRENT.fetch_add(bytes, Ordering::Relaxed) + bytes;
        if STAGE_PEAK.fetch_max(now, Ordering::Relaxed) < now {
            take(&STAGE_PEAK_TAKEN, &AT_STAGE_PEAK, now);
        }
        if PEAK.fetch_max(now, Ordering::Relaxed) < now {
            take(&PEAK_TAKEN, &AT_PEAK, now);
        }
    }

    /// The file gave back `bytes` of its space (at most what it holds).
    pub fn shrink(&self, bytes: u64) {
        let held = self.bytes.load(Ordering::Relaxed);
        let bytes = bytes.min(held);
        self.bytes.fetch_sub(bytes, Ordering::Relaxed);
        BY_KIND[self.kind as usize].fetch_sub(bytes, Ordering::Relaxed);
        CURRENT.fetch_sub(bytes, Ordering::Relaxed);
    }

    /// The file was emptied.
    pub fn release(&self) {
        let held = self.bytes.swap(0, Ordering::Relaxed);
        BY_KIND[self.kind as usize].fetch_sub(held, Ordering::Relaxed);
        CURRENT.fetch_sub(held, Ordering::Relaxed);
    }

    /// Bytes charged.
    pub fn bytes(&self) -> u64 {
        self.bytes.load(Ordering::Relaxed)
    }
}

impl Drop for Charge {
    fn drop(&mut self) {
        self.release();
    }
}
