//! The viewer's event loop (winit 0.30's `ApplicationHandler`): the window and its surface,
//! one frame per redraw — the streaming renderer draws the camera into its offscreen target,
//! the target is blitted (letterboxed) onto the canvas, the overlay drawn over it, and the
//! canvas blitted onto the surface — input to navigation and the overlay, and the script.
//!
//! The canvas is what the window shows; script screenshots read it back. Loading never
//! blocks the loop (the streamer's loader thread); the overlay's statistics are read back
//! from each frame (a wait for that frame's GPU work).

use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use serde_json::json;
use tessera_core::repository::reader::Repository;
use tessera_runtime::camera::Camera;
use tessera_runtime::gpu::target::{RenderTarget, COLOR_FORMAT};
use tessera_runtime::gpu::{GpuContext, GpuStreamer, Renderer};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow};
use winit::window::{Window, WindowId};

use super::blit::{letterbox, Blit};
use super::navigation::Navigation;
use super::overlay::{self, Controls, Stats};
use super::pointer::Pointer;
use super::script::Action;
use super::target::Controller;
use crate::camera_path::Keyframe;

/// Most frames a screenshot waits for the stream to settle (as `render --max-frames`).
pub const SETTLE_FRAMES: u32 = 1000;

/// Most frames a scripted resize waits for the window to take its new size.
pub const RESIZE_FRAMES: u32 = 300;

/// What the script is doing.
pub(super) enum Step {
    /// Running the next actions.
    Next,
    /// Drawing this many more frames.
    Wait(u32),
    /// Drawing until the stream settles (frames drawn so far), then capturing.
    Settle(PathBuf, u32),
    /// Capturing the next frame.
    Capture(PathBuf),
    /// Waiting for the window to have this size (frames waited so far).
    Resize(u32, u32, u32),
    /// Flying a camera path until its last camera.
    Play,
}

/// Everything made once the window exists.
struct Window_ {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    /// The surface texture's view format (its non-sRGB form: the image's bytes are shown
    /// as they are).
    view_format: wgpu::TextureFormat,
    canvas: RenderTarget,
    to_canvas: Blit,
    to_surface: Blit,
    model_source: wgpu::BindGroup,
    canvas_source: wgpu::BindGroup,
    egui: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
}

pub struct App {
    pub ctx: GpuContext,
    pub renderer: Renderer,
    pub streamer: GpuStreamer,
    pub navigation: Navigation,
    pub controls: Controls,
    pub json: bool,
    pub script: Option<VecDeque<Action>>,
    /// The first error (exit 2, or 3 for a device failure); the loop ends on it.
    pub error: Option<anyhow::Error>,
    /// The repository (picks and exports read its patches).
    pub(super) repo: Arc<Repository>,
    /// A height field (fly mode stays above its ground).
    pub(super) terrain: bool,
    /// Where `B` saves bookmarks and 1-9 read them (a camera path file).
    pub(super) bookmarks: PathBuf,
    pub(super) bookmarks_given: bool,
    pub(super) gpu: crate::gpu_args::GpuArgs,
    pub(super) up: Option<[f64; 3]>,
    /// A new repository was opened: the canvas samples the new renderer's target.
    pub(super) model_changed: bool,
    /// Where `K` writes a recorded path (`None`: the next free `tessera-path-NNN.json`).
    pub(super) record: Option<PathBuf>,
    pub(super) step: Step,
    pub(super) show_overlay: bool,
    pub(super) stats: Stats,
    pub(super) pointer: Pointer,
    /// The simplices the last frame drew (picks cast rays against them).
    pub(super) selection: Vec<u32>,
    /// Move keys held: by the keyboard until released (`None`), or by the script for so many
    /// frames.
    pub(super) held: Vec<(char, Option<u32>)>,
    /// The camera whose cut is frozen.
    pub(super) frozen: Option<Camera>,
    pub(super) controller: Option<Controller>,
    pub(super) last_click: Option<(Instant, f64, f64)>,
    /// Cameras recorded since `K`.
    pub(super) recording: Option<Vec<Keyframe>>,
    /// Cameras of a path being played, next first.
    pub(super) playing: VecDeque<Keyframe>,
    /// `--frame-log`: a JSON object per frame.
    pub(super) frame_log: Option<std::io::BufWriter<std::fs::File>>,
    /// Frames drawn.
    pub(super) frames: u64,
    pub(super) last_frame: Option<Instant>,
    win: Option<Window_>,
}

/// What `App::new` needs besides the GPU.
pub struct Setup {
    pub repo: Arc<Repository>,
    pub navigation: Navigation,
    pub controls: Controls,
    pub budget_bytes: u64,
    pub script: Option<Vec<Action>>,
    pub json: bool,
    pub bookmarks: PathBuf,
    /// `--bookmarks` was given (else a dropped repository gets its own default file).
    pub bookmarks_given: bool,
    /// What makes a streaming renderer for a dropped repository.
    pub gpu: crate::gpu_args::GpuArgs,
    /// `--up`, if given (else each model's default).
    pub up: Option<[f64; 3]>,
    pub record: Option<PathBuf>,
    pub frame_log: Option<std::io::BufWriter<std::fs::File>>,
}

impl App {
    pub fn new(
        ctx: GpuContext,
        (renderer, streamer): (Renderer, GpuStreamer),
        setup: Setup,
    ) -> App {
        let stats = Stats {
            adapter: ctx.adapter_description(),
            budget_bytes: setup.budget_bytes,
            size: renderer.size(),
            ..Default::default()
        };
        App {
            ctx,
            renderer,
            streamer,
            navigation: setup.navigation,
            controls: setup.controls,
            json: setup.json,
            script: setup.script.map(VecDeque::from),
            error: None,
            terrain: setup.repo.header().dimension == 2,
            repo: setup.repo,
            bookmarks: setup.bookmarks,
            bookmarks_given: setup.bookmarks_given,
            gpu: setup.gpu,
            up: setup.up,
            model_changed: false,
            record: setup.record,
            step: Step::Next,
            show_overlay: true,
            stats,
            pointer: Pointer::default(),
            selection: Vec::new(),
            held: Vec::new(),
            frozen: None,
            controller: None,
            last_click: None,
            recording: None,
            playing: VecDeque::new(),
            frame_log: setup.frame_log,
            frames: 0,
            last_frame: None,
            win: None,
        }
    }

    /// The window's size in pixels ((1, 1) before it exists).
    pub(super) fn window_size(&self) -> (u32, u32) {
        self.win
            .as_ref()
            .map_or((1, 1), |w| (w.config.width, w.config.height))
    }

    /// Asks for a window size (applied at once on some platforms: then no `Resized` follows).
    pub(super) fn request_size(&mut self, width: u32, height: u32) {
        if let Some(w) = &self.win {
            if let Some(now) = w
                .window
                .request_inner_size(PhysicalSize::new(width, height))
            {
                self.resize(now);
            }
        }
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        self.error.get_or_insert(e);
        event_loop.exit();
    }

    /// Creates the window, its surface and what draws into it.
    fn open_window(&mut self, event_loop: &ActiveEventLoop) -> anyhow::Result<()> {
        let (width, height) = self.renderer.size();
        let window = Arc::new(
            event_loop
                .create_window(
                    Window::default_attributes()
                        .with_title("tessera view")
                        .with_inner_size(PhysicalSize::new(width, height)),
                )
                .map_err(|e| anyhow::anyhow!("cannot open a window: {e}"))?,
        );
        let surface = self
            .ctx
            .instance
            .create_surface(window.clone())
            .map_err(|e| anyhow::anyhow!("cannot make a wgpu surface for the window: {e}"))?;
        if !self.ctx.adapter.is_surface_supported(&surface) {
            anyhow::bail!(
                "the adapter {} cannot present to this window's surface",
                self.ctx.adapter_description()
            );
        }
        let caps = surface.get_capabilities(&self.ctx.adapter);
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| !f.is_srgb())
            .or(caps.formats.first().copied())
            .ok_or_else(|| anyhow::anyhow!("the window's surface offers no format"))?;
        let view_format = format.remove_srgb_suffix();
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            color_space: wgpu::SurfaceColorSpace::Auto,
            width: size.width.max(1),
            height: size.height.max(1),
            desired_maximum_frame_latency: 2,
            present_mode: wgpu::PresentMode::AutoVsync,
            alpha_mode: wgpu::CompositeAlphaMode::Auto,
            view_formats: if view_format == format {
                vec![]
            } else {
                vec![view_format]
            },
        };
        if size.width > 0 && size.height > 0 {
            surface.configure(&self.ctx.device, &config);
        }
        let device = &self.ctx.device;
        let canvas = RenderTarget::new(&self.ctx, config.width, config.height);
        let to_canvas = Blit::new(device, COLOR_FORMAT);
        let to_surface = Blit::new(device, view_format);
        let model_source = to_canvas.source(device, &self.renderer.target().color_view);
        let canvas_source = to_surface.source(device, &canvas.color_view);
        let egui_ctx = egui::Context::default();
        let egui = egui_winit::State::new(
            egui_ctx,
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(self.ctx.limits.max_texture_dimension_2d as usize),
        );
        let egui_renderer = egui_wgpu::Renderer::new(device, COLOR_FORMAT, Default::default());
        self.win = Some(Window_ {
            window,
            surface,
            config,
            view_format,
            canvas,
            to_canvas,
            to_surface,
            model_source,
            canvas_source,
            egui,
            egui_renderer,
        });
        Ok(())
    }

    /// The window's new size: the surface reconfigured and the canvas remade (nothing for a
    /// zero size: a minimised window draws nothing).
    fn resize(&mut self, size: PhysicalSize<u32>) {
        let Some(w) = self.win.as_mut() else { return };
        w.config.width = size.width;
        w.config.height = size.height;
        if size.width == 0 || size.height == 0 {
            return;
        }
        w.surface.configure(&self.ctx.device, &w.config);
        w.canvas = RenderTarget::new(&self.ctx, size.width, size.height);
        w.canvas_source = w.to_surface.source(&self.ctx.device, &w.canvas.color_view);
    }

    /// Script actions not finished yet (0 without a script).
    fn script_left(&self) -> usize {
        let running = usize::from(!matches!(self.step, Step::Next));
        self.script.as_ref().map_or(0, |s| s.len() + running)
    }

    /// One frame (module comment). Returns whether the loop should end (the script is done).
    fn frame(&mut self) -> anyhow::Result<bool> {
        if !self.advance_script()? {
            return Ok(true);
        }
        let Some(w) = self.win.as_ref() else {
            return Ok(false);
        };
        if w.config.width == 0 || w.config.height == 0 {
            return Ok(false); // minimised
        }
        self.before_frame();
        let (width, height) = self.renderer.size();
        let settled = self.draw_model()?;
        self.after_frame()?;
        let w = self.win.as_mut().expect("checked above");

        // The overlay's layout (it may change the controls for the next frame).
        let input = w.egui.take_egui_input(&w.window);
        let egui_ctx = w.egui.egui_ctx().clone();
        let (stats, controls, show) = (&self.stats, &mut self.controls, self.show_overlay);
        let output = egui_ctx.run_ui(input, |ui| {
            if show {
                overlay::ui(ui.ctx(), stats, controls);
            }
        });
        w.egui
            .handle_platform_output(&w.window, output.platform_output);
        let jobs = egui_ctx.tessellate(output.shapes, output.pixels_per_point);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [w.config.width, w.config.height],
            pixels_per_point: output.pixels_per_point,
        };
        let device = &self.ctx.device;
        for (id, deltas) in &output.textures_delta.set {
            for delta in deltas {
                w.egui_renderer
                    .update_texture(device, &self.ctx.queue, *id, delta);
            }
        }
        let mut encoder = device.create_command_encoder(&Default::default());
        let extra =
            w.egui_renderer
                .update_buffers(device, &self.ctx.queue, &mut encoder, &jobs, &screen);
        if std::mem::take(&mut self.model_changed) {
            w.model_source = (w.to_canvas).source(device, &self.renderer.target().color_view);
        }
        {
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("canvas"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &w.canvas.color_view,
                        resolve_target: None,
                        depth_slice: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    ..Default::default()
                })
                .forget_lifetime();
            let viewport = letterbox((width, height), (w.config.width, w.config.height));
            w.to_canvas.draw(&mut pass, &w.model_source, viewport);
            pass.set_viewport(
                0.0,
                0.0,
                w.config.width as f32,
                w.config.height as f32,
                0.0,
                1.0,
            );
            w.egui_renderer.render(&mut pass, &jobs, &screen);
        }
        let capture = match &self.step {
            Step::Capture(path) => Some(path.clone()),
            _ => None,
        };
        if capture.is_some() {
            w.canvas.copy_out(&mut encoder);
        }
        // The canvas onto the window's surface.
        let surface_texture = match w.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => Some(t),
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                w.surface.configure(device, &w.config);
                None
            }
            _ => None, // timeout, occluded, validation: skip this frame's present
        };
        if let Some(t) = &surface_texture {
            let view = t.texture.create_view(&wgpu::TextureViewDescriptor {
                format: Some(w.view_format),
                ..Default::default()
            });
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("present"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    resolve_target: None,
                    depth_slice: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                ..Default::default()
            });
            let full = [0.0, 0.0, w.config.width as f32, w.config.height as f32];
            w.to_surface.draw(&mut pass, &w.canvas_source, full);
        }
        self.ctx
            .queue
            .submit(extra.into_iter().chain([encoder.finish()]));
        if let Some(t) = surface_texture {
            w.window.pre_present_notify();
            self.ctx.queue.present(t);
        }
        for id in &output.textures_delta.free {
            w.egui_renderer.free_texture(id);
        }
        self.ctx.check()?;

        // The script's next step.
        self.step = match std::mem::replace(&mut self.step, Step::Next) {
            Step::Wait(n) if n > 1 => Step::Wait(n - 1),
            Step::Play if !self.playing.is_empty() => Step::Play,
            Step::Settle(path, n) if !settled && n + 1 < SETTLE_FRAMES => Step::Settle(path, n + 1),
            Step::Settle(path, _) => Step::Capture(path),
            Step::Resize(width, height, _)
                if (w.config.width, w.config.height) == (width, height) =>
            {
                Step::Next
            }
            Step::Resize(width, height, n) if n + 1 < RESIZE_FRAMES => {
                Step::Resize(width, height, n + 1)
            }
            Step::Resize(width, height, _) => anyhow::bail!(
                "the window was not resized to {width}×{height} within {RESIZE_FRAMES} frames \
                 (it is {}×{})",
                w.config.width,
                w.config.height
            ),
            Step::Capture(path) => {
                let image = w.canvas.read(&self.ctx)?;
                crate::output::save_png(&image, &path)?;
                eprintln!("screenshot: {}", path.display());
                if self.json {
                    println!(
                        "{}",
                        json!({
                            "path": path.display().to_string(),
                            "triangles": self.stats.triangles,
                            "patches": self.stats.patches,
                            "tolerance": self.stats.tolerance,
                            "gpu_ms": self.stats.gpu_ms,
                            "resident_bytes": self.stats.resident_bytes,
                            "settled": self.stats.settled,
                            "eye": self.navigation.eye(),
                            "pivot": self.navigation.pivot(),
                            "fly": self.controls.fly,
                            "frozen": self.frozen.is_some(),
                            "frame_ms": self.stats.frame_ms,
                            "width": image.width(),
                            "height": image.height(),
                        })
                    );
                }
                Step::Next
            }
            _ => Step::Next,
        };
        Ok(false)
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.win.is_none() {
            if let Err(e) = self.open_window(event_loop) {
                self.fail(event_loop, e);
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(w) = self.win.as_mut() else { return };
        let consumed = w.egui.on_window_event(&w.window, &event).consumed;
        match event {
            WindowEvent::CloseRequested => match self.script_left() {
                0 => event_loop.exit(),
                left => self.fail(
                    event_loop,
                    anyhow::anyhow!(
                        "the window was closed before the script ended ({left} actions left)"
                    ),
                ),
            },
            WindowEvent::Resized(size) => self.resize(size),
            WindowEvent::DroppedFile(path) => self.dropped(&path),
            WindowEvent::RedrawRequested => match self.frame() {
                Ok(true) => event_loop.exit(),
                Ok(false) => {}
                Err(e) => self.fail(event_loop, e),
            },
            // Releases and moves always (a drag that ends over the overlay ends).
            ref other
                if !consumed
                    || matches!(
                        other,
                        WindowEvent::MouseInput {
                            state: ElementState::Released,
                            ..
                        } | WindowEvent::CursorMoved { .. }
                    ) =>
            {
                self.input(other)
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        // Continuous frames: the stream keeps loading while the view is still. A minimised
        // (zero-size) window waits for its next event instead.
        match &self.win {
            Some(w) if w.config.width > 0 && w.config.height > 0 => {
                event_loop.set_control_flow(ControlFlow::Poll);
                w.window.request_redraw();
            }
            _ => event_loop.set_control_flow(ControlFlow::Wait),
        }
    }
}
