//! How the terrain baselines draw: one vertex per sample of the padded square, uploaded once,
//! and per frame the baseline's triangles as indices into it (one draw).

use std::time::Instant;

use anyhow::Context;
use tessera_runtime::camera::Camera;
use tessera_runtime::faces::Faces;
use tessera_runtime::gpu::full_mesh::FullMeshRenderer;
use tessera_runtime::gpu::GpuContext;

use super::grid::BinGrid;

/// The baselines draw with one vertex per sample of the padded square.
pub struct SquareMesh {
    renderer: FullMeshRenderer,
    side: usize,
    /// Swap two corners: the grid's rows run south, mirroring (column, row) into world.
    mirrored: bool,
    indices: Vec<[u32; 3]>,
}

impl SquareMesh {
    pub fn new(
        ctx: &GpuContext,
        grid: &BinGrid,
        origin: [f64; 3],
        size: (u32, u32),
    ) -> anyhow::Result<SquareMesh> {
        let n = grid.side + 1;
        let positions: Vec<[f32; 3]> = (0..n)
            .flat_map(|r| (0..n).map(move |c| [c, r]))
            .map(|p| {
                let w = grid.world(p);
                [0, 1, 2].map(|k| (w[k] - origin[k]) as f32)
            })
            .collect();
        // Both faces, as the terrain baselines always drew (seen from above a height field
        // shows front faces only wherever nothing nearer hides it).
        let renderer = FullMeshRenderer::new(
            ctx,
            &positions,
            &[[0, 1, n as u32]],
            origin,
            size,
            Faces::Both,
        )
        .context("uploading the padded grid")?;
        Ok(SquareMesh {
            renderer,
            side: grid.side as usize,
            mirrored: (grid.spacing[0] < 0.0) != (grid.spacing[1] < 0.0),
            indices: Vec::new(),
        })
    }

    /// Draws `triangles` (sample-point corners, counter-clockwise in (column, row)); returns
    /// the CPU ms of index building, upload, recording and submit.
    pub fn draw(
        &mut self,
        ctx: &GpuContext,
        camera: &Camera,
        triangles: &[[[i32; 2]; 3]],
    ) -> anyhow::Result<f64> {
        let start = Instant::now();
        let n = self.side as u32 + 1;
        self.indices.clear();
        self.indices.extend(triangles.iter().map(|t| {
            let [a, b, c] = t.map(|p| p[1] as u32 * n + p[0] as u32);
            if self.mirrored {
                [a, c, b]
            } else {
                [a, b, c]
            }
        }));
        self.renderer.set_triangles(ctx, &self.indices)?;
        self.renderer.render(ctx, camera, false);
        Ok(start.elapsed().as_secs_f64() * 1e3)
    }
}
