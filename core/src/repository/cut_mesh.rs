//! A cut as one welded mesh: the triangles of the patches of a set of simplices, their vertices
//! merged by global vertex id and stored attributes (the wedges of one vertex, which share its
//! id and differ in attributes at a texture seam or a crease, stay apart), positions in model
//! units and the stored attributes decoded, for exporting what a view draws (`tessera view`'s
//! PLY export).
//!
//! Locked diamond borders share global ids, so a conforming cut of a closed input welds into a
//! watertight mesh (the tests in `tests/tests/cut_mesh.rs` check it).

use std::collections::HashMap;

use super::format::{dequantize_position, oct_decode_normal, ATTR_COLORS, ATTR_NORMALS, ATTR_UVS};
use super::reader::{Repository, RepositoryError};
use crate::cut::{diamond_rhos, select_stateless};
use crate::metric::ScreenSpaceMetric;

/// A welded triangle mesh: one vertex per wedge of the cut (global vertex id and attributes;
/// one per global id where the input has no seams).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CutMesh {
    /// Model-space positions (dequantised, f64).
    pub positions: Vec<[f64; 3]>,
    /// Unit normals (octahedral decode, as the shaders do), if the repository stores normals.
    pub normals: Option<Vec<[f32; 3]>>,
    /// RGBA8 colours as stored, if the repository stores colours.
    pub colors: Option<Vec<[u8; 4]>>,
    /// Texture coordinates as stored, if the repository stores them.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Triangles, three indices into `positions` each, with the patches' winding.
    pub indices: Vec<u32>,
}

impl CutMesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }
}

/// The triangles of the patches of `tets` (tet indices, each once), welded by global vertex id
/// and stored attributes.
/// Vertices are numbered in order of first use; the attribute arrays are `Some` iff the
/// repository's attribute mask has them.
pub fn cut_mesh(repo: &Repository, tets: &[u32]) -> Result<CutMesh, RepositoryError> {
    let h = repo.header();
    let (bbox_min, step, attributes) = (h.bbox_min, h.position_step, h.attributes);
    let mut mesh = CutMesh {
        normals: (attributes & ATTR_NORMALS != 0).then(Vec::new),
        colors: (attributes & ATTR_COLORS != 0).then(Vec::new),
        uvs: (attributes & ATTR_UVS != 0).then(Vec::new),
        ..CutMesh::default()
    };
    let records = repo.tets();
    let triangles: usize = tets
        .iter()
        .filter_map(|&t| records.get(t as usize))
        .map(|r| r.triangle_count as usize)
        .sum();
    mesh.indices.reserve(3 * triangles);
    let mut welded: HashMap<(u32, [u32; 4]), u32> = HashMap::new();
    let mut local: Vec<u32> = Vec::new();
    for &t in tets {
        let patch = repo.patch(t as usize)?;
        let view = patch.view();
        local.clear();
        for (v, id) in view.global_ids().enumerate() {
            let next = mesh.positions.len() as u32;
            // The stored attributes as they are stored: equal bits, one wedge.
            let mut wedge = [0u32; 4];
            if let Some(n) = view.normals() {
                wedge[0] = (n[v][0] as u16 as u32) << 16 | n[v][1] as u16 as u32;
            }
            if let Some(c) = view.colors() {
                wedge[1] = u32::from_le_bytes(c[v]);
            }
            if let Some(uv) = view.uvs() {
                wedge[2..].copy_from_slice(&uv[v].map(f32::to_bits));
            }
            let index = *welded.entry((id, wedge)).or_insert(next);
            if index == next {
                mesh.positions
                    .push(dequantize_position(view.position(v), bbox_min, step));
                if let (Some(out), Some(src)) = (mesh.normals.as_mut(), view.normals()) {
                    out.push(oct_decode_normal(src[v]));
                }
                if let (Some(out), Some(src)) = (mesh.colors.as_mut(), view.colors()) {
                    out.push(src[v]);
                }
                if let (Some(out), Some(src)) = (mesh.uvs.as_mut(), view.uvs()) {
                    out.push(src[v]);
                }
            }
            local.push(index);
        }
        mesh.indices
            .extend(view.triangles().flatten().map(|i| local[i as usize]));
    }
    Ok(mesh)
}

/// The simplices the stateless rule draws at `tau` pixels for an eye at `camera_eye_local`
/// (the repository's f32 frame, `metric::eye_local`) with `metric`, without culling: the
/// whole model at the view's resolution.
pub fn unculled_cut(
    repo: &Repository,
    camera_eye_local: [f32; 3],
    metric: &ScreenSpaceMetric,
    tau: f32,
) -> Vec<u32> {
    let rhos = diamond_rhos(repo.diamonds(), camera_eye_local, metric);
    select_stateless(repo.tets(), &rhos, tau)
}
