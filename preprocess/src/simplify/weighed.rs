//! What meshopt weighs when it simplifies a diamond (issue 47): positions in model sizes, and
//! the attributes the input has with a weight above 0 — normals, colours, texture coordinates
//! (`SimplifySettings`). meshopt sees a vertex's wedges at one position and collapses a seam
//! only along itself (ARCHITECTURE.md, "Wedges and vertex ids").

use meshopt::{SimplifyOptions, VertexDataAdapter};

use super::SimplifySettings;
use crate::vertex_table::VertexTable;

/// A diamond's local wedges: each one's row in the gathered vertex table and the position
/// meshopt sees.
pub(super) struct LocalWedges {
    pub rows: Vec<usize>,
    pub positions: Vec<[f32; 3]>,
}

impl LocalWedges {
    pub fn of(global_of: &[u32], vertices: &VertexTable) -> LocalWedges {
        let index = vertices.row_index();
        let rows: Vec<usize> = global_of
            .iter()
            .map(|&g| index.expect(g) as usize)
            .collect();
        let positions = rows.iter().map(|&r| vertices.simplifier[r]).collect();
        LocalWedges { rows, positions }
    }
}

/// Whether meshopt weighs colours or texture coordinates (not only normals) for `vertices`.
pub(super) fn weighs_more_than_normals(
    vertices: &VertexTable,
    settings: &SimplifySettings,
) -> bool {
    (vertices.colors.is_some() && settings.colour_weight > 0.0)
        || (vertices.uvs.is_some() && settings.uv_weight > 0.0)
}

/// The attributes meshopt weighs for each wedge, interleaved (normal xyz, colour rgb in
/// [0, 1], uv), and their weights: those the input has with a weight above 0. With normals
/// alone this is the call made before colours and UVs were weighed (the same bytes).
fn weighed_attributes(
    rows: &[usize],
    vertices: &VertexTable,
    settings: &SimplifySettings,
) -> (Vec<f32>, Vec<f32>) {
    let normals = vertices
        .normals
        .as_ref()
        .filter(|_| settings.normal_weight > 0.0);
    let colours = vertices
        .colors
        .as_ref()
        .filter(|_| settings.colour_weight > 0.0);
    let uvs = vertices.uvs.as_ref().filter(|_| settings.uv_weight > 0.0);
    let mut weights: Vec<f32> = Vec::new();
    if normals.is_some() {
        weights.extend([settings.normal_weight; 3]);
    }
    if colours.is_some() {
        weights.extend([settings.colour_weight; 3]);
    }
    if uvs.is_some() {
        weights.extend([settings.uv_weight; 2]);
    }
    let mut attributes = Vec::with_capacity(rows.len() * weights.len());
    for &r in rows {
        if let Some(n) = normals {
            attributes.extend_from_slice(&n[r]);
        }
        if let Some(c) = colours {
            attributes.extend(c[r][..3].iter().map(|&x| x as f32 / 255.0));
        }
        if let Some(uv) = uvs {
            attributes.extend_from_slice(&uv[r]);
        }
    }
    debug_assert_eq!(attributes.len(), rows.len() * weights.len());
    (attributes, weights)
}

/// meshopt simplification to `target` triangles with the given locks (it stops earlier where
/// locks leave nothing to collapse), weighing the attributes `weighed_attributes` gives;
/// returns local indices and meshopt's error estimate (in the units of the positions; with
/// weighed attributes, their error mixed in).
pub(super) fn simplify_locked(
    indices: &[u32],
    wedges: &LocalWedges,
    lock: &[bool],
    vertices: &VertexTable,
    settings: &SimplifySettings,
    target: usize,
) -> (Vec<u32>, f32) {
    if indices.is_empty() {
        return (Vec::new(), 0.0);
    }
    let bytes: &[u8] = bytemuck::cast_slice(&wedges.positions);
    let adapter = VertexDataAdapter::new(bytes, 12, 0).expect("tightly packed f32x3 positions");
    let target = target * 3;
    let options = SimplifyOptions::ErrorAbsolute;
    let mut error = 0.0f32;
    let (attributes, weights) = weighed_attributes(&wedges.rows, vertices, settings);
    let out = match weights.is_empty() {
        false => meshopt::simplify_with_attributes_and_locks(
            indices,
            &adapter,
            &attributes,
            &weights,
            weights.len() * 4,
            lock,
            target,
            f32::MAX,
            options,
            Some(&mut error),
        ),
        true => meshopt::simplify_with_locks(
            indices,
            &adapter,
            lock,
            target,
            f32::MAX,
            options,
            Some(&mut error),
        ),
    };
    (out, error)
}
