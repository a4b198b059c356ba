//! The checks a build makes before it starts: of its settings, and of a mesh in memory
//! (`staged_build::validate_staged` makes the same on disk).

use crate::build_config::{BuildConfig, BuildError, MAX_EXTENT};
use crate::hierarchy::Construction;
use crate::mesh::InputMesh;
use crate::simplify::SimplifySettings;

/// The mesh's checks (`staged_build::validate_staged` makes the same on disk); returns its
/// bounding box.
pub(crate) fn validate(mesh: &InputMesh) -> Result<([f64; 3], [f64; 3]), BuildError> {
    if mesh.triangles.is_empty() {
        return Err(BuildError::EmptyMesh);
    }
    if let Some(index) = mesh
        .positions
        .iter()
        .position(|p| p.iter().any(|x| !x.is_finite()))
    {
        return Err(BuildError::NonFinite { index });
    }
    // Spheres and errors are stored in f32 relative to the model: its extent must leave f32
    // room (1e30 is far beyond any real model and far below f32::MAX ≈ 3.4e38).
    let (lo, hi) = bounding_box(&mesh.positions);
    // (Extents are finite: the coordinates were checked above.)
    if let Some(axis) = (0..3).find(|&i| hi[i] - lo[i] > MAX_EXTENT) {
        return Err(BuildError::TooLarge {
            axis,
            extent: hi[axis] - lo[axis],
        });
    }
    // Connectivity is by vertex: two wedges of one vertex are one corner (`mesh.rs`).
    let starts = mesh.vertex_starts();
    for (index, t) in mesh.triangles.iter().enumerate() {
        if let Some(&vertex) = t.iter().find(|&&v| v as usize >= mesh.positions.len()) {
            return Err(BuildError::IndexOutOfRange {
                index,
                vertex,
                count: mesh.positions.len(),
            });
        }
        let t = &t.map(|w| starts.canonical(w));
        // Such a triangle has no edge of its own and no strip can hold it: the repository
        // would silently lose it, and τ = 0 would not give back the input. (Triangles of zero
        // area over three distinct vertices, duplicates and coincident vertices are kept.)
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            let vertex = if t[1] == t[2] { t[1] } else { t[0] };
            return Err(BuildError::RepeatedVertex { index, vertex });
        }
    }
    Ok((lo, hi))
}

pub(crate) fn validate_config(config: &BuildConfig) -> Result<(), BuildError> {
    let SimplifySettings {
        keep,
        normal_weight,
        colour_weight,
        uv_weight,
        coarsest_share,
        ..
    } = config.simplify;
    let keep_ok = keep > 0.0 && keep < 1.0;
    let weight_ok = [normal_weight, colour_weight, uv_weight]
        .iter()
        .all(|w| *w >= 0.0 && w.is_finite());
    let share_ok = coarsest_share > 0.0 && coarsest_share <= 1.0;
    if !keep_ok || !weight_ok || !share_ok {
        return Err(BuildError::Config(format!(
            "simplifier keep {keep} must be in (0, 1), normal weight {normal_weight}, colour \
             weight {colour_weight} and uv weight {uv_weight} finite and ≥ 0, coarsest share \
             {coarsest_share} in (0, 1]"
        )));
    }
    if !(4..=30).contains(&config.lattice_bits) {
        return Err(BuildError::Config(format!(
            "lattice bits {} not in 4..=30",
            config.lattice_bits
        )));
    }
    if config.lattice_bits + config.headroom > 30 {
        return Err(BuildError::Config(format!(
            "lattice bits {} with headroom {} exceed 30",
            config.lattice_bits, config.headroom
        )));
    }
    match config.construction {
        Construction::LeafTriangles(0) => Err(BuildError::Config(
            "leaf triangles must be at least 1".into(),
        )),
        Construction::Levels(l) if l as u32 > config.domain.dim() as u32 * config.lattice_bits => {
            Err(BuildError::Config(format!(
                "{l} levels exceed the lattice's {} levels",
                config.domain.dim() as u32 * config.lattice_bits
            )))
        }
        _ => Ok(()),
    }
}

fn bounding_box(positions: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in positions {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    (lo, hi)
}
