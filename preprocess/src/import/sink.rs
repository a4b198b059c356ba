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
    /// The last `triangles` triangles (one face's) have the face colour `color`: their
    /// corners are wedges of that colour (`FaceColored`). Refused where wedges cannot be kept
    /// (the out-of-core staging).
    fn face_color(&mut self, triangles: usize, color: [u8; 4]) -> Result<(), K> {
        let _ = (triangles, color);
        Err(K::Unsupported {
            at: super::error::Location::None,
            what: "per-face colours in the out-of-core build (--memory keeps no wedges yet; \
                   build without --memory)"
                .into(),
        })
    }
}

/// An in-memory mesh whose faces may carry colours (PLY `face` red/green/blue, OFF colours
/// after a face's indices): each coloured face's corners become raw vertices of their own with
/// the face's colour (`finish`), which the weld keeps as wedges where faces around a vertex
/// differ, and welds back where they agree.
pub(crate) struct FaceColored {
    pub mesh: RawMesh,
    /// The colour of each triangle so far, where its face has one.
    colors: Vec<Option<[u8; 4]>>,
}

impl FaceColored {
    pub fn new(mesh: RawMesh) -> FaceColored {
        FaceColored {
            mesh,
            colors: Vec::new(),
        }
    }

    /// The mesh with its face colours on corners of their own (unchanged without any).
    pub fn finish(self) -> RawMesh {
        let FaceColored { mut mesh, colors } = self;
        if colors.iter().all(Option::is_none) {
            return mesh;
        }
        let n = mesh.positions.len();
        let mut vertex_colors = mesh.colors.take().unwrap_or_else(|| vec![[255; 4]; n]);
        // A vertex no uncoloured face uses takes its first face colour itself; a copy is made
        // only for each further colour (a file whose faces agree reads as vertex colours).
        let mut own = vec![true; n];
        for (t, color) in mesh.triangles.iter().zip(&colors) {
            if color.is_none() {
                t.iter().for_each(|&v| own[v as usize] = false);
            }
        }
        let mut corner_of: rustc_hash::FxHashMap<(u32, [u8; 4]), u32> = Default::default();
        for (t, color) in mesh.triangles.iter_mut().zip(&colors) {
            let Some(c) = *color else { continue };
            for v in t.iter_mut() {
                if std::mem::replace(&mut own[*v as usize], false) {
                    vertex_colors[*v as usize] = c;
                    corner_of.insert((*v, c), *v);
                }
                let next = mesh.positions.len() as u32;
                let at = *corner_of.entry((*v, c)).or_insert(next);
                if at == next {
                    let i = *v as usize;
                    mesh.positions.push(mesh.positions[i]);
                    if let Some(normals) = &mut mesh.normals {
                        normals.push(normals[i]);
                    }
                    if let Some(uvs) = &mut mesh.uvs {
                        uvs.push(uvs[i]);
                    }
                    vertex_colors.push(c);
                }
                *v = at;
            }
        }
        mesh.colors = Some(vertex_colors);
        mesh
    }
}

impl MeshSink for FaceColored {
    fn vertex(&mut self, v: &RawVertex) -> Result<(), K> {
        self.mesh.vertex(v)
    }

    fn triangles(&mut self, t: &[[u32; 3]]) -> Result<(), K> {
        self.colors.extend(t.iter().map(|_| None));
        self.mesh.triangles(t)
    }

    fn forget_colors(&mut self) {
        self.mesh.forget_colors();
    }

    fn face_color(&mut self, triangles: usize, color: [u8; 4]) -> Result<(), K> {
        let from = self.colors.len() - triangles;
        self.colors[from..].fill(Some(color));
        Ok(())
    }
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

    fn face_color(&mut self, triangles: usize, color: [u8; 4]) -> Result<(), K> {
        RawStager::face_color(self, triangles, color).map_err(K::Io)
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
