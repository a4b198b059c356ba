//! Handing a diamond's simplified triangles to its simplices (by source, or by barycentre).

use rustc_hash::FxHashMap as HashMap;
use tessera_core::leb::{Diamond, PreparedSimplex, Simplex, SimplexKey};

use super::Context;
use crate::local_mesh::LocalMesh;
use crate::vertex_table::{LivePatch, VertexTable};

/// Hands the simplified triangles (`simplified`, local ids) to the simplices of D: a triangle
/// the simplifier kept stays with the simplex it came from (`source`; its barycentre is in
/// that simplex's child), a new one goes to the simplex holding its barycentre.
pub(super) fn distribute(
    ctx: &Context,
    diamond: &Diamond,
    local: &LocalMesh,
    source: &[u8],
    simplified: &[u32],
    vertices: &VertexTable,
) -> Vec<(SimplexKey, LivePatch)> {
    let mut out: Vec<(SimplexKey, Vec<[u32; 3]>)> = diamond
        .simplices
        .iter()
        .map(|s| {
            let share = simplified.len() / 3 / diamond.simplices.len();
            (s.key, Vec::with_capacity(share + 8))
        })
        .collect();
    // Keys are local ids in the triangle's own rotation; a repeated triangle keeps its last
    // source.
    let key = |t: &[u32]| ((t[0] as u128) << 64) | ((t[1] as u128) << 32) | t[2] as u128;
    let came_from: HashMap<u128, u8> = local
        .indices
        .chunks_exact(3)
        .zip(source)
        .map(|(t, &slot)| (key(t), slot))
        .collect();
    let prepared: Vec<PreparedSimplex> = diamond.simplices.iter().map(Simplex::prepared).collect();
    let index = vertices.row_index();
    for t in simplified.chunks_exact(3) {
        let tri = [0, 1, 2].map(|k| local.global_of[t[k] as usize]);
        let slot = match came_from.get(&key(t)) {
            Some(&slot) => slot as usize,
            None => holder(
                &diamond.simplices,
                &prepared,
                ctx.frame
                    .barycentre(tri.map(|g| vertices.positions[index.expect(g) as usize])),
            ),
        };
        out[slot].1.push(tri);
    }
    out.into_iter()
        .map(|(key, triangles)| {
            let vertices = vertices.subset(&triangles);
            (
                key,
                LivePatch {
                    triangles,
                    vertices,
                },
            )
        })
        .collect()
}

/// The simplex of the diamond that holds `b` (`prepared` are the simplices' facet planes);
/// when simplification moved a triangle's barycentre outside the diamond, the simplex with the
/// nearest centroid.
fn holder(simplices: &[Simplex], prepared: &[PreparedSimplex], b: [f64; 3]) -> usize {
    if let Some(i) = prepared.iter().position(|s| s.contains_point(b)) {
        return i;
    }
    let centroid = |s: &Simplex| {
        let mut c = [0.0; 3];
        for v in &s.vertices[..4] {
            for i in 0..3 {
                c[i] += v[i] as f64 / 4.0;
            }
        }
        c
    };
    let dist2 = |c: [f64; 3]| (0..3).map(|i| (c[i] - b[i]).powi(2)).sum::<f64>();
    (0..simplices.len())
        .min_by(|&x, &y| dist2(centroid(&simplices[x])).total_cmp(&dist2(centroid(&simplices[y]))))
        .unwrap_or(0)
}
