//! The compaction pass (`shaders/compact.wgsl`), after the traversal in the same compute pass:
//! one workgroup per resident page writes the prefix sums of its selected patches' strip slots
//! and the page's one `DrawIndirectArgs` (3 vertices per slot). Drawing a frame is then one
//! non-indexed indirect draw per page, whatever the model's size; GPU work is proportional to
//! the selection, CPU work to the number of pages.

use super::device::GpuContext;
use super::resident::{ResidentModel, DRAW_ARGS_BYTES};
use super::shaders::compact_source;

/// The compaction pipeline and the per-page draw arguments it writes.
pub struct Compaction {
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    /// `DrawIndirectArgs` × page (indirect draw arguments).
    pub draws: wgpu::Buffer,
    pages: u32,
}

impl Compaction {
    /// `selected` and `counts`: the pages' selection lists and their lengths, as the traversal
    /// fills them.
    pub fn new(
        ctx: &GpuContext,
        model: &ResidentModel,
        selected: &wgpu::Buffer,
        counts: &wgpu::Buffer,
    ) -> Compaction {
        use wgpu::util::DeviceExt;
        use wgpu::BufferUsages as U;
        let device = &ctx.device;
        let pages = model.lists.len() as u32;
        let starts: Vec<u32> = model.lists.iter().map(|l| l.first_entry).collect();
        let list_starts = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("selection list starts"),
            contents: bytemuck::cast_slice(&starts),
            usage: U::STORAGE,
        });
        let draws = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("page draws"),
            size: pages as u64 * DRAW_ARGS_BYTES,
            usage: U::STORAGE | U::INDIRECT,
            mapped_at_creation: false,
        });
        let entry = |binding: u32, read_only: bool| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("compact"),
            entries: &[
                entry(0, true),
                entry(1, true),
                entry(2, true),
                entry(3, false),
                entry(4, false),
            ],
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("compact"),
            layout: &layout,
            entries: &[&model.tets, counts, &list_starts, selected, &draws]
                .iter()
                .enumerate()
                .map(|(i, b)| wgpu::BindGroupEntry {
                    binding: i as u32,
                    resource: b.as_entire_binding(),
                })
                .collect::<Vec<_>>(),
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("compact.wgsl"),
            source: wgpu::ShaderSource::Wgsl(compact_source().into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("compact"),
            layout: Some(
                &device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some("compact"),
                    bind_group_layouts: &[Some(&layout)],
                    immediate_size: 0,
                }),
            ),
            module: &module,
            entry_point: Some("compact"),
            compilation_options: Default::default(),
            cache: None,
        });
        Compaction {
            pipeline,
            group,
            draws,
            pages,
        }
    }

    /// Records the pass's one dispatch (one workgroup per page) into `pass`, after the
    /// traversal's.
    pub fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.dispatch_workgroups(self.pages, 1, 1);
    }
}
