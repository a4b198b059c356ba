//! Patch encoding: vertex-cache-optimised triangle strips with primitive restart, vertices in
//! first-use order, positions quantised on the one global grid (so a vertex shared by patches
//! is bit-identical in all of them), and the attributes the input has.

use tessera_core::repository::format::{oct_encode_normal, quantize_position};
use tessera_core::repository::patch::PatchData;

use crate::local_mesh::local_mesh;
use crate::mesh::InputMesh;

/// Restart marker in `PatchData::strip` (the encoder narrows it to 0xFFFF for u16 patches).
const RESTART: u32 = u32::MAX;

/// Builds the patch of `triangles` (global ids).
pub fn build_patch(
    triangles: &[[u32; 3]],
    mesh: &InputMesh,
    bbox_min: [f64; 3],
    step: [f64; 3],
) -> PatchData {
    // Local indices in first-appearance order.
    let local = local_mesh(triangles, mesh.positions.len());
    let (indices, globals) = (local.indices, local.global_of);
    let vertex_count = globals.len();
    let optimized = meshopt::optimize_vertex_cache_strip(&indices, vertex_count);
    // Renumber vertices by first use in the optimised order (vertex fetch locality).
    let mut remap = vec![u32::MAX; vertex_count];
    let mut order: Vec<u32> = Vec::with_capacity(vertex_count);
    let renumbered: Vec<u32> = optimized
        .iter()
        .map(|&l| {
            if remap[l as usize] == u32::MAX {
                remap[l as usize] = order.len() as u32;
                order.push(globals[l as usize]);
            }
            remap[l as usize]
        })
        .collect();
    let strip = if renumbered.is_empty() {
        Vec::new()
    } else {
        meshopt::stripify(&renumbered, vertex_count, RESTART)
            .expect("stripify of a valid index list")
    };
    PatchData {
        positions: order
            .iter()
            .map(|&g| quantize_position(mesh.positions[g as usize], bbox_min, step))
            .collect(),
        normals: mesh.normals.as_ref().map(|n| {
            order
                .iter()
                .map(|&g| oct_encode_normal(n[g as usize]))
                .collect()
        }),
        colors: mesh
            .colors
            .as_ref()
            .map(|c| order.iter().map(|&g| c[g as usize]).collect()),
        uvs: mesh
            .uvs
            .as_ref()
            .map(|u| order.iter().map(|&g| u[g as usize]).collect()),
        global_ids: order,
        strip,
        triangle_count: triangles.len() as u32,
    }
}
