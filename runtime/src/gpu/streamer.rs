//! The streaming renderer's loop: GPU memory as a cache of the mapped repository under a byte
//! budget. `GpuStreamer::frame` runs one frame on the render thread:
//!
//! 1. frees the pool space of evicted units once every frame that could draw them completed
//!    (`queue.on_submitted_work_done` per submitted frame raises a completed-frame counter);
//! 2. takes what the `Loader` thread finished, places each unit in the pool (`stream_pool`)
//!    and its simplices in record slots (`records.rs`: one pair of slots per child pair),
//!    writes its bytes, its simplices' slot records (no child link yet) and `PatchLocation`s,
//!    then `Residency::complete`s it — within the per-frame upload allowance;
//! 3. writes the flags that changed as child links: each simplex of a diamond that may now
//!    refine gets the slot of its children's pair, each of one that may no longer gets
//!    `NO_INDEX` — after the records they point to (same queue, write order: every write
//!    lands before the frame's commands), only into slots of units placed now;
//! 4. renders and submits the frame with those flags;
//! 5. feedback: the traversal's refined and wanted lists (`feedback.rs`) of the frames read
//!    back by now — a frame or two late —, deduplicated, go to `Residency::feedback`;
//!    `Residency::plan` then evicts (flags cleared now, in effect from the next frame's
//!    upload; space freed by step 1 later) and issues loads to the loader thread.
//!
//! The roots are placed at creation and pinned, their records in slots `0..root_count`. No
//! GPU buffer and no CPU table here is sized by the model's simplex count; per diamond, the
//! CPU keeps the residency's state (`stream::residency`); `placed` holds the placed units only.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use tessera_core::cut::diamond_rhos;
use tessera_core::repository::patch::drawn_patch_bytes;
use tessera_core::repository::reader::Repository;

use super::device::{GpuContext, GpuFailure};
use super::records::{PairSlots, CHILDREN_OFFSET, SLOT_RECORD_BYTES};
use super::renderer::{FrameRequest, Readback, RenderError, Renderer, RendererOptions};
use super::resident::ResidentModel;
use super::stream_budget::{fixed_bytes, largest_unit_bytes, FixedBytes};
use super::stream_pool::{pool_model, Placement, PoolAllocator};
use super::texture_cache::{cache_bytes, layers_for};
use super::texture_pages::{PageSource, PoolFormat, TextureLayout};
use crate::stream::loader::read_unit;
use crate::stream::{stream_frame, LoadedUnit, Loader, Residency, StreamFrame, UnitTable};
use tessera_core::repository::format::NO_INDEX;

pub use super::stream_report::{GpuStreamStats, StreamError, StreamedGpuFrame};

/// A frame number and the refined and wanted lists the CPU reference found for it.
type FeedbackLists = (u64, Vec<(u32, f32)>, Vec<(u32, f32)>);

/// Entries of each feedback list: at most one per simplex, and a share of the target (one per
/// 64 pixels, at least 4,096): a cut's refined and wanted simplices grow with what the view
/// shows. A frame whose lists overflowed is not fed to the residency (its refined list is
/// incomplete, so used units could look unused and be evicted): it requests nothing.
/// Both lists are one storage binding (`limits`): a smaller adapter gets shorter lists, whose
/// overflowed frames request nothing.
pub fn feedback_capacity(tets: usize, width: u32, height: u32, limits: &wgpu::Limits) -> u32 {
    let share = (width as usize * height as usize / 64).max(4096);
    let binding = super::feedback::Feedback::max_capacity(super::resident::page_limit(limits));
    tets.min(share).min(binding as usize) as u32
}

/// Whether unit `u` fits one empty page of the pool: its patches, each 8-aligned as the
/// loader lays them out, within the page's bytes, and its non-empty patches within the page's
/// selection list. Decided from the unit table's sizes where they settle it (nearly always:
/// the pages are made over the largest unit, `stream_budget::fixed_bytes`), so that opening
/// does not read every record through the map.
fn fits_a_page(
    repo: &Repository,
    units: &UnitTable,
    u: u32,
    layout: &super::stream_pool::PoolLayout,
) -> bool {
    let simplices = units.simplices(u);
    let padded = units.bytes(u) + 7 * simplices.len() as u64;
    if padded.max(8) <= layout.page_bytes && simplices.len() as u64 <= layout.patch_capacity as u64
    {
        return true;
    }
    let (tets, attributes) = (repo.tets(), repo.header().attributes);
    let (mut bytes, mut nonempty) = (0u64, 0u64);
    for &s in simplices {
        let t = &tets[s as usize];
        bytes += drawn_patch_bytes(t, attributes).next_multiple_of(8);
        nonempty += u64::from(t.strip_index_count != 0);
    }
    bytes.max(8) <= layout.page_bytes && nonempty <= layout.patch_capacity as u64
}

/// The streaming state of one renderer.
pub struct GpuStreamer {
    repo: Arc<Repository>,
    residency: Residency,
    loader: Loader,
    pool: PoolAllocator,
    /// The pools' sizes at their largest (the layout); `pool` and `slots` grow up to them.
    sizes: FixedBytes,
    /// Placed units' ranges, by unit (only those: nothing here per diamond of the model).
    placed: BTreeMap<u32, Placement>,
    /// Record slots, and per placed unit the first slot of each of its child pairs (in the
    /// order of `UnitTable::simplices`).
    slots: PairSlots,
    pairs: HashMap<u32, Vec<u32>>,
    /// Units read by the loader, waiting for pool space or the upload allowance.
    ready: VecDeque<LoadedUnit>,
    /// Evicted placements and slot pairs, and the last frame that could draw them.
    retired: Vec<(u64, Placement, Vec<u32>)>,
    submitted: u64,
    completed: Arc<AtomicU64>,
    upload_bytes_per_frame: u64,
    first_entries: Vec<u32>,
    /// Simplices whose patch is in the pool (roots included).
    resident_patches: usize,
    /// Bumped at every flags upload; per frame drawn (renderer's number), the version used
    /// and the view's (bumped when the camera, τ or culling changes: feedback from another
    /// view does not make this one settled).
    flags_version: u64,
    versions: VecDeque<(u64, u64, u64)>,
    view: Option<(crate::camera::Camera, f32, tessera_core::cull::CullTests)>,
    view_version: u64,
    /// Whether the last feedback read back saw the flags and view current then, and their
    /// versions then.
    last_feedback: (bool, u64, u64),
    /// Compute the CPU reference every frame (`set_cpu_reference`), and per frame drawn its
    /// refined and wanted lists, to compare with the GPU's when they arrive.
    cpu_reference: bool,
    expected: VecDeque<FeedbackLists>,
    stats: GpuStreamStats,
}

impl GpuStreamer {
    /// A renderer over an empty pool sized from `options.budget_bytes` (every allocation
    /// counted), the roots placed and pinned, every diamond kept from refining until its unit
    /// lands.
    pub fn new(
        ctx: &GpuContext,
        repo: Arc<Repository>,
        options: RendererOptions,
        upload_bytes_per_frame: u64,
    ) -> Result<(Renderer, GpuStreamer), StreamError> {
        Self::with_textures(ctx, repo, options, upload_bytes_per_frame, None)
    }

    /// `new`, the renderer drawing `textures` (`Renderer::set_textures`) when given: their
    /// page pool, tables and request bits take their share of `options.budget_bytes`
    /// (`texture_cache::layers_for`: at most a quarter, and what the viewport can want) and
    /// the geometry the rest; each
    /// `frame` loads the pages the frames asked for.
    pub fn with_textures(
        ctx: &GpuContext,
        repo: Arc<Repository>,
        options: RendererOptions,
        upload_bytes_per_frame: u64,
        textures: Option<Arc<dyn PageSource>>,
    ) -> Result<(Renderer, GpuStreamer), StreamError> {
        let Some(source) = textures else {
            return Self::geometry(ctx, repo, options, upload_bytes_per_frame);
        };
        let layout = TextureLayout::new(source.shapes(), source.bands())?;
        let format = PoolFormat::for_pages(ctx, source.encoding());
        let viewport = (options.width, options.height);
        let layers = layers_for(ctx, &layout, Some(options.budget_bytes), format, viewport)?;
        let bytes = cache_bytes(&layout, layers, format);
        let geometry = RendererOptions {
            budget_bytes: options.budget_bytes - bytes,
            ..options
        };
        let (mut renderer, mut streamer) =
            Self::geometry(ctx, repo, geometry, upload_bytes_per_frame)?;
        renderer.set_textures(ctx, source, layers)?;
        streamer.stats.max_gpu_bytes += bytes;
        Ok((renderer, streamer))
    }

    /// `new` without textures.
    fn geometry(
        ctx: &GpuContext,
        repo: Arc<Repository>,
        options: RendererOptions,
        upload_bytes_per_frame: u64,
    ) -> Result<(Renderer, GpuStreamer), StreamError> {
        // The size first: an impossible target would otherwise read as a budget problem.
        super::target::check_target_size(&ctx.limits, options.width, options.height)
            .map_err(RenderError::from)?;
        // The unit table and the pools' sizes read the whole directory through the map, the
        // tet table a mebibyte at a time, dropping its pages behind them
        // (`Repository::scan_tets`); the rest of what they read (the diamond table) is dropped
        // after each (`release_pages`), and after the pool model and at the end.
        let units = UnitTable::from_repository(&repo);
        repo.release_pages();
        let sizes = fixed_bytes(ctx, &repo, &options, largest_unit_bytes(&units));
        repo.release_pages();
        let layout = sizes.layout;
        let roots = units.root_bytes();
        let root_count = units.roots().len() as u32;
        let pool_bytes = sizes.pool_bytes();
        // Padding (each patch 8-aligned) and fragmentation need slack: the residency gets
        // seven eighths of the pool. Record slots come in pairs and do not fragment: the
        // residency gets every one.
        let budget = pool_bytes - pool_bytes / 8;
        let record_budget =
            root_count as u64 + 2 * PairSlots::pairs_within(sizes.slots, root_count) as u64;
        let binding = super::resident::page_limit(&ctx.limits);
        let root_records = (root_count as u64 + 2) * super::records::SLOT_RECORD_BYTES;
        // The records are one binding, and a unit (the roots are one) lands whole in a page.
        for (what, bytes) in [("records", root_records), ("patches", roots)] {
            if bytes > binding {
                return Err(StreamError::RootsOverBindingLimit {
                    roots: root_count,
                    what,
                    bytes,
                    limit: binding,
                });
            }
        }
        let too_small = StreamError::BudgetTooSmall {
            budget: options.budget_bytes,
            fixed: sizes.fixed + sizes.record_bytes(),
            roots,
        };
        if sizes.total() > options.budget_bytes || roots > budget || root_count > sizes.slots {
            return Err(too_small);
        }
        let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        // The pools start with one page and a few record slots and grow, up to the layout,
        // as units need room (`streamer/growth.rs`): a view that needs little allocates
        // little whatever the budget.
        let first_slots = sizes
            .slots
            .min(root_count.next_multiple_of(2) + 2 * options.pool_growth.first_slot_pairs);
        let model: ResidentModel = pool_model(ctx, &repo, &layout, 1, first_slots);
        repo.release_pages();
        let capacity = feedback_capacity(
            repo.tets().len(),
            options.width,
            options.height,
            &ctx.limits,
        );
        let mut renderer =
            Renderer::with_model(ctx, &repo, options, model, capacity, Some(repo.clone()))?;
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(StreamError::Device(GpuFailure(format!(
                "allocating {} bytes of pools and working buffers: {e}",
                sizes.total()
            ))));
        }
        ctx.check()?;
        let mut residency =
            Residency::with_records(units, budget, record_budget).map_err(|_| too_small)?;
        residency.track_changed_flags();
        // A unit lands whole in one page (≤ one storage binding): one that no empty page can
        // hold is refused now, so its diamond stays unrefined and the stream still settles.
        for u in 0..residency.units().len() as u32 {
            if !fits_a_page(&repo, residency.units(), u, &layout) {
                residency.refuse(u);
            }
        }
        repo.release_pages();
        let mut streamer = GpuStreamer {
            loader: Loader::new(repo.clone()),
            placed: BTreeMap::new(),
            residency,
            pool: PoolAllocator::new(1, layout.page_bytes, layout.patch_capacity),
            slots: PairSlots::new(first_slots, root_count),
            sizes,
            pairs: HashMap::new(),
            ready: VecDeque::new(),
            retired: Vec::new(),
            submitted: 0,
            completed: Arc::new(AtomicU64::new(0)),
            upload_bytes_per_frame,
            first_entries: renderer
                .model()
                .lists
                .iter()
                .map(|l| l.first_entry)
                .collect(),
            resident_patches: 0,
            flags_version: 0,
            versions: VecDeque::new(),
            view: None,
            view_version: 0,
            last_feedback: (false, 0, 0),
            cpu_reference: false,
            expected: VecDeque::new(),
            stats: GpuStreamStats {
                max_gpu_bytes: sizes.total(),
                ..Default::default()
            },
            repo,
        };
        streamer.count_allocations(renderer.model());
        let root_simplices: Vec<u32> = streamer.residency.units().roots().to_vec();
        let bytes = read_unit(&streamer.repo, &root_simplices).map_err(StreamError::Roots)?;
        let root_slots: Vec<u32> = (0..root_count).collect();
        if streamer
            .place(ctx, &mut renderer, &bytes, &root_slots)
            .is_none()
        {
            return Err(StreamError::BudgetTooSmall {
                budget: options.budget_bytes,
                fixed: sizes.fixed + sizes.record_bytes(),
                roots,
            });
        }
        // Sizing the pools and the unit table read the whole directory through the map: drop
        // those pages from the resident set (the units' records are read again as they land).
        streamer.repo.release_pages();
        Ok((renderer, streamer))
    }

    /// The residency (flags, states, totals).
    pub fn residency(&self) -> &Residency {
        &self.residency
    }

    /// Also run the CPU reference (`stream::stream_frame`) every frame for the flags drawn:
    /// `StreamedGpuFrame::reference` is then filled, and the GPU's feedback is compared with
    /// it (`GpuStreamStats::feedback_mismatches`). Off by default (O(diamonds) per frame).
    pub fn set_cpu_reference(&mut self, on: bool) {
        self.cpu_reference = on;
    }

    /// Simplices whose patch is in the pool now (roots included).
    pub fn resident_patches(&self) -> usize {
        self.resident_patches
    }

    /// Streaming totals.
    pub fn stats(&self) -> GpuStreamStats {
        GpuStreamStats {
            fragmentation: self.pool.fragmentation(),
            ..self.stats
        }
    }

    /// Step 3: writes the child link of every simplex of diamond `d` that is in a slot now:
    /// the slot of its children's pair in R(d) when `d` may refine, else `NO_INDEX`. The
    /// simplices of `d` were created by its parents (the roots when it has none), so they are
    /// found in the parents' placed units, read through the map.
    fn write_links(&self, ctx: &GpuContext, renderer: &Renderer, d: u32) {
        let tets = self.repo.tets();
        let units = self.residency.units();
        let on = self.residency.may_refine()[d as usize];
        let children = if on { self.pairs.get(&d) } else { None };
        debug_assert!(!on || children.is_some(), "diamond {d} may refine unplaced");
        let link = |s: u32| -> u32 {
            let Some(pairs) = children else {
                return NO_INDEX;
            };
            let c = tets[s as usize].first_child;
            match units.simplices(d).binary_search(&c) {
                Ok(k) if k % 2 == 0 => pairs[k / 2],
                _ => NO_INDEX, // not in R(d): the reader's checks rule this out
            }
        };
        let records = &renderer.model().records;
        let write = |slot: u32, s: u32| {
            ctx.queue.write_buffer(
                records,
                slot as u64 * SLOT_RECORD_BYTES + CHILDREN_OFFSET,
                bytemuck::bytes_of(&link(s)),
            );
        };
        let parents = units.parents(d);
        if parents.is_empty() {
            for &s in units.roots() {
                if tets[s as usize].diamond == d {
                    write(s, s);
                }
            }
        }
        for &p in parents {
            let Some(pairs) = self.pairs.get(&p) else {
                continue; // evicted: its slots are not its simplices' any more
            };
            for (k, &s) in units.simplices(p).iter().enumerate() {
                if tets[s as usize].diamond == d {
                    write(pairs[k / 2] + (k % 2) as u32, s);
                }
            }
        }
    }

    /// Steps 1–3 of the module comment; returns the units uploaded.
    fn land(&mut self, ctx: &GpuContext, renderer: &mut Renderer) -> Result<usize, RenderError> {
        let _ = ctx.device.poll(wgpu::PollType::Poll);
        let completed = self.completed.load(Ordering::Acquire);
        let (pool, slots) = (&mut self.pool, &mut self.slots);
        self.retired.retain(|(frame, placed, pairs)| {
            let done = *frame <= completed;
            if done {
                pool.free(*placed);
                for &p in pairs {
                    slots.free(p);
                }
            }
            !done
        });
        let finished = self.loader.finished();
        for unit in &finished {
            if let Ok(bytes) = &unit.result {
                self.stats.read_seconds += bytes.read_seconds;
            }
        }
        self.ready.extend(finished);
        let (mut uploaded, mut uploaded_bytes) = (0, 0u64);
        let mut waiting = VecDeque::new();
        while let Some(unit) = self.ready.pop_front() {
            match &unit.result {
                Err(_) => self.residency.complete(unit.unit, false),
                Ok(bytes) => {
                    let over = uploaded > 0
                        && uploaded_bytes + bytes.bytes.len() as u64 > self.upload_bytes_per_frame;
                    let placed = (!over)
                        .then(|| self.place_unit(ctx, renderer, unit.unit, bytes))
                        .flatten();
                    match placed {
                        Some(placed) => {
                            self.placed.insert(unit.unit, placed);
                            self.residency.complete(unit.unit, true);
                            uploaded += 1;
                            uploaded_bytes += placed.bytes;
                        }
                        None => {
                            self.stats.space_waits += 1;
                            // Retired ranges free up within a frame or two: make room only
                            // when nothing else will (`stream/residency/space.rs`).
                            let keep = over
                                || !self.retired.is_empty()
                                || self.make_room(unit.unit, bytes);
                            if keep {
                                waiting.push_back(unit);
                            }
                        }
                    }
                }
            }
        }
        self.ready = waiting;
        // The flags (child links) after the records they point to: both are queue writes,
        // applied in order before the frame's commands.
        if self.residency.take_flags_changed() {
            for d in self.residency.take_changed_flags() {
                self.write_links(ctx, renderer, d);
            }
            self.flags_version += 1;
        }
        Ok(uploaded)
    }

    /// One frame: lands what loaded, renders `request` with the resulting flags, feeds back
    /// and plans (module comment). `readback` as for `Renderer::render`.
    pub fn frame(
        &mut self,
        ctx: &GpuContext,
        renderer: &mut Renderer,
        request: &FrameRequest,
        readback: Readback,
    ) -> Result<StreamedGpuFrame, StreamError> {
        // A device that failed (lost, out of memory: recorded by its callbacks) ends here.
        ctx.check()?;
        let uploads = self.land(ctx, renderer)?;
        renderer.render(ctx, request, readback);
        ctx.check()?;
        // Texture pages the frames before asked for (their read-backs, a frame or two late).
        renderer.update_textures(ctx)?;
        self.submitted += 1;
        let (frame, completed) = (self.submitted, self.completed.clone());
        ctx.queue.on_submitted_work_done(move || {
            completed.fetch_max(frame, Ordering::AcqRel);
        });

        let may_refine_words = if self.cpu_reference {
            self.residency.may_refine_words()
        } else {
            Vec::new()
        };
        let drawn = renderer.frames_submitted();
        let view = Some((request.camera, request.tau, request.cull));
        if self.view != view {
            self.view = view;
            self.view_version += 1;
        }
        self.versions
            .push_back((drawn, self.flags_version, self.view_version));
        // The CPU reference for the flags this frame was drawn with, when asked for (checks).
        let reference = if self.cpu_reference {
            let origin = self.repo.header().origin;
            let eye = request.camera.eye_local(origin);
            let rhos = diamond_rhos(self.repo.diamonds(), eye, &request.camera.metric());
            let reference = stream_frame(
                self.repo.tets(),
                self.repo.header().root_tet_count as usize,
                &rhos,
                self.residency.may_refine(),
                request.tau,
                eye,
                &request.cull,
            );
            self.expected
                .push_back((drawn, reference.refined.clone(), reference.wanted.clone()));
            reference
        } else {
            StreamFrame::default()
        };
        // Feedback: the GPU lists of the frames read back by now (a frame or two late).
        let (mut loads, mut evictions, mut fresh) = (Vec::new(), 0, None);
        for mut fb in renderer.take_feedback(ctx)? {
            for list in [&mut fb.refined, &mut fb.wanted] {
                list.sort_unstable_by_key(|&(d, _)| d);
                list.dedup_by_key(|&mut (d, _)| d);
            }
            self.stats.feedback_overflow += fb.overflow as u64;
            if fb.overflow > 0 {
                continue; // incomplete: requests nothing (feedback_capacity)
            }
            self.stats.feedback_frames += 1;
            while self.expected.front().is_some_and(|e| e.0 < fb.frame) {
                self.expected.pop_front();
            }
            if let Some(e) = self.expected.front().filter(|e| e.0 == fb.frame) {
                if e.1 != fb.refined || e.2 != fb.wanted {
                    self.stats.feedback_mismatches += 1;
                }
            }
            while self.versions.front().is_some_and(|v| v.0 < fb.frame) {
                self.versions.pop_front();
            }
            fresh = Some(self.versions.front().is_some_and(|&(f, v, w)| {
                f == fb.frame && v == self.flags_version && w == self.view_version
            }));
            self.residency.feedback(&fb.refined, &fb.wanted);
            let plan = self.residency.plan(self.upload_bytes_per_frame);
            for &u in &plan.evict {
                self.retire(u);
            }
            evictions += plan.evict.len();
            loads.extend(plan.load);
        }
        for &u in &loads {
            self.loader
                .submit(u, self.residency.units().simplices(u).to_vec());
        }
        let stats = self.residency.stats();
        // Settled: the latest feedback saw the current flags and view, and asked for nothing
        // more. A frame whose feedback is not back yet (a slow GPU) keeps the last feedback's
        // verdict while neither the flags nor the view changed since.
        let fresh = match fresh {
            Some(fresh) => {
                self.last_feedback = (fresh, self.flags_version, self.view_version);
                fresh
            }
            None => self.last_feedback == (true, self.flags_version, self.view_version),
        };
        let settled =
            fresh && loads.is_empty() && stats.loading_units == 0 && self.ready.is_empty();
        let plan_loads = loads.len();
        Ok(StreamedGpuFrame {
            reference,
            may_refine_words,
            loads: plan_loads,
            evictions,
            uploads,
            settled,
            stats,
        })
    }
}

mod growth;
mod placement;
