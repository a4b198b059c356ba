//! GPU timestamps around a frame, where the adapter has them (`TIMESTAMP_QUERY`): one query at
//! the start of the frame's first pass and one at the end of its last, resolved and copied to a
//! read-back buffer in the same submission.
//!
//! Caveat (BENCHMARKS.md): lavapipe does not cover compute passes with its timestamps, so there
//! the figure is the draw pass alone.

use super::device::{GpuContext, GpuFailure};
use super::target::read_buffer;

/// The queries of one frame.
pub struct FrameTimer {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    period_ns: f32,
}

impl FrameTimer {
    /// A timer, or `None` where the adapter has no timestamps.
    pub fn new(ctx: &GpuContext, label: &str) -> Option<FrameTimer> {
        if !ctx.capabilities.timestamps {
            return None;
        }
        let buffer = |usage| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 16,
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        Some(FrameTimer {
            set: ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some(label),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolve: buffer(U::QUERY_RESOLVE | U::COPY_SRC),
            read: buffer(U::MAP_READ | U::COPY_DST),
            period_ns: ctx.queue.get_timestamp_period(),
        })
    }

    /// Timestamp writes for a compute pass that starts the frame.
    pub fn compute_start(&self) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: None,
        }
    }

    /// Timestamp writes for the render pass that ends the frame (and starts it too when
    /// `starts_frame`).
    pub fn render_end(&self, starts_frame: bool) -> wgpu::RenderPassTimestampWrites<'_> {
        wgpu::RenderPassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: starts_frame.then_some(0),
            end_of_pass_write_index: Some(1),
        }
    }

    /// Records the resolve and the copy to the read-back buffer (after the frame's passes).
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.set, 0..2, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.read, 0, 16);
    }

    /// Milliseconds between the two timestamps of the last resolved frame (blocks until that
    /// frame is done); `None` if the clock went backwards.
    pub fn read_ms(&self, ctx: &GpuContext) -> Result<Option<f64>, GpuFailure> {
        let ticks: Vec<u64> =
            bytemuck::pod_collect_to_vec(&read_buffer(ctx, &self.read, "the GPU timestamps")?);
        Ok(ticks[1]
            .checked_sub(ticks[0])
            .map(|elapsed| elapsed as f64 * self.period_ns as f64 * 1e-6))
    }
}
