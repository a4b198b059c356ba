//! What the renderer is asked and answers: its options, one frame's request, what a frame
//! leaves behind and what to read back, and why a renderer cannot be made.

use tessera_core::cull::CullTests;

use super::frame::ShadingMode;
use super::resident::ResidentError;
use crate::camera::Camera;

/// Default GPU memory budget of the resident pool.
pub const DEFAULT_BUDGET_BYTES: u64 = 2 << 30;

/// What `Renderer::new` needs besides the repository.
#[derive(Clone, Copy, Debug)]
pub struct RendererOptions {
    /// Target size in pixels.
    pub width: u32,
    pub height: u32,
    /// Bytes the resident model may take on the GPU.
    pub budget_bytes: u64,
    /// At most this many strip slots per page in the frame's index buffer (`None`:
    /// `resident::DEFAULT_INDEX_SLOTS`, and never more than the page has or one storage binding
    /// holds); a frame selecting more is drawn by vertex pulling instead (tests force that path
    /// with a small value).
    pub index_slots: Option<u64>,
    /// Streaming: how the pools grow (`stream_pool::PoolGrowth`).
    pub pool_growth: super::stream_pool::PoolGrowth,
}

impl Default for RendererOptions {
    fn default() -> Self {
        RendererOptions {
            width: 1920,
            height: 1080,
            budget_bytes: DEFAULT_BUDGET_BYTES,
            index_slots: None,
            pool_growth: Default::default(),
        }
    }
}

/// One frame to draw.
#[derive(Clone, Copy, Debug)]
pub struct FrameRequest {
    pub camera: Camera,
    /// Pixel tolerance τ.
    pub tau: f32,
    /// Culling besides the cut rule (frustum from `camera.view_volume()` when on).
    pub cull: CullTests,
    pub mode: ShadingMode,
    /// Overlay the triangle edges (ignored where the adapter has no line mode).
    pub wireframe: bool,
    /// Draw both sides of every face (the fill passes; the check passes have their own face
    /// rules). One face rule: a two-sided frame must not cull patches by their normal cones
    /// (`FrameRequest::two_sided` sets both), and a one-sided frame (the default) drops back
    /// faces in the rasteriser as the cones do, so the picture does not depend on τ through
    /// which patches the cones dropped.
    pub two_sided: bool,
    /// Draw from this camera instead of `camera` (a frozen cut inspected from elsewhere); the
    /// traversal, culling, streaming and the CPU reference all use `camera`. `None`: draw from
    /// `camera`, bit-identically to `Some(camera)`.
    pub draw_camera: Option<Camera>,
}

impl FrameRequest {
    /// Lit, one-sided, frustum and normal-cone culling on, no wireframe.
    pub fn new(camera: Camera, tau: f32) -> FrameRequest {
        FrameRequest {
            camera,
            tau,
            cull: CullTests {
                frustum: Some(camera.view_volume()),
                cones: true,
            },
            mode: ShadingMode::Lit,
            wireframe: false,
            two_sided: false,
            draw_camera: None,
        }
    }

    /// The camera the frame is drawn from: `draw_camera`, else `camera`.
    pub fn drawn_from(&self) -> &Camera {
        self.draw_camera.as_ref().unwrap_or(&self.camera)
    }

    /// Both sides of every face drawn and normal-cone culling off (`render --two-sided`).
    pub fn two_sided(self) -> FrameRequest {
        FrameRequest {
            two_sided: true,
            cull: CullTests {
                cones: false,
                ..self.cull
            },
            ..self
        }
    }
}

/// Everything one frame left behind (`Renderer::render_and_read`).
#[derive(Clone, Debug)]
pub struct Frame {
    pub image: image::RgbaImage,
    /// The simplices drawn, ascending.
    pub selection: Vec<u32>,
    /// Triangles of the drawn patches.
    pub triangles: u64,
    /// `Renderer::read_gpu_ms`.
    pub gpu_ms: Option<f64>,
    /// What `Renderer::render` returned.
    pub cpu_ms: f64,
}

/// A frame's time in two phases (`Renderer::render_phased`), each from its first CPU
/// instruction to the GPU's idle: choosing what to draw (ours: the GPU traversal, compaction
/// and expansion; a peer's: its CPU cut and upload) and drawing it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FramePhases {
    pub select_ms: f64,
    pub raster_ms: f64,
}

/// What to copy out of a frame for the `read_*` calls.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Readback {
    pub image: bool,
    pub selection: bool,
}

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Resident(#[from] ResidentError),
    #[error(transparent)]
    BadSize(#[from] super::target::TargetSizeError),
    /// The device failed while the renderer was made (out of memory, lost).
    #[error("{0}")]
    Device(#[from] super::device::GpuFailure),
    #[error("{got} may_refine words given; the model's {diamonds} diamonds take {expected}")]
    MayRefineLength {
        got: usize,
        expected: usize,
        diamonds: u32,
    },
}
