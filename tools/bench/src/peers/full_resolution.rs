//! The full-resolution peer: the whole source mesh in one indexed draw (`FullMeshRenderer`),
//! whatever the view and τ. Its frame is the reference picture of every view, its frame time
//! the baseline, and its error 0 by definition (it draws the original).

use tessera_runtime::camera::Camera;
use tessera_runtime::gpu::full_mesh::FullMeshRenderer;
use tessera_runtime::gpu::{FramePhases, GpuContext};
use tessera_runtime::measure::Surface;

use super::peer_mesh::PeerMesh;
use crate::subject::{waited_ms, Drawn, Subject};

pub struct FullResolution<'m> {
    mesh: &'m PeerMesh,
    renderer: FullMeshRenderer,
}

impl<'m> FullResolution<'m> {
    /// `renderer` must hold all of `mesh`.
    pub fn new(mesh: &'m PeerMesh, renderer: FullMeshRenderer) -> FullResolution<'m> {
        FullResolution { mesh, renderer }
    }
}

impl Subject for FullResolution<'_> {
    fn name(&self) -> &'static str {
        "full_resolution"
    }

    fn submit(&mut self, ctx: &GpuContext, camera: &Camera, _tau: f32) -> anyhow::Result<f64> {
        Ok(self.renderer.render(ctx, camera, false))
    }

    fn phased_frame(
        &mut self,
        ctx: &GpuContext,
        camera: &Camera,
        _tau: f32,
    ) -> anyhow::Result<FramePhases> {
        // Nothing to choose: the whole mesh is resident.
        let raster_ms = waited_ms(ctx, || {
            self.renderer.render(ctx, camera, false);
            Ok(())
        })?;
        Ok(FramePhases {
            select_ms: 0.0,
            raster_ms,
        })
    }

    fn gpu_ms(&self, ctx: &GpuContext) -> anyhow::Result<Option<f64>> {
        Ok(self.renderer.read_gpu_ms(ctx)?)
    }

    fn measured_frame(
        &mut self,
        ctx: &GpuContext,
        camera: &Camera,
        _tau: f32,
    ) -> anyhow::Result<(Drawn, image::RgbaImage)> {
        self.renderer.render(ctx, camera, true);
        let drawn = Drawn {
            patches: 1,
            triangles: self.mesh.triangles.len() as u64,
            level: None,
        };
        Ok((drawn, self.renderer.read_image(ctx)?))
    }

    fn surface(&self) -> Surface<'_> {
        Surface {
            positions: &self.mesh.positions_f64,
            triangles: &self.mesh.triangles,
        }
    }
}
