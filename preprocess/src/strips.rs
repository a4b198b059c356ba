//! Patch encoding: vertex-cache-optimised triangle strips with restart markers, every segment
//! starting at an even strip position (`even_segments`: the renderer knows a triangle's winding
//! parity from its position alone, `PatchView::parse` checks it), vertices in order of first use
//! by the strip, positions quantised on the one global grid (so a vertex shared by patches
//! is bit-identical in all of them), normals on the 10-bit octahedral grid
//! (`format::oct_encode_normal_grid`, a pure function of the vertex: identical everywhere too), and
//! the attributes the input has.

use tessera_core::repository::format::{oct_encode_normal_grid, quantize_position};
use tessera_core::repository::patch::PatchData;

use crate::local_mesh::local_mesh;
use crate::vertex_table::VertexTable;

/// Restart marker in `PatchData::strip` (the encoder narrows it to 0xFFFF for u16 patches).
const RESTART: u32 = u32::MAX;

/// Builds the patch of `triangles` (global ids, every one carried by `vertices`);
/// `numbering_table` as `local_mesh` takes it.
pub fn build_patch(
    triangles: &[[u32; 3]],
    vertices: &VertexTable,
    numbering_table: Option<usize>,
    bbox_min: [f64; 3],
    step: [f64; 3],
) -> PatchData {
    // Local indices in first-appearance order.
    let local = local_mesh(triangles, numbering_table);
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
        even_segments(
            &meshopt::stripify(&renumbered, vertex_count, RESTART)
                .expect("stripify of a valid index list"),
        )
    };
    // Renumber again by first use in the strip itself: then every index is either the next
    // new vertex or one seen before, which the packed strip codes in a few bits
    // (`tessera_core::repository::strip_codec`).
    let (strip, order) = strip_first_use(&strip, &order);
    let index = vertices.row_index();
    let rows: Vec<usize> = order.iter().map(|&g| index.expect(g) as usize).collect();
    PatchData {
        positions: rows
            .iter()
            .map(|&r| quantize_position(vertices.positions[r], bbox_min, step))
            .collect(),
        normals: vertices
            .normals
            .as_ref()
            .map(|n| rows.iter().map(|&r| oct_encode_normal_grid(n[r])).collect()),
        colors: vertices
            .colors
            .as_ref()
            .map(|c| rows.iter().map(|&r| c[r]).collect()),
        uvs: vertices
            .uvs
            .as_ref()
            .map(|u| rows.iter().map(|&r| u[r]).collect()),
        global_ids: order,
        strip,
        triangle_count: triangles.len() as u32,
    }
}

/// `strip` renumbered by first use (restart markers kept), with `order` (global id of each
/// vertex) permuted to match. Every vertex of `order` is used by the strip.
fn strip_first_use(strip: &[u32], order: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let mut remap = vec![u32::MAX; order.len()];
    let mut first_use: Vec<u32> = Vec::with_capacity(order.len());
    let renumbered = strip
        .iter()
        .map(|&i| {
            if i == RESTART {
                return RESTART;
            }
            if remap[i as usize] == u32::MAX {
                remap[i as usize] = first_use.len() as u32;
                first_use.push(order[i as usize]);
            }
            remap[i as usize]
        })
        .collect();
    assert_eq!(
        first_use.len(),
        order.len(),
        "a patch vertex the strip does not use"
    );
    (renumbered, first_use)
}

/// `strip` with one extra restart marker wherever a segment would start at an odd position, so
/// that every segment starts at an even one: the k-th strip slot (s[k], s[k+1], s[k+2]) then
/// has the winding parity of k, which the vertex shader derives from k alone. Triangles and
/// their order are unchanged.
pub fn even_segments(strip: &[u32]) -> Vec<u32> {
    let mut out = Vec::with_capacity(strip.len() + strip.len() / 8);
    for &index in strip {
        if index == RESTART {
            out.push(RESTART);
            // The next segment would start at out.len(): make it even.
            if out.len() % 2 == 1 {
                out.push(RESTART);
            }
        } else {
            out.push(index);
        }
    }
    // Trailing markers carry nothing.
    while out.last() == Some(&RESTART) {
        out.pop();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: u32 = RESTART;

    #[test]
    fn segments_start_even_and_keep_their_triangles() {
        let cases: &[&[u32]] = &[
            &[],
            &[0, 1, 2],
            &[0, 1, 2, 3, R, 4, 5, 6],
            &[0, 1, 2, R, 3, 4, 5, 6, R, 7, 8, 9, R],
            &[0, 1, 2, 2, 3, 4, R, R, 5, 6, 7],
        ];
        for &strip in cases {
            let even = even_segments(strip);
            let mut start = 0;
            for (k, &i) in even.iter().enumerate() {
                if i == R {
                    start = k + 1;
                } else {
                    assert_eq!(start % 2, 0, "{strip:?} → {even:?}");
                }
            }
            let triangles = |s: &[u32]| {
                let patch = PatchData {
                    strip: s.to_vec(),
                    ..Default::default()
                };
                patch.triangles().collect::<Vec<[u32; 3]>>()
            };
            assert_eq!(triangles(&even), triangles(strip), "{strip:?} → {even:?}");
        }
        assert_eq!(even_segments(&[0, 1, 2, R, 3, 4, 5]), [0, 1, 2, R, 3, 4, 5]);
        assert_eq!(
            even_segments(&[0, 1, 2, 3, R, 4, 5, 6]),
            [0, 1, 2, 3, R, R, 4, 5, 6]
        );
    }
}
