//! How many bytes the build's temporary files hold, now and at most (`build --json`
//! `temp_bytes_peak`; issue 12 wants them under 1.5× the input). Every temporary file the
//! out-of-core stages make carries a [`Charge`]: it grows as the file is written and is given
//! back when the file is dropped (the files have no names, so dropping frees them).

use std::sync::atomic::{AtomicU64, Ordering};

static CURRENT: AtomicU64 = AtomicU64::new(0);
static PEAK: AtomicU64 = AtomicU64::new(0);

/// Bytes the temporary files alive hold.
pub fn current() -> u64 {
    CURRENT.load(Ordering::Relaxed)
}

/// The most they held since the last `reset_peak`.
pub fn peak() -> u64 {
    PEAK.load(Ordering::Relaxed)
}

/// Starts a new peak from what is held now.
pub fn reset_peak() {
    PEAK.store(current(), Ordering::Relaxed);
}

/// The bytes one temporary file holds, counted in the totals until dropped or released.
#[derive(Debug, Default)]
pub struct Charge(AtomicU64);

impl Charge {
    pub fn new() -> Charge {
        Charge(AtomicU64::new(0))
    }

    /// The file grew by `bytes`.
    pub fn grow(&self, bytes: u64) {
        self.0.fetch_add(bytes, Ordering::Relaxed);
        let now = CURRENT.fetch_add(bytes, Ordering::Relaxed) + bytes;
        PEAK.fetch_max(now, Ordering::Relaxed);
    }

    /// The file gave back `bytes` of its space (at most what it holds).
    pub fn shrink(&self, bytes: u64) {
        let held = self.0.load(Ordering::Relaxed);
        let bytes = bytes.min(held);
        self.0.fetch_sub(bytes, Ordering::Relaxed);
        CURRENT.fetch_sub(bytes, Ordering::Relaxed);
    }

    /// The file was emptied.
    pub fn release(&self) {
        let held = self.0.swap(0, Ordering::Relaxed);
        CURRENT.fetch_sub(held, Ordering::Relaxed);
    }

    /// Bytes charged.
    pub fn bytes(&self) -> u64 {
        self.0.load(Ordering::Relaxed)
    }
}

impl Drop for Charge {
    fn drop(&mut self) {
        self.release();
    }
}
