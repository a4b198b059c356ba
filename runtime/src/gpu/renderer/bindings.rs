//! The renderer's buffers and bind groups over the model: the selection lists and the draw's
//! groups, made at creation and again when a streaming pool grows (`Renderer::rebind_model`).

use super::super::compact::PageDraw;
use super::super::device::GpuContext;
use super::super::resident::{ResidentModel, ENTRY_BYTES};

pub(super) fn storage_entry(
    binding: u32,
    read_only: bool,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub(super) fn uniform_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub(super) fn bind_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// Bytes between consecutive pages' `PageDraw`s: bound as a uniform (the expansion) and as
/// read-only storage (the draw), so aligned for both.
pub(crate) fn page_draw_stride(limits: &wgpu::Limits) -> u64 {
    (limits.min_uniform_buffer_offset_alignment as u64)
        .max(limits.min_storage_buffer_offset_alignment as u64)
        .max(16)
}

/// The pages' selection lists (`Selected` × entry) and their lengths (u32 × page), and their
/// read-back copies: sized by the model's pages (`rebind_model` remakes them).
pub(super) struct SelectionBuffers {
    pub selected: wgpu::Buffer,
    pub counts: wgpu::Buffer,
    pub selected_read: wgpu::Buffer,
    pub counts_read: wgpu::Buffer,
}

/// A buffer of at least `size` bytes, rounded up to a multiple of 4 (and at least 4).
pub(super) fn buffer(
    device: &wgpu::Device,
    label: &str,
    size: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(4).next_multiple_of(4),
        usage,
        mapped_at_creation: false,
    })
}

impl SelectionBuffers {
    pub fn new(device: &wgpu::Device, model: &ResidentModel) -> SelectionBuffers {
        use wgpu::BufferUsages as U;
        let buffer = |label: &str, size: u64, usage: U| buffer(device, label, size, usage);
        let selected_bytes = model.entry_count.max(1) as u64 * ENTRY_BYTES;
        let counts_bytes = model.lists.len() as u64 * 4;
        let selected = buffer("selection lists", selected_bytes, U::STORAGE | U::COPY_SRC);
        let counts = buffer(
            "selection counts",
            counts_bytes,
            U::STORAGE | U::COPY_SRC | U::COPY_DST,
        );
        let selected_read = buffer(
            "selection lists read-back",
            selected_bytes,
            U::MAP_READ | U::COPY_DST,
        );
        let counts_read = buffer(
            "selection counts read-back",
            counts_bytes,
            U::MAP_READ | U::COPY_DST,
        );

        SelectionBuffers {
            selected,
            counts,
            selected_read,
            counts_read,
        }
    }
}

/// The draw's model-wide bind group, the pages' `PageDraw`s (`page_draw_stride` apart) and a
/// bind group per page; `buffers`: the frame uniforms, the selection lists and their counts.
pub(super) fn draw_groups(
    ctx: &GpuContext,
    (draw_layout, page_layout): (&wgpu::BindGroupLayout, &wgpu::BindGroupLayout),
    model: &ResidentModel,
    attributes: u32,
    (uniforms, selected, counts): (&wgpu::Buffer, &wgpu::Buffer, &wgpu::Buffer),
) -> (wgpu::BindGroup, wgpu::Buffer, Vec<wgpu::BindGroup>) {
    use wgpu::BufferUsages as U;
    let device = &ctx.device;
    let draw_group = bind_group(
        device,
        "draw",
        draw_layout,
        &[
            uniforms,
            &model.records,
            &model.locations,
            selected,
            counts,
            &model.page_simplices,
        ],
    );
    // Each page's `PageDraw`, one stride apart (`page_draw_stride`).
    let stride = page_draw_stride(&ctx.limits);
    let mut page_draw_bytes = vec![0u8; (stride * model.lists.len() as u64) as usize];
    for (p, list) in model.lists.iter().enumerate() {
        let at = p * stride as usize;
        let draw = PageDraw {
            page: p as u32,
            first_entry: list.first_entry,
            patch_count: list.capacity,
            attributes,
        };
        page_draw_bytes[at..at + 16].copy_from_slice(bytemuck::bytes_of(&draw));
    }
    let page_draw = {
        use wgpu::util::DeviceExt;
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("page draws"),
            contents: &page_draw_bytes,
            // Uniform in the expansion (`expand.wgsl`), storage in the draw (`draw.wgsl`).
            usage: U::UNIFORM | U::STORAGE,
        })
    };
    let page_groups = model
        .pages
        .iter()
        .enumerate()
        .map(|(p, page)| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("page"),
                layout: page_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: page.buffer.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &page_draw,
                            offset: p as u64 * stride,
                            size: wgpu::BufferSize::new(16),
                        }),
                    },
                ],
            })
        })
        .collect();
    (draw_group, page_draw, page_groups)
}
