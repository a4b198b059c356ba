//! Where the streaming readers put what they read: in memory (`RawMesh`) or on disk
//! (`RawStager`, the out-of-core build's staging), through one trait, so that a file read
//! either way gives the same vertices and triangles.

use super::error::ImportErrorKind as K;
use super::RawMesh;
use crate::external::{RawStager, RawVertex};

/// Where a reader puts what it reads: in memory (`RawMesh`) or on disk (`RawStager`, the
/// out-of-core build's staging).
pub(crate) trait MeshSink {
    fn vertex(&mut self, v: &RawVertex) -> Result<(), K>;
    fn triangles(&mut self, t: &[[u32; 3]]) -> Result<(), K>;
    /// Drops the colours (an OBJ keeps them only if every vertex has them, which is known
    /// only at its end).
    fn forget_colors(&mut self);
}

impl MeshSink for RawMesh {
    fn vertex(&mut self, v: &RawVertex) -> Result<(), K> {
        self.positions.push(v.position);
        if let Some(n) = &mut self.normals {
            n.push(v.normal);
        }
        if let Some(c) = &mut self.colors {
            c.push(v.color);
        }
        if let Some(uv) = &mut self.uvs {
            uv.push(v.uv);
        }
        Ok(())
    }

    fn triangles(&mut self, t: &[[u32; 3]]) -> Result<(), K> {
        self.triangles.extend_from_slice(t);
        Ok(())
    }

    fn forget_colors(&mut self) {
        self.colors = None;
    }
}

impl MeshSink for RawStager {
    fn vertex(&mut self, v: &RawVertex) -> Result<(), K> {
        self.push_vertex(v).map_err(K::Io)
    }

    fn triangles(&mut self, t: &[[u32; 3]]) -> Result<(), K> {
        self.push_triangles(t).map_err(K::Io)
    }

    fn forget_colors(&mut self) {
        RawStager::forget_colors(self);
    }
}

/// The attributes a file's vertices carry, and how many vertices and face-like records its
/// header declares (a hint for preallocation, bounded by the file's size where known).
pub(crate) struct Declared {
    pub normals: bool,
    pub colors: bool,
    pub uvs: bool,
    pub vertex_capacity: usize,
    pub face_capacity: usize,
}

/// An in-memory mesh with room for what `d` declares.
pub(crate) fn in_memory(d: &Declared) -> RawMesh {
    RawMesh {
        positions: Vec::with_capacity(d.vertex_capacity),
        triangles: Vec::with_capacity(d.face_capacity),
        normals: d.normals.then(|| Vec::with_capacity(d.vertex_capacity)),
        colors: d.colors.then(|| Vec::with_capacity(d.vertex_capacity)),
        uvs: d.uvs.then(|| Vec::with_capacity(d.vertex_capacity)),
    }
}

/// A vertex with a position and no attributes (or their defaults).
pub(crate) fn at(position: [f64; 3]) -> RawVertex {
    RawVertex {
        position,
        normal: [0.0; 3],
        color: [0, 0, 0, 255],
        uv: [0.0; 2],
    }
}
