//! The pixel check under partial residency (`check --gpu --gpu-budget N`): the views of
//! `pixel_check` (closed models from outside), each drawn by the streaming renderer for a
//! few frames while its units stream in and others are evicted, every frame checked — flag
//! pixels (back faces: cracks) counted, and the GPU's selection compared with the CPU
//! streaming reference (`stream::stream_frame`) for the flags that frame was drawn with.
//! Terrains are checked fully resident only (their walls and excused holes are
//! `pixel_check`'s).

use tessera_core::cull::CullTests;
use tessera_core::repository::reader::Repository;

use crate::camera::{bounding_radius, Camera};
use crate::gpu::{
    FrameRequest, GpuContext, GpuStreamer, Readback, Renderer, ShadingMode, StreamError,
    FLAG_COLOUR,
};
use crate::pixel_check::{PixelCheckConfig, PixelCheckReport, WorstFrame};
use crate::views::outside_views;

/// Streamed frames drawn (and checked) per view and tolerance.
pub const FRAMES_PER_VIEW: usize = 4;

/// Runs the check; the renderer and streamer must hold `repo`, whose dimension is 3.
pub fn check_pixels_streaming(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    streamer: &mut GpuStreamer,
    repo: &Repository,
    config: &PixelCheckConfig,
) -> Result<PixelCheckReport, StreamError> {
    let h = repo.header();
    let (width, height) = renderer.size();
    let radius = bounding_radius(h.bbox_min, h.bbox_max);
    let centre = [0, 1, 2].map(|i| 0.5 * (h.bbox_min[i] + h.bbox_max[i]));
    let mut report = PixelCheckReport::default();
    streamer.set_cpu_reference(true);
    for (view, eye) in outside_views(h.bbox_min, h.bbox_max, config.views)
        .into_iter()
        .enumerate()
    {
        let camera = Camera {
            up: config.up,
            fov_y_degrees: config.fov_degrees,
            width,
            height,
            ..Camera::looking_at(eye, centre, radius)
        };
        for &tau in &config.tolerances {
            let request = FrameRequest {
                camera,
                tau,
                cull: CullTests {
                    frustum: Some(camera.view_volume()),
                    cones: false,
                },
                mode: ShadingMode::Check,
                wireframe: false,
                two_sided: false,
                draw_camera: None,
            };
            for _ in 0..FRAMES_PER_VIEW {
                let frame = streamer.frame(
                    ctx,
                    renderer,
                    &request,
                    Readback {
                        image: true,
                        selection: true,
                    },
                )?;
                let image = renderer.read_image(ctx)?;
                let mut cpu = frame.reference.selection;
                cpu.retain(|&i| repo.tets()[i as usize].strip_index_count > 0);
                if renderer.read_selection(ctx)? != cpu {
                    report.selection_mismatches += 1;
                }
                let flags = image.pixels().filter(|p| p.0 == FLAG_COLOUR).count() as u64;
                report.add_frame(
                    &image,
                    flags,
                    WorstFrame {
                        view,
                        tolerance: tau,
                        flag_pixels: flags,
                        eye,
                    },
                );
            }
        }
    }
    // A frame whose GPU feedback differs from the reference's counts as a mismatch too.
    report.selection_mismatches += streamer.stats().feedback_mismatches as usize;
    Ok(report)
}
