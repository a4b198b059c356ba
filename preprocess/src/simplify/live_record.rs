//! A live patch's record, in the live store's file and in a level's result spill: triangle
//! count, vertex count, attribute bits (u32 each), then the triangles (u16 rows of the vertex
//! table, or u32 global ids), ids, positions (f32 where lossless, or f64), simplifier
//! positions (left out where `SimplifierScale` gives them back) and the attributes present,
//! little-endian. A patch whose table holds every corner and whose positions are f32 (a
//! leaf's always, most others) is packed instead: rows, ids and positions bit-packed
//! (`external/packed_columns.rs`), the rest as above.

use super::positions::SimplifierScale;
use crate::external::packed_columns;
use crate::vertex_table::{LivePatch, RowIndex, VertexTable};

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
/// Rows, ids and positions packed (`external/packed_columns.rs`); the ids section's bytes are the bits
/// above `PACKED_IDS_SHIFT`.
const PACKED: u32 = 64;
const PACKED_IDS_SHIFT: u32 = 8;

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

/// Bytes of an unpacked record.
fn record_bytes(head: &[u8]) -> u64 {
    let (t, v, bits) = head_fields(head);
    let (triangle, _, per_vertex) = layout(bits);
    (HEAD + triangle * t + per_vertex * v) as u64
}

/// A patch's triangles as indices into its vertex table, if every corner is in the table,
/// its ids ascending (as `VertexTable` keeps them: a corner's row is found by binary search).
fn local_rows(patch: &LivePatch) -> Option<Vec<[u32; 3]>> {
    let ids = &patch.vertices.ids;
    if !ids.windows(2).all(|w| w[0] < w[1]) {
        return None;
    }
    let index = RowIndex::new(ids);
    patch
        .triangles
        .iter()
        .map(|t| Some([index.get(t[0])?, index.get(t[1])?, index.get(t[2])?]))
        .collect()
}

/// The columns after the positions: simplifier positions unless derived, attributes present.
fn put_rest(patch: &LivePatch, derived: bool, out: &mut Vec<u8>) {
    let v = &patch.vertices;
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
}

/// The packed record of a patch whose table holds every corner (`rows`) and whose positions
/// are f32; `None` where its ids section would not fit the head.
fn encode_packed(patch: &LivePatch, rows: &[[u32; 3]], attribute_bits: u32) -> Option<Vec<u8>> {
    let v = &patch.vertices;
    let mut out = vec![0u8; HEAD];
    packed_columns::put_rows(rows, v.ids.len(), &mut out);
    let ids_at = out.len();
    packed_columns::put_ids(&v.ids, &mut out);
    let ids_bytes = u32::try_from(out.len() - ids_at).ok()?;
    if ids_bytes >= 1 << (32 - PACKED_IDS_SHIFT) {
        return None;
    }
    let narrow: Vec<[f32; 3]> = v.positions.iter().map(|p| p.map(|x| x as f32)).collect();
    packed_columns::put_positions(&narrow, &mut out);
    let bits = attribute_bits | PACKED | (ids_bytes << PACKED_IDS_SHIFT);
    for (i, word) in [patch.triangles.len() as u32, v.ids.len() as u32, bits]
        .into_iter()
        .enumerate()
    {
        out[4 * i..4 * i + 4].copy_from_slice(&word.to_le_bytes());
    }
    Some(out)
}

/// A patch's record (also `result_spill.rs`'s). Lossless: triangles are written as u16 rows
/// of the vertex table and positions as f32 where that gives back the same values (a patch
/// of an input read as f32 always) and simplifier positions are left out where `scale` computes
/// them again, which makes a leaf's record about half the size of a plain one.
pub(super) fn encode_patch(patch: &LivePatch, scale: &SimplifierScale) -> Vec<u8> {
    let v = &patch.vertices;
    let rows = local_rows(patch);
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
    let attribute_bits = (v.normals.is_some() as u32 * NORMALS)
        | (v.colors.is_some() as u32 * COLORS)
        | (v.uvs.is_some() as u32 * UVS)
        | (derived as u32 * SIMPLIFIER_DERIVED);
    if let (Some(rows), true, false) = (&rows, positions_f32, v.ids.is_empty()) {
        if let Some(mut out) = encode_packed(patch, rows, attribute_bits) {
            put_rest(patch, derived, &mut out);
            return out;
        }
    }
    let local: Option<Vec<[u16; 3]>> = rows
        .filter(|_| v.ids.len() <= 1 << 16)
        .map(|rows| rows.iter().map(|r| r.map(|i| i as u16)).collect());
    let bits = attribute_bits
        | (local.is_some() as u32 * LOCAL_U16)
        | (positions_f32 as u32 * POSITIONS_F32);
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
    put_rest(patch, derived, &mut out);
    debug_assert_eq!(out.len() as u64, record_bytes(&out[..HEAD]));
    out
}

// Records are written from aligned vectors but read at any offset: copy, never cast in place.
fn column<T: bytemuck::Pod>(bytes: &[u8]) -> Vec<T> {
    bytemuck::pod_collect_to_vec(bytes)
}

/// A packed record's rows and ids, and where its positions start.
fn packed_rows_and_ids(bytes: &[u8]) -> std::io::Result<(Vec<[u32; 3]>, Vec<u32>, usize)> {
    let (t, v, bits) = head_fields(bytes);
    let ids_at = HEAD + packed_columns::rows_bytes(t, v);
    let positions_at = ids_at + (bits >> PACKED_IDS_SHIFT) as usize;
    if bytes.len() < positions_at {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "a live record shorter than its head says",
        ));
    }
    let rows = packed_columns::get_rows(&bytes[HEAD..ids_at], t, v)?;
    let ids = packed_columns::get_ids(&bytes[ids_at..positions_at], v)?;
    Ok((rows, ids, positions_at))
}

/// The triangles (global ids) of a record's first bytes: the head, the triangles and, for
/// rows, the ids.
pub(super) fn decode_triangles(bytes: &[u8]) -> std::io::Result<Vec<[u32; 3]>> {
    let (t, v, bits) = head_fields(bytes);
    if bits & PACKED != 0 {
        let (rows, ids, _) = packed_rows_and_ids(bytes)?;
        return Ok(rows.iter().map(|r| r.map(|i| ids[i as usize])).collect());
    }
    let (triangle, ..) = layout(bits);
    let triangles = &bytes[HEAD..HEAD + triangle * t];
    if bits & LOCAL_U16 == 0 {
        return Ok(column(triangles));
    }
    let ids: Vec<u32> = column(&bytes[HEAD + triangle * t..HEAD + triangle * t + 4 * v]);
    let rows: Vec<[u16; 3]> = column(triangles);
    Ok(rows.iter().map(|r| r.map(|i| ids[i as usize])).collect())
}

/// Bytes `decode_triangles` needs of a record with this head.
pub(super) fn triangle_bytes(head: &[u8]) -> usize {
    let (t, v, bits) = head_fields(head);
    if bits & PACKED != 0 {
        return HEAD + packed_columns::rows_bytes(t, v) + (bits >> PACKED_IDS_SHIFT) as usize;
    }
    let (triangle, ..) = layout(bits);
    HEAD + triangle * t + if bits & LOCAL_U16 != 0 { 4 * v } else { 0 }
}

/// The patch of a record written by `encode_patch` with the same `scale`.
pub(super) fn decode_patch(bytes: &[u8], scale: &SimplifierScale) -> std::io::Result<LivePatch> {
    let (t, v, bits) = head_fields(bytes);
    let (triangle, position, _) = layout(bits);
    let (triangles, ids, positions, rest_at) = if bits & PACKED != 0 {
        let (rows, ids, positions_at) = packed_rows_and_ids(bytes)?;
        let (narrow, length) = packed_columns::get_positions(&bytes[positions_at..], v)?;
        let triangles = rows.iter().map(|r| r.map(|i| ids[i as usize])).collect();
        let positions = narrow.iter().map(|p| p.map(f64::from)).collect();
        (triangles, ids, positions, positions_at + length)
    } else {
        let triangles = decode_triangles(bytes)?;
        let at = HEAD + triangle * t;
        let ids: Vec<u32> = column(&bytes[at..at + 4 * v]);
        let at = at + 4 * v;
        let positions: Vec<[f64; 3]> = if position == 12 {
            let narrow: Vec<[f32; 3]> = column(&bytes[at..at + 12 * v]);
            narrow.iter().map(|p| p.map(f64::from)).collect()
        } else {
            column(&bytes[at..at + 24 * v])
        };
        (triangles, ids, positions, at + position * v)
    };
    let mut at = rest_at;
    let mut take = |n: usize| {
        let part = &bytes[at..at + n];
        at += n;
        part
    };
    let simplifier: Vec<[f32; 3]> = if bits & SIMPLIFIER_DERIVED != 0 {
        positions.iter().map(|&p| scale.position(p)).collect()
    } else {
        column(take(12 * v))
    };
    let normals = (bits & NORMALS != 0).then(|| column(take(12 * v)));
    let colors = (bits & COLORS != 0).then(|| column(take(4 * v)));
    let uvs = (bits & UVS != 0).then(|| column(take(8 * v)));
    Ok(LivePatch {
        triangles,
        vertices: VertexTable {
            ids,
            positions,
            simplifier,
            normals,
            colors,
            uvs,
        },
    })
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
        let mut large = patch(3, false);
        large.vertices.positions[0][0] = 0.1; // not an f32: unpacked
        large.vertices.ids = (0..70_000).map(|i| 10 * i + 3).collect();
        large.vertices.positions = (0..70_000).map(|i| [i as f64, 0.1, 2.0]).collect();
        large.vertices.simplifier = large
            .vertices
            .positions
            .iter()
            .map(|&p| scale().position(p))
            .collect();
        large.triangles = vec![[3, 13, 699_993]];
        // (patch, packed, triangle bytes and position bytes if not, derived)
        for (p, packed, triangle, position, derived) in [
            (&compact, true, 0, 0, true),
            (&wide, false, 6, 24, true),
            (&foreign, false, 12, 12, true),
            (&twice, false, 12, 12, true),
            (&nudged, true, 0, 0, false),
            (&large, false, 12, 24, true),
        ] {
            let record = encode_patch(p, &scale());
            let (_, v, bits) = head_fields(&record);
            assert_eq!(bits & PACKED != 0, packed);
            if !packed {
                assert_eq!(layout(bits).0, triangle);
                assert_eq!(layout(bits).1, position);
                assert_eq!(record.len() as u64, record_bytes(&record[..HEAD]));
            }
            assert_eq!(bits & SIMPLIFIER_DERIVED != 0, derived);
            assert_eq!(&decode_patch(&record, &scale()).unwrap(), p);
            assert_eq!(
                decode_triangles(&record[..triangle_bytes(&record)]).unwrap(),
                p.triangles
            );
            assert_eq!(v, p.vertices.ids.len());
            // Damage within the packed sections is an error, not a panic.
            if packed {
                let cut = &record[..triangle_bytes(&record) - 1];
                assert!(decode_triangles(cut).is_err());
            }
        }
        let size = |p: &LivePatch| encode_patch(p, &scale()).len();
        assert!(size(&compact) < size(&wide));
        assert_eq!(size(&compact) + 12 * 5, size(&nudged));
    }
}
