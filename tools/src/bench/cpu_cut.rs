//! The measured error of our cut without a GPU: the CPU reference selection
//! (`tessera_core::cut::select_visible`, the rule with the frustum and normal-cone tests of a
//! lit frame — what `Renderer` draws for the same camera), measured like a drawn frame
//! (`measure::drawn_cut` + `measure::pixel_errors`). `bench build` uses it per leaf size.

use tessera_core::cull::CullTests;
use tessera_core::cut::{diamond_rhos, select_visible};
use tessera_core::repository::reader::Repository;
use tessera_runtime::camera::Camera;
use tessera_runtime::measure::{
    drawn_cut, pixel_errors, ErrorSummary, ReferenceMesh, SamplingConfig,
};

/// The error of the τ cut over `cameras`, all samples pooled (`None` when none is on screen).
/// `reference`: the original mesh relative to the repository origin.
pub fn cut_error(
    repo: &Repository,
    reference: &ReferenceMesh,
    cameras: &[Camera],
    tau: f32,
    sampling: &SamplingConfig,
) -> anyhow::Result<Option<ErrorSummary>> {
    let h = repo.header();
    let mut errors = Vec::new();
    for (v, camera) in cameras.iter().enumerate() {
        let eye = camera.eye_local(h.origin);
        let rhos = diamond_rhos(repo.diamonds(), eye, &camera.metric());
        let tests = CullTests {
            frustum: Some(camera.view_volume()),
            cones: true,
        };
        let selection = select_visible(repo.tets(), &rhos, tau, eye, &tests);
        let surface = drawn_cut(repo, &selection)?;
        let sampling = SamplingConfig {
            seed: sampling.seed.wrapping_add(v as u64),
            ..*sampling
        };
        errors.extend(
            pixel_errors(reference, surface.surface(), camera, h.origin, &sampling).errors_px,
        );
    }
    Ok(ErrorSummary::of(&errors))
}
