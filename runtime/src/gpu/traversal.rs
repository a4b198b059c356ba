//! The traversal pass (`shaders/traverse.wgsl`): stateless and top-down, one indirect dispatch
//! per depth of the simplex tree. Depth 0 visits the roots; each visited simplex either appends
//! its patch to its page's selection list or queues its two children for the next depth and raises that depth's workgroup
//! count (`atomicMax` on its indirect arguments). GPU work is proportional to the simplices the
//! descent reaches (about twice the cut), CPU work to the tree's depth (one dispatch each).

use tessera_core::cut::may_refine_all;

use super::device::GpuContext;
use super::resident::ResidentModel;
use super::shaders::{traverse_source, TRAVERSE_WORKGROUP};

/// Largest workgroup count of one dispatch dimension; threads stride beyond it.
const MAX_WORKGROUPS: u32 = super::shaders::MAX_WORKGROUPS_PER_DIMENSION;
/// Bytes of one `DispatchIndirectArgs` (x, y, z).
const DISPATCH_ARGS_BYTES: u64 = 12;

/// `Step` in traverse.wgsl: what differs between the dispatches of one frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Step {
    depth: u32,
    root_count: u32,
    /// 1: the `may_refine` words gate refinement (fully resident); 0: the slots' child links
    /// alone (streaming, `records.rs`).
    gate_words: u32,
    pad: u32,
}

/// The traversal's pipeline and working buffers.
pub struct Traversal {
    pipeline: wgpu::ComputePipeline,
    tables_layout: wgpu::BindGroupLayout,
    step_layout: wgpu::BindGroupLayout,
    /// The `Step` of every depth, `step_stride` apart.
    steps_buffer: wgpu::Buffer,
    tables: wgpu::BindGroup,
    /// Even depths read queue 0 and write queue 1; odd depths the other way round.
    steps: [wgpu::BindGroup; 2],
    step_stride: u32,
    queued: wgpu::Buffer,
    /// Indirect arguments of the even and of the odd depths (depth d at slot d / 2).
    dispatches: [wgpu::Buffer; 2],
    /// What both hold at the start of a frame, one after the other: the roots' workgroups at
    /// depth 0, no workgroups deeper (x = 0, y = z = 1).
    dispatch_template: wgpu::Buffer,
    dispatch_bytes: u64,
    depth_count: u32,
    /// `may_refine` flag words, one bit per diamond (fully resident; one unused word when
    /// streaming, where the slots' child links are the flags).
    may_refine: wgpu::Buffer,
    diamond_count: u32,
    streamed: bool,
}

fn entry(
    binding: u32,
    ty: wgpu::BufferBindingType,
    has_dynamic_offset: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset,
            min_binding_size: None,
        },
        count: None,
    }
}

impl Traversal {
    /// The pipeline and buffers for `model`; `frame` holds the `FrameUniforms`, `selected` and
    /// `counts` receive the pages' selection lists and their lengths.
    pub fn new(
        ctx: &GpuContext,
        model: &ResidentModel,
        frame: &wgpu::Buffer,
        selected: &wgpu::Buffer,
        counts: &wgpu::Buffer,
        feedback: &wgpu::Buffer, // streaming feedback lists (feedback.rs)
    ) -> Traversal {
        use wgpu::util::DeviceExt;
        use wgpu::BufferBindingType as B;
        use wgpu::BufferUsages as U;
        let device = &ctx.device;
        let depths = model.depth_count.max(1);
        let storage = |read_only| B::Storage { read_only };
        let tables_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("traverse tables"),
            entries: &[
                entry(0, B::Uniform, false),
                entry(1, storage(true), false),  // slot records
                entry(2, storage(true), false),  // locations
                entry(3, storage(false), false), // selection lists
                entry(4, storage(false), false), // their counts
                entry(5, storage(false), false), // queued per depth
                entry(6, storage(true), false),  // may_refine words
                entry(7, storage(false), false), // feedback
            ],
        });
        let step_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("traverse step"),
            entries: &[
                entry(0, B::Uniform, true),
                entry(1, storage(true), false),
                entry(2, storage(false), false),
                entry(3, storage(false), false),
            ],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("traverse.wgsl"),
            source: wgpu::ShaderSource::Wgsl(traverse_source().into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("traverse"),
            layout: Some(
                &device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some("traverse"),
                    bind_group_layouts: &[Some(&tables_layout), Some(&step_layout)],
                    immediate_size: 0,
                }),
            ),
            module: &module,
            entry_point: Some("traverse"),
            compilation_options: Default::default(),
            cache: None,
        });

        // One counter per depth (plus one the deepest dispatch may write), and the indirect
        // arguments of every depth.
        let queued = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("traversal queued"),
            size: 4 * (depths as u64 + 1),
            usage: U::STORAGE | U::COPY_DST,
            mapped_at_creation: false,
        });
        let slots = depths as u64 / 2 + 1;
        let dispatch_bytes = slots * DISPATCH_ARGS_BYTES;
        let mut template: Vec<u32> = (0..2 * slots).flat_map(|_| [0, 1, 1]).collect();
        template[0] = model
            .root_count
            .div_ceil(TRAVERSE_WORKGROUP)
            .clamp(1, MAX_WORKGROUPS);
        let dispatch_template = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("traversal dispatch template"),
            contents: bytemuck::cast_slice(&template),
            usage: U::COPY_SRC,
        });
        let dispatch_buffer = |label| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: dispatch_bytes,
                usage: U::STORAGE | U::INDIRECT | U::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let dispatches = [
            dispatch_buffer("traversal dispatches (even depths)"),
            dispatch_buffer("traversal dispatches (odd depths)"),
        ];
        let words = if model.streamed {
            vec![0u32]
        } else {
            may_refine_all(model.diamond_count as usize)
        };
        let may_refine = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("may refine"),
            contents: bytemuck::cast_slice(&words),
            usage: U::STORAGE | U::COPY_DST,
        });
        let step_stride = std::mem::size_of::<Step>()
            .next_multiple_of(ctx.limits.min_uniform_buffer_offset_alignment as usize)
            as u32;
        let mut step_bytes = vec![0u8; (step_stride * depths) as usize];
        for depth in 0..depths {
            let at = (depth * step_stride) as usize;
            let step = Step {
                depth,
                root_count: model.root_count,
                gate_words: u32::from(!model.streamed),
                pad: 0,
            };
            let bytes = bytemuck::bytes_of(&step);
            step_bytes[at..at + bytes.len()].copy_from_slice(bytes);
        }
        let steps_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("traversal steps"),
            contents: &step_bytes,
            usage: U::UNIFORM,
        });
        let (tables, steps) = Self::groups(
            ctx,
            (&tables_layout, &step_layout, &steps_buffer),
            model,
            [frame, selected, counts, &queued, &may_refine, feedback],
            &dispatches,
        );
        Traversal {
            pipeline,
            tables_layout,
            step_layout,
            steps_buffer,
            tables,
            steps,
            step_stride,
            queued,
            dispatches,
            dispatch_template,
            dispatch_bytes,
            depth_count: depths,
            may_refine,
            diamond_count: model.diamond_count,
            streamed: model.streamed,
        }
    }

    /// Binds the traversal to a model whose record slots or pages changed (a streaming pool
    /// that grew, `stream_pool::grow`): new queues sized by its slots and new bind groups over
    /// its buffers and the new selection lists; the pipeline and everything else are kept.
    pub fn rebind(
        &mut self,
        ctx: &GpuContext,
        model: &ResidentModel,
        frame: &wgpu::Buffer,
        selected: &wgpu::Buffer,
        counts: &wgpu::Buffer,
        feedback: &wgpu::Buffer,
    ) {
        let (tables, steps) = Self::groups(
            ctx,
            (&self.tables_layout, &self.step_layout, &self.steps_buffer),
            model,
            [
                frame,
                selected,
                counts,
                &self.queued,
                &self.may_refine,
                feedback,
            ],
            &self.dispatches,
        );
        self.tables = tables;
        self.steps = steps;
    }

    /// The queues (sized by the model's slots) and the bind groups: `buffers` are the frame
    /// uniforms, the selection lists, their counts, the per-depth counters, the `may_refine`
    /// words and the feedback lists.
    fn groups(
        ctx: &GpuContext,
        (tables_layout, step_layout, steps_buffer): (
            &wgpu::BindGroupLayout,
            &wgpu::BindGroupLayout,
            &wgpu::Buffer,
        ),
        model: &ResidentModel,
        buffers: [&wgpu::Buffer; 6],
        dispatches: &[wgpu::Buffer; 2],
    ) -> (wgpu::BindGroup, [wgpu::BindGroup; 2]) {
        use wgpu::BufferUsages as U;
        let device = &ctx.device;
        let [frame, selected, counts, queued, may_refine, feedback] = buffers;
        // A depth's queue holds at most every slot (a reached simplex is in a slot).
        let queue = |label| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 4 * (model.slot_count.max(1) as u64),
                usage: U::STORAGE,
                mapped_at_creation: false,
            })
        };
        let queues = [queue("traversal queue 0"), queue("traversal queue 1")];
        let tables = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("traverse tables"),
            layout: tables_layout,
            entries: &[
                frame,
                &model.records,
                &model.locations,
                selected,
                counts,
                queued,
                may_refine,
                feedback,
            ]
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect::<Vec<_>>(),
        });
        let step_group = |input: &wgpu::Buffer, output: &wgpu::Buffer, next: &wgpu::Buffer| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("traverse step"),
                layout: step_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: steps_buffer,
                            offset: 0,
                            size: wgpu::BufferSize::new(std::mem::size_of::<Step>() as u64),
                        }),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: input.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: output.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: next.as_entire_binding(),
                    },
                ],
            })
        };
        let steps = [
            step_group(&queues[0], &queues[1], &dispatches[1]),
            step_group(&queues[1], &queues[0], &dispatches[0]),
        ];
        (tables, steps)
    }

    /// Replaces the `may_refine` flags (`tessera_core::cut`: one bit per diamond, closed
    /// downwards by the caller) for the frames that follow; `false` when `words` is not
    /// `may_refine_all(diamonds).len()` words long, or when streaming (whose flags are the
    /// slots' child links: nothing is written then).
    pub fn set_may_refine(&self, queue: &wgpu::Queue, words: &[u32]) -> bool {
        if self.streamed || words.len() != may_refine_all(self.diamond_count as usize).len() {
            return false;
        }
        queue.write_buffer(&self.may_refine, 0, bytemuck::cast_slice(words));
        true
    }

    /// Resets the traversal's counters and dispatch arguments (before the compute pass; the
    /// selection lists' counts are the caller's to clear).
    pub fn reset(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(&self.queued, 0, None);
        for (k, dispatches) in self.dispatches.iter().enumerate() {
            encoder.copy_buffer_to_buffer(
                &self.dispatch_template,
                k as u64 * self.dispatch_bytes,
                dispatches,
                0,
                self.dispatch_bytes,
            );
        }
    }

    /// Records the traversal's dispatches, one per depth, into `pass`.
    pub fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.tables, &[]);
        for depth in 0..self.depth_count {
            pass.set_bind_group(
                1,
                &self.steps[depth as usize % 2],
                &[depth * self.step_stride],
            );
            pass.dispatch_workgroups_indirect(
                &self.dispatches[depth as usize % 2],
                (depth / 2) as u64 * DISPATCH_ARGS_BYTES,
            );
        }
    }

    /// Dispatches per frame.
    pub fn depth_count(&self) -> u32 {
        self.depth_count
    }
}
