//! The renderer: `new` makes every resource (resident model, pipelines, selection lists, index
//! regions, target), `render` records one frame — one compute pass (the traversal appends the
//! selected patches to their page's list, the compaction turns each list into draw arguments,
//! the expansion writes the indices), then per resident page one indexed indirect draw and its
//! vertex-pulling fallback, one of them empty — and submits it; the `read_*` calls fetch what
//! a frame left behind (image, selection, GPU time). Per-frame CPU work is O(1) in the model: one uniform write and a fixed number of
//! commands per resident page.

use std::time::Instant;

use tessera_core::repository::format::Header;
use tessera_core::repository::reader::Repository;

use super::compact::{Compaction, INDEXED_DRAW_OFFSET, PAGE_ARGS_BYTES, PULL_DRAW_OFFSET};
use super::device::{GpuContext, GpuFailure};
use super::draw_pipelines::{DrawPipelines, Pass};
use super::feedback::{Feedback, FeedbackFrame};
use super::frame::{FrameUniforms, ShadingMode};
use super::resident::ResidentModel;
use super::shaders::draw_source;
use super::target::{read_buffer, RenderTarget, BACKGROUND};
use super::timing::FrameTimer;
use super::traversal::Traversal;

mod bindings;
mod textures;
pub use textures::Settled;

pub(crate) use bindings::page_draw_stride;
use bindings::{draw_groups, storage_entry, uniform_entry, SelectionBuffers};

pub use super::frame_request::{
    Frame, FramePhases, FrameRequest, Readback, RenderError, RendererOptions, DEFAULT_BUDGET_BYTES,
};

/// How a read-back selection (record slots) becomes simplices, and their triangle counts.
enum Directory {
    /// Fully resident: slot = simplex; triangles of each simplex's patch.
    Resident { triangle_counts: Vec<u32> },
    /// Streaming: per slot the simplex whose record it holds (set as units land,
    /// `set_slot_simplex`); triangle counts read through the map.
    Streamed {
        slot_simplices: Vec<u32>,
        repo: std::sync::Arc<Repository>,
    },
}

pub struct Renderer {
    header: Header,
    directory: Directory,
    model: ResidentModel,
    target: RenderTarget,
    uniforms: wgpu::Buffer,
    /// The pages' selection lists and their lengths, and their read-back copies.
    lists: SelectionBuffers,
    traversal: Traversal,
    compaction: Compaction,
    draw_group: wgpu::BindGroup,
    page_groups: Vec<wgpu::BindGroup>,
    /// The draw's bind group layouts (model-wide, per page): kept for `rebind_model`.
    draw_layout: wgpu::BindGroupLayout,
    page_layout: wgpu::BindGroupLayout,
    /// Per pass: the indexed draw (`vs_indexed`) and the vertex-pulling one (`vs_main`).
    indexed: DrawPipelines,
    pulled: DrawPipelines,
    timer: Option<FrameTimer>,
    skirts: super::skirts::CheckSkirts,
    /// Streaming: the traversal's feedback lists and their read-back ring (`feedback.rs`),
    /// and the frames submitted (numbers the feedback).
    feedback: Feedback,
    frames_submitted: u64,
    /// Textures streamed as pages (`set_textures`); `None`: drawn as without.
    textures: Option<super::texture_cache::TextureCache>,
}

impl Renderer {
    /// Uploads `repo` (within `options.budget_bytes`) and makes every pipeline and buffer.
    pub fn new(
        ctx: &GpuContext,
        repo: &Repository,
        options: RendererOptions,
    ) -> Result<Renderer, RenderError> {
        super::target::check_target_size(&ctx.limits, options.width, options.height)?;
        let model = ResidentModel::upload(ctx, repo, options.budget_bytes, options.index_slots)?;
        Self::with_model(ctx, repo, options, model, 0, None)
    }

    /// The renderer over a model already made: the fully resident one (`new`) or the
    /// streaming pool (`streamer.rs`, whose pages and record slots start empty, `streamed`
    /// the shared repository), with streaming feedback lists of `feedback_capacity` entries
    /// each (`feedback.rs`; 0 for none). (Streaming: split out of `new`, unchanged otherwise.)
    pub fn with_model(
        ctx: &GpuContext,
        repo: &Repository,
        options: RendererOptions,
        model: ResidentModel,
        feedback_capacity: u32,
        streamed: Option<std::sync::Arc<Repository>>,
    ) -> Result<Renderer, RenderError> {
        super::target::check_target_size(&ctx.limits, options.width, options.height)?;
        let device = &ctx.device;
        use wgpu::BufferUsages as U;
        let uniforms = bindings::buffer(
            device,
            "frame uniforms",
            std::mem::size_of::<FrameUniforms>() as u64,
            U::UNIFORM | U::COPY_DST,
        );
        let lists = SelectionBuffers::new(device, &model);
        let (selected, counts) = (&lists.selected, &lists.counts);

        let feedback = Feedback::new(ctx, feedback_capacity); // streaming
        let traversal = Traversal::new(ctx, &model, &uniforms, selected, counts, &feedback.lists);

        // Drawing.
        let both = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let vertex = wgpu::ShaderStages::VERTEX;
        let draw_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("draw"),
            entries: &[
                uniform_entry(0, both),
                storage_entry(1, true, both),
                storage_entry(2, true, vertex),
                storage_entry(3, true, vertex),
                storage_entry(4, true, vertex),
                storage_entry(5, true, vertex),
            ],
        });
        let page_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("page"),
            // The page's `PageDraw` is a storage binding in the draw (`draw.wgsl`: lavapipe).
            entries: &[
                storage_entry(0, true, vertex),
                storage_entry(1, true, vertex),
            ],
        });
        let stride = page_draw_stride(&ctx.limits);
        let (draw_group, page_draw, page_groups) = draw_groups(
            ctx,
            (&draw_layout, &page_layout),
            &model,
            repo.header().attributes,
            (&uniforms, selected, counts),
        );
        let compaction = Compaction::new(ctx, &model, selected, counts, (&page_draw, stride));
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("draw.wgsl"),
            source: wgpu::ShaderSource::Wgsl(draw_source().into()),
        });
        let layouts = [&draw_layout, &page_layout];
        let wireframe = ctx.capabilities.wireframe;
        let attributes = repo.header().attributes;
        let pipelines =
            |vertex| DrawPipelines::new(device, &layouts, &module, vertex, attributes, wireframe);
        let (indexed, pulled) = (pipelines("vs_indexed"), pipelines("vs_main"));
        let skirts = super::skirts::CheckSkirts::new(device, &draw_layout, &module);

        let directory = match streamed {
            Some(repo) => Directory::Streamed {
                slot_simplices: vec![u32::MAX; model.slot_count as usize],
                repo,
            },
            None => Directory::Resident {
                triangle_counts: repo.tets().iter().map(|t| t.triangle_count).collect(),
            },
        };
        // An allocation that failed (out of memory) or a device lost while making them.
        ctx.check()?;
        Ok(Renderer {
            header: *repo.header(),
            directory,
            target: RenderTarget::new(ctx, options.width, options.height),
            model,
            uniforms,
            lists,
            traversal,
            compaction,
            draw_group,
            page_groups,
            draw_layout,
            page_layout,
            indexed,
            pulled,
            timer: FrameTimer::new(ctx, "frame timestamps"),
            skirts,
            feedback,
            frames_submitted: 0,
            textures: None,
        })
    }

    /// Walls the check modes draw with the model (`skirts.rs`: terrains with holes); empty
    /// meshes remove them.
    pub fn set_check_skirts(&mut self, ctx: &GpuContext, meshes: &super::skirts::SkirtMeshes) {
        self.skirts.set(&ctx.device, meshes);
    }

    /// The model, to grow a streaming pool (`stream_pool::grow`); `rebind_model` must follow
    /// before the next frame.
    pub(crate) fn model_mut(&mut self) -> &mut ResidentModel {
        &mut self.model
    }

    /// Remakes what is sized by the model's pages and record slots (selection lists, the
    /// traversal's queues, the pages' arguments and every bind group over the model's
    /// buffers) after a streaming pool grew; pipelines and everything else are kept.
    pub(crate) fn rebind_model(&mut self, ctx: &GpuContext) {
        self.lists = SelectionBuffers::new(&ctx.device, &self.model);
        let (selected, counts) = (&self.lists.selected, &self.lists.counts);
        self.traversal.rebind(
            ctx,
            &self.model,
            &self.uniforms,
            selected,
            counts,
            &self.feedback.lists,
        );
        let (draw_group, page_draw, page_groups) = draw_groups(
            ctx,
            (&self.draw_layout, &self.page_layout),
            &self.model,
            self.header.attributes,
            (&self.uniforms, selected, counts),
        );
        let stride = page_draw_stride(&ctx.limits);
        self.compaction
            .rebind(ctx, &self.model, selected, counts, (&page_draw, stride));
        // The page draws' buffer lives on in the bind groups over it.
        (self.draw_group, self.page_groups) = (draw_group, page_groups);
        if let Directory::Streamed { slot_simplices, .. } = &mut self.directory {
            slot_simplices.resize(self.model.slot_count as usize, u32::MAX);
        }
    }

    /// Replaces the `may_refine` flags the traversal reads (`tessera_core::cut`: one bit per
    /// diamond, closed downwards with `close_may_refine`; all set at creation): a diamond whose
    /// flag is clear does not refine, ρ'(D) = 0.
    pub fn set_may_refine(&self, ctx: &GpuContext, words: &[u32]) -> Result<(), RenderError> {
        if self.traversal.set_may_refine(&ctx.queue, words) {
            Ok(())
        } else {
            let diamonds = self.model.diamond_count;
            Err(RenderError::MayRefineLength {
                got: words.len(),
                expected: tessera_core::cut::may_refine_all(diamonds as usize).len(),
                diamonds,
            })
        }
    }

    /// The resident model (sizes, pages, selection lists).
    pub fn model(&self) -> &ResidentModel {
        &self.model
    }

    /// The offscreen target the frames are drawn into (`tessera view` samples its colour).
    pub fn target(&self) -> &RenderTarget {
        &self.target
    }

    /// Target size.
    pub fn size(&self) -> (u32, u32) {
        (self.target.width, self.target.height)
    }

    /// Replaces the target with one of another size, if the adapter's limits allow it (the
    /// size is refused naming the limit, as at creation). A streaming renderer's budget
    /// counted the target it was made with.
    pub fn resize(&mut self, ctx: &GpuContext, width: u32, height: u32) -> Result<(), RenderError> {
        super::target::check_target_size(&ctx.limits, width, height)?;
        self.target = RenderTarget::new(ctx, width, height);
        Ok(())
    }

    /// Records and submits one frame; returns the CPU milliseconds spent (uniforms, commands,
    /// submit — not waiting for the GPU). The camera's viewport should match the target.
    pub fn render(&mut self, ctx: &GpuContext, request: &FrameRequest, readback: Readback) -> f64 {
        let start = Instant::now();
        let mut encoder = self.begin_frame(ctx, request);
        self.encode_selection(&mut encoder, true);
        self.encode_draw(&mut encoder, request, true);
        if let Some(t) = &self.timer {
            t.resolve(&mut encoder);
        }
        if readback.selection {
            let lists = &self.lists;
            encoder.copy_buffer_to_buffer(&lists.counts, 0, &lists.counts_read, 0, None);
            encoder.copy_buffer_to_buffer(&lists.selected, 0, &lists.selected_read, 0, None);
        }
        if readback.image {
            self.target.copy_out(&mut encoder);
        }
        if let Some(textures) = &mut self.textures {
            textures.copy_out(&mut encoder);
        }
        ctx.queue.submit([encoder.finish()]);
        ctx.submitted();
        self.feedback.after_submit(); // streaming
        if let Some(textures) = &mut self.textures {
            textures.after_submit();
        }
        start.elapsed().as_secs_f64() * 1e3
    }

    /// Renders `request` as `render` does (no read-back, no timestamps), its two phases
    /// submitted and waited for apart (issue 46: where a frame's time goes): the selection
    /// (uniforms, traversal, compaction and expansion) and the raster (the draws). Each
    /// phase's time runs from its first CPU instruction to the GPU's idle. Their sum is not
    /// `render`'s waited frame (an extra wait between them, and a frame drawn warm right after
    /// the same one): compare phases with phases.
    pub fn render_phased(
        &mut self,
        ctx: &GpuContext,
        request: &FrameRequest,
    ) -> Result<FramePhases, GpuFailure> {
        let start = Instant::now();
        let mut encoder = self.begin_frame(ctx, request);
        self.encode_selection(&mut encoder, false);
        ctx.queue.submit([encoder.finish()]);
        ctx.submitted();
        self.feedback.after_submit(); // streaming
        ctx.wait_idle()?;
        let select_ms = start.elapsed().as_secs_f64() * 1e3;
        let raster = Instant::now();
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame's draws"),
            });
        self.encode_draw(&mut encoder, request, false);
        ctx.queue.submit([encoder.finish()]);
        ctx.submitted();
        ctx.wait_idle()?;
        Ok(FramePhases {
            select_ms,
            raster_ms: raster.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// The frame's uniforms written; its encoder.
    fn begin_frame(&mut self, ctx: &GpuContext, request: &FrameRequest) -> wgpu::CommandEncoder {
        let uniforms = FrameUniforms::new(
            &request.camera,
            request.drawn_from(),
            &self.header,
            request.tau,
            &request.cull,
            request.mode,
            self.model.tet_count,
        );
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));
        ctx.device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            })
    }

    /// The selection: the traversal, compaction and expansion (one compute pass), and the
    /// streaming feedback's copy; the frame's first timestamp where `timed`.
    fn encode_selection(&mut self, encoder: &mut wgpu::CommandEncoder, timed: bool) {
        encoder.clear_buffer(&self.lists.counts, 0, None);
        self.feedback.clear(encoder); // streaming
        self.traversal.reset(encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("traverse and compact"),
                timestamp_writes: self
                    .timer
                    .as_ref()
                    .filter(|_| timed)
                    .map(FrameTimer::compute_start),
            });
            self.traversal.dispatch(&mut pass);
            self.compaction.dispatch(&mut pass);
        }
        self.frames_submitted += 1; // streaming: this frame's feedback, numbered
        self.feedback.copy_out(encoder, self.frames_submitted);
    }

    /// The draws of the selection (one render pass); the frame's last timestamp where `timed`.
    fn encode_draw(&self, encoder: &mut wgpu::CommandEncoder, request: &FrameRequest, timed: bool) {
        {
            let background = if request.mode.is_check() {
                wgpu::Color::BLACK
            } else {
                BACKGROUND
            };
            let mut pass = self.target.begin_pass(
                encoder,
                "draw",
                background,
                self.timer
                    .as_ref()
                    .filter(|_| timed)
                    .map(|t| t.render_end(false)),
            );
            pass.set_bind_group(0, &self.draw_group, &[]);
            if let Some(textures) = &self.textures {
                pass.set_bind_group(2, &textures.group, &[]);
            }
            // One face rule (see `FrameRequest::two_sided`).
            let colour = request.mode == ShadingMode::Color;
            let fill = match (request.two_sided, request.mode.is_lit(), colour) {
                (true, _, true) => Pass::FillColour,
                (false, _, true) => Pass::FillFrontColour,
                (true, false, false) => Pass::Fill,
                (false, false, false) => Pass::FillFront,
                (true, true, false) => Pass::FillLit,
                (false, true, false) => Pass::FillFrontLit,
            };
            let fill_and_wire = [fill, Pass::Wire];
            let passes: &[Pass] = match (request.mode, request.wireframe) {
                (ShadingMode::Check, _) => &[Pass::CheckFront, Pass::CheckBack],
                (ShadingMode::CheckUnderside, _) => &[Pass::CheckFrontUnder, Pass::CheckBackUnder],
                (_, true) => &fill_and_wire,
                (_, false) => &fill_and_wire[..1],
            };
            pass.set_index_buffer(
                self.compaction.indices().slice(..),
                wgpu::IndexFormat::Uint32,
            );
            for &which in passes {
                // Per page, the GPU left exactly one of the two draws a non-zero count.
                for (pipelines, indexed) in [(&self.indexed, true), (&self.pulled, false)] {
                    let Some(pipeline) = pipelines.get(which) else {
                        continue;
                    };
                    pass.set_pipeline(pipeline);
                    for (p, list) in self.model.lists.iter().enumerate() {
                        if list.capacity == 0 {
                            continue;
                        }
                        pass.set_bind_group(1, &self.page_groups[p], &[]);
                        let args = p as u64 * PAGE_ARGS_BYTES;
                        if indexed {
                            pass.draw_indexed_indirect(
                                self.compaction.args(),
                                args + INDEXED_DRAW_OFFSET,
                            );
                        } else {
                            pass.draw_indirect(self.compaction.args(), args + PULL_DRAW_OFFSET);
                        }
                    }
                }
                match which {
                    Pass::CheckFront | Pass::CheckBack => {
                        self.skirts
                            .draw(&mut pass, false, which == Pass::CheckFront)
                    }
                    Pass::CheckFrontUnder | Pass::CheckBackUnder => {
                        self.skirts
                            .draw(&mut pass, true, which == Pass::CheckFrontUnder)
                    }
                    Pass::Fill
                    | Pass::FillFront
                    | Pass::FillColour
                    | Pass::FillFrontColour
                    | Pass::FillLit
                    | Pass::FillFrontLit
                    | Pass::Wire => {}
                }
            }
        }
    }

    /// Streaming: the feedback of the frames whose lists are readable now, oldest first,
    /// without waiting (`feedback.rs`); numbered as `frames_submitted` counted them.
    pub fn take_feedback(&mut self, ctx: &GpuContext) -> Result<Vec<FeedbackFrame>, GpuFailure> {
        self.feedback.take(ctx)
    }

    /// Frames submitted so far.
    pub fn frames_submitted(&self) -> u64 {
        self.frames_submitted
    }

    /// Renders `request` and reads everything back (blocks until the frame is done); the
    /// device's failure if it failed.
    pub fn render_and_read(
        &mut self,
        ctx: &GpuContext,
        request: &FrameRequest,
    ) -> Result<Frame, GpuFailure> {
        let cpu_ms = self.render(
            ctx,
            request,
            Readback {
                image: true,
                selection: true,
            },
        );
        let image = self.read_image(ctx)?;
        let selection = self.read_selection(ctx)?;
        Ok(Frame {
            triangles: self.triangles_of(&selection),
            gpu_ms: self.read_gpu_ms(ctx)?,
            image,
            selection,
            cpu_ms,
        })
    }

    /// Triangles of the patches of `selection` (simplices).
    pub fn triangles_of(&self, selection: &[u32]) -> u64 {
        match &self.directory {
            Directory::Resident { triangle_counts } => selection
                .iter()
                .map(|&i| triangle_counts[i as usize] as u64)
                .sum(),
            Directory::Streamed { repo, .. } => selection
                .iter()
                .map(|&i| repo.tets()[i as usize].triangle_count as u64)
                .sum(),
        }
    }

    /// Streaming: record slot `slot` now holds simplex `simplex` (the streamer, as a unit
    /// lands); a fully resident renderer ignores it.
    pub fn set_slot_simplex(&mut self, slot: u32, simplex: u32) {
        if let Directory::Streamed { slot_simplices, .. } = &mut self.directory {
            slot_simplices[slot as usize] = simplex;
        }
    }

    /// The image of the last frame rendered with `Readback::image` (a device failure or a
    /// failed read-back: `GpuFailure`).
    pub fn read_image(&self, ctx: &GpuContext) -> Result<image::RgbaImage, GpuFailure> {
        self.target.read(ctx)
    }

    /// The simplices drawn by the last frame rendered with `Readback::selection`, ascending
    /// (streaming: read before the next frame lands units, which may reuse slots).
    pub fn read_selection(&self, ctx: &GpuContext) -> Result<Vec<u32>, GpuFailure> {
        let counts: Vec<u32> = bytemuck::pod_collect_to_vec(&read_buffer(
            ctx,
            &self.lists.counts_read,
            "the selection",
        )?);
        let entries: Vec<u32> = bytemuck::pod_collect_to_vec(&read_buffer(
            ctx,
            &self.lists.selected_read,
            "the selection",
        )?);
        let mut selected = Vec::new();
        for (list, &count) in self.model.lists.iter().zip(&counts) {
            let count = count.min(list.capacity);
            for entry in list.first_entry..list.first_entry + count {
                // `Selected`: the record slot, then its first strip slot.
                let slot = entries[entry as usize * 2];
                selected.push(match &self.directory {
                    Directory::Resident { .. } => slot,
                    Directory::Streamed { slot_simplices, .. } => slot_simplices[slot as usize],
                });
            }
        }
        selected.sort_unstable();
        Ok(selected)
    }

    /// GPU milliseconds from the start of the traversal to the end of the draws of the last
    /// frame, where the adapter has timestamps (blocks until that frame is done).
    pub fn read_gpu_ms(&self, ctx: &GpuContext) -> Result<Option<f64>, GpuFailure> {
        match &self.timer {
            Some(timer) => timer.read_ms(ctx),
            None => Ok(None),
        }
    }
}
