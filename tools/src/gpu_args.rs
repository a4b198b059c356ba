//! The GPU options every rendering command shares, and what they make.

use clap::Args;
use tessera_core::repository::reader::Repository;
use tessera_runtime::gpu::{
    Backend, DeviceOptions, GpuContext, RenderError, Renderer, RendererOptions,
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
    /// GPU memory budget for the resident model, MiB.
    #[arg(long, default_value_t = 2048)]
    pub gpu_budget: u64,
}

impl GpuArgs {
    /// The device on the chosen adapter.
    pub fn context(&self) -> anyhow::Result<GpuContext> {
        Ok(GpuContext::open(&DeviceOptions {
            adapter: self.adapter.clone(),
            backend: self.backend,
        })?)
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
                budget_bytes: self.gpu_budget << 20,
                ..Default::default()
            },
        )
    }
}
