//! Probes of driver behaviour that feature bits do not promise.
//!
//! lavapipe in Mesa 22.3 (Debian 12) advertises `MULTI_DRAW_INDIRECT_COUNT`, but its
//! `vkCmdDrawIndexedIndirectCount` ignores primitive restart: a strip's restart marker is drawn
//! as vertex 65,535, and patches grow spikes. Rather than trusting a driver list, the renderer
//! draws one tiny strip with a restart through the count path and looks at the result.

use wgpu::util::DeviceExt;

use super::device::GpuContext;
use super::target::read_buffer;

const SIZE: u32 = 16;

const SHADER: &str = r#"
@group(0) @binding(0) var<storage, read> corners: array<vec2<f32>>;
@vertex
fn vs(@builtin(vertex_index) v: u32) -> @builtin(position) vec4<f32> {
    // A restart drawn as an index reads past the 6 corners: the centre of the screen.
    var p = vec2<f32>(0.0, 0.0);
    if v < 6u {
        p = corners[v];
    }
    return vec4<f32>(p, 0.5, 1.0);
}
@fragment
fn fs() -> @location(0) vec4<f32> {
    return vec4<f32>(1.0, 1.0, 1.0, 1.0);
}
"#;

/// True when an indexed strip with a primitive restart, drawn by
/// `multi_draw_indexed_indirect_count`, leaves the gap the restart makes (two separate corner
/// triangles, the centre untouched). Needs `MULTI_DRAW_INDIRECT_COUNT`.
pub fn count_draws_restart_strips(ctx: &GpuContext) -> bool {
    let device = &ctx.device;
    let init = |label: &str, contents: &[u8], usage| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage,
        })
    };
    use wgpu::BufferUsages as U;
    // Triangle 0..3 in the top-left corner, 3..6 in the bottom-right one.
    let corners: [[f32; 2]; 6] = [
        [-1.0, 1.0],
        [-1.0, 0.5],
        [-0.5, 1.0],
        [1.0, -1.0],
        [1.0, -0.5],
        [0.5, -1.0],
    ];
    let corners = init("probe corners", bytemuck::cast_slice(&corners), U::STORAGE);
    let indices: [u16; 8] = [0, 1, 2, 0xFFFF, 3, 4, 5, 0];
    let indices = init("probe strip", bytemuck::cast_slice(&indices), U::INDEX);
    // index_count, instance_count, first_index, base_vertex, first_instance
    let args: [u32; 5] = [7, 1, 0, 0, 0];
    let args = init("probe draw", bytemuck::cast_slice(&args), U::INDIRECT);
    let count = init("probe count", bytemuck::bytes_of(&1u32), U::INDIRECT);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("restart probe"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("restart probe"),
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleStrip,
            strip_index_format: Some(wgpu::IndexFormat::Uint16),
            ..Default::default()
        },
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::TextureFormat::Rgba8Unorm.into())],
        }),
        multiview_mask: None,
        cache: None,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("restart probe"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: corners.as_entire_binding(),
        }],
    });
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("restart probe"),
        size: wgpu::Extent3d {
            width: SIZE,
            height: SIZE,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let row = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("restart probe read-back"),
        size: (row * SIZE) as u64,
        usage: U::COPY_DST | U::MAP_READ,
        mapped_at_creation: false,
    });
    let view = texture.create_view(&Default::default());
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("restart probe"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint16);
        pass.multi_draw_indexed_indirect_count(&args, 0, &count, 0, 1);
    }
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture: &texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &readback,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(SIZE),
            },
        },
        wgpu::Extent3d {
            width: SIZE,
            height: SIZE,
            depth_or_array_layers: 1,
        },
    );
    ctx.queue.submit([encoder.finish()]);
    let pixels = read_buffer(ctx, &readback);
    let at = |x: u32, y: u32| pixels[(y * row + 4 * x) as usize];
    // Both corner triangles drawn; nothing in the middle half of the image, where the triangles
    // through the misread restart vertex would be.
    let middle = SIZE / 4..3 * SIZE / 4;
    let middle_clear = middle
        .clone()
        .all(|y| middle.clone().all(|x| at(x, y) == 0));
    at(0, 0) == 255 && at(SIZE - 1, SIZE - 1) == 255 && middle_clear
}
