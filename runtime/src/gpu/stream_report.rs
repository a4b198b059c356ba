//! What the streaming renderer reports: why it cannot be made (`StreamError`), what one
//! frame did (`StreamedGpuFrame`) and its running totals (`GpuStreamStats`).

use super::renderer::RenderError;
use crate::stream::{ResidencyStats, StreamFrame};

/// Why a streaming renderer cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum StreamError {
    #[error(
        "the GPU budget of {budget} bytes is too small: the fixed allocations (record slots, \
         lists, queues, target) take {fixed} bytes and the pinned roots {roots} bytes more"
    )]
    BudgetTooSmall { budget: u64, fixed: u64, roots: u64 },
    #[error(
        "the model's {roots} roots need {bytes} bytes of {what} in one binding, more than the \
         adapter's max_storage_buffer_binding_size ({limit} bytes)"
    )]
    RootsOverBindingLimit {
        roots: u32,
        what: &'static str,
        bytes: u64,
        limit: u64,
    },
    #[error("reading the roots' patches: {0}")]
    Roots(tessera_core::repository::RepositoryError),
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The textures cannot be drawn (budget, adapter, a page that cannot be read).
    #[error(transparent)]
    Textures(super::texture_pages::TextureError),
    /// The device failed (lost, out of memory, a failed read-back): nothing more can be
    /// drawn.
    #[error("{0}")]
    Device(#[from] super::device::GpuFailure),
}

impl From<super::texture_pages::TextureError> for StreamError {
    /// A device failure stays one (exit 3).
    fn from(e: super::texture_pages::TextureError) -> StreamError {
        match e {
            super::texture_pages::TextureError::Device(failure) => StreamError::Device(failure),
            other => StreamError::Textures(other),
        }
    }
}

/// What one streamed frame did.
#[derive(Clone, Debug)]
pub struct StreamedGpuFrame {
    /// The CPU reference's view of the frame (selection, refined, wanted) for the flags the
    /// GPU drew with (empty unless `set_cpu_reference`).
    pub reference: StreamFrame,
    /// The `may_refine` words the frame was drawn with (D / 32 words; empty unless
    /// `set_cpu_reference`: they are O(diamonds)).
    pub may_refine_words: Vec<u32>,
    /// Loads issued, evictions planned, units uploaded by this frame.
    pub loads: usize,
    pub evictions: usize,
    pub uploads: usize,
    /// Nothing issued, nothing loading or waiting for pool space.
    pub settled: bool,
    pub stats: ResidencyStats,
}

/// Streaming totals besides `ResidencyStats`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpuStreamStats {
    /// Every GPU allocation the renderer has made, by the accounting of `stream_budget`
    /// (the pools grow as units need room and never shrink: also the peak).
    pub gpu_bytes: u64,
    /// What `gpu_bytes` may grow to, the pools at their largest (≤ the budget).
    pub max_gpu_bytes: u64,
    /// The fixed part of it (everything but the record slots and the page pool).
    pub fixed_bytes: u64,
    /// Record slots (the paged directory, `records.rs`) and their bytes (records, locations,
    /// traversal queue entries).
    pub record_slots: u32,
    pub record_bytes: u64,
    /// Bytes of the page pool, and its pages.
    pub pool_bytes: u64,
    pub pool_pages: u32,
    /// Times the pools grew (a page added, record slots doubled, or both).
    pub pool_growths: u64,
    /// Bytes written into the pool (units uploaded, roots included).
    pub uploaded_bytes: u64,
    /// Seconds the loader thread spent reading (and decoding, when packed) the units it
    /// delivered, summed.
    pub read_seconds: f64,
    /// Pool fragmentation (1 − largest free range / free bytes) now.
    pub fragmentation: f64,
    /// Frames a loaded unit waited for pool space, summed.
    pub space_waits: u64,
    /// Frames whose GPU feedback was read back and used.
    pub feedback_frames: u64,
    /// List appends past the capacity (requests lost), summed.
    pub feedback_overflow: u64,
    /// With the CPU reference on: frames whose GPU feedback differed from the reference's.
    pub feedback_mismatches: u64,
}
