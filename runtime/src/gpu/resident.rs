//! The resident model: the repository's tables and patches in GPU memory.
//!
//! The diamond and tet tables are uploaded exactly as they are in the file. The patch blob is
//! uploaded in *pages*, contiguous byte ranges of the blob no larger than one storage binding
//! (128 MiB on lavapipe); each page is both the vertex-pulling storage buffer and the index
//! buffer of its patches. The only derived data is one 16-byte `PatchLocation` per simplex:
//! which draw list its patch belongs to and where its strip and positions start in its page.
//!
//! Everything is made once at load; a frame touches none of it on the CPU. The pool has a byte
//! budget: a model that does not fit is refused with the numbers (streaming pages in and out
//! by the cut is the next step; pages are the unit it will swap).

use bytemuck::{Pod, Zeroable};
use tessera_core::repository::format::NO_INDEX;
use tessera_core::repository::patch::{strip_byte_offset, MAX_U16_PATCH_VERTICES};
use tessera_core::repository::reader::{Repository, RepositoryError};
use wgpu::util::DeviceExt;

use super::device::GpuContext;

/// "No draw list": an empty patch.
pub const NO_LIST: u32 = u32::MAX;
/// Bytes of one indexed indirect draw (`wgpu::util::DrawIndexedIndirectArgs`).
pub const DRAW_ARGS_BYTES: u64 = 20;

/// Where a simplex's patch lives and how it is drawn; mirrors `PatchLocation` in
/// `shaders/records.wgsl`. One per simplex.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct PatchLocation {
    /// Draw list: 2 × page + 1 if the strip has u32 indices; `NO_LIST` for an empty patch.
    pub list: u32,
    /// First slot of that list in the draw array.
    pub first_slot: u32,
    /// Start of the strip in the page, in indices (2 or 4 bytes).
    pub first_index: u32,
    /// Start of the positions in the page, in 8-byte slots (the draw's base vertex).
    pub base_vertex: i32,
}

/// One draw list: the patches of one page with one index width.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DrawList {
    pub page: usize,
    /// u32 strip indices (patches over 65,535 vertices) instead of u16.
    pub wide: bool,
    pub first_slot: u32,
    /// Patches that may be drawn from this list (its slots).
    pub capacity: u32,
}

/// A resident page of the patch blob.
pub struct Page {
    pub buffer: wgpu::Buffer,
    /// Its byte range in the patch blob.
    pub blob_range: std::ops::Range<u64>,
}

/// Why a model cannot be made resident.
#[derive(Debug, thiserror::Error)]
pub enum ResidentError {
    #[error(
        "the model needs {needed_mib:.1} MiB of GPU memory ({tables_mib:.1} MiB of tables and \
         working buffers, \
         {patches_mib:.1} MiB of patches) but the budget is {budget_mib:.1} MiB; raise it \
         (--gpu-budget) or build with fewer levels: streaming patches in and out is not \
         implemented yet"
    )]
    OverBudget {
        needed_mib: f64,
        tables_mib: f64,
        patches_mib: f64,
        budget_mib: f64,
    },
    #[error(
        "tet {tet}: its patch of {bytes} bytes exceeds the adapter's largest buffer binding \
         ({limit} bytes)"
    )]
    PatchTooLarge { tet: usize, bytes: u64, limit: u64 },
    #[error("the model has {count} simplices; the traversal addresses at most {max}")]
    TooManySimplices { count: usize, max: usize },
    #[error(transparent)]
    Repository(#[from] RepositoryError),
}

/// The repository in GPU memory.
pub struct ResidentModel {
    /// `DiamondRecord` × diamond count (at least one record, so the binding is never empty).
    pub diamonds: wgpu::Buffer,
    /// `TetRecord` × tet count.
    pub tets: wgpu::Buffer,
    /// `PatchLocation` × tet count.
    pub locations: wgpu::Buffer,
    pub pages: Vec<Page>,
    /// Two per page (u16, u32), in order: list `l` is `lists[l]`.
    pub lists: Vec<DrawList>,
    /// Slots of all lists together (draw array length).
    pub slot_count: u32,
    pub tet_count: u32,
    /// Roots are simplices `0..root_count`.
    pub root_count: u32,
    /// Depths of the simplex tree (longest root-to-leaf chain + 1): the traversal's dispatches.
    pub depth_count: u32,
    /// Bytes this model holds on the GPU (tables, locations, pages).
    pub resident_bytes: u64,
}

/// Largest page: one storage binding, and one buffer, of the device.
pub fn page_limit(limits: &wgpu::Limits) -> u64 {
    limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size)
        & !7
}

impl ResidentModel {
    /// Validates every patch (`Repository::validate_patches`), lays the blob out in pages and
    /// uploads everything, if it fits in `budget_bytes`.
    pub fn upload(
        ctx: &GpuContext,
        repo: &Repository,
        budget_bytes: u64,
    ) -> Result<ResidentModel, ResidentError> {
        let tets = repo.tets();
        // Dispatch rows of 65,535 workgroups × 64 threads; far beyond any real model.
        let max = 65_535 * 64 * 65_535usize;
        if tets.len() > max {
            return Err(ResidentError::TooManySimplices {
                count: tets.len(),
                max,
            });
        }
        repo.validate_patches()?;
        let limit = page_limit(&ctx.limits);
        let layout = lay_out_pages(repo, limit)?;

        let diamond_bytes: &[u8] = if repo.diamonds().is_empty() {
            &[0; 56]
        } else {
            bytemuck::cast_slice(repo.diamonds())
        };
        let tet_bytes: &[u8] = bytemuck::cast_slice(tets);
        let location_bytes: &[u8] = bytemuck::cast_slice(&layout.locations);
        let tables = (diamond_bytes.len() + tet_bytes.len() + location_bytes.len()) as u64;
        let patches: u64 = layout.pages.iter().map(|r| r.end - r.start).sum();
        // Per-frame working buffers: the draw list and the traversal's two queues.
        let working = layout.slot_count as u64 * DRAW_ARGS_BYTES + 2 * 4 * tets.len() as u64;
        let needed = tables + patches + working;
        if needed > budget_bytes {
            let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
            return Err(ResidentError::OverBudget {
                needed_mib: mib(needed),
                tables_mib: mib(tables + working),
                patches_mib: mib(patches),
                budget_mib: mib(budget_bytes),
            });
        }

        let device = &ctx.device;
        let storage = |label: &str, contents: &[u8], extra: wgpu::BufferUsages| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE | extra,
            })
        };
        let blob = repo.patch_blob();
        let pages = layout
            .pages
            .iter()
            .map(|range| Page {
                buffer: storage(
                    "patch page",
                    // An empty model still gets a (tiny) page to bind.
                    if range.is_empty() {
                        &[0; 8]
                    } else {
                        &blob[range.start as usize..range.end as usize]
                    },
                    wgpu::BufferUsages::INDEX,
                ),
                blob_range: range.clone(),
            })
            .collect();
        Ok(ResidentModel {
            diamonds: storage("diamonds", diamond_bytes, wgpu::BufferUsages::empty()),
            tets: storage("tets", tet_bytes, wgpu::BufferUsages::empty()),
            locations: storage("locations", location_bytes, wgpu::BufferUsages::empty()),
            pages,
            lists: layout.lists,
            slot_count: layout.slot_count,
            tet_count: tets.len() as u32,
            root_count: repo.header().root_tet_count as u32,
            depth_count: tree_depths(repo),
            resident_bytes: needed - working,
        })
    }
}

/// Depths of the simplex tree: the reader checked that children come after their parents, so
/// one pass in table order sees every parent before its children.
fn tree_depths(repo: &Repository) -> u32 {
    let tets = repo.tets();
    let mut depth = vec![0u32; tets.len()];
    let mut deepest = 0;
    for (i, t) in tets.iter().enumerate() {
        if t.first_child != NO_INDEX {
            let c = t.first_child as usize;
            depth[c] = depth[i] + 1;
            depth[c + 1] = depth[i] + 1;
            deepest = deepest.max(depth[i] + 1);
        }
    }
    deepest + 1
}

/// The page layout, before upload.
#[derive(Debug)]
struct PageLayout {
    pages: Vec<std::ops::Range<u64>>,
    locations: Vec<PatchLocation>,
    lists: Vec<DrawList>,
    slot_count: u32,
}

/// Greedy pages: patches in blob order, a new page whenever the next patch would end beyond
/// `limit` bytes from the page's start.
fn lay_out_pages(repo: &Repository, limit: u64) -> Result<PageLayout, ResidentError> {
    let tets = repo.tets();
    let mut order: Vec<usize> = (0..tets.len()).collect();
    order.sort_by_key(|&i| tets[i].patch_offset);
    let mut pages: Vec<std::ops::Range<u64>> = Vec::new();
    let mut page_of = vec![0usize; tets.len()];
    for &i in &order {
        let t = &tets[i];
        let (start, end) = (t.patch_offset, t.patch_offset + t.patch_bytes as u64);
        if t.patch_bytes as u64 > limit {
            return Err(ResidentError::PatchTooLarge {
                tet: i,
                bytes: t.patch_bytes as u64,
                limit,
            });
        }
        match pages.last_mut() {
            Some(page) if end - page.start <= limit => page.end = page.end.max(end),
            _ => pages.push(start..end),
        }
        page_of[i] = pages.len() - 1;
    }
    if pages.is_empty() {
        pages.push(0..0);
    }
    // Count each list's patches, then hand out slots list by list.
    let mut capacity = vec![0u32; 2 * pages.len()];
    let mut views: Vec<Option<(usize, bool)>> = Vec::with_capacity(tets.len());
    for (i, t) in tets.iter().enumerate() {
        if t.strip_index_count == 0 {
            views.push(None);
            continue;
        }
        let wide = t.vertex_count as usize > MAX_U16_PATCH_VERTICES;
        let list = 2 * page_of[i] + wide as usize;
        capacity[list] += 1;
        views.push(Some((list, wide)));
    }
    let mut lists = Vec::with_capacity(capacity.len());
    let mut next = 0u32;
    for (l, &c) in capacity.iter().enumerate() {
        lists.push(DrawList {
            page: l / 2,
            wide: l % 2 == 1,
            first_slot: next,
            capacity: c,
        });
        next += c;
    }
    let mut locations = Vec::with_capacity(tets.len());
    for (i, v) in views.into_iter().enumerate() {
        let Some((list, wide)) = v else {
            locations.push(PatchLocation {
                list: NO_LIST,
                first_slot: 0,
                first_index: 0,
                base_vertex: 0,
            });
            continue;
        };
        let t = &tets[i];
        let in_page = t.patch_offset - pages[page_of[i]].start;
        let strip_offset =
            strip_byte_offset(t.vertex_count as usize, repo.header().attributes) as u64;
        let index_bytes = if wide { 4 } else { 2 };
        locations.push(PatchLocation {
            list: list as u32,
            first_slot: lists[list].first_slot,
            first_index: ((in_page + strip_offset) / index_bytes) as u32,
            base_vertex: (in_page / 8) as i32,
        });
    }
    Ok(PageLayout {
        pages,
        locations,
        lists,
        slot_count: next,
    })
}
