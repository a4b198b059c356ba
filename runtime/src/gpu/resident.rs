//! The resident model: the repository's tables and patches in GPU memory.
//!
//! The traversal reads one `SlotRecord` per simplex (`records.rs`: the tet record with its
//! diamond's sphere and error, slot = simplex id), made from the file's tables. The patch blob is
//! uploaded in *pages*, contiguous byte ranges of the blob no larger than one storage binding
//! (128 MiB on lavapipe); the vertex shader pulls strip indices, positions and attributes from
//! it. Besides the records, one 16-byte `PatchLocation` per simplex: its page, where that
//! page's selection list starts, and where its strip and positions start in the page.
//!
//! Everything is made once at load; a frame touches none of it on the CPU. The pool has a byte
//! budget: a model that does not fit is refused with the numbers. A model streamed under a
//! budget is not made here but in `stream_pool.rs` (a pool of pages that units come and go in).

use bytemuck::{Pod, Zeroable};
use tessera_core::repository::format::TetRecord;
use tessera_core::repository::patch::{
    strip_byte_offset, PatchSource, PatchView, MAX_U16_PATCH_VERTICES,
};
use tessera_core::repository::reader::{Repository, RepositoryError};
use tessera_core::repository::PatchCodec;
use wgpu::util::DeviceExt;

use super::device::GpuContext;
use super::records::SlotRecord;

/// "No page": an empty patch.
pub const NO_PAGE: u32 = u32::MAX;
/// Bytes of one page's draw and dispatch arguments (16 u32, `records.wgsl`).
pub const PAGE_ARGS_BYTES: u64 = 64;
/// Bytes of one strip slot in the index buffer (three u32 indices).
pub const INDEX_SLOT_BYTES: u64 = 12;
/// Most slots of one page's index region: 3 × this fits in a u32 draw count.
pub const MAX_INDEX_SLOTS: u64 = 0x5555_5555;
/// Default cap of a page's index region: 4 M strip slots (48 MiB), more than a 1080p frame at
/// τ ≥ 0.5 px selects on the models measured (the dragon's every leaf: 1.45 M slots); a frame
/// beyond it is drawn by pulling.
pub const DEFAULT_INDEX_SLOTS: u64 = 1 << 22;
/// Bytes of one `PatchLocation`.
pub const PATCH_LOCATION_BYTES: u64 = std::mem::size_of::<PatchLocation>() as u64;
/// Bytes of one selection-list entry (`Selected` in records.wgsl: simplex, first strip slot).
pub const ENTRY_BYTES: u64 = 8;

/// Where a simplex's patch lives and how it is drawn; mirrors `PatchLocation` in
/// `shaders/records.wgsl`. One per record slot (fully resident: per simplex).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct PatchLocation {
    /// Resident page; `NO_PAGE` for an empty patch.
    pub page: u32,
    /// First entry of that page's selection list.
    pub first_entry: u32,
    /// Start of the strip in the page, in indices (2 bytes, or 4 over 65,535 vertices).
    pub first_index: u32,
    /// Start of the positions in the page, in 8-byte slots.
    pub base_vertex: u32,
}

/// One page's selection list: the traversal appends the page's selected patches there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SelectionList {
    pub first_entry: u32,
    /// Non-empty patches of the page (the most the list can hold).
    pub capacity: u32,
    /// Strip slots of all those patches together (the most a frame can draw from the page).
    pub slots: u64,
    /// Slots a frame's index buffer region holds for this page (`ResidentModel::upload`): a
    /// frame whose selected slots fit is drawn indexed, else by vertex pulling.
    pub index_capacity: u32,
    /// Where that region starts in the index buffer, in indices.
    pub first_index: u64,
}

/// A resident page of the patch blob.
pub struct Page {
    pub buffer: wgpu::Buffer,
    /// Its byte range in the patch blob as drawn (decoded, when the repository is packed).
    pub blob_range: std::ops::Range<u64>,
}

/// Why a model cannot be made resident.
#[derive(Debug, thiserror::Error)]
pub enum ResidentError {
    #[error(
        "the model needs {needed_mib:.1} MiB of GPU memory ({tables_mib:.1} MiB of tables and \
         working buffers, \
         {patches_mib:.1} MiB of patches) but the budget is {budget_mib:.1} MiB: this command \
         uploads the whole repository; raise --gpu-budget, or use `render` or `check --gpu \
         --gpu-budget MIB`, which stream it"
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
    #[error(
        "the {buffer} take {bytes} bytes, more than the adapter's \
         max_storage_buffer_binding_size ({limit} bytes) lets one binding hold: this command \
         uploads the whole repository; `render` and `check --gpu --gpu-budget MIB` stream it"
    )]
    BindingTooLarge {
        buffer: &'static str,
        bytes: u64,
        limit: u64,
    },
    #[error(
        "the patch blob needs {pages} pages of one storage binding each, more than the {max} \
         a renderer can draw on this adapter (one compaction workgroup per page: \
         max_compute_workgroups_per_dimension; 64 bytes of draw arguments per page in one \
         binding: max_storage_buffer_binding_size): `render` and `check --gpu --gpu-budget \
         MIB` stream it"
    )]
    TooManyPages { pages: usize, max: u64 },
    #[error("the model has {count} simplices; the traversal addresses at most {max}")]
    TooManySimplices { count: usize, max: usize },
    #[error(transparent)]
    Repository(#[from] RepositoryError),
}

/// The repository in GPU memory.
pub struct ResidentModel {
    /// `SlotRecord` × slot count (`records.rs`); the compaction, expansion and draw read them
    /// as `TetRecord`s (the fields they read are at the same places).
    pub records: wgpu::Buffer,
    /// `PatchLocation` × slot count.
    pub locations: wgpu::Buffer,
    /// Record slots: the simplices when fully resident, the streaming pool's slots otherwise.
    pub slot_count: u32,
    /// Streaming: slots are a pool (`records.rs`), flags are the slots' child links.
    pub streamed: bool,
    pub pages: Vec<Page>,
    /// One per page, in order.
    pub lists: Vec<SelectionList>,
    /// Per page, its non-empty patches' simplices sorted by `base_vertex`, at the page's
    /// `first_entry` (the indexed draw's vertex shader finds a vertex's patch there).
    pub page_simplices: wgpu::Buffer,
    /// Indices of all pages' index regions together.
    pub index_count: u64,
    /// Entries of all lists together.
    pub entry_count: u32,
    pub tet_count: u32,
    pub diamond_count: u32,
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

/// Most pages a renderer can draw: the compaction dispatches one workgroup per page
/// (`MAX_WORKGROUPS_PER_DIMENSION`), and the pages' draw arguments are one storage binding.
pub fn max_pages(limits: &wgpu::Limits) -> u64 {
    max_pages_within(page_limit(limits))
}

/// `max_pages` for a storage binding of `binding` bytes.
pub fn max_pages_within(binding: u64) -> u64 {
    (super::shaders::MAX_WORKGROUPS_PER_DIMENSION as u64)
        .min(binding / PAGE_ARGS_BYTES)
        .max(1)
}

impl ResidentModel {
    /// Validates every patch (`Repository::validate_patches` for a raw repository; a packed
    /// one's patches as they are decoded into their pages, once), lays the blob out in pages
    /// and uploads everything, if it fits in `budget_bytes`.
    ///
    /// Each page's index region holds `min(its slots, one storage binding / 12 B,
    /// index_slots)` strip slots (`index_slots`: `None` for `DEFAULT_INDEX_SLOTS`).
    pub fn upload(
        ctx: &GpuContext,
        repo: &Repository,
        budget_bytes: u64,
        index_slots: Option<u64>,
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
        if repo.codec() == PatchCodec::Raw {
            repo.validate_patches()?;
        }
        let limit = page_limit(&ctx.limits);
        let mut layout = lay_out_pages(repo, limit)?;
        let max_pages = max_pages(&ctx.limits);
        if layout.pages.len() as u64 > max_pages {
            return Err(ResidentError::TooManyPages {
                pages: layout.pages.len(),
                max: max_pages,
            });
        }
        // Regions start at storage-offset-aligned indices (bound one page at a time), and
        // all fit one buffer; a page left without a region is always drawn by pulling.
        let align = (ctx.limits.min_storage_buffer_offset_alignment as u64 / 4).max(1);
        // (`PageInfo` holds a region's start as u32.)
        let max_indices = (ctx.limits.max_buffer_size / 4).min(u32::MAX as u64);
        let mut index_count = 0u64;
        for list in &mut layout.lists {
            let start = index_count.next_multiple_of(align);
            let mut capacity = list
                .slots
                .min(limit / INDEX_SLOT_BYTES)
                .min(index_slots.unwrap_or(DEFAULT_INDEX_SLOTS))
                .min(MAX_INDEX_SLOTS);
            if start + 3 * capacity > max_indices {
                capacity = 0;
            }
            list.index_capacity = capacity as u32;
            list.first_index = start;
            if capacity > 0 {
                index_count = start + 3 * capacity;
            }
        }

        let records = SlotRecord::all(tets, repo.diamonds());
        let record_bytes: &[u8] = bytemuck::cast_slice(&records);
        let location_bytes: &[u8] = bytemuck::cast_slice(&layout.locations);
        let tables = (record_bytes.len() + location_bytes.len()) as u64;
        let patches: u64 = layout.pages.iter().map(|r| r.end - r.start).sum();
        // Per-frame working buffers: the selection lists, the per-page draws and the
        // traversal's two queues.
        let working = layout.entry_count as u64 * (ENTRY_BYTES + 4)
            + layout.pages.len() as u64 * PAGE_ARGS_BYTES
            + 2 * 4 * tets.len() as u64
            + 4 * index_count;
        // Each of these is one storage binding.
        let limit = page_limit(&ctx.limits);
        for (buffer, bytes) in [
            ("slot records", record_bytes.len() as u64),
            ("patch locations", location_bytes.len() as u64),
            ("traversal queues", 4 * tets.len() as u64),
            ("selection lists", layout.entry_count as u64 * ENTRY_BYTES),
        ] {
            if bytes > limit {
                return Err(ResidentError::BindingTooLarge {
                    buffer,
                    bytes,
                    limit,
                });
            }
        }
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
        let mut order: Vec<usize> = (0..tets.len()).collect();
        order.sort_by_key(|&i| layout.placed[i].start);
        let mut pages = Vec::with_capacity(layout.pages.len());
        for range in &layout.pages {
            let bytes = page_bytes(repo, range, &order, &layout.placed)?;
            pages.push(Page {
                buffer: storage("patch page", bytes.bytes(), wgpu::BufferUsages::empty()),
                blob_range: range.clone(),
            });
        }
        Ok(ResidentModel {
            records: storage("slot records", record_bytes, wgpu::BufferUsages::empty()),
            locations: storage("locations", location_bytes, wgpu::BufferUsages::empty()),
            slot_count: tets.len() as u32,
            streamed: false,
            pages,
            lists: layout.lists,
            page_simplices: storage(
                "page simplices",
                bytemuck::cast_slice(&layout.page_simplices),
                wgpu::BufferUsages::empty(),
            ),
            index_count,
            entry_count: layout.entry_count,
            tet_count: tets.len() as u32,
            diamond_count: repo.diamonds().len() as u32,
            root_count: repo.header().root_tet_count as u32,
            depth_count: tree_depths(repo),
            resident_bytes: needed - working,
        })
    }
}

/// Depths of the simplex tree (longest root-to-leaf chain + 1), from the levels: the reader
/// checked that every non-root simplex descends from a root with one level per step, so this
/// reads the table through the map and allocates nothing. (Shared with the streaming pool,
/// `stream_pool.rs`.)
pub(crate) fn tree_depths(repo: &Repository) -> u32 {
    let tets = repo.tets();
    let roots = (repo.header().root_tet_count as usize).min(tets.len());
    let root_level = tets[..roots].iter().map(|t| t.level).min().unwrap_or(0);
    // A split simplex's children are one level below its diamond's (opening checks it), so
    // the deepest simplex is a root or a child of the deepest diamond: the diamond table is
    // read (its pages dropped behind), not the tet table, ~20× larger.
    let mut deepest = tets[..roots].iter().map(|t| t.level).max().unwrap_or(0);
    repo.scan_diamonds(|_, d| deepest = deepest.max(d.level + 1));
    deepest.saturating_sub(root_level) + 1
}

/// The page layout, before upload.
#[derive(Debug)]
struct PageLayout {
    /// Each page's range of the decoded patch blob.
    pages: Vec<std::ops::Range<u64>>,
    /// Each tet's patch's range of the decoded patch blob.
    placed: Vec<std::ops::Range<u64>>,
    locations: Vec<PatchLocation>,
    lists: Vec<SelectionList>,
    entry_count: u32,
    /// `ResidentModel::page_simplices` (at least one entry).
    page_simplices: Vec<u32>,
}

/// Where each tet's patch lies in the patch blob as drawn: where the record says in a raw
/// repository; in a packed one, the decoded patches back to back in blob order.
fn decoded_ranges(
    repo: &Repository,
    order: &[usize],
) -> Result<Vec<std::ops::Range<u64>>, ResidentError> {
    let tets = repo.tets();
    let mut placed = vec![0..0; tets.len()];
    let mut at = 0u64;
    for &i in order {
        placed[i] = match repo.codec() {
            PatchCodec::Raw => {
                let t = &tets[i];
                t.patch_offset..t.patch_offset + t.patch_bytes as u64
            }
            PatchCodec::Packed | PatchCodec::PackedV1 | PatchCodec::Coded => {
                let size = repo.decoded_patch_bytes(i)? as u64;
                at += size;
                at - size..at
            }
        };
    }
    Ok(placed)
}

/// The bytes of page `range` of the patch blob as drawn: a slice of the map, or the page's
/// patches decoded (the tets in `order` whose `placed` range lies in it).
fn page_bytes<'a>(
    repo: &'a Repository,
    range: &std::ops::Range<u64>,
    order: &[usize],
    placed: &[std::ops::Range<u64>],
) -> Result<PageBytes<'a>, ResidentError> {
    if range.is_empty() {
        // An empty model still gets a (tiny) page to bind.
        return Ok(PageBytes::Decoded(vec![0], 8));
    }
    let len = (range.end - range.start) as usize;
    match repo.codec() {
        PatchCodec::Raw => Ok(PageBytes::Mapped(
            &repo.patch_blob()[range.start as usize..range.end as usize],
        )),
        PatchCodec::Packed | PatchCodec::PackedV1 | PatchCodec::Coded => {
            repo.verify_ids()?;
            // 8-aligned words, so each decoded patch is parsed in place.
            let mut words = vec![0u64; len.div_ceil(8)];
            let inside = order
                .iter()
                .filter(|&&i| range.start <= placed[i].start && placed[i].end <= range.end);
            for &i in inside {
                let to = (placed[i].start - range.start) as usize
                    ..(placed[i].end - range.start) as usize;
                let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut words);
                repo.read_patch(i, &mut bytes[to.clone()])?;
                // What `validate_patches` checks of a patch, on the decoded bytes here.
                let source = PatchSource {
                    patch_blob: &bytemuck::cast_slice(&words)[..len],
                    id_blob: repo.id_blob(),
                    attributes: repo.header().attributes,
                    input_vertex_count: repo.header().input_vertex_count,
                };
                let record = TetRecord {
                    patch_offset: to.start as u64,
                    patch_bytes: to.len() as u32,
                    ..repo.tets()[i]
                };
                PatchView::parse(&source, &record).map_err(|e| match e {
                    RepositoryError::Corrupt(m) => {
                        RepositoryError::Corrupt(format!("tet {i}: {m}"))
                    }
                    other => other,
                })?;
            }
            Ok(PageBytes::Decoded(words, len))
        }
    }
}

/// A page's bytes as drawn: borrowed from the map, or decoded into 8-aligned words.
enum PageBytes<'a> {
    Mapped(&'a [u8]),
    Decoded(Vec<u64>, usize),
}

impl PageBytes<'_> {
    fn bytes(&self) -> &[u8] {
        match self {
            PageBytes::Mapped(bytes) => bytes,
            PageBytes::Decoded(words, len) => &bytemuck::cast_slice(words)[..*len],
        }
    }
}

/// Greedy pages: patches in blob order, a new page whenever the next patch would end beyond
/// `limit` bytes from the page's start.
fn lay_out_pages(repo: &Repository, limit: u64) -> Result<PageLayout, ResidentError> {
    let tets = repo.tets();
    let mut order: Vec<usize> = (0..tets.len()).collect();
    order.sort_by_key(|&i| tets[i].patch_offset);
    let placed = decoded_ranges(repo, &order)?;
    let mut pages: Vec<std::ops::Range<u64>> = Vec::new();
    let mut page_of = vec![0usize; tets.len()];
    for &i in &order {
        let (start, end) = (placed[i].start, placed[i].end);
        if end - start > limit {
            return Err(ResidentError::PatchTooLarge {
                tet: i,
                bytes: end - start,
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
    // Count each page's non-empty patches, then hand out list entries page by page.
    let mut capacity = vec![0u32; pages.len()];
    let mut slots = vec![0u64; pages.len()];
    for (i, t) in tets.iter().enumerate() {
        if t.strip_index_count != 0 {
            capacity[page_of[i]] += 1;
            slots[page_of[i]] += t.strip_index_count.saturating_sub(2) as u64;
        }
    }
    let mut lists = Vec::with_capacity(capacity.len());
    let mut next = 0u32;
    for (&c, &s) in capacity.iter().zip(&slots) {
        lists.push(SelectionList {
            first_entry: next,
            capacity: c,
            slots: s,
            index_capacity: 0,
            first_index: 0,
        });
        next += c;
    }
    // Blob order is base-vertex order within a page.
    let mut page_simplices = Vec::with_capacity(next.max(1) as usize);
    for p in 0..pages.len() {
        page_simplices.extend(
            order
                .iter()
                .filter(|&&i| page_of[i] == p && tets[i].strip_index_count != 0)
                .map(|&i| i as u32),
        );
    }
    if page_simplices.is_empty() {
        page_simplices.push(0);
    }
    let mut locations = Vec::with_capacity(tets.len());
    for (i, t) in tets.iter().enumerate() {
        if t.strip_index_count == 0 {
            locations.push(PatchLocation {
                page: NO_PAGE,
                first_entry: 0,
                first_index: 0,
                base_vertex: 0,
            });
            continue;
        }
        let page = page_of[i];
        let wide = t.vertex_count as usize > MAX_U16_PATCH_VERTICES;
        let in_page = placed[i].start - pages[page].start;
        let strip_offset =
            strip_byte_offset(t.vertex_count as usize, repo.header().attributes) as u64;
        let index_bytes = if wide { 4 } else { 2 };
        locations.push(PatchLocation {
            page: page as u32,
            first_entry: lists[page].first_entry,
            first_index: ((in_page + strip_offset) / index_bytes) as u32,
            base_vertex: (in_page / 8) as u32,
        });
    }
    Ok(PageLayout {
        pages,
        placed,
        locations,
        lists,
        entry_count: next,
        page_simplices,
    })
}
