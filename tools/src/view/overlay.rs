//! The overlay (egui): live statistics of the last frame and the controls (tolerance slider,
//! display mode). Drawn into the canvas after the model by egui-wgpu.

use crate::cmd_render::Mode;

/// What the overlay shows, refreshed every frame.
#[derive(Clone, Debug, Default)]
pub struct Stats {
    /// Wall-clock milliseconds between the last two frames.
    pub frame_ms: f64,
    /// GPU milliseconds of the last frame (traversal and draws), where the adapter has
    /// timestamps.
    pub gpu_ms: Option<f64>,
    pub triangles: u64,
    pub patches: usize,
    /// Every GPU allocation of the streaming renderer, and the budget it must fit.
    pub resident_bytes: u64,
    pub budget_bytes: u64,
    pub resident_patches: usize,
    /// Units requested and not landed yet.
    pub pending_units: usize,
    /// Whether the stream has nothing more to load for this view.
    pub settled: bool,
    /// Adapter name, backend and device type.
    pub adapter: String,
    /// Render size (the image is scaled to the window).
    pub size: (u32, u32),
}

/// The controls the overlay may change.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Controls {
    pub tolerance: f32,
    pub mode: Mode,
}

/// Tolerance slider range, pixels.
const TOLERANCE_RANGE: std::ops::RangeInclusive<f32> = 0.25..=64.0;

/// Lays out the overlay for this frame; changes `controls` as the user moves them.
pub fn ui(ctx: &egui::Context, stats: &Stats, controls: &mut Controls) {
    egui::Window::new("tessera")
        .default_pos([8.0, 8.0])
        .resizable(false)
        .show(ctx, |ui| {
            let fps = if stats.frame_ms > 0.0 {
                1e3 / stats.frame_ms
            } else {
                0.0
            };
            ui.label(format!("{fps:.1} fps   {:.1} ms / frame", stats.frame_ms));
            ui.label(match stats.gpu_ms {
                Some(g) => format!("GPU {g:.2} ms"),
                None => "GPU ms: n/a (no timestamps)".to_string(),
            });
            ui.label(format!(
                "{} triangles in {} patches",
                stats.triangles, stats.patches
            ));
            ui.label(format!(
                "resident {:.1} / {:.1} MB, {} patches",
                stats.resident_bytes as f64 / 1e6,
                stats.budget_bytes as f64 / 1e6,
                stats.resident_patches
            ));
            ui.label(if stats.settled {
                "stream settled".to_string()
            } else {
                format!("streaming: {} units pending", stats.pending_units)
            });
            ui.label(&stats.adapter); // name (backend, device type)
            ui.label(format!("render size {}×{}", stats.size.0, stats.size.1));
            ui.separator();
            ui.add(
                egui::Slider::new(&mut controls.tolerance, TOLERANCE_RANGE)
                    .logarithmic(true)
                    .text("tolerance px"),
            );
            ui.horizontal(|ui| {
                for (mode, name) in [
                    (Mode::Lit, "lit"),
                    (Mode::Patches, "patches"),
                    (Mode::Levels, "levels"),
                    (Mode::Check, "check"),
                ] {
                    ui.radio_value(&mut controls.mode, mode, name);
                }
            });
            ui.label("drag: orbit   right drag: pan   wheel: zoom   R: reset   H: overlay   S: screenshot");
        });
}
