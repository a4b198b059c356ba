//! The terrain part of `tessera demo`: a diamond-square terrain with a map of regions
//! (seed 002, `tessera gen terrain`'s defaults), built on the 2D hierarchy and put through the
//! geometric check; with a GPU also rendered (lit at τ = 1 px) and put through the pixel check
//! from above and below.

use std::path::Path;
use std::time::Instant;

use tessera_core::repository::reader::Repository;
use tessera_preprocess::dem::TerrainOptions;
use tessera_preprocess::diamond_square::{generate, TerrainParams};
use tessera_preprocess::{build_repository, BuildConfig, Domain};
use tessera_runtime::camera::{Camera, Z_UP};
use tessera_runtime::geometric_check::{check_cuts, decode_all_patches, CheckConfig};
use tessera_runtime::gpu::{FrameRequest, GpuContext, Renderer, RendererOptions};
use tessera_runtime::pixel_check::{check_pixels, PixelCheckConfig};

use crate::output::save_png;

/// The frame written next to the mesh's.
pub const TERRAIN_FRAME: &str = "terrain-lit-tau-1.png";

/// Views of the terrain's pixel check (half from below).
const PIXEL_VIEWS: usize = 8;

/// What the terrain part found: lines of the report, and whether both checks were clean.
pub struct TerrainDemo {
    pub lines: Vec<String>,
    pub clean: bool,
}

/// Generates, builds and checks the terrain in `dir_for_repo`; renders into `frames_dir` when
/// given and a GPU is there (else says why not).
pub fn terrain_demo(
    dir_for_repo: &Path,
    views: usize,
    frames_dir: Option<&Path>,
    device: &tessera_runtime::gpu::DeviceOptions,
    size: (u32, u32),
) -> anyhow::Result<TerrainDemo> {
    let params = TerrainParams::default();
    let t = Instant::now();
    let grid = generate(&params)?;
    let mut mesh = grid.to_mesh(&TerrainOptions::default());
    // As `tessera build` of the same grid: shaded with computed normals.
    tessera_preprocess::normals::compute_missing_normals(&mut mesh);
    let generate_seconds = t.elapsed().as_secs_f64();
    let path = dir_for_repo.join("terrain.tsr");
    let config = BuildConfig::for_domain(Domain::HeightField);
    let summary = build_repository(&mesh, &config, &path, &|_| {})?;
    let repo = Repository::open(&path)?;
    let t = Instant::now();
    let patches = decode_all_patches(&repo)?;
    let report = check_cuts(
        &repo,
        &patches,
        &CheckConfig {
            views,
            ..Default::default()
        },
    );
    drop(patches);
    let mut lines = vec![
        format!(
            "terrain: diamond-square, {} × {} samples {} m apart, regions {} (seed {}; \
             `tessera gen terrain` makes it), {} triangles, generated in {generate_seconds:.2} s",
            grid.columns,
            grid.rows,
            params.spacing,
            params.regions.join(","),
            params.seed,
            mesh.triangles.len()
        ),
        format!(
            "  built in {:.2} s (2D hierarchy: {} triangles, depth {}, {:.1} triangles a patch), {} bytes",
            summary.seconds,
            summary.tetrahedra,
            summary.depth,
            summary.patch_triangles as f64 / summary.tetrahedra.max(1) as f64,
            summary.repository_bytes
        ),
        format!(
            "  geometric check: {} cuts in {:.2} s: {} cracks, {} non-manifold edges introduced, {} monotonicity violations",
            report.cuts_checked,
            t.elapsed().as_secs_f64(),
            report.cracks,
            report.nonmanifold_introduced,
            report.monotonicity_violations
        ),
    ];
    let mut clean = report.is_clean();
    if let Some(dir) = frames_dir {
        match GpuContext::open(device) {
            Err(e) => lines.push(format!(
                "  terrain frames skipped: {}",
                e.to_string().trim_end()
            )),
            Ok(ctx) => {
                let (width, height) = size;
                let mut renderer = Renderer::new(
                    &ctx,
                    &repo,
                    RendererOptions {
                        width,
                        height,
                        ..Default::default()
                    },
                )?;
                let h = repo.header();
                let camera = Camera {
                    width,
                    height,
                    ..Camera::orbit(h.bbox_min, h.bbox_max, Z_UP, 30.0, 35.0, 1.4)
                };
                let frame = renderer.render_and_read(&ctx, &FrameRequest::new(camera, 1.0))?;
                let file = dir.join(TERRAIN_FRAME);
                save_png(&frame.image, &file)?;
                lines.push(format!(
                    "  {}: lit at τ = 1 px: {} patches, {} triangles (camera as `tessera render --orbit 30,35,1.4`)",
                    file.display(),
                    frame.selection.len(),
                    frame.triangles
                ));
                let px = check_pixels(
                    &ctx,
                    &mut renderer,
                    &repo,
                    &PixelCheckConfig {
                        views: PIXEL_VIEWS,
                        ..Default::default()
                    },
                )?;
                lines.push(format!(
                    "  pixel check from above and below: {} frames, {} flag pixels, {} selection mismatches",
                    px.frames, px.flag_pixels, px.selection_mismatches
                ));
                clean &= px.is_clean();
            }
        }
    }
    Ok(TerrainDemo { lines, clean })
}
