//! The discrete-LOD peer (seed 004's run-time scheme): a few whole-object levels made
//! offline, one picked per object and frame by distance, drawn in one call.
//!
//! - Levels: shares of the source's triangles (`LEVEL_FRACTIONS` by default, halving down to
//!   1/256; `tessera bench --lod-fractions`), each simplified from the source by
//!   `meshopt::simplify` (absolute error, no target error: the count decides); level 0 is the
//!   source itself with error 0. Each level records meshopt's error estimate in model units.
//!   More levels only add choices (each level is made from the source alone): before
//!   2026-12-07 four, 1, 1/4, 1/16, 1/64.
//! - Choice: the coarsest level whose error projects to ≤ τ pixels at the distance from the
//!   eye to the object's bounding sphere: ρ_l = err_l · K / max(|centre − eye| − radius, near)
//!   (`ScreenSpaceMetric::rho`, the formula of our ρ with one sphere for the whole object).
//! - Drawing: one `FullMeshRenderer` per level (all resident), no culling.

use std::time::Instant;
use tessera_runtime::faces::Faces;

use anyhow::Context;
use tessera_core::metric::{center_minus_eye, ScreenSpaceMetric};
use tessera_runtime::camera::Camera;
use tessera_runtime::gpu::full_mesh::FullMeshRenderer;
use tessera_runtime::gpu::{FramePhases, GpuContext};
use tessera_runtime::measure::Surface;

use super::peer_mesh::PeerMesh;
use crate::subject::{waited_ms, Drawn, Subject};

/// Share of the source's triangles in each level by default, finest first: halving, from
/// the source down to 1/256 (9 levels, 2x the source's triangles resident in all).
pub const LEVEL_FRACTIONS: [f64; 9] = [
    1.0, 0.5, 0.25, 0.125, 0.0625, 0.03125, 0.015625, 0.0078125, 0.00390625,
];

/// Checks a list of level shares: the first 1 (the source), then strictly decreasing, all
/// above 0.
pub fn check_fractions(fractions: &[f64]) -> Result<(), String> {
    if fractions.first() != Some(&1.0) {
        return Err("the first level must be 1 (the source itself)".into());
    }
    if let Some(w) = fractions.windows(2).find(|w| !(w[1] < w[0] && w[1] > 0.0)) {
        return Err(format!(
            "{} after {}: shares must decrease strictly and stay above 0",
            w[1], w[0]
        ));
    }
    Ok(())
}

/// One level as built.
#[derive(Clone, Debug)]
pub struct Level {
    /// Requested share of the source's triangles.
    pub fraction: f64,
    pub triangles: Vec<[u32; 3]>,
    /// meshopt's simplification error, model units (0 for the source).
    pub error: f64,
    /// Time to simplify it.
    pub seconds: f64,
}

/// Simplifies the source to every share of `fractions` (`check_fractions`), each from the
/// source.
pub fn build_levels(mesh: &PeerMesh, fractions: &[f64]) -> Vec<Level> {
    assert_eq!(check_fractions(fractions), Ok(()), "{fractions:?}");
    let adapter = mesh.vertex_adapter();
    fractions
        .iter()
        .map(|&fraction| {
            if fraction >= 1.0 {
                return Level {
                    fraction,
                    triangles: mesh.triangles.clone(),
                    error: 0.0,
                    seconds: 0.0,
                };
            }
            let start = Instant::now();
            let target = ((mesh.triangles.len() as f64 * fraction) as usize).max(1) * 3;
            let mut error = 0.0f32;
            let indices = meshopt::simplify(
                mesh.indices(),
                &adapter,
                target,
                f32::MAX,
                meshopt::SimplifyOptions::ErrorAbsolute,
                Some(&mut error),
            );
            Level {
                fraction,
                triangles: indices
                    .chunks_exact(3)
                    .map(|t| [t[0], t[1], t[2]])
                    .collect(),
                error: error as f64,
                seconds: start.elapsed().as_secs_f64(),
            }
        })
        .collect()
}

/// The coarsest of the levels with `errors` (model units, finest first) whose error projects
/// to ≤ `tau` pixels of `metric` at the object's bounding sphere `(centre, radius)` seen from
/// `eye_local` (both relative to the repository origin); level 0 when none does. The frame's
/// choice (`DiscreteLod::level_for`), and the dense error pass's.
pub fn level_at(
    mut errors: impl DoubleEndedIterator<Item = f64> + ExactSizeIterator,
    (centre, radius): ([f32; 3], f32),
    eye_local: [f32; 3],
    metric: &ScreenSpaceMetric,
    tau: f32,
) -> usize {
    let c = center_minus_eye(centre, eye_local);
    errors
        .rposition(|e| metric.rho(e as f32, c, radius) <= tau)
        .unwrap_or(0)
}

pub struct DiscreteLod<'m> {
    mesh: &'m PeerMesh,
    levels: Vec<(Level, FullMeshRenderer)>,
    /// The object's bounding sphere, relative to the repository origin.
    centre: [f32; 3],
    radius: f32,
    origin: [f64; 3],
    /// The level of the last measured frame.
    last: usize,
}

impl<'m> DiscreteLod<'m> {
    /// Uploads every level (one renderer each, `width` × `height` targets, drawing `faces`).
    /// `(centre, radius)`: the object's bounding sphere relative to `origin` (the
    /// repository's).
    pub fn new(
        ctx: &GpuContext,
        mesh: &'m PeerMesh,
        levels: Vec<Level>,
        (centre, radius): ([f32; 3], f32),
        origin: [f64; 3],
        size: (u32, u32),
        faces: Faces,
    ) -> anyhow::Result<DiscreteLod<'m>> {
        let levels = levels
            .into_iter()
            .enumerate()
            .map(|(i, level)| {
                let renderer = FullMeshRenderer::new(
                    ctx,
                    &mesh.positions,
                    &level.triangles,
                    origin,
                    size,
                    faces,
                )
                .with_context(|| format!("uploading discrete level {i}"))?;
                Ok((level, renderer))
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        Ok(DiscreteLod {
            mesh,
            levels,
            centre,
            radius,
            origin,
            last: 0,
        })
    }

    /// The levels as built (for the report).
    pub fn levels(&self) -> impl Iterator<Item = &Level> {
        self.levels.iter().map(|(l, _)| l)
    }

    /// The coarsest level whose projected error is ≤ τ (level 0 when none is).
    pub fn level_for(&self, camera: &Camera, tau: f32) -> usize {
        level_at(
            self.levels.iter().map(|(l, _)| l.error),
            (self.centre, self.radius),
            camera.eye_local(self.origin),
            &camera.metric(),
            tau,
        )
    }

    /// The object's bounding sphere, relative to the repository origin.
    pub fn sphere(&self) -> ([f32; 3], f32) {
        (self.centre, self.radius)
    }
}

impl Subject for DiscreteLod<'_> {
    fn name(&self) -> &'static str {
        "discrete_lod"
    }

    fn submit(&mut self, ctx: &GpuContext, camera: &Camera, tau: f32) -> anyhow::Result<f64> {
        let start = Instant::now();
        let level = self.level_for(camera, tau);
        self.last = level;
        self.levels[level].1.render(ctx, camera, false);
        Ok(start.elapsed().as_secs_f64() * 1e3)
    }

    fn phased_frame(
        &mut self,
        ctx: &GpuContext,
        camera: &Camera,
        tau: f32,
    ) -> anyhow::Result<FramePhases> {
        // The level's choice queues no GPU work: the wait returns at once.
        let select_ms = waited_ms(ctx, || {
            self.last = self.level_for(camera, tau);
            Ok(())
        })?;
        let raster_ms = waited_ms(ctx, || {
            self.levels[self.last].1.render(ctx, camera, false);
            Ok(())
        })?;
        Ok(FramePhases {
            select_ms,
            raster_ms,
        })
    }

    fn gpu_ms(&self, ctx: &GpuContext) -> anyhow::Result<Option<f64>> {
        Ok(self.levels[self.last].1.read_gpu_ms(ctx)?)
    }

    fn measured_frame(
        &mut self,
        ctx: &GpuContext,
        camera: &Camera,
        tau: f32,
    ) -> anyhow::Result<(Drawn, image::RgbaImage)> {
        let level = self.level_for(camera, tau);
        self.last = level;
        let (l, renderer) = &mut self.levels[level];
        renderer.render(ctx, camera, true);
        let drawn = Drawn {
            patches: 1,
            triangles: l.triangles.len() as u64,
            level: Some(level as u32),
        };
        Ok((drawn, renderer.read_image(ctx)?))
    }

    fn surface(&self) -> Surface<'_> {
        Surface {
            positions: &self.mesh.positions_f64,
            triangles: &self.levels[self.last].0.triangles,
        }
    }
}
