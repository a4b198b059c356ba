//! The surface a set of patches draws, dequantised to model coordinates, and how far an
//! object-space cut of a repository is from its leaves (the input on the position lattice):
//! what `tessera bench errors` and the bounded-error tests measure.

use super::format::{dequantize_position, NO_INDEX};
use super::reader::{Repository, RepositoryError};
use crate::cut::select_stateless;
use crate::hausdorff::sampled_directed;

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
    let drawn = select_stateless(tets, &errors, epsilon);
    let largest_error = drawn
        .iter()
        .map(|&t| match tets[t as usize].diamond {
            NO_INDEX => 0.0,
            d => errors[d as usize] as f64,
        })
        .fold(0.0, f64::max);
    let cut = patch_surface(repo, drawn.iter().map(|&t| t as usize))?;
    // One position list: the cut's vertices, then the leaves'.
    let offset = cut.positions.len() as u32;
    let positions: Vec<[f64; 3]> = cut
        .positions
        .iter()
        .chain(&leaves.positions)
        .copied()
        .collect();
    let leaf_indices: Vec<u32> = leaves.indices.iter().map(|i| i + offset).collect();
    let distance = sampled_directed(&positions, &cut.indices, &leaf_indices, cut_steps).max(
        sampled_directed(&positions, &leaf_indices, &cut.indices, leaf_steps),
    );
    let points = |steps: usize| ((steps + 1) * (steps + 2) / 2) as u64;
    Ok(CutMeasure {
        simplices: drawn.len(),
        triangles: cut.triangle_count(),
        largest_error,
        distance,
        samples: cut.triangle_count() as u64 * points(cut_steps)
            + leaves.triangle_count() as u64 * points(leaf_steps),
    })
}
