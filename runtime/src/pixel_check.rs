//! The pixel crack check on the GPU: render a closed model from outside with front faces grey
//! and back faces in `FLAG_COLOUR`; a closed, consistently oriented surface seen from outside
//! shows no back face, so every flag pixel is a crack (or a fold the simplification made).
//!
//! A terrain (a repository of dimension 2) is open: a crack in it shows the background, or the
//! far side of the surface. It is checked from above with the flag on its underside and from
//! below with the flag on its top (`ShadingMode::CheckUnderside`), eyes over its rectangle
//! (`views::terrain_views`), with walls on each frame's border edges that simplify the input's
//! border drawn into both passes (`gpu/skirts.rs`: what a ray through a nodata hole meets is
//! then a wall or nothing, at every τ; a crack gets no wall), and every *hole pixel*
//! (background or flag) counts — except where the input itself lets the eye through: the
//! input (τ = 0, exactly its triangles) is rendered from each view first, and a hole pixel
//! within ⌈2τ⌉ + 1 pixels of one of the input's own hole pixels (beyond the outline, the
//! horizon, down a hole) is counted as `excused_pixels` instead. The reach allows for the
//! cut's error (max about 1.5 τ measured on the dragon); a crack inside the terrain, farther
//! than that from the input's own hole pixels, is a flag pixel.
//!
//! Each frame also reads back the GPU traversal's selection and compares it with the CPU
//! reference (`tessera_core::cut::select_visible`, same f32 operations): a mismatch is counted.
//! Back-face (cone) culling is off here: it would hide exactly the back faces a crack shows.

use tessera_core::cull::CullTests;
use tessera_core::cut::{diamond_rhos, select_visible};
use tessera_core::repository::reader::Repository;

use crate::camera::{bounding_radius, Camera};
use crate::gpu::{
    FrameRequest, GpuContext, GpuFailure, Readback, Renderer, ShadingMode, FLAG_COLOUR,
};
use crate::views::{outside_views, terrain_views};

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

impl PixelCheckReport {
    /// Counts one checked frame with `flags` flag pixels (`frame` names it, with those flags).
    pub(crate) fn add_frame(&mut self, image: &image::RgbaImage, flags: u64, frame: WorstFrame) {
        self.covered_pixels += image.pixels().filter(|p| p.0 != BACKGROUND).count() as u64;
        self.frames += 1;
        self.flag_pixels += flags;
        if flags > 0 {
            self.frames_with_flags += 1;
        }
        if flags > self.worst.as_ref().map_or(0, |w| w.flag_pixels) {
            self.worst = Some(frame);
        }
    }
}

/// Totals over every frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PixelCheckReport {
    pub frames: usize,
    /// Pixels of `FLAG_COLOUR` over all frames (terrains: hole pixels, module comment).
    pub flag_pixels: u64,
    /// Frames with at least one flag pixel.
    pub frames_with_flags: usize,
    /// Frames whose GPU selection differs from the CPU reference.
    pub selection_mismatches: usize,
    /// Pixels covered by the model, over all frames (shows the frames saw something).
    pub covered_pixels: u64,
    /// Terrains: hole pixels next to the input's own (not counted as flags).
    pub excused_pixels: u64,
    /// Terrains: the part of `flag_pixels` seen from below.
    pub flag_pixels_from_below: u64,
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
) -> Result<PixelCheckReport, GpuFailure> {
    let h = repo.header();
    let (width, height) = renderer.size();
    let radius = bounding_radius(h.bbox_min, h.bbox_max);
    if h.dimension == 2 {
        let views: Vec<(Camera, ShadingMode)> = terrain_views(h.bbox_min, h.bbox_max, config.views)
            .into_iter()
            .map(|v| {
                let camera = Camera {
                    up: crate::camera::Z_UP,
                    fov_y_degrees: config.fov_degrees,
                    width,
                    height,
                    ..Camera::looking_at(v.eye, v.target, radius)
                };
                let mode = if v.from_below {
                    ShadingMode::CheckUnderside
                } else {
                    ShadingMode::Check
                };
                (camera, mode)
            })
            .collect();
        // A patch that does not decode is the geometric check's finding; its frames then have
        // no walls, which can only add flag pixels.
        let skirts = crate::gpu::skirts::SkirtSource::new(repo).ok();
        let report = check_views(
            ctx,
            renderer,
            repo,
            &views,
            &config.tolerances,
            skirts.as_ref(),
        );
        renderer.set_check_skirts(ctx, &Default::default());
        return report;
    }
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
) -> Result<PixelCheckReport, GpuFailure> {
    let views: Vec<(Camera, ShadingMode)> =
        cameras.iter().map(|&c| (c, ShadingMode::Check)).collect();
    check_views(ctx, renderer, repo, &views, tolerances, None)
}

const BACKGROUND: [u8; 4] = [0, 0, 0, 255];

/// What the renderer draws of a cut: the CPU reference selection without empty patches (the
/// GPU's read-back selection has none).
fn drawn_selection(
    repo: &Repository,
    rhos: &[f32],
    tau: f32,
    eye_local: [f32; 3],
    cull: &CullTests,
) -> Vec<u32> {
    let mut selection = select_visible(repo.tets(), rhos, tau, eye_local, cull);
    selection.retain(|&i| repo.tets()[i as usize].strip_index_count > 0);
    selection
}

/// Each pixel's Chebyshev distance to the nearest `marked` pixel (`u32::MAX` when none is):
/// the two-pass chessboard distance transform, O(pixels) whatever the reach asked later.
fn chessboard_distance(marked: &[bool], width: usize, height: usize) -> Vec<u32> {
    let mut d: Vec<u32> = marked
        .iter()
        .map(|&m| if m { 0 } else { u32::MAX })
        .collect();
    let step = |v: u32| v.saturating_add(1);
    for y in 0..height {
        for x in 0..width {
            let mut best = d[y * width + x];
            if x > 0 {
                best = best.min(step(d[y * width + x - 1]));
            }
            if y > 0 {
                for xx in x.saturating_sub(1)..(x + 2).min(width) {
                    best = best.min(step(d[(y - 1) * width + xx]));
                }
            }
            d[y * width + x] = best;
        }
    }
    for y in (0..height).rev() {
        for x in (0..width).rev() {
            let mut best = d[y * width + x];
            if x + 1 < width {
                best = best.min(step(d[y * width + x + 1]));
            }
            if y + 1 < height {
                for xx in x.saturating_sub(1)..(x + 2).min(width) {
                    best = best.min(step(d[(y + 1) * width + xx]));
                }
            }
            d[y * width + x] = best;
        }
    }
    d
}

/// (x, y) of every pixel of `image` that is a hole: the flag colour, or with `background`
/// also the background (front faces are never black: their shading is at least 0.1875 grey).
fn hole_pixels(image: &image::RgbaImage, background: bool) -> Vec<(u32, u32)> {
    image
        .enumerate_pixels()
        .filter(|(_, _, p)| p.0 == FLAG_COLOUR || (background && p.0 == BACKGROUND))
        .map(|(x, y, _)| (x, y))
        .collect()
}

/// The check of every (view, τ), each view in its mode. With `terrain` (a height field: its
/// walls), every frame gets the walls of its cut, and the input's own hole pixels (and their
/// neighbourhood) are excused (module comment).
fn check_views(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    repo: &Repository,
    views: &[(Camera, ShadingMode)],
    tolerances: &[f32],
    terrain: Option<&crate::gpu::skirts::SkirtSource>,
) -> Result<PixelCheckReport, GpuFailure> {
    let excuse_input = terrain.is_some();
    let set_walls = |renderer: &mut Renderer, selection: &[u32]| {
        if let Some(source) = terrain {
            let walls = source.walls(repo, selection).unwrap_or_default();
            renderer.set_check_skirts(ctx, &walls);
        }
    };
    assert!(
        views
            .iter()
            .all(|(c, _)| (c.width, c.height) == renderer.size()),
        "every camera has the renderer's size"
    );
    let h = repo.header();
    let mut report = PixelCheckReport::default();
    for (view, &(camera, mode)) in views.iter().enumerate() {
        let eye = camera.eye;
        let cull = CullTests {
            frustum: Some(camera.view_volume()),
            cones: false,
        };
        let eye_local = camera.eye_local(h.origin);
        let rhos = diamond_rhos(repo.diamonds(), eye_local, &camera.metric());
        let request = |tau: f32| FrameRequest {
            camera,
            tau,
            cull,
            mode,
            wireframe: false,
            two_sided: false,
            draw_camera: None,
        };
        // How far (Chebyshev pixels) each pixel is from one of the input's own hole pixels.
        let (width, height) = renderer.size();
        let input_hole_distance = if excuse_input {
            let input = drawn_selection(repo, &rhos, 0.0, eye_local, &cull);
            set_walls(renderer, &input);
            renderer.render(
                ctx,
                &request(0.0),
                Readback {
                    image: true,
                    selection: false,
                },
            );
            let mut holes = vec![false; (width * height) as usize];
            for (x, y) in hole_pixels(&renderer.read_image(ctx)?, true) {
                holes[(y * width + x) as usize] = true;
            }
            Some(chessboard_distance(&holes, width as usize, height as usize))
        } else {
            None
        };
        for &tau in tolerances {
            let cpu = drawn_selection(repo, &rhos, tau, eye_local, &cull);
            set_walls(renderer, &cpu);
            renderer.render(
                ctx,
                &request(tau),
                Readback {
                    image: true,
                    selection: true,
                },
            );
            let image = renderer.read_image(ctx)?;
            let gpu = renderer.read_selection(ctx)?;
            if gpu != cpu {
                report.selection_mismatches += 1;
            }
            let mut flags = 0u64;
            let reach = (2.0 * tau.max(0.0)).ceil() as u32 + 1;
            for (x, y) in hole_pixels(&image, excuse_input) {
                let near_input_hole = input_hole_distance
                    .as_ref()
                    .is_some_and(|d| d[(y * width + x) as usize] <= reach);
                if near_input_hole {
                    report.excused_pixels += 1;
                } else {
                    flags += 1;
                }
            }
            if mode == ShadingMode::CheckUnderside {
                report.flag_pixels_from_below += flags;
            }
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
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::chessboard_distance;

    #[test]
    fn the_distance_transform_is_the_brute_force_chebyshev_distance() {
        let (w, h) = (23, 17);
        let mut seed = 12345u64;
        let marked: Vec<bool> = (0..w * h)
            .map(|_| {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (seed >> 33).is_multiple_of(29)
            })
            .collect();
        let d = chessboard_distance(&marked, w, h);
        for y in 0..h {
            for x in 0..w {
                let brute = (0..h)
                    .flat_map(|yy| (0..w).map(move |xx| (xx, yy)))
                    .filter(|&(xx, yy)| marked[yy * w + xx])
                    .map(|(xx, yy)| x.abs_diff(xx).max(y.abs_diff(yy)) as u32)
                    .min()
                    .unwrap_or(u32::MAX);
                assert_eq!(d[y * w + x], brute, "({x}, {y})");
            }
        }
        assert!(chessboard_distance(&[false; 6], 3, 2)
            .iter()
            .all(|&v| v == u32::MAX));
    }
}
