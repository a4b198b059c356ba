//! A live patch's record, in the live store's file and in a level's result spill: triangle
//! count, vertex count, attribute bits (u32 each), then the triangles (u16 rows of the vertex
//! table, or u32 global ids), ids, positions (f32 where lossless, or f64), simplifier
//! positions (left out where `SimplifierScale` gives them back) and the attributes present,
//! little-endian.

use super::positions::SimplifierScale;
use crate::vertex_table::{LivePatch, VertexTable};

/// Bytes of a record's head.
pub(super) const HEAD: usize = 12;
const NORMALS: u32 = 1;
const COLORS: u32 = 2;
const UVS: u32 = 4;
/// Triangles as u16 rows of the vertex table (else u32 global ids).
const LOCAL_U16: u32 = 8;
/// Positions as f32 (else f64).
const POSITIONS_F32: u32 = 16;
/// No simplifier positions: each is its position's `SimplifierScale::position` (every vertex
/// but the few `separate_coincident` moved; a patch holding one of those stores them all).
const SIMPLIFIER_DERIVED: u32 = 32;

fn head_fields(head: &[u8]) -> (usize, usize, u32) {
    let word = |i: usize| u32::from_le_bytes(head[4 * i..4 * i + 4].try_into().expect("4 bytes"));
    (word(0) as usize, word(1) as usize, word(2))
}

/// Bytes of a record's triangles, of a vertex's position and of a vertex's whole row.
fn layout(bits: u32) -> (usize, usize, usize) {
    let triangle = if bits & LOCAL_U16 != 0 { 6 } else { 12 };
    let position = if bits & POSITIONS_F32 != 0 { 12 } else { 24 };
    let per_vertex = 4
        + position
        + if bits & SIMPLIFIER_DERIVED != 0 {
            0
        } else {
            12
        }
        + if bits & NORMALS != 0 { 12 } else { 0 }
        + if bits & COLORS != 0 { 4 } else { 0 }
        + if bits & UVS != 0 { 8 } else { 0 };
    (triangle, position, per_vertex)
}

fn record_bytes(head: &[u8]) -> u64 {
    let (t, v, bits) = head_fields(head);
    let (triangle, _, per_vertex) = layout(bits);
    (HEAD + triangle * t + per_vertex * v) as u64
}

/// A patch's triangles as indices into its vertex table, if every corner is in the table
/// and the table has at most 65,536 rows, its ids ascending (as `VertexTable` keeps them:
/// a corner's row is found by binary search).
fn local_u16(patch: &LivePatch) -> Option<Vec<[u16; 3]>> {
    let ids = &patch.vertices.ids;
    if ids.len() > 1 << 16 || !ids.windows(2).all(|w| w[0] < w[1]) {
        return None;
    }
    let row = |g: u32| ids.binary_search(&g).ok().map(|r| r as u16);
    patch
        .triangles
        .iter()
        .map(|t| Some([row(t[0])?, row(t[1])?, row(t[2])?]))
        .collect()
}

/// A patch's record (also `result_spill.rs`'s). Lossless: triangles are written as u16 rows
/// of the vertex table and positions as f32 where that gives back the same values (a patch
/// of an input read as f32 always) and simplifier positions are left out where `scale` computes
/// them again, which makes a leaf's record about half the size of a plain one.
pub(super) fn encode_patch(patch: &LivePatch, scale: &SimplifierScale) -> Vec<u8> {
    let v = &patch.vertices;
    let local = local_u16(patch);
    let positions_f32 = v
        .positions
        .iter()
        .flatten()
        .all(|&x| (x as f32) as f64 == x);
    let derived = v
        .positions
        .iter()
        .zip(&v.simplifier)
        .all(|(&p, s)| scale.position(p).map(f32::to_bits) == s.map(f32::to_bits));
    let bits = (v.normals.is_some() as u32 * NORMALS)
        | (v.colors.is_some() as u32 * COLORS)
        | (v.uvs.is_some() as u32 * UVS)
        | (local.is_some() as u32 * LOCAL_U16)
        | (positions_f32 as u32 * POSITIONS_F32)
        | (derived as u32 * SIMPLIFIER_DERIVED);
    let (triangle, _, per_vertex) = layout(bits);
    let mut out =
        Vec::with_capacity(HEAD + triangle * patch.triangles.len() + per_vertex * v.ids.len());
    for word in [patch.triangles.len() as u32, v.ids.len() as u32, bits] {
        out.extend_from_slice(&word.to_le_bytes());
    }
    match &local {
        Some(rows) => out.extend_from_slice(bytemuck::cast_slice(rows)),
        None => out.extend_from_slice(bytemuck::cast_slice(&patch.triangles)),
    }
    out.extend_from_slice(bytemuck::cast_slice(&v.ids));
    if positions_f32 {
        for p in &v.positions {
            for x in p {
                out.extend_from_slice(&(*x as f32).to_le_bytes());
            }
        }
    } else {
        out.extend_from_slice(bytemuck::cast_slice(&v.positions));
    }
    if !derived {
        out.extend_from_slice(bytemuck::cast_slice(&v.simplifier));
    }
    if let Some(n) = &v.normals {
        out.extend_from_slice(bytemuck::cast_slice(n));
    }
    if let Some(c) = &v.colors {
        out.extend_from_slice(bytemuck::cast_slice(c));
    }
    if let Some(u) = &v.uvs {
        out.extend_from_slice(bytemuck::cast_slice(u));
    }
    debug_assert_eq!(out.len() as u64, record_bytes(&out[..HEAD]));
    out
}

// Records are written from aligned vectors but read at any offset: copy, never cast in place.
fn column<T: bytemuck::Pod>(bytes: &[u8]) -> Vec<T> {
    bytemuck::pod_collect_to_vec(bytes)
}

/// The triangles (global ids) of a record's first bytes: the head, the triangles and, for
/// rows, the ids.
pub(super) fn decode_triangles(bytes: &[u8]) -> Vec<[u32; 3]> {
    let (t, v, bits) = head_fields(bytes);
    let (triangle, ..) = layout(bits);
    let triangles = &bytes[HEAD..HEAD + triangle * t];
    if bits & LOCAL_U16 == 0 {
        return column(triangles);
    }
    let ids: Vec<u32> = column(&bytes[HEAD + triangle * t..HEAD + triangle * t + 4 * v]);
    let rows: Vec<[u16; 3]> = column(triangles);
    rows.iter().map(|r| r.map(|i| ids[i as usize])).collect()
}

/// Bytes `decode_triangles` needs of a record with this head.
pub(super) fn triangle_bytes(head: &[u8]) -> usize {
    let (t, v, bits) = head_fields(head);
    let (triangle, ..) = layout(bits);
    HEAD + triangle * t + if bits & LOCAL_U16 != 0 { 4 * v } else { 0 }
}

/// The patch of a record written by `encode_patch` with the same `scale`.
pub(super) fn decode_patch(bytes: &[u8], scale: &SimplifierScale) -> LivePatch {
    let (t, v, bits) = head_fields(bytes);
    let (triangle, position, _) = layout(bits);
    let triangles = decode_triangles(bytes);
    let mut at = HEAD + triangle * t;
    let mut take = |n: usize| {
        let part = &bytes[at..at + n];
        at += n;
        part
    };
    let ids: Vec<u32> = column(take(4 * v));
    let positions: Vec<[f64; 3]> = if position == 12 {
        let narrow: Vec<[f32; 3]> = column(take(12 * v));
        narrow.iter().map(|p| p.map(f64::from)).collect()
    } else {
        column(take(24 * v))
    };
    let simplifier: Vec<[f32; 3]> = if bits & SIMPLIFIER_DERIVED != 0 {
        positions.iter().map(|&p| scale.position(p)).collect()
    } else {
        column(take(12 * v))
    };
    let normals = (bits & NORMALS != 0).then(|| column(take(12 * v)));
    let colors = (bits & COLORS != 0).then(|| column(take(4 * v)));
    let uvs = (bits & UVS != 0).then(|| column(take(8 * v)));
    LivePatch {
        triangles,
        vertices: VertexTable {
            ids,
            positions,
            simplifier,
            normals,
            colors,
            uvs,
        },
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// The simplifier's scale of the test patches' model.
    pub(in crate::simplify) fn scale() -> SimplifierScale {
        let frame =
            crate::frame::LatticeFrame::around_box([0.0, 0.0, -2.0], [60.0, 1.0, 0.0], 20, 3);
        SimplifierScale::of(&frame)
    }

    /// A small patch of five vertices (ids from `seed`), with or without attributes; its
    /// simplifier positions are `scale`'s.
    pub(in crate::simplify) fn patch(seed: u32, attributes: bool) -> LivePatch {
        let ids: Vec<u32> = (0..5).map(|i| seed * 10 + i).collect();
        let positions: Vec<[f64; 3]> = ids.iter().map(|&g| [g as f64, 0.5, -1.0]).collect();
        LivePatch {
            triangles: vec![[ids[0], ids[1], ids[2]], [ids[2], ids[3], ids[4]]],
            vertices: VertexTable {
                simplifier: positions.iter().map(|&p| scale().position(p)).collect(),
                positions,
                normals: attributes.then(|| ids.iter().map(|&g| [0.0, g as f32, 1.0]).collect()),
                colors: attributes.then(|| ids.iter().map(|&g| [g as u8, 1, 2, 3]).collect()),
                uvs: attributes.then(|| ids.iter().map(|&g| [g as f32, 0.0]).collect()),
                ids,
            },
        }
    }

    #[test]
    fn records_are_compact_where_lossless_and_exact_everywhere() {
        let compact = patch(3, true);
        let mut wide = patch(3, true);
        wide.vertices.positions[1][0] = 0.1; // not an f32
        wide.vertices.simplifier[1] = scale().position(wide.vertices.positions[1]);
        let mut foreign = patch(3, false);
        foreign.triangles[1][2] = 999; // a corner outside the table
        let mut twice = patch(3, false);
        twice.vertices.ids[4] = twice.vertices.ids[3]; // an id in two rows
        let mut nudged = patch(3, true);
        nudged.vertices.simplifier[2][1] =
            f32::from_bits(nudged.vertices.simplifier[2][1].to_bits() + 1);
        for (p, triangle, position, derived) in [
            (&compact, 6, 12, true),
            (&wide, 6, 24, true),
            (&foreign, 12, 12, true),
            (&twice, 12, 12, true),
            (&nudged, 6, 12, false),
        ] {
            let record = encode_patch(p, &scale());
            let (_, v, bits) = head_fields(&record);
            assert_eq!(layout(bits).0, triangle);
            assert_eq!(layout(bits).1, position);
            assert_eq!(bits & SIMPLIFIER_DERIVED != 0, derived);
            assert_eq!(record.len() as u64, record_bytes(&record[..HEAD]));
            assert_eq!(&decode_patch(&record, &scale()), p);
            assert_eq!(
                decode_triangles(&record[..triangle_bytes(&record)]),
                p.triangles
            );
            assert_eq!(v, p.vertices.ids.len());
        }
        let size = |p: &LivePatch| encode_patch(p, &scale()).len();
        assert!(size(&compact) < size(&wide));
        assert_eq!(size(&compact) + 12 * 5, size(&nudged));
    }
}
