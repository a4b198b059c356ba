//! The overlay (egui): live statistics of the last frame and the controls (tolerance slider,
//! target modes, display mode, wireframe, culling, freezing the cut, fly mode). Drawn into
//! the canvas after the model by egui-wgpu.

use super::target::Target;
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
    /// Times the last frame was drawn again to hold the triangle budget.
    pub redraws: u32,
    /// Units loaded per second (averaged over the last frames).
    pub loads_per_second: f64,
    /// Units requested and not landed yet.
    pub pending_units: usize,
    /// The triangle count the frame-time target is holding now.
    pub goal_triangles: Option<f64>,
    /// The tolerance the last frame was drawn with, pixels.
    pub tolerance: f32,
    /// Whether the stream has nothing more to load for this view.
    pub settled: bool,
    /// Adapter name, backend and device type.
    pub adapter: String,
    /// Render size (the image is scaled to the window).
    pub size: (u32, u32),
    /// The last frames' times, for the graph.
    pub history: super::graph::History,
    /// CPU milliseconds of the last frame in the streaming renderer.
    pub cpu_ms: f64,
    /// The last thing a key or a pick did (pivot set, file written, ...), shown until the
    /// next.
    pub message: String,
}

/// The controls the overlay may change.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Controls {
    pub tolerance: f32,
    pub mode: Mode,
    /// Face normals in the lit and normals modes, whatever normals the model stores (`--flat`).
    pub flat: bool,
    /// The triangles' edges over the fill.
    pub wireframe: bool,
    /// Patches outside the view volume are not drawn.
    pub frustum_culling: bool,
    /// Patches whose normal cones face away are not drawn.
    pub cone_culling: bool,
    /// The cut stays the one selected when it was frozen, seen from wherever the camera goes.
    pub frozen: bool,
    /// Fly mode (a left drag looks around; WASD move in both modes).
    pub fly: bool,
    /// What the tolerance follows: the slider, a frame time or a triangle count.
    pub target: TargetChoice,
    pub target_ms: f64,
    pub target_triangles: u64,
    /// The GPU budget being edited, MiB, and whether "apply" was pressed (the streaming
    /// renderer is remade under it).
    pub budget_mib: f64,
    pub apply_budget: bool,
}

impl Controls {
    pub fn new(tolerance: f32, mode: Mode) -> Controls {
        Controls {
            tolerance,
            mode,
            flat: false,
            wireframe: false,
            frustum_culling: true,
            cone_culling: true,
            frozen: false,
            fly: false,
            target: TargetChoice::Off,
            target_ms: 33.0,
            target_triangles: 1_000_000,
            budget_mib: 0.0,
            apply_budget: false,
        }
    }

    /// The shading the frame asks for.
    pub fn shading(&self) -> tessera_runtime::gpu::ShadingMode {
        crate::cmd_render::shading(self.mode, self.flat)
    }

    /// The target the controller should hold, if any.
    pub fn target(&self) -> Option<Target> {
        match self.target {
            TargetChoice::Off => None,
            TargetChoice::FrameTime => Some(Target::FrameMs(self.target_ms)),
            TargetChoice::Triangles => Some(Target::Triangles(self.target_triangles)),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetChoice {
    Off,
    FrameTime,
    Triangles,
}

/// The keys, as the overlay lists them (docs/cli.md too).
pub const KEY_HELP: &str = "drag: orbit (fly: look)   right drag: pan   wheel: zoom to cursor   \
double-click: pivot\nW A S D Q E: move   F: fly   C: freeze cut   R: reset   H: overlay   \
P: screenshot   X: export cut   B: bookmark   1-9: go to bookmark   K: record path";

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
                Some(g) => format!("GPU {g:.2} ms   CPU {:.2} ms", stats.cpu_ms),
                None => format!("GPU ms: n/a (no timestamps)   CPU {:.2} ms", stats.cpu_ms),
            });
            stats.history.ui(ui, egui::vec2(300.0, 60.0));
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
                format!(
                    "streaming: {} units pending, {:.0} loads/s",
                    stats.pending_units, stats.loads_per_second
                )
            });
            ui.label(&stats.adapter); // name (backend, device type)
            ui.label(format!("render size {}×{}", stats.size.0, stats.size.1));
            if !stats.message.is_empty() {
                ui.label(&stats.message);
            }
            ui.separator();
            ui.add_enabled(
                controls.target == TargetChoice::Off,
                egui::Slider::new(&mut controls.tolerance, TOLERANCE_RANGE)
                    // A τ from the command line, the script or the target controller may lie
                    // outside the slider's range: kept, not clamped.
                    .clamping(egui::SliderClamping::Edits)
                    .logarithmic(true)
                    .text("tolerance px"),
            );
            ui.horizontal(|ui| {
                ui.label("hold:");
                ui.radio_value(&mut controls.target, TargetChoice::Off, "τ");
                ui.radio_value(&mut controls.target, TargetChoice::FrameTime, "frame ms");
                ui.radio_value(&mut controls.target, TargetChoice::Triangles, "triangles");
            });
            match controls.target {
                TargetChoice::Off => {}
                TargetChoice::FrameTime => {
                    ui.add(
                        egui::Slider::new(&mut controls.target_ms, 4.0..=500.0)
                            .clamping(egui::SliderClamping::Edits)
                            .logarithmic(true)
                            .text("target ms"),
                    );
                    ui.label(format!(
                        "τ {:.3} px, holding {:.0} triangles",
                        controls.tolerance,
                        stats.goal_triangles.unwrap_or(0.0)
                    ));
                }
                TargetChoice::Triangles => {
                    ui.add(
                        egui::Slider::new(&mut controls.target_triangles, 1_000..=100_000_000)
                            .clamping(egui::SliderClamping::Edits)
                            .logarithmic(true)
                            .text("target triangles"),
                    );
                    ui.label(format!("τ {:.3} px", controls.tolerance));
                }
            }
            ui.horizontal(|ui| {
                for (mode, name) in [
                    (Mode::Lit, "lit"),
                    (Mode::Patches, "patches"),
                    (Mode::Levels, "levels"),
                    (Mode::Check, "check"),
                    (Mode::Color, "color"),
                    (Mode::Normals, "normals"),
                ] {
                    ui.radio_value(&mut controls.mode, mode, name);
                }
                ui.add_enabled(
                    crate::cmd_render::has_normals(controls.mode),
                    egui::Checkbox::new(&mut controls.flat, "flat"),
                );
                ui.checkbox(&mut controls.wireframe, "wireframe");
            });
            ui.horizontal(|ui| {
                ui.label("cull:");
                ui.checkbox(&mut controls.frustum_culling, "frustum");
                ui.checkbox(&mut controls.cone_culling, "back-facing patches");
            });
            ui.horizontal(|ui| {
                ui.label("GPU budget");
                ui.add(
                    egui::DragValue::new(&mut controls.budget_mib)
                        .range(1.0..=1.0e6)
                        .speed(1.0)
                        .suffix(" MiB"),
                );
                controls.apply_budget |= ui.button("apply").clicked();
            });
            ui.horizontal(|ui| {
                ui.checkbox(&mut controls.frozen, "freeze cut (C)");
                ui.checkbox(&mut controls.fly, "fly (F)");
            });
            ui.label(KEY_HELP);
        });
}
