//! The pixel crack check on the GPU: render a closed model from outside with front faces grey
//! and back faces in `FLAG_COLOUR`; a closed, consistently oriented surface seen from outside
//! shows no back face, so every flag pixel is a crack (or a fold the simplification made).
//!
//! Each frame also reads back the GPU traversal's selection and compares it with the CPU
//! reference (`tessera_core::cut::select_visible`, same f32 operations): a mismatch is counted.
//! Back-face (cone) culling is off here: it would hide exactly the back faces a crack shows.

use tessera_core::cull::CullTests;
use tessera_core::cut::{diamond_rhos, select_visible};
use tessera_core::repository::reader::Repository;

use crate::camera::{bounding_radius, Camera};
use crate::gpu::{FrameRequest, GpuContext, Readback, Renderer, ShadingMode, FLAG_COLOUR};
use crate::views::outside_views;

/// What to check.
#[derive(Clone, Debug)]
pub struct PixelCheckConfig {
    /// Number of camera positions, all outside the model's bounding sphere.
    pub views: usize,
    /// Pixel tolerances τ.
    pub tolerances: Vec<f32>,
    /// Up axis of the cameras.
    pub up: [f64; 3],
    /// Vertical field of view, degrees (the image size is the renderer's).
    pub fov_degrees: f64,
}

impl Default for PixelCheckConfig {
    fn default() -> Self {
        PixelCheckConfig {
            views: 32,
            tolerances: vec![0.5, 1.0, 2.0, 4.0, 8.0],
            up: crate::camera::Y_UP,
            fov_degrees: 60.0,
        }
    }
}

/// The worst frame.
#[derive(Clone, Debug, PartialEq)]
pub struct WorstFrame {
    pub view: usize,
    pub tolerance: f32,
    pub flag_pixels: u64,
    pub eye: [f64; 3],
}

/// Totals over every frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PixelCheckReport {
    pub frames: usize,
    /// Pixels of `FLAG_COLOUR` over all frames.
    pub flag_pixels: u64,
    /// Frames with at least one flag pixel.
    pub frames_with_flags: usize,
    /// Frames whose GPU selection differs from the CPU reference.
    pub selection_mismatches: usize,
    /// Pixels covered by the model, over all frames (shows the frames saw something).
    pub covered_pixels: u64,
    pub worst: Option<WorstFrame>,
}

impl PixelCheckReport {
    pub fn is_clean(&self) -> bool {
        self.flag_pixels == 0 && self.selection_mismatches == 0
    }
}

/// Renders every (view, τ) pair and counts flag pixels and selection mismatches. The renderer
/// must hold `repo`.
pub fn check_pixels(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    repo: &Repository,
    config: &PixelCheckConfig,
) -> PixelCheckReport {
    let h = repo.header();
    let (width, height) = renderer.size();
    let radius = bounding_radius(h.bbox_min, h.bbox_max);
    let centre = [0, 1, 2].map(|i| 0.5 * (h.bbox_min[i] + h.bbox_max[i]));
    let cameras: Vec<Camera> = outside_views(h.bbox_min, h.bbox_max, config.views)
        .into_iter()
        .map(|eye| Camera {
            up: config.up,
            fov_y_degrees: config.fov_degrees,
            width,
            height,
            ..Camera::looking_at(eye, centre, radius)
        })
        .collect();
    check_pixels_at(ctx, renderer, repo, &cameras, &config.tolerances)
}

/// The same check from the given cameras (each must see the closed model from outside, and
/// have the renderer's size), at every tolerance of `tolerances`; `WorstFrame::view` is the
/// index into `cameras`.
pub fn check_pixels_at(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    repo: &Repository,
    cameras: &[Camera],
    tolerances: &[f32],
) -> PixelCheckReport {
    assert!(
        cameras
            .iter()
            .all(|c| (c.width, c.height) == renderer.size()),
        "every camera has the renderer's size"
    );
    let h = repo.header();
    let mut report = PixelCheckReport::default();
    for (view, &camera) in cameras.iter().enumerate() {
        let eye = camera.eye;
        let cull = CullTests {
            frustum: Some(camera.view_volume()),
            cones: false,
        };
        let eye_local = camera.eye_local(h.origin);
        let rhos = diamond_rhos(repo.diamonds(), eye_local, &camera.metric());
        for &tau in tolerances {
            let request = FrameRequest {
                camera,
                tau,
                cull,
                mode: ShadingMode::Check,
                wireframe: false,
            };
            renderer.render(
                ctx,
                &request,
                Readback {
                    image: true,
                    selection: true,
                },
            );
            let image = renderer.read_image(ctx);
            let gpu = renderer.read_selection(ctx);
            let mut cpu = select_visible(repo.tets(), &rhos, tau, eye_local, &cull);
            cpu.retain(|&i| repo.tets()[i as usize].strip_index_count > 0);
            if gpu != cpu {
                report.selection_mismatches += 1;
            }
            let mut flags = 0u64;
            for p in image.pixels() {
                if p.0 == FLAG_COLOUR {
                    flags += 1;
                }
                if p.0 != [0, 0, 0, 255] {
                    report.covered_pixels += 1;
                }
            }
            report.frames += 1;
            report.flag_pixels += flags;
            if flags > 0 {
                report.frames_with_flags += 1;
            }
            if flags > report.worst.as_ref().map_or(0, |w| w.flag_pixels) {
                report.worst = Some(WorstFrame {
                    view,
                    tolerance: tau,
                    flag_pixels: flags,
                    eye,
                });
            }
        }
    }
    report
}
