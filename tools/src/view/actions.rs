//! What the viewer does between frames: the script's next actions, keys (pressed, held,
//! released), the double-click pick and the wheel towards the cursor, fly moves (kept above
//! a terrain's ground), freezing the cut, the target controller, export, bookmarks and camera
//! paths (recorded and played). `app.rs` draws; this file decides what the next frame shows.

use std::path::{Path, PathBuf};

use tessera_core::metric::center_minus_eye;
use tessera_core::repository::reader::Repository;
use tessera_runtime::camera::Camera;
use tessera_runtime::vec3::{add, dot, length, scale, sub};

use super::app::{App, Step};
use super::pick::ray_cast;
use super::script::Action;
use super::target::Controller;
use crate::camera_path::{CameraPath, Keyframe};
use crate::cmd_render::default_up;

/// Two left presses this close in time (ms) and space (window px) are a double-click.
const DOUBLE_CLICK_MS: u128 = 400;
const DOUBLE_CLICK_PX: f64 = 5.0;
/// Fly speed: this share of the distance to the surface ahead, per second.
const FLY_RATE: f64 = 1.0;
/// The slowest fly speed and a terrain's least clearance, in bounding radii.
const MIN_FLY_SPEED: f64 = 1e-4;
const GROUND_CLEARANCE: f64 = 1e-3;
/// The keys that move the eye while held, and their direction (right, up, forward).
const MOVES: [(char, [f64; 3]); 6] = [
    ('w', [0.0, 0.0, 1.0]),
    ('s', [0.0, 0.0, -1.0]),
    ('a', [-1.0, 0.0, 0.0]),
    ('d', [1.0, 0.0, 0.0]),
    ('e', [0.0, 1.0, 0.0]),
    ('q', [0.0, -1.0, 0.0]),
];

impl App {
    /// Runs script actions until one needs frames; false when the script has ended.
    pub(super) fn advance_script(&mut self) -> anyhow::Result<bool> {
        if self.script.is_none() {
            return Ok(true);
        }
        while matches!(self.step, Step::Next) {
            let Some(action) = self.script.as_mut().and_then(|s| s.pop_front()) else {
                return Ok(false);
            };
            match action {
                Action::Orbit(orbit) => self.navigation.set_orbit(orbit),
                Action::Tolerance(t) => self.controls.tolerance = t,
                Action::Mode(m) => self.controls.mode = m,
                Action::WaitFrames(n) if n > 0 => self.step = Step::Wait(n),
                Action::WaitFrames(_) => {}
                Action::Screenshot(path) => self.step = Step::Settle(path, 0),
                Action::Key(c, frames) => {
                    if is_move(c) {
                        self.held.push((c, Some(frames)));
                        self.step = Step::Wait(frames);
                    } else {
                        self.key(c);
                    }
                }
                Action::Overlay(on) => self.show_overlay = on,
                Action::Drag(button, line) => {
                    let height = self.window_size().1;
                    (self.pointer).drag(button, line, 8, &mut self.navigation, height);
                }
                Action::Wheel(lines) => self.navigation.zoom(lines),
                Action::WheelAt([x, y, lines]) => self.wheel_at(Some((x, y)), lines),
                Action::DoubleClick([x, y]) => self.pick_pivot(x, y),
                Action::TargetMs(ms) => {
                    self.controls.target = super::overlay::TargetChoice::FrameTime;
                    self.controls.target_ms = ms;
                }
                Action::BudgetTriangles(n) => {
                    self.controls.target = super::overlay::TargetChoice::Triangles;
                    self.controls.target_triangles = n;
                }
                Action::TargetOff => self.controls.target = super::overlay::TargetChoice::Off,
                Action::Freeze(on) => self.set_frozen(on),
                Action::Fly(on) => self.set_fly(on),
                Action::Wireframe(on) => self.controls.wireframe = on,
                Action::Flat(on) => self.controls.flat = on,
                Action::Culling(frustum, cones) => {
                    let c = &mut self.controls;
                    c.frustum_culling = frustum.unwrap_or(c.frustum_culling);
                    c.cone_culling = cones.unwrap_or(c.cone_culling);
                }
                Action::Export(path) => {
                    self.export(&path)?;
                }
                Action::Open(path) => self.open(&path)?,
                Action::GpuBudget(mib) => self.set_budget(mib)?,
                Action::Play(path) => {
                    self.playing = CameraPath::load(&path)?.frames().into();
                    self.step = Step::Play;
                }
                Action::Resize(width, height) => {
                    self.request_size(width, height);
                    self.step = Step::Resize(width, height, 0);
                }
            }
        }
        Ok(true)
    }

    /// A key pressed (keyboard or script).
    pub(super) fn key(&mut self, c: char) {
        match c {
            'r' => self.navigation.reset(),
            'h' => self.show_overlay = !self.show_overlay,
            // The window's content as it is, at the next frame.
            'p' => self.step = Step::Capture(next_free("tessera-view", "png")),
            'f' => self.set_fly(!self.controls.fly),
            'c' => self.set_frozen(!self.controls.frozen),
            'x' => {
                let path = next_free("tessera-cut", "ply");
                if let Err(e) = self.export(&path) {
                    self.say(format!("export failed: {e:#}"));
                }
            }
            'b' => self.add_bookmark(),
            '1'..='9' => self.go_to_bookmark(c as usize - '1' as usize),
            'k' => self.toggle_recording(),
            c if is_move(c) && !self.held.iter().any(|&(h, _)| h == c) => {
                self.held.push((c, None));
            }
            _ => {}
        }
    }

    fn set_fly(&mut self, on: bool) {
        self.controls.fly = on;
        self.navigation.fly = on;
    }

    /// Freezes the cut of the view as it is now (or lets the cut follow the camera again).
    fn set_frozen(&mut self, on: bool) {
        self.controls.frozen = on;
        let (width, height) = self.renderer.size();
        self.frozen = on.then(|| self.navigation.camera(width, height));
    }

    /// A key released on the keyboard.
    pub(super) fn key_released(&mut self, c: char) {
        self.held.retain(|&(h, frames)| h != c || frames.is_some());
    }

    /// A left button press at the cursor: the second of a double-click picks the pivot.
    pub(super) fn left_pressed(&mut self) {
        let Some((x, y)) = self.pointer.cursor() else {
            return;
        };
        let now = std::time::Instant::now();
        match self.last_click {
            Some((t, x0, y0))
                if (now - t).as_millis() <= DOUBLE_CLICK_MS
                    && (x - x0).hypot(y - y0) <= DOUBLE_CLICK_PX =>
            {
                self.last_click = None;
                self.pick_pivot(x, y);
            }
            _ => self.last_click = Some((now, x, y)),
        }
    }

    /// The wheel: towards the surface under the cursor where there is one, else the pivot.
    pub(super) fn wheel_at(&mut self, cursor: Option<(f64, f64)>, lines: f64) {
        match cursor.and_then(|(x, y)| self.surface_under(x, y)) {
            Some(p) => self.navigation.zoom_towards(p, lines),
            None => self.navigation.zoom(lines),
        }
    }

    /// The point of the drawn cut under window pixel (x, y), if any.
    fn surface_under(&self, x: f64, y: f64) -> Option<[f64; 3]> {
        let (wx, wy) = self.window_size();
        let (width, height) = self.renderer.size();
        let [vx, vy, vw, vh] = super::blit::letterbox((width, height), (wx, wy));
        let rx = (x - vx as f64) / vw as f64 * width as f64;
        let ry = (y - vy as f64) / vh as f64 * height as f64;
        if !(0.0..width as f64).contains(&rx) || !(0.0..height as f64).contains(&ry) {
            return None;
        }
        let camera = self.navigation.camera(width, height);
        let dir = self.navigation.ray(rx, ry, width, height);
        let t = ray_cast(&self.repo, &self.selection, camera.eye, dir)?;
        Some(add(camera.eye, scale(dir, t)))
    }

    /// Double-click: the pivot moves to the surface under (x, y), the eye stays.
    pub(super) fn pick_pivot(&mut self, x: f64, y: f64) {
        match self.surface_under(x, y) {
            Some(p) => {
                self.navigation.set_pivot(p);
                self.say(format!("pivot at {:.6} {:.6} {:.6}", p[0], p[1], p[2]));
            }
            None => self.say("no surface under the cursor: the pivot stays".into()),
        }
    }

    /// Before a frame: held keys move the eye (at a speed scaled by the distance to the
    /// surface ahead), a camera path being played takes its next camera, fly mode and the
    /// frozen cut follow the controls.
    pub(super) fn before_frame(&mut self) {
        self.navigation.fly = self.controls.fly;
        // The controller follows the target chosen (the script's or the overlay's).
        if self.controls.target() != self.controller.as_ref().map(|c| c.target) {
            self.controller = self.controls.target().map(Controller::new);
        }
        if std::mem::take(&mut self.controls.apply_budget) {
            if let Err(e) = self.set_budget(self.controls.budget_mib) {
                self.say(format!("the budget stays: {e:#}"));
            }
        }
        let (width, height) = self.renderer.size();
        let view = self.navigation.camera(width, height);
        // The overlay's checkbox.
        if self.controls.frozen != self.frozen.is_some() {
            self.set_frozen(self.controls.frozen);
        }
        if let Some(k) = self.playing.pop_front() {
            self.navigation.set_eye_and_pivot(k.eye, k.target);
        }
        let mut direction = [0.0; 3];
        for &(c, _) in &self.held {
            if let Some((_, d)) = MOVES.iter().find(|(m, _)| *m == c) {
                direction = add(direction, *d);
            }
        }
        for (_, frames) in &mut self.held {
            if let Some(n) = frames {
                *n = n.saturating_sub(1);
            }
        }
        self.held.retain(|&(_, frames)| frames != Some(0));
        if direction == [0.0; 3] {
            return;
        }
        let radius = self.navigation.radius();
        let eye = self.navigation.eye();
        let forward = view.basis().forward;
        let ahead = ray_cast(&self.repo, &self.selection, eye, forward)
            .unwrap_or_else(|| length(sub(self.navigation.pivot(), eye)));
        // The last frame's time, within reason (the first frame: 1/60 s).
        let dt = match self.stats.frame_ms {
            ms if ms > 0.0 => (ms / 1e3).min(0.1),
            _ => 1.0 / 60.0,
        };
        let speed = (FLY_RATE * ahead).max(MIN_FLY_SPEED * radius);
        let norm = length(direction);
        self.navigation
            .fly(scale(direction, speed * dt / norm.max(1e-300)));
        if self.terrain && self.controls.fly {
            self.stay_above_ground();
        }
    }

    /// A terrain in fly mode: the eye at least `GROUND_CLEARANCE` radii above the drawn
    /// surface under it.
    fn stay_above_ground(&mut self) {
        let up = self.navigation.up();
        let up = scale(up, 1.0 / length(up).max(1e-300));
        let radius = self.navigation.radius();
        let eye = self.navigation.eye();
        let h = *self.repo.header();
        // From above the whole box, straight down through the eye.
        let top = (0..8)
            .map(|corner| {
                let c = [0, 1, 2].map(|i| match corner >> i & 1 {
                    0 => h.bbox_min[i],
                    _ => h.bbox_max[i],
                });
                dot(c, up)
            })
            .fold(f64::NEG_INFINITY, f64::max);
        let lift = (top - dot(eye, up)).max(0.0) + radius;
        let origin = add(eye, scale(up, lift));
        let Some(t) = ray_cast(&self.repo, &self.selection, origin, scale(up, -1.0)) else {
            return;
        };
        let ground = sub(origin, scale(up, t));
        self.navigation
            .keep_above(ground, GROUND_CLEARANCE * radius);
    }

    /// The cut's camera and, when the cut is frozen, the camera it is drawn from.
    pub(super) fn cameras(&self) -> (Camera, Option<Camera>) {
        let (width, height) = self.renderer.size();
        let view = self.navigation.camera(width, height);
        match self.frozen {
            Some(cut) => (cut, Some(view)),
            None => (view, None),
        }
    }

    /// After a frame: the frame log gets its line, the target controller sets the next τ, a
    /// recording takes the camera.
    pub(super) fn after_frame(&mut self) -> anyhow::Result<()> {
        self.frames += 1;
        if let Some(log) = &mut self.frame_log {
            let s = &self.stats;
            let line = serde_json::json!({
                "frame": self.frames,
                "frame_ms": s.frame_ms,
                "gpu_ms": s.gpu_ms,
                "cpu_ms": s.cpu_ms,
                "triangles": s.triangles,
                "patches": s.patches,
                "tolerance": s.tolerance,
                "settled": s.settled,
                "pending_units": s.pending_units,
                "redraws": s.redraws,
                "eye": self.navigation.eye(),
            });
            std::io::Write::write_fmt(log, format_args!("{line}\n"))
                .map_err(|e| anyhow::anyhow!("cannot write the frame log: {e}"))?;
        }
        let ceiling = self.tau_ceiling();
        if let Some(c) = self.controller.as_mut() {
            self.controls.tolerance = c.update(
                self.controls.tolerance,
                self.stats.frame_ms,
                self.stats.triangles,
                self.stats.pending_units > 0,
                ceiling,
            );
            self.stats.goal_triangles = c.goal();
        }
        if let Some(frames) = &mut self.recording {
            frames.push(Keyframe {
                eye: self.navigation.eye(),
                target: self.navigation.pivot(),
            });
        }
        Ok(())
    }

    /// Twice the largest ρ of the root diamonds for the cut's camera: above it only the roots
    /// are drawn (ρ is monotone up the DAG, so the roots' diamonds hold the largest), so the
    /// target controller never raises τ past it. Reads the root records only.
    fn tau_ceiling(&self) -> f32 {
        let (camera, _) = self.cameras();
        let h = self.repo.header();
        let eye = camera.eye_local(h.origin);
        let metric = camera.metric();
        let diamonds = self.repo.diamonds();
        let roots = &self.repo.tets()[..h.root_tet_count as usize];
        let max = roots
            .iter()
            .filter_map(|t| diamonds.get(t.diamond as usize))
            .map(|d| metric.rho(d.error, center_minus_eye(d.center, eye), d.radius))
            .fold(0.0f32, f32::max);
        if max > 0.0 {
            2.0 * max
        } else {
            f32::INFINITY
        }
    }

    /// The current cut (the whole model at the view's resolution; the frozen cut's camera
    /// when frozen) as a binary PLY.
    pub(super) fn export(&mut self, path: &Path) -> anyhow::Result<()> {
        let (camera, _) = self.cameras();
        let (triangles, vertices) =
            super::export::export_cut(&self.repo, &camera, self.controls.tolerance, path)?;
        self.say(format!(
            "exported {triangles} triangles, {vertices} vertices to {}",
            path.display()
        ));
        Ok(())
    }

    fn add_bookmark(&mut self) {
        let file = self.bookmarks.clone();
        let mut marks = if file.exists() {
            match CameraPath::load(&file) {
                Ok(p) => p,
                Err(e) => return self.say(format!("bookmarks not saved: {e:#}")),
            }
        } else {
            CameraPath::default()
        };
        if marks.frames_between == 0 {
            marks.frames_between = 30;
        }
        marks.keyframes.push(Keyframe {
            eye: self.navigation.eye(),
            target: self.navigation.pivot(),
        });
        let n = marks.keyframes.len();
        match marks.save(&file) {
            Ok(()) => self.say(format!("bookmark {n} saved to {}", file.display())),
            Err(e) => self.say(format!("bookmark not saved: {e:#}")),
        }
    }

    fn go_to_bookmark(&mut self, index: usize) {
        match CameraPath::load(&self.bookmarks) {
            Ok(marks) => match marks.keyframes.get(index) {
                Some(k) => {
                    self.navigation.set_eye_and_pivot(k.eye, k.target);
                    self.say(format!("bookmark {}", index + 1));
                }
                None => self.say(format!(
                    "no bookmark {} ({} saved in {})",
                    index + 1,
                    marks.keyframes.len(),
                    self.bookmarks.display()
                )),
            },
            Err(e) => self.say(format!("no bookmarks: {e:#}")),
        }
    }

    fn toggle_recording(&mut self) {
        match self.recording.take() {
            None => {
                self.recording = Some(Vec::new());
                self.say("recording the camera path (K stops)".into());
            }
            Some(keyframes) if keyframes.is_empty() => self.say("nothing recorded".into()),
            Some(keyframes) => {
                let path = CameraPath {
                    keyframes,
                    frames_between: 1,
                    pause_frames: 0,
                };
                let file = self
                    .record
                    .clone()
                    .unwrap_or_else(|| next_free("tessera-path", "json"));
                match path.save(&file) {
                    Ok(()) => self.say(format!(
                        "{} cameras recorded to {} (`bench stream --path` flies it)",
                        path.keyframes.len(),
                        file.display()
                    )),
                    Err(e) => self.say(format!("the path was not saved: {e:#}")),
                }
            }
        }
    }

    /// Another repository in the window (a dropped file, or the script's `open`): a new
    /// streaming renderer under the same budget, the navigation's settings at the new
    /// model's initial view; the frozen cut, target controller, path and selection cleared.
    /// On an error the current model stays.
    pub(super) fn open(&mut self, path: &Path) -> anyhow::Result<()> {
        crate::repository_arg::refuse_input_file(path, "view")?;
        let repo = std::sync::Arc::new(Repository::open(path)?);
        let size = self.renderer.size();
        let (renderer, streamer) = self.gpu.streaming(&self.ctx, repo.clone(), size)?;
        // The old renderer's memory goes before the new model's first frame.
        (self.renderer, self.streamer) = (renderer, streamer);
        let h = *repo.header();
        let up = self.up.unwrap_or(default_up(h.dimension));
        self.navigation = self.navigation.for_model(h.bbox_min, h.bbox_max, up);
        self.terrain = h.dimension == 2;
        self.repo = repo;
        self.selection.clear();
        self.set_frozen(false);
        self.controller = None;
        self.playing.clear();
        self.held.clear();
        if !self.bookmarks_given {
            self.bookmarks = super::default_bookmarks(path);
        }
        self.model_changed = true;
        self.say(format!("opened {}", path.display()));
        Ok(())
    }

    /// The streaming renderer remade under `mib` MiB (the view, frozen cut and targets kept;
    /// the new pool starts from the roots and streams the view again). On an error (a budget
    /// below the fixed allocations and the roots) the current renderer stays.
    pub(super) fn set_budget(&mut self, mib: f64) -> anyhow::Result<()> {
        let mut gpu = self.gpu.clone();
        gpu.gpu_budget = Some(mib);
        let size = self.renderer.size();
        let (renderer, streamer) = gpu.streaming(&self.ctx, self.repo.clone(), size)?;
        (self.renderer, self.streamer) = (renderer, streamer);
        self.stats.budget_bytes = gpu.budget_bytes(&self.ctx);
        self.controls.budget_mib = mib;
        self.gpu = gpu;
        self.selection.clear();
        self.model_changed = true;
        self.say(format!("GPU budget {mib} MiB"));
        Ok(())
    }

    /// A file dropped on the window: opened, or the reason in the overlay.
    pub(super) fn dropped(&mut self, path: &Path) {
        if let Err(e) = self.open(path) {
            self.say(format!("cannot open {}: {e:#}", path.display()));
        }
    }

    /// Shown in the overlay and on standard error.
    pub(super) fn say(&mut self, message: String) {
        eprintln!("{message}");
        self.stats.message = message;
    }
}

fn is_move(c: char) -> bool {
    MOVES.iter().any(|(m, _)| *m == c)
}

/// The first `STEM-NNN.EXT` (NNN from 001) not in the current directory, absolute when the
/// current directory is known.
pub fn next_free(stem: &str, extension: &str) -> PathBuf {
    let dir = std::env::current_dir().unwrap_or_default();
    (1..)
        .map(|n| dir.join(format!("{stem}-{n:03}.{extension}")))
        .find(|p| !p.exists())
        .expect("a free name")
}
