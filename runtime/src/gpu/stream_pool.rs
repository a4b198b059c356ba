//! The page pool of the streaming renderer: GPU pages, allocated one at a time as units need
//! room up to the layout the budget allows (`grow_model`, `streamer/growth.rs`), into which
//! whole units (R(D), `stream::units`) are placed as they land and from which they are freed
//! once no frame in flight can draw them.
//!
//! Each page is one storage binding (≤ `resident::page_limit`), bound by the draw exactly as
//! the fully resident model's pages are; the traversal and the draw do not know the
//! difference. A unit's patches are placed back to back (each 8-aligned, as the loader lays
//! them out) in one free range of one page, first fit; every page has a selection list sized
//! for the most non-empty patches the page can hold (its bytes over the smallest non-empty
//! patch), and the allocator also refuses a placement that would exceed it, so the
//! traversal's appends (which do not check capacity) never overflow.
//!
//! The directory is paged beside it: the units' simplices get record slots (`records.rs`), so
//! nothing here is sized by the model's simplex or diamond count.

use tessera_core::repository::format::TetRecord;
use tessera_core::repository::patch::drawn_patch_bytes;
use tessera_core::repository::reader::Repository;

use super::device::GpuContext;
use super::records::SLOT_RECORD_BYTES;
use super::resident::{
    page_limit, tree_depths, Page, PatchLocation, ResidentModel, SelectionList, NO_PAGE,
    PATCH_LOCATION_BYTES,
};

/// Where a placed unit lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Placement {
    pub page: u32,
    /// Byte offset in the page.
    pub offset: u64,
    /// Bytes taken (a multiple of 8).
    pub bytes: u64,
    /// Non-empty patches (entries of the page's selection list).
    pub patches: u32,
}

/// One page's free ranges (sorted, coalesced) and its patch count.
#[derive(Clone, Debug)]
struct PageSpace {
    free: Vec<(u64, u64)>,
    patches: u32,
}

/// First-fit allocation of units in fixed pages.
#[derive(Clone, Debug)]
pub struct PoolAllocator {
    page_bytes: u64,
    patch_capacity: u32,
    pages: Vec<PageSpace>,
}

impl PoolAllocator {
    /// `pages` pages of `page_bytes` bytes (a multiple of 8), each holding at most
    /// `patch_capacity` non-empty patches.
    pub fn new(pages: usize, page_bytes: u64, patch_capacity: u32) -> PoolAllocator {
        PoolAllocator {
            page_bytes,
            patch_capacity,
            pages: vec![
                PageSpace {
                    free: vec![(0, page_bytes)],
                    patches: 0
                };
                pages
            ],
        }
    }

    /// The first page and free range (index in the page's list) with room for `bytes`
    /// (already rounded) and list room for `patches`.
    fn find(&self, bytes: u64, patches: u32) -> Option<(usize, usize)> {
        self.pages.iter().enumerate().find_map(|(p, page)| {
            if page.patches + patches > self.patch_capacity {
                return None;
            }
            let k = page.free.iter().position(|&(_, len)| len >= bytes)?;
            Some((p, k))
        })
    }

    /// Whether `allocate(bytes, patches)` would succeed now.
    pub fn has_room(&self, bytes: u64, patches: u32) -> bool {
        self.find(bytes.next_multiple_of(8).max(8), patches)
            .is_some()
    }

    /// Places `bytes` (rounded up to 8) holding `patches` non-empty patches; `None` when no
    /// page has a free range that large and list room for the patches.
    pub fn allocate(&mut self, bytes: u64, patches: u32) -> Option<Placement> {
        let bytes = bytes.next_multiple_of(8).max(8);
        let (p, k) = self.find(bytes, patches)?;
        let page = &mut self.pages[p];
        let (start, len) = page.free[k];
        if len == bytes {
            page.free.remove(k);
        } else {
            page.free[k] = (start + bytes, len - bytes);
        }
        page.patches += patches;
        Some(Placement {
            page: p as u32,
            offset: start,
            bytes,
            patches,
        })
    }

    /// One more empty page (the pool grew, `grow_model`).
    pub fn add_page(&mut self) {
        self.pages.push(PageSpace {
            free: vec![(0, self.page_bytes)],
            patches: 0,
        });
    }

    /// Returns a placement's range to its page (coalescing with its neighbours).
    pub fn free(&mut self, placed: Placement) {
        let page = &mut self.pages[placed.page as usize];
        page.patches -= placed.patches;
        let k = page.free.partition_point(|&(s, _)| s < placed.offset);
        page.free.insert(k, (placed.offset, placed.bytes));
        if k + 1 < page.free.len() && page.free[k].0 + page.free[k].1 == page.free[k + 1].0 {
            page.free[k].1 += page.free[k + 1].1;
            page.free.remove(k + 1);
        }
        if k > 0 && page.free[k - 1].0 + page.free[k - 1].1 == page.free[k].0 {
            page.free[k - 1].1 += page.free[k].1;
            page.free.remove(k);
        }
    }

    /// Free bytes over every page.
    pub fn free_bytes(&self) -> u64 {
        self.pages
            .iter()
            .flat_map(|p| p.free.iter().map(|&(_, len)| len))
            .sum()
    }

    /// Fragmentation: 1 − (largest free range / free bytes), 0 when nothing or one range is
    /// free.
    pub fn fragmentation(&self) -> f64 {
        let free = self.free_bytes();
        let largest = self
            .pages
            .iter()
            .flat_map(|p| p.free.iter().map(|&(_, len)| len))
            .max()
            .unwrap_or(0);
        if free == 0 {
            0.0
        } else {
            1.0 - largest as f64 / free as f64
        }
    }

    /// Bytes of every page together.
    pub fn capacity_bytes(&self) -> u64 {
        self.page_bytes * self.pages.len() as u64
    }

    /// Number of pages.
    pub fn page_count(&self) -> usize {
        self.pages.len()
    }

    /// Page `page`'s free ranges (offset, length), sorted and coalesced.
    pub fn free_ranges(&self, page: usize) -> &[(u64, u64)] {
        &self.pages[page].free
    }

    /// Non-empty patches placed in page `page`.
    pub fn page_patches(&self, page: usize) -> u32 {
        self.pages[page].patches
    }

    /// Most non-empty patches a page holds.
    pub fn patch_capacity(&self) -> u32 {
        self.patch_capacity
    }
}

/// Largest page of a streaming pool: the pool is allocated a page at a time as units need
/// room (`grow_model`), so a view that needs little allocates little whatever the budget; the
/// pages are this size (or twice the largest unit, where larger: `stream_budget`) or one
/// storage binding, whichever is smaller. Fewer, larger pages would save a draw and a compaction workgroup each per
/// frame, but allocate in larger steps: the first page is what the roots alone cost.
pub const GROWTH_PAGE_BYTES: u64 = 8 << 20;

/// Record slots a streaming pool starts with besides the roots' (pairs of slots); they grow
/// by doubling as units need them (`grow_model`).
pub const INITIAL_SLOT_PAIRS: u32 = 1024;

/// Most non-empty patches one page holds (its selection list's entries): a page of
/// `GROWTH_PAGE_BYTES` reaches it only with patches of 128 bytes on average. Sizing the lists
/// for the smallest patch instead made them up to 3 MiB a page (with their read-back copies)
/// on models with a few one-triangle patches; a page of many smaller patches fills by count
/// first (the allocator enforces it) and the next unit goes to another page.
pub const MAX_PAGE_PATCHES: u64 = 1 << 16;

/// How a streaming pool grows: the largest page it adds (never below the largest unit nor
/// above one storage binding) and the record-slot pairs it starts with besides the roots'.
/// The defaults are `GROWTH_PAGE_BYTES` and `INITIAL_SLOT_PAIRS`; tests force many growths
/// with small values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PoolGrowth {
    pub page_bytes: u64,
    pub first_slot_pairs: u32,
}

impl Default for PoolGrowth {
    fn default() -> Self {
        PoolGrowth {
            page_bytes: GROWTH_PAGE_BYTES,
            first_slot_pairs: INITIAL_SLOT_PAIRS,
        }
    }
}

/// The pool's shape for a byte budget.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PoolLayout {
    pub pages: usize,
    pub page_bytes: u64,
    /// Selection-list entries per page.
    pub patch_capacity: u32,
}

/// What the pool's lists are sized from: the model's smallest non-empty patch (8-aligned,
/// at least 8 bytes; 8 when there is none) and its number of non-empty patches.
#[derive(Clone, Copy, Debug)]
pub struct PatchSizes {
    pub smallest: u64,
    pub nonempty: u64,
}

impl PatchSizes {
    /// None yet: feed every tet record to `add`, then `finish`.
    pub(crate) fn new() -> PatchSizes {
        PatchSizes {
            smallest: u64::MAX,
            nonempty: 0,
        }
    }

    /// Counts `t`, a record of a repository with the `attributes` mask.
    pub(crate) fn add(&mut self, t: &TetRecord, attributes: u32) {
        if t.strip_index_count != 0 {
            self.nonempty += 1;
            let drawn = drawn_patch_bytes(t, attributes);
            self.smallest = self.smallest.min(drawn.next_multiple_of(8).max(8));
        }
    }

    /// The sizes of a table held in memory, of a repository with the `attributes` mask
    /// (tests; the streamer scans the map).
    pub fn of(tets: &[TetRecord], attributes: u32) -> PatchSizes {
        let mut sizes = PatchSizes::new();
        for t in tets {
            sizes.add(t, attributes);
        }
        sizes.finish()
    }

    pub(crate) fn finish(mut self) -> PatchSizes {
        if self.nonempty == 0 {
            self.smallest = 8;
        }
        self
    }
}

impl PoolLayout {
    /// Pages of at most `limit` and `page_cap` bytes filling `pool_bytes`; lists sized from the smallest
    /// non-empty patch (8-aligned), capped by `MAX_PAGE_PATCHES`, the model's non-empty patches, by the record
    /// slots (`slots`: a resident patch has one) and by one storage binding (`limit`) for
    /// every page's list together (the traversal binds them as one array; the allocator then
    /// places fewer patches in a page).
    ///
    /// At most `resident::max_pages` pages (one compaction workgroup each, their draw
    /// arguments one binding; `limit` is that binding): a larger pool is cut to them.
    pub fn new(
        patches: PatchSizes,
        pool_bytes: u64,
        limit: u64,
        page_cap: u64,
        slots: u32,
    ) -> PoolLayout {
        let page_cap = limit.min(page_cap).max(8);
        let pool_bytes = pool_bytes.min(super::resident::max_pages_within(limit) * page_cap);
        let pages = pool_bytes.div_ceil(page_cap).max(1) as usize;
        let page_bytes = (pool_bytes / pages as u64) & !7;
        let (smallest, count) = (patches.smallest, patches.nonempty);
        PoolLayout {
            pages,
            page_bytes,
            patch_capacity: (page_bytes / smallest)
                .min(MAX_PAGE_PATCHES)
                .min(count)
                .min(slots as u64)
                .min(limit / super::resident::ENTRY_BYTES / pages as u64)
                .max(1) as u32,
        }
    }

    /// Bytes of the selection lists (entries) over every page.
    pub fn entry_bytes(&self) -> u64 {
        self.pages as u64 * self.patch_capacity as u64 * super::resident::ENTRY_BYTES
    }
}

/// The location of a patch placed at byte `at` of page `page` (`resident::lay_out_pages`'s
/// rule, with the page's start at the unit's placement).
pub fn location_at(repo: &Repository, t: &TetRecord, page: u32, at: u64) -> PatchLocation {
    use tessera_core::repository::patch::{strip_byte_offset, MAX_U16_PATCH_VERTICES};
    if t.strip_index_count == 0 {
        return PatchLocation {
            page: NO_PAGE,
            first_entry: 0,
            first_index: 0,
            base_vertex: 0,
        };
    }
    let wide = t.vertex_count as usize > MAX_U16_PATCH_VERTICES;
    let strip_offset = strip_byte_offset(t.vertex_count as usize, repo.header().attributes) as u64;
    let index_bytes = if wide { 4 } else { 2 };
    PatchLocation {
        page,
        first_entry: 0, // set by the caller: the page's list start
        first_index: ((at + strip_offset) / index_bytes) as u32,
        base_vertex: (at / 8) as u32,
    }
}

/// A resident model whose pages are the empty pool and whose `slots` record slots are empty:
/// every record and location is written by the streamer as its unit lands (a slot is read
/// only once a link or the roots reach it), `pages` pages (of at most `layout.pages`) of
/// `layout.page_bytes`; `grow_model` adds pages and slots.
pub fn pool_model(
    ctx: &GpuContext,
    repo: &Repository,
    layout: &PoolLayout,
    pages: usize,
    slots: u32,
) -> ResidentModel {
    use wgpu::BufferUsages as U;
    let device = &ctx.device;
    let buffer = |label: &str, size: u64, usage: U| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(16),
            usage,
            mapped_at_creation: false,
        })
    };
    debug_assert!(layout.page_bytes <= page_limit(&ctx.limits));
    let (records, locations) = slot_buffers(ctx, slots);
    let mut model = ResidentModel {
        records,
        locations,
        slot_count: slots,
        streamed: true,
        pages: Vec::new(),
        lists: Vec::new(),
        page_simplices: buffer("page simplices (unused by pulled draws)", 16, U::STORAGE),
        index_count: 0,
        entry_count: 0,
        tet_count: repo.tets().len() as u32,
        diamond_count: repo.diamonds().len() as u32,
        root_count: repo.header().root_tet_count as u32,
        depth_count: tree_depths(repo),
        resident_bytes: 0,
    };
    add_pages(ctx, &mut model, layout, pages);
    model
}

/// The records and locations of `slots` record slots (copied from when the pool grows).
fn slot_buffers(ctx: &GpuContext, slots: u32) -> (wgpu::Buffer, wgpu::Buffer) {
    use wgpu::BufferUsages as U;
    let buffer = |label: &str, size: u64| {
        ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(16),
            usage: U::STORAGE | U::COPY_DST | U::COPY_SRC,
            mapped_at_creation: false,
        })
    };
    (
        buffer("slot records", slots as u64 * SLOT_RECORD_BYTES),
        buffer("slot locations", slots as u64 * PATCH_LOCATION_BYTES),
    )
}

/// Adds `pages` empty pages (and their selection lists) to a pool model.
fn add_pages(ctx: &GpuContext, model: &mut ResidentModel, layout: &PoolLayout, pages: usize) {
    for _ in 0..pages {
        let p = model.pages.len() as u32;
        model.pages.push(Page {
            buffer: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pool page"),
                size: layout.page_bytes.max(8),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            blob_range: 0..0,
        });
        model.lists.push(SelectionList {
            first_entry: p * layout.patch_capacity,
            capacity: layout.patch_capacity,
            // No index region: a pool page's contents change as units come and go, and the
            // indexed draw's page-simplex table is static, so pool pages are always drawn by
            // vertex pulling (the draw's fallback path).
            slots: 0,
            index_capacity: 0,
            first_index: 0,
        });
    }
    model.entry_count = model.pages.len() as u32 * layout.patch_capacity;
    model.resident_bytes = model.slot_count as u64 * (SLOT_RECORD_BYTES + PATCH_LOCATION_BYTES)
        + model.pages.len() as u64 * layout.page_bytes;
}

/// Grows a pool model to `pages` pages and `slots` record slots (neither shrinks): new
/// pages are empty; the records and locations are copied into larger buffers by a command
/// submitted now, so the queue writes that follow (the next frame's) land after it. The
/// caller rebinds the renderer (`Renderer::rebind_model`) before the next frame.
pub fn grow_model(
    ctx: &GpuContext,
    model: &mut ResidentModel,
    layout: &PoolLayout,
    pages: usize,
    slots: u32,
) {
    if slots > model.slot_count {
        let (records, locations) = slot_buffers(ctx, slots);
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("grow record slots"),
            });
        let old = model.slot_count as u64;
        encoder.copy_buffer_to_buffer(&model.records, 0, &records, 0, old * SLOT_RECORD_BYTES);
        encoder.copy_buffer_to_buffer(
            &model.locations,
            0,
            &locations,
            0,
            old * PATCH_LOCATION_BYTES,
        );
        ctx.queue.submit([encoder.finish()]);
        (model.records, model.locations, model.slot_count) = (records, locations, slots);
    }
    add_pages(ctx, model, layout, pages.saturating_sub(model.pages.len()));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_fit_reuses_and_coalesces_freed_ranges() {
        let mut pool = PoolAllocator::new(2, 64, 3);
        let a = pool.allocate(20, 1).unwrap();
        let b = pool.allocate(16, 1).unwrap();
        let c = pool.allocate(24, 1).unwrap();
        assert_eq!((a.page, a.offset, a.bytes), (0, 0, 24));
        assert_eq!((b.offset, c.offset), (24, 40));
        // The list of page 0 is full: the next unit goes to page 1 though bytes are left.
        let d = pool.allocate(8, 1).unwrap();
        assert_eq!(d.page, 1);
        assert!(pool.allocate(64, 1).is_none());
        pool.free(a);
        pool.free(b);
        assert!(pool.fragmentation() > 0.0);
        let e = pool.allocate(40, 2).unwrap();
        assert_eq!((e.page, e.offset), (0, 0));
        pool.free(e);
        pool.free(c);
        pool.free(d);
        assert_eq!(pool.free_bytes(), 128);
        assert_eq!(pool.fragmentation(), 0.5); // two pages, one free range each
    }

    #[test]
    fn an_added_page_takes_what_no_page_had_room_for() {
        let mut pool = PoolAllocator::new(1, 64, 2);
        pool.allocate(48, 1).unwrap();
        assert!(!pool.has_room(24, 1));
        assert!(pool.has_room(16, 1));
        assert!(!pool.has_room(8, 2)); // list room: one entry left
        pool.add_page();
        assert!(pool.has_room(24, 2));
        let placed = pool.allocate(24, 2).unwrap();
        assert_eq!((placed.page, placed.offset), (1, 0));
        assert_eq!((pool.page_count(), pool.capacity_bytes()), (2, 128));
    }

    #[test]
    fn pages_are_capped_for_growth_but_never_below_the_cap_asked() {
        let sizes = PatchSizes {
            smallest: 64,
            nonempty: 1 << 20,
        };
        let layout = PoolLayout::new(sizes, 100 << 20, 128 << 20, 8 << 20, 1 << 20);
        assert_eq!(layout.pages, 13);
        assert!(layout.page_bytes <= 8 << 20 && layout.page_bytes > 7 << 20);
        // A pool smaller than the cap is one page; a cap above the binding is the binding.
        assert_eq!(
            PoolLayout::new(sizes, 1 << 20, 128 << 20, 8 << 20, 1 << 20).pages,
            1
        );
        let big = PoolLayout::new(sizes, 1 << 30, 128 << 20, 1 << 40, 1 << 20);
        assert_eq!((big.pages, big.page_bytes), (8, 128 << 20));
        // An even division leaves every page over half the cap: 1.5 caps make two pages of
        // 0.75 cap (why the budget's cap is twice the largest unit).
        let split = PoolLayout::new(sizes, 12 << 20, 128 << 20, 8 << 20, 1 << 20);
        assert_eq!((split.pages, split.page_bytes), (2, 6 << 20));
    }
}
