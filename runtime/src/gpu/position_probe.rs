//! Reads back the clip positions the draw pass gives stored positions: a compute pass running
//! the very functions draw.wgsl's vertex stages call (`unpack_position`, then
//! `clip_position(eye_relative_position(q))`, `shaders/position.wgsl`) on given packed
//! positions, with given frame uniforms. For precision tests and debugging.

use wgpu::util::DeviceExt;

use super::frame::FrameUniforms;
use super::shaders::position_probe_source;
use super::target::read_buffer;
use super::{GpuContext, GpuFailure};

/// Positions per dispatch: 64-thread workgroups, at most 65,535 of them (and at most one
/// storage binding of clip positions, below).
const CHUNK: usize = 64 * super::shaders::MAX_WORKGROUPS_PER_DIMENSION as usize;

/// The clip position (x, y, z, w) of each packed position (`format::pack_position`) under
/// `uniforms`, as the GPU computes it; the device's failure if it failed.
pub fn clip_positions(
    ctx: &GpuContext,
    uniforms: &FrameUniforms,
    packed: &[[u32; 2]],
) -> Result<Vec<[f32; 4]>, GpuFailure> {
    let device = &ctx.device;
    let chunk = CHUNK.min((super::resident::page_limit(&ctx.limits) / 16).max(1) as usize);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("position probe"),
        source: wgpu::ShaderSource::Wgsl(position_probe_source().into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("position probe"),
        layout: None,
        module: &module,
        entry_point: Some("probe"),
        compilation_options: Default::default(),
        cache: None,
    });
    let frame = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("position probe frame"),
        contents: bytemuck::bytes_of(uniforms),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let mut out = Vec::with_capacity(packed.len());
    for chunk in packed.chunks(chunk) {
        let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("position probe input"),
            contents: bytemuck::cast_slice(chunk),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let bytes = 16 * chunk.len() as u64;
        let clip = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("position probe output"),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("position probe read-back"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("position probe"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: frame.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: input.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: clip.as_entire_binding(),
                },
            ],
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(chunk.len().div_ceil(64) as u32, 1, 1);
        }
        encoder.copy_buffer_to_buffer(&clip, 0, &readback, 0, bytes);
        ctx.queue.submit([encoder.finish()]);
        out.extend_from_slice(bytemuck::cast_slice::<u8, [f32; 4]>(&read_buffer(
            ctx,
            &readback,
            "the probed positions",
        )?));
    }
    Ok(out)
}
