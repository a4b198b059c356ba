//! What the trade-off benchmark asks of each renderer it measures: a timed frame, and a frame
//! read back for measuring (its image, its counts, and the surface it drew).

use std::time::Instant;

use tessera_runtime::camera::Camera;
use tessera_runtime::gpu::{FramePhases, GpuContext};
use tessera_runtime::measure::Surface;

/// The times of one frame, waited for.
#[derive(Clone, Copy, Debug)]
pub struct FrameTimes {
    /// CPU work of the frame: the subject's selection, recording and submit (not the wait),
    /// without its uploads.
    pub cpu_ms: f64,
    /// CPU time the frame spent uploading what it selected (the cluster DAG's triangles; 0
    /// for a subject whose data stays resident).
    pub upload_ms: f64,
    /// From the first CPU instruction of the frame to the end of the GPU's work.
    pub wall_ms: f64,
    /// GPU timestamps, where the adapter has them (on lavapipe they miss compute passes).
    pub gpu_ms: Option<f64>,
    /// The same view and τ drawn again with its phases waited for apart
    /// (`Subject::phased_frame`), where asked for.
    pub phases: Option<FramePhases>,
}

/// What a measured frame drew.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Drawn {
    /// Draw units: our patches, DAG clusters, 1 for a one-draw mesh.
    pub patches: u64,
    pub triangles: u64,
    /// The discrete level drawn, for a subject that has levels.
    pub level: Option<u32>,
}

/// A renderer under measurement, at a pixel tolerance τ. One camera size for all frames.
pub trait Subject {
    /// Its name in the report (`"ours"`, `"discrete_lod"`, ...).
    fn name(&self) -> &'static str;

    /// Records and submits one frame of `camera` at `tau` and returns the CPU milliseconds it
    /// spent (everything the subject does per frame on the CPU, before waiting).
    fn submit(&mut self, ctx: &GpuContext, camera: &Camera, tau: f32) -> anyhow::Result<f64>;

    /// One frame of `camera` at `tau` with its selection and its raster waited for apart
    /// (`FramePhases`): where the frame's time goes.
    fn phased_frame(
        &mut self,
        ctx: &GpuContext,
        camera: &Camera,
        tau: f32,
    ) -> anyhow::Result<FramePhases>;

    /// GPU milliseconds of the last frame, where the adapter has timestamps.
    fn gpu_ms(&self, ctx: &GpuContext) -> anyhow::Result<Option<f64>>;

    /// The part of the last `submit`'s CPU milliseconds spent uploading per-frame data (charged
    /// apart from the selection: a resident implementation would not pay it).
    fn upload_ms(&self) -> f64 {
        0.0
    }

    /// Renders one frame with read-back: its counts and image; the surface it drew is then
    /// `surface()`.
    fn measured_frame(
        &mut self,
        ctx: &GpuContext,
        camera: &Camera,
        tau: f32,
    ) -> anyhow::Result<(Drawn, image::RgbaImage)>;

    /// The triangles the last measured frame drew, positions as drawn, relative to the
    /// repository origin.
    fn surface(&self) -> Surface<'_>;
}

/// Milliseconds from the first CPU instruction of `work` to the GPU's idle after it.
pub fn waited_ms(
    ctx: &GpuContext,
    work: impl FnOnce() -> anyhow::Result<()>,
) -> anyhow::Result<f64> {
    let start = Instant::now();
    work()?;
    ctx.wait_idle()?;
    Ok(start.elapsed().as_secs_f64() * 1e3)
}

/// One frame of `subject`, waited for, with its times.
pub fn timed_frame(
    subject: &mut dyn Subject,
    ctx: &GpuContext,
    camera: &Camera,
    tau: f32,
) -> anyhow::Result<FrameTimes> {
    let mut cpu_ms = 0.0;
    let wall_ms = waited_ms(ctx, || {
        cpu_ms = subject.submit(ctx, camera, tau)?;
        Ok(())
    })?;
    let upload_ms = subject.upload_ms();
    Ok(FrameTimes {
        cpu_ms: cpu_ms - upload_ms,
        upload_ms,
        wall_ms,
        gpu_ms: subject.gpu_ms(ctx)?,
        phases: None,
    })
}
