//! `tessera gen mesh`: a deterministic, closed, watertight, 2-manifold procedural mesh of any
//! size with the demo's relief, streamed as binary PLY in constant memory.
//!
//! The connectivity ([`CubeSphere`]) and every position ([`Surface`]) are pure functions of an
//! index, so the writer ([`write_ply`]) computes fixed-size blocks of vertices and triangles
//! (in parallel) and writes them out: memory does not grow with the triangle count, and the
//! same parameters give the same bytes. Counts: exactly the requested number of triangles
//! when it is even, else one more (a closed triangle mesh has an even count: 3F = 2E); at
//! least [`MIN_TRIANGLES`].

mod cube_sphere;
mod ply_stream;
mod shuffle;
mod surface;

pub use cube_sphere::{CubeSphere, CubeVertex, MAX_TRIANGLES, MIN_TRIANGLES};
pub use ply_stream::{vertex_bytes, write_ply, PLY_FACE_BYTES};
pub use shuffle::Shuffle;
pub use surface::{Surface, MAX_DENSITY_RANGE};

use crate::mesh::InputMesh;

/// What `gen mesh` is asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshParams {
    /// Requested triangles (odd counts round up to even).
    pub triangles: u64,
    pub seed: u64,
    /// Write the vertices in a pseudo-random order ([`Shuffle`]).
    pub shuffle_vertices: bool,
    /// Ratio of the largest to the smallest triangle area the density warp makes (≥ 1).
    pub density_range: f64,
    /// Give every vertex an RGB colour ([`GenMesh::colour`]): a large attributed input.
    pub colour: bool,
}

/// The triangle count made for a request: the request rounded up to even.
pub fn achievable_triangles(requested: u64) -> u64 {
    requested.saturating_add(requested % 2)
}

/// One generated mesh: vertex and triangle `i` in output order, each in O(1).
#[derive(Clone, Debug, PartialEq)]
pub struct GenMesh {
    pub params: MeshParams,
    pub topology: CubeSphere,
    pub surface: Surface,
    shuffle: Option<Shuffle>,
}

impl GenMesh {
    /// Checks the parameters (a message naming the bad one otherwise).
    pub fn new(params: MeshParams) -> Result<GenMesh, String> {
        let r = params.density_range;
        if !(r.is_finite() && (1.0..=MAX_DENSITY_RANGE).contains(&r)) {
            return Err(format!(
                "--density-range {r}: must be a number from 1 to {MAX_DENSITY_RANGE:e}"
            ));
        }
        let topology = CubeSphere::with_triangles(achievable_triangles(params.triangles))
            .map_err(|e| format!("--triangles {}: {e}", params.triangles))?;
        let shuffle = params
            .shuffle_vertices
            .then(|| Shuffle::new(topology.vertex_count(), params.seed));
        Ok(GenMesh {
            params,
            topology,
            surface: Surface::new(params.seed, r),
            shuffle,
        })
    }

    pub fn vertex_count(&self) -> u64 {
        self.topology.vertex_count()
    }

    pub fn triangle_count(&self) -> u64 {
        self.topology.triangle_count()
    }

    /// The cube point of connectivity vertex `i`, in [−1, 1]³.
    fn cube_point(&self, i: u64) -> [f64; 3] {
        let n = self.topology.n;
        match self.topology.vertex(i) {
            CubeVertex::Lattice(p) => p.map(|x| (2 * x) as f64 / n as f64 - 1.0),
            CubeVertex::CellCentre { face, u, v } => {
                let doubled = CubeSphere {
                    n: 2 * n,
                    splits: 0,
                };
                let p = doubled.face_point(face, 2 * u + 1, 2 * v + 1);
                p.map(|x| x as f64 / n as f64 - 1.0)
            }
        }
    }

    /// The position written in vertex slot `slot` (output order).
    pub fn position(&self, slot: u64) -> [f32; 3] {
        let i = match &self.shuffle {
            Some(s) => s.inverse(slot),
            None => slot,
        };
        self.surface.position(self.cube_point(i)).map(|x| x as f32)
    }

    /// The colour written in vertex slot `slot` (with [`MeshParams::colour`]): the direction
    /// from the centre as a hue, darkened in the relief's hollows and lightened on its ridges,
    /// so it varies both with place and at the scale of the relief.
    pub fn colour(&self, slot: u64) -> [u8; 3] {
        let p = self.position(slot).map(f64::from);
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2])
            .sqrt()
            .max(f64::MIN_POSITIVE);
        let shade = (0.55 + 2.0 * (r - 1.0)).clamp(0.2, 1.0);
        p.map(|x| {
            ((0.5 + 0.5 * x / r) * shade * 255.0)
                .round()
                .clamp(0.0, 255.0) as u8
        })
    }

    /// Triangle `t`'s vertex slots (output order), counter-clockwise from outside.
    pub fn triangle(&self, t: u64) -> [u32; 3] {
        self.topology.triangle(t).map(|i| {
            let slot = match &self.shuffle {
                Some(s) => s.forward(i),
                None => i,
            };
            slot as u32
        })
    }

    /// The whole mesh in memory (for tests and small meshes: O(N), unlike [`write_ply`]).
    pub fn to_input_mesh(&self) -> InputMesh {
        InputMesh {
            positions: (0..self.vertex_count())
                .map(|i| self.position(i).map(f64::from))
                .collect(),
            triangles: (0..self.triangle_count())
                .map(|t| self.triangle(t))
                .collect(),
            normals: None,
            colors: self.params.colour.then(|| {
                (0..self.vertex_count())
                    .map(|i| {
                        let [r, g, b] = self.colour(i);
                        [r, g, b, 255]
                    })
                    .collect()
            }),
            uvs: None,
        }
    }
}

#[cfg(test)]
mod tests;
