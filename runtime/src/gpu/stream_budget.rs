//! The streaming renderer's GPU budget: every allocation the renderer makes, counted from the
//! same sizes the constructors use, and the two pools that the rest of the budget buys.
//!
//! Fixed (independent of the model and of what is resident): the traversal's `may_refine`
//! word (one: the slots' links are the flags), counters, dispatch arguments and step uniforms;
//! the feedback lists and their read-back ring; per pool page a selection list (and its
//! read-back copy), a count (and its copy), an indirect draw, a list start and a page-draw
//! uniform slot; the frame uniforms and timestamps; the target (colour, depth, read-back).
//! Nothing here is sized by the model's simplex or diamond count: the directory is paged.
//!
//! The pools: record slots (`records.rs`: per slot an 88-byte record, a 16-byte location and
//! one entry in each of the traversal's two queues) and the page pool (patch bytes, in pages
//! of at most one storage binding). The rest of the budget is split between them so that the
//! slots hold as many simplices as the pages' bytes do at the model's level with the smallest
//! patches per simplex (`model_needs`); the residency keeps each within its own budget (a
//! view whose units have still smaller patches runs out of slots first and settles coarser,
//! as it would for bytes). Neither is ever larger than the whole model needs.
//!
//! That split is the pools' largest size, what the budget allows. They are allocated as they
//! fill (`streamer/growth.rs`): one page (`stream_pool::GROWTH_PAGE_BYTES` at most) and a few
//! slots at first, a page at a time and slots doubling after, with the per-page fixed part
//! following the pages (`FixedBytes::allocated`); so the roots alone cost about the same on
//! every model whatever the budget.
//!
//! Textures (`GpuStreamer::with_textures`) come off the top: their cache takes at most a
//! quarter of the budget (`texture_cache::layers_for`, which states the rule), and what is
//! counted here is sized from the rest.

use tessera_core::repository::patch::drawn_patch_bytes;
use tessera_core::repository::reader::Repository;

use crate::stream::UnitTable;

use super::device::GpuContext;
use super::records::SLOT_RECORD_BYTES;
use super::renderer::RendererOptions;
use super::resident::{page_limit, ENTRY_BYTES, PAGE_ARGS_BYTES};
use super::stream_pool::{PatchSizes, PoolLayout};

/// Bytes per record slot: the record, its location and its entry in each traversal queue.
pub const SLOT_BYTES: u64 = SLOT_RECORD_BYTES + 16 + 2 * 4;

/// The fixed bytes, the record slots and the page pool's layout for a budget.
#[derive(Clone, Copy, Debug)]
pub struct FixedBytes {
    /// Everything but the two pools, with every page of the layout allocated.
    pub fixed: u64,
    /// Of which: what does not depend on the pages, and what each page adds.
    pub base: u64,
    pub per_page: u64,
    /// Record slots (roots' included); they take `slots × SLOT_BYTES`.
    pub slots: u32,
    pub layout: PoolLayout,
}

impl FixedBytes {
    /// Bytes of the record slots.
    pub fn record_bytes(&self) -> u64 {
        self.slots as u64 * SLOT_BYTES
    }

    /// Bytes of the page pool.
    pub fn pool_bytes(&self) -> u64 {
        self.layout.pages as u64 * self.layout.page_bytes
    }

    /// Every allocation, the pools at their largest.
    pub fn total(&self) -> u64 {
        self.fixed + self.record_bytes() + self.pool_bytes()
    }

    /// The fixed part and every allocation with `pages` pages and `slots` record slots
    /// allocated (the pools grow up to the layout, `stream_pool::grow_model`).
    pub fn allocated(&self, pages: usize, slots: u32) -> (u64, u64) {
        let fixed = self.base + pages as u64 * self.per_page;
        let total = fixed + slots as u64 * SLOT_BYTES + pages as u64 * self.layout.page_bytes;
        (fixed, total)
    }
}

/// Bytes of the allocations that depend neither on the pools nor on the model.
fn base_bytes(ctx: &GpuContext, repo: &Repository, options: &RendererOptions) -> u64 {
    let depths = 64u64; // generous: dispatch arguments and step uniforms per depth
    let uniform_align = (ctx.limits.min_uniform_buffer_offset_alignment as u64).max(256);
    let traversal = 4 + 4 * depths * 4 + uniform_align * depths;
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
        &ctx.limits,
    ));
    traversal + target + frame + feedback + no_index_regions
}

/// Bytes per pool page besides the page itself.
fn per_page_bytes(ctx: &GpuContext, layout: &PoolLayout) -> u64 {
    // Lists and their read-back copies, counts and copies, the page's draw and dispatch
    // arguments, its `PageInfo` (16 B), a list start and a page-draw slot.
    2 * layout.patch_capacity as u64 * ENTRY_BYTES
        + 2 * 4
        + PAGE_ARGS_BYTES
        + 16
        + 4
        + super::renderer::page_draw_stride(&ctx.limits)
}

/// What the whole model would take: every patch (8-aligned) with the residency's slack (it is
/// given 7/8 of the pool), and a slot per simplex; and the patch bytes per simplex that the
/// slots are provisioned for. Read through the map; nothing allocated.
///
/// A view's working set is not the model's average: on the generated meshes the coarse
/// and middle levels hold 280–700 bytes of patch per simplex (many half-empty simplices) and
/// the finest 1.5–1.9 KB, against an average of 1.1–1.2 KB, and a close view at τ = 0.5 on the
/// 2 M-triangle model kept 840 B per resident simplex, on the 20 M one 413 B. Slots
/// provisioned at the average ran out first there (half the pages unused, 157 units left
/// wanted on the 2 M model; at half the average, on the 20 M one). So the slots are sized for
/// the level with the fewest bytes per simplex, but never for less than a quarter of the
/// average (a guard against a model whose slots would take most of a budget).
struct ModelNeeds {
    bytes: u64,
    simplices: u64,
    bytes_per_slot: f64,
    patches: PatchSizes,
}

fn model_needs(repo: &Repository) -> ModelNeeds {
    let mut per_level = [(0u64, 0u64); 64];
    let mut patches = PatchSizes::new();
    // One pass over the directory, its pages dropped behind it (`scan_tets`).
    let attributes = repo.header().attributes;
    repo.scan_tets(|_, t| {
        let level = &mut per_level[(t.level as usize).min(63)];
        level.0 += 1;
        level.1 += drawn_patch_bytes(t, attributes).next_multiple_of(8);
        patches.add(t, attributes);
    });
    let patches = patches.finish();
    let simplices: u64 = per_level.iter().map(|l| l.0).sum();
    let bytes: u64 = per_level.iter().map(|l| l.1).sum();
    let average = bytes as f64 / simplices.max(1) as f64;
    let densest = per_level
        .iter()
        .filter(|l| l.0 > 0)
        .map(|l| l.1 as f64 / l.0 as f64)
        .fold(f64::INFINITY, f64::min);
    ModelNeeds {
        bytes: bytes * 8 / 7 + 64,
        simplices,
        bytes_per_slot: densest.max(average / 4.0).max(8.0),
        patches,
    }
}

/// The largest unit's bytes as the pool places them (each patch 8-aligned: at most 7 bytes
/// of padding a patch; the pinned roots are one unit too).
pub fn largest_unit_bytes(units: &UnitTable) -> u64 {
    let unit = |bytes: u64, patches: usize| bytes + 7 * patches as u64;
    (0..units.len() as u32)
        .map(|u| unit(units.bytes(u), units.simplices(u).len()))
        .chain([unit(units.root_bytes(), units.roots().len())])
        .max()
        .unwrap_or(0)
}

/// The fixed part and the pools for `options.budget_bytes` (the pools may be empty or the
/// fixed part over budget: the caller refuses those with the numbers); `largest_unit`
/// (`largest_unit_bytes`): no page is smaller.
pub fn fixed_bytes(
    ctx: &GpuContext,
    repo: &Repository,
    options: &RendererOptions,
    largest_unit: u64,
) -> FixedBytes {
    let limit = page_limit(&ctx.limits);
    let base = base_bytes(ctx, repo, options);
    let roots = repo.header().root_tet_count;
    let needs = model_needs(repo);
    // Pages as the pool grows by them, never smaller than a unit: `PoolLayout::new` divides
    // the pool evenly into pages of at most the cap, each then over half the cap (two or more
    // pages) or the whole pool (one), so a cap over twice the largest unit fits every unit.
    let page_cap = options.pool_growth.page_bytes.max(2 * largest_unit + 16);
    let (all_bytes, all_slots) = (needs.bytes, needs.simplices);
    let rest = options.budget_bytes.saturating_sub(base);
    // A slot per `bytes_per_slot` of the residency's 7/8 of the pages.
    let share = SLOT_BYTES as f64 / (SLOT_BYTES as f64 + needs.bytes_per_slot * 8.0 / 7.0);
    // At least the roots and one pair; never more than the model has (+1 for parity), nor
    // than one storage binding of records holds (the records are one binding; locations and
    // queue entries are smaller). Roots alone over that binding: the streamer refuses.
    let max_slots = (limit / SLOT_RECORD_BYTES) & !1;
    let clamp = |s: u64| {
        s.min(all_slots + 1)
            .max(roots + 2)
            .next_multiple_of(2)
            .min(max_slots)
    };
    let slots_for = |bytes: u64| clamp((bytes as f64 * share / SLOT_BYTES as f64) as u64);
    let mut available = rest;
    for _ in 0..8 {
        let slots = slots_for(available);
        let pool = available.saturating_sub(slots * SLOT_BYTES).min(all_bytes);
        // Pages capped at what the model needs: what they leave goes to slots (up to the
        // model's).
        let slots = slots.max(clamp((available.saturating_sub(pool) / SLOT_BYTES) & !1));
        let layout = PoolLayout::new(needs.patches, pool, limit, page_cap, slots as u32);
        let per_page = per_page_bytes(ctx, &layout);
        let fixed = base + layout.pages as u64 * per_page;
        let candidate = FixedBytes {
            fixed,
            base,
            per_page,
            slots: slots as u32,
            layout,
        };
        if candidate.total() <= options.budget_bytes {
            return candidate;
        }
        available = available.saturating_sub(candidate.total() - options.budget_bytes);
    }
    let slots = slots_for(0);
    let layout = PoolLayout::new(needs.patches, 0, limit, page_cap, slots as u32);
    let per_page = per_page_bytes(ctx, &layout);
    FixedBytes {
        fixed: base + per_page,
        base,
        per_page,
        slots: slots as u32,
        layout,
    }
}
