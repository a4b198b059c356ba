//! The surface a set of patches draws, dequantised to model coordinates: what measurements of
//! a cut against the input compare (`tessera bench errors`, the bounded-error tests).

use super::format::dequantize_position;
use super::reader::{Repository, RepositoryError};

/// The triangles of the patches of `tets`, as one position list (model units, each patch's
/// vertices once) and a flat index list into it.
pub fn patch_surface(
    repo: &Repository,
    tets: impl IntoIterator<Item = usize>,
) -> Result<(Vec<[f64; 3]>, Vec<u32>), RepositoryError> {
    let h = repo.header();
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for t in tets {
        let patch = repo.patch(t)?;
        let view = patch.view();
        let first = positions.len() as u32;
        positions.extend(
            (0..view.vertex_count())
                .map(|v| dequantize_position(view.position(v), h.bbox_min, h.position_step)),
        );
        indices.extend(view.triangles().flatten().map(|i| first + i));
    }
    Ok((positions, indices))
}
