//! The measured error of our cut without a GPU: the CPU reference selection
//! (`tessera_core::cut::select_visible`, the rule with the frustum and normal-cone tests of a
//! lit frame — what `Renderer` draws for the same camera), measured like a drawn frame
//! (`measure::drawn_cut` + `measure::two_sided_errors`: both ways, visible samples only, as
//! `bench` measures). `bench build` uses it per leaf size.

use tessera_core::cull::CullTests;
use tessera_core::cut::{diamond_rhos, select_visible};
use tessera_core::repository::reader::Repository;
use tessera_runtime::camera::Camera;
use tessera_runtime::faces::Faces;
use tessera_runtime::measure::{
    drawn_cut, original_sampling, two_sided_errors, visible_samples, ErrorSummary, ReferenceMesh,
    SamplingConfig,
};

/// The two-sided error of the τ cut over `cameras`, all samples of both directions pooled
/// (`None` when none is seen).
/// `reference`: the original mesh relative to the repository origin.
pub fn cut_error(
    repo: &Repository,
    reference: &ReferenceMesh,
    cameras: &[Camera],
    tau: f32,
    sampling: &SamplingConfig,
) -> anyhow::Result<Option<ErrorSummary>> {
    let rule = |camera: &Camera, eye| diamond_rhos(repo.diamonds(), eye, &camera.metric());
    Ok(cut_error_with(repo, reference, cameras, tau, sampling, rule)?.error)
}

/// A measured cut over several views: its mean triangle count and the pooled error.
pub struct MeasuredCut {
    pub triangles: f64,
    pub error: Option<ErrorSummary>,
}

/// `cut_error` with each camera's ρ from `rhos_of(camera, eye_local)` instead of the
/// run-time rule (`bench breakdown` measures another projection this way), and the cut's
/// triangles (mean over the views) besides the error.
pub fn cut_error_with(
    repo: &Repository,
    reference: &ReferenceMesh,
    cameras: &[Camera],
    tau: f32,
    sampling: &SamplingConfig,
    rhos_of: impl Fn(&Camera, [f32; 3]) -> Vec<f32>,
) -> anyhow::Result<MeasuredCut> {
    let h = repo.header();
    let mut errors = Vec::new();
    let mut triangles = 0u64;
    for (v, camera) in cameras.iter().enumerate() {
        let eye = camera.eye_local(h.origin);
        let rhos = rhos_of(camera, eye);
        let tests = CullTests {
            frustum: Some(camera.view_volume()),
            cones: true,
        };
        let selection = select_visible(repo.tets(), &rhos, tau, eye, &tests);
        triangles += selection
            .iter()
            .map(|&t| repo.tets()[t as usize].triangle_count as u64)
            .sum::<u64>();
        let surface = drawn_cut(repo, &selection)?;
        let sampling = SamplingConfig {
            seed: sampling.seed.wrapping_add(v as u64),
            ..*sampling
        };
        // One-sided, as the cut was culled (normal cones on).
        let original = visible_samples(
            reference,
            camera,
            h.origin,
            &original_sampling(&sampling),
            Faces::Front,
        );
        let both = two_sided_errors(
            reference,
            &original,
            surface.surface(),
            camera,
            h.origin,
            &sampling,
            Faces::Front,
        )?;
        errors.extend(both.to_original.errors_px);
        errors.extend(both.to_cut.errors_px);
    }
    Ok(MeasuredCut {
        triangles: triangles as f64 / cameras.len().max(1) as f64,
        error: ErrorSummary::of(&errors),
    })
}
