//! The checks every triangle mesh handed to the runtime from outside a repository gets (the
//! benchmarks' peers and references): finite positions, indices within the vertices.

/// What is wrong with a triangle mesh.
#[derive(Clone, Copy, Debug, thiserror::Error, PartialEq)]
pub enum MeshProblem {
    #[error("triangle {triangle} uses vertex {vertex}, but the mesh has {count} vertices")]
    IndexOutOfRange {
        triangle: usize,
        vertex: u32,
        count: usize,
    },
    #[error("vertex {vertex} has a non-finite coordinate")]
    NonFinite { vertex: usize },
}

/// The first vertex with a NaN or infinite coordinate, as an error.
pub fn check_finite<T: Copy + Into<f64>>(positions: &[[T; 3]]) -> Result<(), MeshProblem> {
    match positions
        .iter()
        .position(|p| !p.iter().all(|&x| x.into().is_finite()))
    {
        Some(vertex) => Err(MeshProblem::NonFinite { vertex }),
        None => Ok(()),
    }
}

/// The first triangle with an index ≥ `count`, as an error.
pub fn check_indices(triangles: &[[u32; 3]], count: usize) -> Result<(), MeshProblem> {
    for (triangle, t) in triangles.iter().enumerate() {
        if let Some(&vertex) = t.iter().find(|&&v| v as usize >= count) {
            return Err(MeshProblem::IndexOutOfRange {
                triangle,
                vertex,
                count,
            });
        }
    }
    Ok(())
}
