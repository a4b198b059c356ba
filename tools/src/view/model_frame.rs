//! One frame of the model: the request from the controls (the frozen cut's camera, culling,
//! wireframe), the streaming renderer's frame, the selection and times read back into the
//! overlay's statistics — and, under a triangle budget, the same view drawn again at once
//! when the count misses it.

use std::time::Instant;

use tessera_core::cull::CullTests;
use tessera_runtime::gpu::{FrameRequest, Readback};

use super::app::App;
use super::overlay::Stats;
use crate::gpu_args::device_failure;

/// A triangle budget missed by more than this (relative) redraws the frame, at most
/// `REDRAWS` times.
const REDRAW_MISS: f64 = 0.05;
const REDRAWS: u32 = 3;

impl App {
    /// Draws the model into the renderer's target and reads its statistics back; whether the
    /// stream has settled for this view.
    pub(super) fn draw_model(&mut self) -> anyhow::Result<bool> {
        let (cut_camera, draw_camera) = self.cameras();
        let mut request = FrameRequest {
            mode: self.controls.shading(),
            wireframe: self.controls.wireframe,
            cull: CullTests {
                frustum: (self.controls.frustum_culling).then(|| cut_camera.view_volume()),
                cones: self.controls.cone_culling,
            },
            draw_camera,
            ..FrameRequest::new(cut_camera, self.controls.tolerance)
        };
        let readback = Readback {
            image: false,
            selection: true,
        };
        // A triangle budget missed by more than `REDRAW_MISS` is drawn again at once with τ
        // corrected from the count just read, or between two tries that straddled it (at most
        // `REDRAWS` times): the frame shown holds the budget even when the camera moved since
        // the last one.
        let mut redraws = 0;
        let mut tried = super::target::Bracket::default();
        let mut cpu_ms = 0.0;
        let (f, selection) = loop {
            let started = Instant::now();
            let f = (self.streamer)
                .frame(&self.ctx, &mut self.renderer, &request, readback)
                .map_err(device_failure)?;
            cpu_ms += started.elapsed().as_secs_f64() * 1e3;
            let selection = self.renderer.read_selection(&self.ctx)?;
            let loading = f.stats.pending_units + f.stats.loading_units > 0;
            let triangles = self.renderer.triangles_of(&selection);
            let corrected = match (&self.controller, redraws < REDRAWS) {
                (Some(c), true) => {
                    c.redraw_tolerance(request.tau, triangles, REDRAW_MISS, &mut tried)
                }
                _ => None,
            };
            // While units load, a count too low is redrawn once only: a lower τ draws what is
            // resident, which may or may not be finer (the count rises anyway as units land).
            let corrected = corrected.filter(|&tau| !loading || tau > request.tau || redraws == 0);
            match corrected {
                Some(tau) if tau != request.tau => {
                    request.tau = tau;
                    self.controls.tolerance = tau;
                    redraws += 1;
                }
                _ => break (f, selection),
            }
        };
        self.stats.redraws = redraws;
        let now = Instant::now();
        let gpu = self.streamer.stats();
        self.stats = Stats {
            frame_ms: self
                .last_frame
                .map_or(0.0, |t| (now - t).as_secs_f64() * 1e3),
            gpu_ms: self.renderer.read_gpu_ms(&self.ctx)?,
            triangles: self.renderer.triangles_of(&selection),
            patches: selection.len(),
            resident_bytes: gpu.gpu_bytes,
            resident_patches: self.streamer.resident_patches(),
            pending_units: f.stats.pending_units + f.stats.loading_units,
            loads_per_second: {
                let seconds = self.last_frame.map_or(0.0, |t| (now - t).as_secs_f64());
                let rate = if seconds > 0.0 {
                    f.loads as f64 / seconds
                } else {
                    0.0
                };
                0.9 * self.stats.loads_per_second + 0.1 * rate
            },
            settled: f.settled,
            tolerance: request.tau,
            ..std::mem::take(&mut self.stats)
        };
        self.stats.cpu_ms = cpu_ms;
        let times = super::graph::FrameTimes {
            frame: self.stats.frame_ms,
            gpu: self.stats.gpu_ms,
            cpu: cpu_ms,
        };
        self.stats.history.push(times);
        self.selection = selection;
        self.last_frame = Some(now);
        Ok(f.settled)
    }
}
