//! The streaming renderer's GPU budget: every allocation the renderer makes, counted from the
//! same sizes the constructors use, and the page pool that the rest of the budget buys.
//!
//! Fixed (independent of what is resident): the diamond, tet and location tables; the
//! traversal's two queues, its `may_refine` words, counters, dispatch arguments and step
//! uniforms; the feedback lists and their read-back ring; per pool page a selection list (and its read-back copy), a count (and its copy),
//! an indirect draw, a list start and a page-draw uniform slot; the frame uniforms and
//! timestamps; the target (colour, depth, read-back). The pool gets what is left, in pages of
//! at most one storage binding.

use tessera_core::repository::reader::Repository;

use super::device::GpuContext;
use super::renderer::RendererOptions;
use super::resident::{page_limit, ENTRY_BYTES, PAGE_ARGS_BYTES};
use super::stream_pool::PoolLayout;

/// The fixed bytes and the pool's layout for a budget.
#[derive(Clone, Copy, Debug)]
pub struct FixedBytes {
    pub fixed: u64,
    pub layout: PoolLayout,
}

/// Bytes of the allocations that do not depend on the pool's pages.
fn base_bytes(ctx: &GpuContext, repo: &Repository, options: &RendererOptions) -> u64 {
    let tets = repo.tets().len().max(1) as u64;
    let diamonds = repo.diamonds().len().max(1) as u64;
    let depths = 64u64; // generous: dispatch arguments and step uniforms per depth
    let uniform_align = (ctx.limits.min_uniform_buffer_offset_alignment as u64).max(256);
    let tables = 56 * diamonds + 88 * tets + 16 * tets;
    let traversal =
        2 * 4 * tets + 4 * diamonds.div_ceil(32) + 4 * depths * 4 + uniform_align * depths;
    let (w, h) = (options.width as u64, options.height as u64);
    let padded_row = (4 * w).next_multiple_of(256);
    let target = 4 * w * h + 4 * w * h + padded_row * h;
    let frame = 4096; // uniforms, timestamps and their read-back
                      // The streaming pool has no index regions (its pages are drawn by vertex pulling): the
                      // index buffer and the page-simplex table are their 16-byte minimums.
    let no_index_regions = 16 + 16;
    let feedback = super::feedback::Feedback::bytes(super::streamer::feedback_capacity(
        repo.tets().len(),
        options.width,
        options.height,
    ));
    tables + traversal + target + frame + feedback + no_index_regions
}

/// Bytes per pool page besides the page itself.
fn per_page_bytes(ctx: &GpuContext, layout: &PoolLayout) -> u64 {
    let uniform_align = (ctx.limits.min_uniform_buffer_offset_alignment as u64).max(8);
    // Lists and their read-back copies, counts and copies, the page's draw and dispatch
    // arguments, its `PageInfo` (16 B), a list start and a page-draw uniform slot.
    2 * layout.patch_capacity as u64 * ENTRY_BYTES
        + 2 * 4
        + PAGE_ARGS_BYTES
        + 16
        + 4
        + uniform_align
}

/// The fixed part and the pool for `options.budget_bytes` (the pool may be empty or the fixed
/// part over budget: the caller refuses those with the numbers).
pub fn fixed_bytes(ctx: &GpuContext, repo: &Repository, options: &RendererOptions) -> FixedBytes {
    let limit = page_limit(&ctx.limits);
    let base = base_bytes(ctx, repo, options);
    // The lists take a share of each page's bytes: shrink the pool until both fit.
    // Never more pool than the whole repository needs: every patch (8-aligned) and the
    // residency's slack (it is given 7/8 of the pool).
    let everything: u64 = repo
        .tets()
        .iter()
        .map(|t| (t.patch_bytes as u64).next_multiple_of(8))
        .sum::<u64>()
        * 8
        / 7
        + 64;
    let mut pool = options.budget_bytes.saturating_sub(base).min(everything);
    for _ in 0..8 {
        let layout = PoolLayout::new(repo.tets(), pool, limit);
        let fixed = base + layout.pages as u64 * per_page_bytes(ctx, &layout);
        let total = fixed + layout.pages as u64 * layout.page_bytes;
        if total <= options.budget_bytes {
            return FixedBytes { fixed, layout };
        }
        pool = pool.saturating_sub(total - options.budget_bytes);
    }
    let layout = PoolLayout::new(repo.tets(), 0, limit);
    FixedBytes {
        fixed: base + per_page_bytes(ctx, &layout),
        layout,
    }
}
