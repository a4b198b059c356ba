//! The surface a set of patches draws, dequantised to model coordinates, and how far a cut
//! is from the repository's leaves (the input on the position lattice): object-space cuts
//! (`tessera bench errors`, the bounded-error tests), screen-space cuts in pixels (`check
//! --errors`), and any triangle surface measured the same way (`measure_screen_surface`: the
//! peers' cuts in `tessera bench`'s dense error pass).

use super::format::{dequantize_position, NO_INDEX};
use super::reader::{Repository, RepositoryError};
use crate::cut::{diamond_rhos, select_stateless};
use crate::hausdorff::sampled_directed_weighted;
use crate::metric::{eye_local, ScreenSpaceMetric};
use crate::vec3::{length, sub};

/// Triangles as one position list (model units) and a flat index list into it.
#[derive(Clone, Debug, Default)]
pub struct PatchSurface {
    pub positions: Vec<[f64; 3]>,
    pub indices: Vec<u32>,
}

impl PatchSurface {
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }
}

/// The triangles of the patches of `tets`, each patch's vertices once.
pub fn patch_surface(
    repo: &Repository,
    tets: impl IntoIterator<Item = usize>,
) -> Result<PatchSurface, RepositoryError> {
    let h = repo.header();
    let mut surface = PatchSurface::default();
    for t in tets {
        let patch = repo.patch(t)?;
        let view = patch.view();
        let first = surface.positions.len() as u32;
        surface.positions.extend(
            (0..view.vertex_count())
                .map(|v| dequantize_position(view.position(v), h.bbox_min, h.position_step)),
        );
        surface
            .indices
            .extend(view.triangles().flatten().map(|i| first + i));
    }
    Ok(surface)
}

/// The leaves' triangles: the input, on the position lattice.
pub fn leaf_surface(repo: &Repository) -> Result<PatchSurface, RepositoryError> {
    let tets = repo.tets();
    patch_surface(
        repo,
        (0..tets.len()).filter(|&t| tets[t].diamond == NO_INDEX),
    )
}

/// One object-space cut against the leaves.
#[derive(Clone, Copy, Debug)]
pub struct CutMeasure {
    /// Simplices drawn: err(diamond) ≤ ε < err(parent diamond).
    pub simplices: usize,
    pub triangles: usize,
    /// The largest stored error of a drawn simplex's diamond (0 for leaves).
    pub largest_error: f64,
    /// The largest sampled distance, both ways between the cut and the leaves: exact at each
    /// sample, so a lower bound on the two-sided Hausdorff distance.
    pub distance: f64,
    /// Points sampled: `cut_steps` and `leaf_steps` lattice steps a triangle side.
    pub samples: u64,
}

/// The simplices of the object-space cut at `epsilon`: err(diamond) ≤ ε < err(parent diamond).
pub fn object_cut(repo: &Repository, epsilon: f32) -> Vec<u32> {
    let errors: Vec<f32> = repo.diamonds().iter().map(|d| d.error).collect();
    select_stateless(repo.tets(), &errors, epsilon)
}

/// Measures the cut at object-space threshold `epsilon` against `leaves` (`leaf_surface`).
pub fn measure_object_cut(
    repo: &Repository,
    leaves: &PatchSurface,
    epsilon: f32,
    cut_steps: usize,
    leaf_steps: usize,
) -> Result<CutMeasure, RepositoryError> {
    let errors: Vec<f32> = repo.diamonds().iter().map(|d| d.error).collect();
    let tets = repo.tets();
    let drawn = object_cut(repo, epsilon);
    let largest_error = drawn
        .iter()
        .map(|&t| match tets[t as usize].diamond {
            NO_INDEX => 0.0,
            d => errors[d as usize] as f64,
        })
        .fold(0.0, f64::max);
    let cut = patch_surface(repo, drawn.iter().map(|&t| t as usize))?;
    let (distance, samples) = both_ways(&cut, leaves, (cut_steps, leaf_steps), |_, d| d, |_, d| d);
    Ok(CutMeasure {
        simplices: drawn.len(),
        triangles: cut.triangle_count(),
        largest_error,
        distance,
        samples,
    })
}

/// One screen-space cut (the run-time rule for an eye, no culling), or any surface, against
/// the leaves.
#[derive(Clone, Copy, Debug)]
pub struct ScreenCutMeasure {
    pub triangles: usize,
    /// The largest sampled error in pixels, both ways (see `measure_screen_surface`).
    pub max_px: f64,
    pub samples: u64,
}

/// The quantisation error of `repo`'s positions: half the diagonal of a position step (the
/// leaves stand within it of the input; every stored error counts it).
pub fn quantisation_error(repo: &Repository) -> f64 {
    let h = repo.header();
    0.5 * h.position_step.iter().map(|s| s * s).sum::<f64>().sqrt()
}

/// Measures the cut the rule draws at `tau` pixels for `eye` (model coordinates) with
/// `metric`, against `leaves`, in pixels: the run-time rule's selection without culling,
/// measured by `measure_screen_surface` with `repo`'s quantisation error. What `check
/// --errors` reports for each of its cuts.
pub fn measure_screen_cut(
    repo: &Repository,
    leaves: &PatchSurface,
    eye: [f64; 3],
    metric: &ScreenSpaceMetric,
    tau: f32,
    steps: (usize, usize),
) -> Result<ScreenCutMeasure, RepositoryError> {
    let h = repo.header();
    let rhos = diamond_rhos(repo.diamonds(), eye_local(eye, h.origin), metric);
    let drawn = select_stateless(repo.tets(), &rhos, tau);
    let cut = patch_surface(repo, drawn.iter().map(|&t| t as usize))?;
    let q = quantisation_error(repo);
    Ok(measure_screen_surface(&cut, leaves, eye, metric, q, steps))
}

/// Measures any triangle surface `cut` (model coordinates: ours, a peer's selection, a
/// simplified mesh) against `leaves` (`leaf_surface`) for `eye` (model coordinates) in pixels
/// of `metric`, sampled both ways, in the terms the stored errors bound (`build
/// --bounded-errors`):
/// - a cut sample x at distance d from the leaves counts (d − q)·k / max(|x − eye|, near):
///   x lies in its diamond's sphere, so |x − eye| is at least the distance ρ divides by;
/// - a leaf sample y at distance d from the cut counts (d − q)·k / max(|y − eye| + d, near):
///   the point of the cut y is carried to is at most that far from the eye;
///
/// with q the quantisation error (`quantisation_error`: the leaves stand within it of the
/// input the bounds are measured against). Each is a lower estimate of what the bound covers,
/// so a value above τ shows the stored errors are not bounds for this view. Every sample
/// counts, seen from the eye or not, facing it or not.
///
/// Density: a barycentric lattice of `steps.0` steps a side on each cut triangle and `steps.1`
/// on each leaf ((s+1)(s+2)/2 points each; `check --errors` uses (4, 2): 15 and 6). An empty
/// cut against non-empty leaves measures infinite. The leaves measured against themselves
/// measure 0.
///
/// Cost: one nearest-triangle query per sample, so about the leaves' samples (6 a leaf at
/// s = 2) plus the cut's; a grid is built over each side once per call.
pub fn measure_screen_surface(
    cut: &PatchSurface,
    leaves: &PatchSurface,
    eye: [f64; 3],
    metric: &ScreenSpaceMetric,
    q: f64,
    steps: (usize, usize),
) -> ScreenCutMeasure {
    assert!(q >= 0.0 && q.is_finite(), "quantisation error {q}");
    assert!(eye.iter().all(|x| x.is_finite()), "eye {eye:?}");
    let (k, near) = (metric.k as f64, metric.near as f64);
    let from_eye = |p: [f64; 3]| length(sub(p, eye));
    let (max_px, samples) = both_ways(
        cut,
        leaves,
        steps,
        |p, d| match d.is_finite() {
            true => (d - q).max(0.0) * k / from_eye(p).max(near),
            false => f64::INFINITY,
        },
        |p, d| match d.is_finite() {
            true => (d - q).max(0.0) * k / (from_eye(p) + d).max(near),
            false => f64::INFINITY,
        },
    );
    ScreenCutMeasure {
        triangles: cut.triangle_count(),
        max_px,
        samples,
    }
}

/// The largest weighed sample distance both ways between `cut` and `leaves` (`weigh_cut` for
/// samples on the cut, `weigh_leaf` for samples on the leaves, `steps` lattice steps a side on
/// each), and the number of samples.
fn both_ways(
    cut: &PatchSurface,
    leaves: &PatchSurface,
    steps: (usize, usize),
    weigh_cut: impl Fn([f64; 3], f64) -> f64,
    weigh_leaf: impl Fn([f64; 3], f64) -> f64,
) -> (f64, u64) {
    // One position list: the cut's vertices, then the leaves'.
    let offset = cut.positions.len() as u32;
    let positions: Vec<[f64; 3]> = cut
        .positions
        .iter()
        .chain(&leaves.positions)
        .copied()
        .collect();
    let leaf_indices: Vec<u32> = leaves.indices.iter().map(|i| i + offset).collect();
    let forward =
        sampled_directed_weighted(&positions, &cut.indices, &leaf_indices, steps.0, weigh_cut);
    let reverse =
        sampled_directed_weighted(&positions, &leaf_indices, &cut.indices, steps.1, weigh_leaf);
    let points = |steps: usize| ((steps + 1) * (steps + 2) / 2) as u64;
    let samples = cut.triangle_count() as u64 * points(steps.0)
        + leaves.triangle_count() as u64 * points(steps.1);
    (forward.max(reverse), samples)
}
