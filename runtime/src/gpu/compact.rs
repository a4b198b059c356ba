//! The compaction and expansion passes (`shaders/compact.wgsl`, `shaders/expand.wgsl`), after
//! the traversal in the same compute pass. Compaction: one workgroup per resident page writes
//! the prefix sums of its selected patches' strip slots and the page's arguments (16 words,
//! `records.wgsl`). Expansion: one indirect dispatch per page, one thread per slot, writes the
//! slot's triangle as three u32 indices into the page's index region. A page is then drawn
//! with one indexed draw, or — when a frame selects more slots than its region holds — with
//! one non-indexed draw whose vertex shader finds its slot itself; the GPU chooses (exactly one
//! of the two has a non-zero count), the CPU issues both. GPU work is proportional to the
//! selection, CPU work to the number of pages.

use super::device::GpuContext;
use super::resident::ResidentModel;
pub use super::resident::PAGE_ARGS_BYTES;
use super::shaders::{compact_source, expand_source};

/// Byte offsets inside a page's arguments (`records.wgsl`).
pub const PULL_DRAW_OFFSET: u64 = 0;
pub const INDEXED_DRAW_OFFSET: u64 = 16;
const EXPAND_DISPATCH_OFFSET: u64 = 36;

/// `PageInfo` in records.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct PageInfo {
    first_entry: u32,
    index_capacity: u32,
    first_index: u32,
    pad: u32,
}

/// `PageDraw` in expand.wgsl and draw.wgsl: which page a draw or an expansion is about.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PageDraw {
    pub page: u32,
    pub first_entry: u32,
    pub patch_count: u32,
    /// The model's attribute flags (`Header::attributes`, as `FrameUniforms`' `counts.w`):
    /// the vertex stage reads them here, from storage, not from the frame's uniforms
    /// (`draw.wgsl`: lavapipe).
    pub attributes: u32,
}

/// The passes' pipelines and what they write.
pub struct Compaction {
    pipeline: wgpu::ComputePipeline,
    expand: wgpu::ComputePipeline,
    /// The compaction's, the expansion's tables' and an expansion page's bind group layouts.
    layouts: [wgpu::BindGroupLayout; 3],
    bound: Bound,
}

fn entry(binding: u32, ty: wgpu::BufferBindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn pipeline(
    device: &wgpu::Device,
    label: &str,
    source: String,
    layouts: &[Option<&wgpu::BindGroupLayout>],
) -> wgpu::ComputePipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(
            &device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: layouts,
                immediate_size: 0,
            }),
        ),
        module: &module,
        entry_point: Some(label),
        compilation_options: Default::default(),
        cache: None,
    })
}

fn group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    resources: &[wgpu::BindingResource<'_>],
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout,
        entries: &resources
            .iter()
            .enumerate()
            .map(|(i, r)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: r.clone(),
            })
            .collect::<Vec<_>>(),
    })
}

fn pipeline_of(
    device: &wgpu::Device,
    tables_layout: &wgpu::BindGroupLayout,
    page_layout: &wgpu::BindGroupLayout,
) -> wgpu::ComputePipeline {
    pipeline(
        device,
        "expand",
        expand_source(),
        &[Some(tables_layout), Some(page_layout)],
    )
}

/// What depends on the model's pages and index regions: remade when a streaming pool grows.
struct Bound {
    group: wgpu::BindGroup,
    expand_tables: wgpu::BindGroup,
    /// One per page, with a non-empty selection list.
    expand_pages: Vec<Option<wgpu::BindGroup>>,
    /// The pages' arguments (`PAGE_ARGS_BYTES` each): draws and dispatches.
    args: wgpu::Buffer,
    /// The pages' index regions (u32).
    indices: wgpu::Buffer,
    pages: u32,
}

impl Bound {
    fn new(
        ctx: &GpuContext,
        [layout, tables_layout, page_layout]: &[wgpu::BindGroupLayout; 3],
        model: &ResidentModel,
        selected: &wgpu::Buffer,
        counts: &wgpu::Buffer,
        page_draws: (&wgpu::Buffer, u64),
    ) -> Bound {
        use wgpu::util::DeviceExt;
        use wgpu::BufferUsages as U;
        let device = &ctx.device;
        let pages = model.lists.len() as u32;
        let infos: Vec<PageInfo> = model
            .lists
            .iter()
            .map(|l| PageInfo {
                first_entry: l.first_entry,
                index_capacity: l.index_capacity,
                first_index: l.first_index as u32,
                pad: 0,
            })
            .collect();
        let page_infos = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("page infos"),
            contents: bytemuck::cast_slice(&infos),
            usage: U::STORAGE,
        });
        let args = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("page draws and dispatches"),
            size: pages as u64 * PAGE_ARGS_BYTES,
            usage: U::STORAGE | U::INDIRECT,
            mapped_at_creation: false,
        });
        let indices = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("index regions"),
            size: (4 * model.index_count).max(16),
            usage: U::STORAGE | U::INDEX,
            mapped_at_creation: false,
        });
        let group_0 = group(
            device,
            layout,
            &[
                model.records.as_entire_binding(),
                counts.as_entire_binding(),
                page_infos.as_entire_binding(),
                selected.as_entire_binding(),
                args.as_entire_binding(),
            ],
        );
        let expand_tables = group(
            device,
            tables_layout,
            &[
                model.records.as_entire_binding(),
                counts.as_entire_binding(),
                selected.as_entire_binding(),
                model.locations.as_entire_binding(),
                args.as_entire_binding(),
            ],
        );
        let (page_draw_buffer, stride) = page_draws;
        let expand_pages = model
            .lists
            .iter()
            .zip(&model.pages)
            .enumerate()
            .map(|(p, (list, page))| {
                (list.capacity > 0 && list.index_capacity > 0).then(|| {
                    group(
                        device,
                        page_layout,
                        &[
                            page.buffer.as_entire_binding(),
                            wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                                buffer: page_draw_buffer,
                                offset: p as u64 * stride,
                                size: wgpu::BufferSize::new(16),
                            }),
                            wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                                buffer: &indices,
                                offset: 4 * list.first_index,
                                size: wgpu::BufferSize::new(12 * list.index_capacity as u64),
                            }),
                        ],
                    )
                })
            })
            .collect();
        Bound {
            group: group_0,
            expand_tables,
            expand_pages,
            args,
            indices,
            pages,
        }
    }
}

impl Compaction {
    /// `selected` and `counts`: the pages' selection lists and their lengths, as the traversal
    /// fills them; `page_draws`: each page's `PageDraw`, `stride` bytes apart (uniform).
    pub fn new(
        ctx: &GpuContext,
        model: &ResidentModel,
        selected: &wgpu::Buffer,
        counts: &wgpu::Buffer,
        page_draws: (&wgpu::Buffer, u64),
    ) -> Compaction {
        use wgpu::BufferBindingType as B;
        let device = &ctx.device;
        let read = B::Storage { read_only: true };
        let write = B::Storage { read_only: false };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("compact"),
            entries: &[
                entry(0, read),
                entry(1, read),
                entry(2, read),
                entry(3, write),
                entry(4, write),
            ],
        });
        let tables_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("expand tables"),
            entries: &[
                entry(0, read),
                entry(1, read),
                entry(2, read),
                entry(3, read),
                entry(4, read),
            ],
        });
        let page_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("expand page"),
            entries: &[entry(0, read), entry(1, B::Uniform), entry(2, write)],
        });
        let pipeline = pipeline(device, "compact", compact_source(), &[Some(&layout)]);
        let expand = pipeline_of(device, &tables_layout, &page_layout);
        let layouts = [layout, tables_layout, page_layout];
        let bound = Bound::new(ctx, &layouts, model, selected, counts, page_draws);
        Compaction {
            pipeline,
            expand,
            layouts,
            bound,
        }
    }

    /// Makes the buffers sized by the model's pages and index regions and the bind groups over
    /// them (at creation, and when a streaming pool grew: `stream_pool::grow`); the pipelines
    /// are kept.
    pub fn rebind(
        &mut self,
        ctx: &GpuContext,
        model: &ResidentModel,
        selected: &wgpu::Buffer,
        counts: &wgpu::Buffer,
        page_draws: (&wgpu::Buffer, u64),
    ) {
        self.bound = Bound::new(ctx, &self.layouts, model, selected, counts, page_draws);
    }

    /// The pages' draw and dispatch arguments (`PAGE_ARGS_BYTES` each).
    pub fn args(&self) -> &wgpu::Buffer {
        &self.bound.args
    }

    /// The pages' index regions (u32).
    pub fn indices(&self) -> &wgpu::Buffer {
        &self.bound.indices
    }

    /// Records the compaction's dispatch (one workgroup per page), then one expansion dispatch
    /// per page, into `pass`, after the traversal's.
    pub fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bound.group, &[]);
        pass.dispatch_workgroups(self.bound.pages, 1, 1);
        pass.set_pipeline(&self.expand);
        pass.set_bind_group(0, &self.bound.expand_tables, &[]);
        for (p, group) in self.bound.expand_pages.iter().enumerate() {
            if let Some(group) = group {
                pass.set_bind_group(1, group, &[]);
                pass.dispatch_workgroups_indirect(
                    &self.bound.args,
                    p as u64 * PAGE_ARGS_BYTES + EXPAND_DISPATCH_OFFSET,
                );
            }
        }
    }
}
