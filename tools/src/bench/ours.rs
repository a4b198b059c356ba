//! Ours: the repository drawn by `Renderer` (GPU traversal with the stateless rule ρ ≤ τ <
//! ρ(parent), frustum and normal-cone culling, batched strips). The measured surface is what
//! the GPU selected (`read_selection`), dequantised from the patches (`measure::drawn_cut`).

use tessera_core::repository::reader::Repository;
use tessera_runtime::camera::Camera;
use tessera_runtime::faces::Faces;
use tessera_runtime::gpu::{FramePhases, FrameRequest, GpuContext, Readback, Renderer};
use tessera_runtime::measure::{drawn_cut, DrawnSurface, Surface};

use tessera_bench::subject::{Drawn, Subject};

pub struct Ours<'r> {
    repo: &'r Repository,
    renderer: Renderer,
    surface: DrawnSurface,
    faces: Faces,
}

impl<'r> Ours<'r> {
    /// `renderer` must hold `repo`, with a target of the cameras' size; frames draw `faces`
    /// (`Both`: `FrameRequest::two_sided`, no cone culling).
    pub fn new(repo: &'r Repository, renderer: Renderer, faces: Faces) -> Ours<'r> {
        Ours {
            repo,
            renderer,
            surface: DrawnSurface::default(),
            faces,
        }
    }

    fn request(&self, camera: &Camera, tau: f32) -> FrameRequest {
        let request = FrameRequest::new(*camera, tau);
        match self.faces {
            Faces::Front => request,
            Faces::Both => request.two_sided(),
        }
    }
}

impl Subject for Ours<'_> {
    fn name(&self) -> &'static str {
        "ours"
    }

    fn submit(&mut self, ctx: &GpuContext, camera: &Camera, tau: f32) -> anyhow::Result<f64> {
        Ok(self
            .renderer
            .render(ctx, &self.request(camera, tau), Readback::default()))
    }

    fn phased_frame(
        &mut self,
        ctx: &GpuContext,
        camera: &Camera,
        tau: f32,
    ) -> anyhow::Result<FramePhases> {
        Ok(self
            .renderer
            .render_phased(ctx, &self.request(camera, tau))?)
    }

    fn gpu_ms(&self, ctx: &GpuContext) -> anyhow::Result<Option<f64>> {
        Ok(self.renderer.read_gpu_ms(ctx)?)
    }

    fn measured_frame(
        &mut self,
        ctx: &GpuContext,
        camera: &Camera,
        tau: f32,
    ) -> anyhow::Result<(Drawn, image::RgbaImage)> {
        let frame = self
            .renderer
            .render_and_read(ctx, &self.request(camera, tau))?;
        self.surface = drawn_cut(self.repo, &frame.selection)?;
        let drawn = Drawn {
            patches: frame.selection.len() as u64,
            triangles: frame.triangles,
            level: None,
        };
        Ok((drawn, frame.image))
    }

    fn surface(&self) -> Surface<'_> {
        self.surface.surface()
    }
}
