//! What meshopt sees of the vertices: f32 positions relative to the model, distinct vertices
//! that coincide in f32 moved apart (the staged build does the same against a sorted stream,
//! `external/joins.rs::coincident_nudges`, with the same steps), and how `local_mesh` numbers
//! them.

use rayon::prelude::*;
use rustc_hash::FxHashSet as HashSet;

use crate::frame::LatticeFrame;
use crate::mesh::VertexStarts;

/// `local_mesh`'s table size: the vertex count, or none under a memory budget (a 4-byte entry
/// per vertex and worker thread would grow with the input).
pub(crate) fn numbering_table(vertex_count: usize, budgeted: bool) -> Option<usize> {
    (!budgeted).then_some(vertex_count)
}

/// What meshopt sees of an input position: relative to the model origin, in model sizes, in
/// f32 (`separate_coincident` then moves apart distinct vertices that land on one point). The
/// staged build (`staged_build.rs`) computes the same.
pub fn simplifier_position(frame: &LatticeFrame, p: [f64; 3]) -> [f32; 3] {
    SimplifierScale::of(frame).position(p)
}

/// What `simplifier_position` needs of the frame, so that a live record can leave out the
/// simplifier's positions it can compute again (`live_record.rs`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SimplifierScale {
    origin: [f64; 3],
    size: f64,
}

impl SimplifierScale {
    pub(crate) fn of(frame: &LatticeFrame) -> SimplifierScale {
        SimplifierScale {
            origin: frame.model_origin,
            size: frame.model_size(),
        }
    }

    /// `simplifier_position`, bit for bit.
    #[inline]
    pub(crate) fn position(&self, p: [f64; 3]) -> [f32; 3] {
        [0, 1, 2].map(|i| ((p[i] - self.origin[i]) / self.size) as f32)
    }
}

/// Moves apart, by a few f32 ulps, distinct vertices whose f32 positions coincide (detail
/// below f32 resolution; the welded input has no two vertices at the same f64 position), and
/// gives every wedge its vertex's position (`starts`: the wedges of one vertex are one point).
///
/// Why: meshopt identifies vertices by position (attribute "wedges") and drops every triangle
/// with two corners at one position, even a triangle no collapse touched, so a closed surface
/// of such detail would come out open — a crack by ids. With every vertex's position unique,
/// meshopt sees only the topology we give it, and the wedges of one vertex (bit-identical
/// positions) as the seam they are: it collapses a seam only along itself. The nudge (a
/// relative 1e-7 of the model) changes the simplifier's decisions, not the stored positions,
/// which come from the f64 input.
pub(super) fn separate_coincident(positions: &mut [[f32; 3]], starts: &VertexStarts) {
    nudge_vertices(positions, starts);
    if !starts.is_identity() {
        for w in 0..positions.len() as u32 {
            let v = starts.canonical(w);
            if v != w {
                positions[w as usize] = positions[v as usize];
            }
        }
    }
}

/// `separate_coincident`'s nudges, of each vertex's first wedge.
fn nudge_vertices(positions: &mut [[f32; 3]], starts: &VertexStarts) {
    let key = |p: &[f32; 3]| p.map(f32::to_bits);
    let mut order: Vec<u32> = (0..positions.len() as u32)
        .filter(|&v| starts.canonical(v) == v)
        .collect();
    order.par_sort_unstable_by_key(|&v| (key(&positions[v as usize]), v));
    let duplicates: Vec<u32> = order
        .chunk_by(|&a, &b| key(&positions[a as usize]) == key(&positions[b as usize]))
        .flat_map(|run| run[1..].iter().copied())
        .collect();
    if duplicates.is_empty() {
        return; // the common case
    }
    let mut taken: HashSet<[u32; 3]> = positions.iter().map(key).collect();
    for v in duplicates {
        // Step x, then y, then z up one ulp at a time until the position is free.
        let mut p = positions[v as usize];
        for k in 0.. {
            ulp_step(&mut p, k);
            if taken.insert(key(&p)) {
                break;
            }
        }
        positions[v as usize] = p;
    }
}

/// The k-th step of a coincident vertex's walk: x, then y, then z up one f32 ulp.
pub fn ulp_step(p: &mut [f32; 3], k: usize) {
    let axis = k % 3;
    p[axis] = p[axis].next_up();
}
