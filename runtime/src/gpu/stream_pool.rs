//! The page pool of the streaming renderer: a fixed set of GPU pages, allocated once, into
//! which whole units (R(D), `stream::units`) are placed as they land and from which they are
//! freed once no frame in flight can draw them.
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

    /// Places `bytes` (rounded up to 8) holding `patches` non-empty patches; `None` when no
    /// page has a free range that large and list room for the patches.
    pub fn allocate(&mut self, bytes: u64, patches: u32) -> Option<Placement> {
        let bytes = bytes.next_multiple_of(8).max(8);
        for (p, page) in self.pages.iter_mut().enumerate() {
            if page.patches + patches > self.patch_capacity {
                continue;
            }
            if let Some(k) = page.free.iter().position(|&(_, len)| len >= bytes) {
                let (start, len) = page.free[k];
                if len == bytes {
                    page.free.remove(k);
                } else {
                    page.free[k] = (start + bytes, len - bytes);
                }
                page.patches += patches;
                return Some(Placement {
                    page: p as u32,
                    offset: start,
                    bytes,
                    patches,
                });
            }
        }
        None
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
    /// Pages of at most `limit` bytes filling `pool_bytes`; lists sized from the smallest
    /// non-empty patch (8-aligned), capped by the model's non-empty patches, by the record
    /// slots (`slots`: a resident patch has one) and by one storage binding (`limit`) for
    /// every page's list together (the traversal binds them as one array; the allocator then
    /// places fewer patches in a page).
    ///
    /// At most `resident::max_pages` pages (one compaction workgroup each, their draw
    /// arguments one binding; `limit` is that binding): a larger pool is cut to them.
    pub fn new(patches: PatchSizes, pool_bytes: u64, limit: u64, slots: u32) -> PoolLayout {
        let pool_bytes = pool_bytes.min(super::resident::max_pages_within(limit) * limit);
        let pages = pool_bytes.div_ceil(limit).max(1) as usize;
        let page_bytes = (pool_bytes / pages as u64) & !7;
        let (smallest, count) = (patches.smallest, patches.nonempty);
        PoolLayout {
            pages,
            page_bytes,
            patch_capacity: (page_bytes / smallest)
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
/// only once a link or the roots reach it), `layout.pages` pages of `layout.page_bytes`.
pub fn pool_model(
    ctx: &GpuContext,
    repo: &Repository,
    layout: &PoolLayout,
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
    let pages = (0..layout.pages)
        .map(|_| Page {
            buffer: buffer(
                "pool page",
                layout.page_bytes.max(8),
                U::STORAGE | U::COPY_DST,
            ),
            blob_range: 0..0,
        })
        .collect();
    let lists = (0..layout.pages as u32)
        .map(|p| SelectionList {
            first_entry: p * layout.patch_capacity,
            capacity: layout.patch_capacity,
            // No index region: a pool page's contents change as units come and go, and the
            // indexed draw's page-simplex table is static, so pool pages are always drawn by
            // vertex pulling (the draw's fallback path).
            slots: 0,
            index_capacity: 0,
            first_index: 0,
        })
        .collect();
    let record_bytes = slots as u64 * (SLOT_RECORD_BYTES + PATCH_LOCATION_BYTES);
    ResidentModel {
        records: buffer(
            "slot records",
            slots as u64 * SLOT_RECORD_BYTES,
            U::STORAGE | U::COPY_DST,
        ),
        locations: buffer(
            "slot locations",
            slots as u64 * PATCH_LOCATION_BYTES,
            U::STORAGE | U::COPY_DST,
        ),
        slot_count: slots,
        streamed: true,
        pages,
        lists,
        page_simplices: buffer("page simplices (unused by pulled draws)", 16, U::STORAGE),
        index_count: 0,
        entry_count: layout.pages as u32 * layout.patch_capacity,
        tet_count: repo.tets().len() as u32,
        diamond_count: repo.diamonds().len() as u32,
        root_count: repo.header().root_tet_count as u32,
        depth_count: tree_depths(repo),
        resident_bytes: record_bytes + layout.pages as u64 * layout.page_bytes,
    }
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
}
