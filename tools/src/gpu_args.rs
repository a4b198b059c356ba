//! The GPU options every rendering command shares, and what they make.

use clap::Args;
use std::sync::Arc;
use tessera_core::repository::reader::Repository;

use tessera_runtime::gpu::repository_pages::RepositoryPages;
use tessera_runtime::gpu::{
    Backend, DeviceOptions, GpuContext, GpuStreamer, RenderError, Renderer, RendererOptions,
    StreamError,
};

#[derive(Args, Clone, Debug)]
pub struct GpuArgs {
    /// Adapter name substring (default: $TESSERA_ADAPTER, else the best present).
    #[arg(long)]
    pub adapter: Option<String>,
    /// wgpu backend: vulkan, gl, metal or dx12 (default: $WGPU_BACKEND, else any). A backend
    /// that lacks what tessera needs is refused with what is missing.
    #[arg(long)]
    pub backend: Option<Backend>,
    /// GPU memory budget, MiB (fractions allowed): every allocation of the renderer (tables, page pool, lists,
    /// staging, uniforms, target). `render` streams patches into it; default: a quarter of
    /// the host memory on a CPU adapter (lavapipe, llvmpipe), else 2048 (wgpu does not report
    /// an adapter's memory).
    #[arg(long)]
    pub gpu_budget: Option<f64>,
}

/// A device failure (lost, out of memory, a failed map): exit 3.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct DeviceFailure(pub String);

/// Total host memory from /proc/meminfo, bytes.
fn host_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib << 10)
}

impl GpuArgs {
    /// The device on the chosen adapter.
    pub fn context(&self) -> anyhow::Result<GpuContext> {
        Ok(GpuContext::open(&DeviceOptions {
            adapter: self.adapter.clone(),
            backend: self.backend,
            limits: None,
        })?)
    }

    /// `context`, on an instance that knows the display of the window it will draw into
    /// (`tessera view`; the GL backend needs it to present).
    pub fn context_for_display(
        &self,
        display: Box<dyn wgpu::wgt::WgpuHasDisplayHandle>,
    ) -> anyhow::Result<GpuContext> {
        Ok(GpuContext::open_with_display(
            &DeviceOptions {
                adapter: self.adapter.clone(),
                backend: self.backend,
                limits: None,
            },
            display,
        )?)
    }

    /// Our renderer of `repo` at `size`, within the budget.
    pub fn renderer(
        &self,
        ctx: &GpuContext,
        repo: &Repository,
        (width, height): (u32, u32),
    ) -> Result<Renderer, RenderError> {
        Renderer::new(
            ctx,
            repo,
            RendererOptions {
                width,
                height,
                budget_bytes: self.budget_bytes(ctx),
                ..Default::default()
            },
        )
    }

    /// The budget in bytes: `--gpu-budget`, else the default rule (the flag's help).
    pub fn budget_bytes(&self, ctx: &GpuContext) -> u64 {
        match self.gpu_budget {
            Some(mib) => (mib.max(0.0) * (1u64 << 20) as f64) as u64,
            None if ctx.info.device_type == wgpu::DeviceType::Cpu => {
                host_memory().map_or(2048 << 20, |b| b / 4)
            }
            None => 2048 << 20,
        }
    }

    /// The streaming renderer of `repo` at `size` (`gpu::streamer`): a page pool within the
    /// budget, the roots resident, the rest loaded as views need it. A budget too small for
    /// the fixed allocations and the roots is an error with both numbers (exit 2); a device
    /// failure is a `DeviceFailure` (exit 3).
    pub fn streaming(
        &self,
        ctx: &GpuContext,
        repo: Arc<Repository>,
        (width, height): (u32, u32),
    ) -> anyhow::Result<(Renderer, GpuStreamer)> {
        let options = RendererOptions {
            width,
            height,
            budget_bytes: self.budget_bytes(ctx),
            ..Default::default()
        };
        // A textured repository draws its textures (lit and color modes), their page cache
        // taking its share of the budget (`texture_cache::layers_for`).
        let textures = RepositoryPages::source(repo.clone());
        GpuStreamer::with_textures(ctx, repo, options, UPLOAD_BYTES_PER_FRAME, textures)
            .map_err(device_failure)
    }
}

/// Bytes of units issued (and uploaded) per frame.
pub const UPLOAD_BYTES_PER_FRAME: u64 = 4 << 20;

/// A streaming error as the CLI reports it: device failures become `DeviceFailure`.
pub fn device_failure(e: StreamError) -> anyhow::Error {
    match e {
        StreamError::Device(failure) => DeviceFailure(failure.to_string()).into(),
        other => other.into(),
    }
}
