//! `tessera gen mesh`: a deterministic, closed, watertight, 2-manifold procedural mesh of any
//! size with the demo's relief, streamed as binary PLY in constant memory.
//!
//! The connectivity ([`CubeSphere`]) and every position ([`Surface`]) are pure functions of an
//! index, so the writer ([`write_ply`]) computes fixed-size blocks of vertices and triangles
//! (in parallel) and writes them out: memory does not grow with the triangle count, and the
//! same parameters give the same bytes. Counts: exactly the requested number of triangles
//! when it is even, else one more (a closed triangle mesh has an even count: 3F = 2E); at
//! least [`MIN_TRIANGLES`].
//!
//! With texture coordinates ([`GenMesh::with_uvs`]) every cube face is a chart of its own in
//! a 3 × 2 atlas (gutters between the charts), so the vertices on the cube's edges are
//! written once a face: seams, which the importer keeps as wedges of one vertex. `gen mesh
//! --texture N` writes an N × N procedural PNG beside the mesh (`texture.rs`, streamed a row
//! at a time) and names it in the PLY header (`comment TextureFile`, MeshLab's convention).

mod cube_sphere;
mod ply_stream;
mod shuffle;
mod surface;
pub mod texture;

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
    /// Texture coordinates, one chart a cube face ([`GenMesh::with_uvs`]).
    uvs: bool,
    /// The texture file the PLY header names (`comment TextureFile`), beside the PLY
    /// ([`GenMesh::with_texture_file`]).
    texture_file: Option<String>,
}

/// The share of a chart's atlas cell left empty on each side (keeps texels of one chart from
/// bleeding into the next).
const GUTTER: f64 = 1.0 / 64.0;

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
            uvs: false,
            texture_file: None,
        })
    }

    /// The same mesh with texture coordinates (`gen mesh --uv`): one chart a cube face, the
    /// cube's edges written once a face they bound (module docs). The same positions and
    /// triangles; more vertices.
    pub fn with_uvs(mut self, uvs: bool) -> GenMesh {
        self.uvs = uvs;
        let p = self.params;
        self.shuffle = p
            .shuffle_vertices
            .then(|| Shuffle::new(self.vertex_count(), p.seed));
        self
    }

    /// The same mesh whose PLY header names the texture `file` (`comment TextureFile`, a
    /// name relative to the PLY's directory, on one line), as `gen mesh --texture` writes it
    /// beside the mesh (`texture.rs`).
    pub fn with_texture_file(mut self, file: Option<String>) -> GenMesh {
        assert!(
            file.as_ref().is_none_or(|f| !f.contains('\n')),
            "a texture file name on one line"
        );
        self.texture_file = file;
        self
    }

    /// The texture file the PLY header names.
    pub fn texture_file(&self) -> Option<&str> {
        self.texture_file.as_deref()
    }

    /// Whether vertices have texture coordinates.
    pub fn has_uvs(&self) -> bool {
        self.uvs
    }

    pub fn vertex_count(&self) -> u64 {
        match self.uvs {
            true => self.topology.charted_vertex_count(),
            false => self.topology.vertex_count(),
        }
    }

    pub fn triangle_count(&self) -> u64 {
        self.topology.triangle_count()
    }

    /// The cube point of connectivity vertex `i`, in [−1, 1]³.
    fn cube_point(&self, i: u64) -> [f64; 3] {
        let n = self.topology.n;
        let vertex = match self.uvs {
            true => self.topology.charted_vertex(i).0,
            false => self.topology.vertex(i),
        };
        match vertex {
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

    /// The connectivity vertex in slot `slot`.
    fn unshuffled(&self, slot: u64) -> u64 {
        match &self.shuffle {
            Some(s) => s.inverse(slot),
            None => slot,
        }
    }

    /// The position written in vertex slot `slot` (output order).
    pub fn position(&self, slot: u64) -> [f32; 3] {
        let i = self.unshuffled(slot);
        self.surface.position(self.cube_point(i)).map(|x| x as f32)
    }

    /// The texture coordinates written in vertex slot `slot` (with [`GenMesh::with_uvs`]):
    /// face f's chart is cell (f mod 3, f div 3) of a 3 × 2 atlas, inset by [`GUTTER`].
    pub fn uv(&self, slot: u64) -> [f32; 2] {
        let (_, face, chart) = self.topology.charted_vertex(self.unshuffled(slot));
        let cell = [(face % 3) as f64, (face / 3) as f64];
        let cells = [3.0, 2.0];
        [0, 1].map(|k| ((cell[k] + GUTTER + (1.0 - 2.0 * GUTTER) * chart[k]) / cells[k]) as f32)
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
        let corners = match self.uvs {
            true => self.topology.charted_triangle(t),
            false => self.topology.triangle(t),
        };
        corners.map(|i| {
            let slot = match &self.shuffle {
                Some(s) => s.forward(i),
                None => i,
            };
            slot as u32
        })
    }

    /// The whole mesh in memory (for tests and small meshes: O(N), unlike [`write_ply`]);
    /// with texture coordinates, welded as the importer welds the PLY (wedges).
    pub fn to_input_mesh(&self) -> InputMesh {
        if self.uvs {
            let mesh = self.unwelded();
            return crate::import::weld(crate::import::RawMesh {
                positions: mesh.positions,
                triangles: mesh.triangles,
                normals: mesh.normals,
                colors: mesh.colors,
                uvs: mesh.uvs,
            })
            .mesh;
        }
        self.unwelded()
    }

    /// Every vertex slot as written.
    fn unwelded(&self) -> InputMesh {
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
            uvs: self
                .uvs
                .then(|| (0..self.vertex_count()).map(|i| self.uv(i)).collect()),
        }
    }
}

#[cfg(test)]
mod tests;
