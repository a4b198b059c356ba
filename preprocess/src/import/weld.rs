//! Welding and cleaning, applied to every imported mesh: merge corners with bit-identical
//! positions and attributes, keep corners at one position that differ in attributes as
//! *wedges* of one vertex (`mesh.rs`), drop degenerate and duplicate triangles, drop
//! unreferenced vertices.

use super::ImportReport;
use crate::mesh::InputMesh;

/// A mesh as read from a file, before welding. Triangle ids index `positions`; attribute
/// vectors, where present, have one entry per position.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RawMesh {
    pub positions: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
    pub normals: Option<Vec<[f32; 3]>>,
    pub colors: Option<Vec<[u8; 4]>>,
    pub uvs: Option<Vec<[f32; 2]>>,
}

/// Welds and cleans `raw`:
///
/// - vertices with bit-identical positions (`-0.0` equal to `0.0`) become one vertex;
/// - among the raw vertices of one vertex that a kept triangle uses, those with bit-identical
///   attributes (normal, colour, texture coordinate; `-0.0` as `0.0`) become one wedge, and
///   distinct attributes stay distinct wedges (texture seams, creases, per-face colours);
/// - triangles with two corners at one position are dropped (degenerate);
/// - triangles over the same three vertices (positions) as an earlier one, in any order or
///   orientation, are dropped (duplicate); the first keeps its winding and its wedges;
/// - vertices no remaining triangle uses are dropped.
///
/// Vertices are numbered in the order of their first raw vertex, a vertex's wedges
/// consecutively (in the order of their first raw vertex), so the wedge index of the result is
/// what `InputMesh` describes. An input whose corners at one position all carry the same
/// attributes (or none) has one wedge a vertex: the mesh, ids and order of a plain weld by
/// position. Non-manifold configurations are kept as they are. The result may have no
/// triangles.
///
/// # Panics
/// If a triangle refers to a position that does not exist, or an attribute vector's length
/// differs from the number of positions.
pub fn weld(raw: RawMesh) -> ImportReport {
    let n = raw.positions.len();
    assert!(n <= u32::MAX as usize, "too many vertices: {n}");
    for attr_len in [
        raw.normals.as_ref().map(Vec::len),
        raw.colors.as_ref().map(Vec::len),
        raw.uvs.as_ref().map(Vec::len),
    ]
    .into_iter()
    .flatten()
    {
        assert_eq!(
            attr_len, n,
            "attribute length differs from the number of positions"
        );
    }

    // Group bit-identical positions; groups are numbered in order of their first vertex.
    let (group_of, first_of_group) = group_positions(&raw.positions);
    let groups = first_of_group.len();

    // Drop degenerate and then duplicate triangles (by position groups), keeping the raw
    // corners of the kept ones.
    let mut grouped = Vec::with_capacity(raw.triangles.len());
    let mut corners = Vec::with_capacity(raw.triangles.len());
    for t in &raw.triangles {
        let m = t.map(|v| group_of[v as usize]);
        if m[0] != m[1] && m[1] != m[2] && m[0] != m[2] {
            grouped.push(m);
            corners.push(*t);
        }
    }
    let degenerate = raw.triangles.len() - grouped.len();
    let duplicate = remove_duplicates(&mut grouped, groups, &mut corners);
    drop(grouped);

    // Number the wedges: referenced vertices in group order, each one's wedges consecutive.
    let wedges = number_wedges(&raw, &group_of, groups, &corners);
    let triangles = corners
        .iter()
        .map(|t| t.map(|v| wedges.wedge_of[v as usize]))
        .collect();
    let kept = &wedges.first_raw; // raw index of each wedge's first raw vertex
                                  // Every wedge of a vertex takes its vertex's first position bits, so they are identical.
    let positions = kept
        .iter()
        .map(|&i| raw.positions[first_of_group[group_of[i as usize] as usize] as usize])
        .collect();
    let mesh = InputMesh {
        positions,
        triangles,
        normals: pick_attr(&raw.normals, kept),
        colors: pick_attr(&raw.colors, kept),
        uvs: pick_attr(&raw.uvs, kept),
    };
    ImportReport {
        raw_vertices: n,
        raw_triangles: raw.triangles.len(),
        welded_vertices: n - groups,
        degenerate_triangles: degenerate,
        duplicate_triangles: duplicate,
        unreferenced_vertices: groups - wedges.vertices,
        mesh,
        textures: None,
        missing_textures: Vec::new(),
    }
}

/// The wedges of a weld: each raw vertex's wedge (`u32::MAX` where no kept triangle uses it),
/// each wedge's first raw vertex, and how many vertices they form.
struct Wedges {
    wedge_of: Vec<u32>,
    first_raw: Vec<u32>,
    vertices: usize,
}

/// The attribute bits that tell wedges apart (`-0.0` as `0.0`).
fn attribute_key(raw: &RawMesh, i: usize) -> [u32; 6] {
    let bits = |x: f32| if x == 0.0 { 0 } else { x.to_bits() };
    let mut key = [0u32; 6];
    if let Some(n) = &raw.normals {
        key[..3].copy_from_slice(&n[i].map(bits));
    }
    if let Some(c) = &raw.colors {
        key[3] = u32::from_le_bytes(c[i]);
    }
    if let Some(uv) = &raw.uvs {
        key[4..].copy_from_slice(&uv[i].map(bits));
    }
    key
}

/// Numbers the wedges of the raw vertices that `corners` use: vertices in group order, a
/// vertex's wedges consecutive, in the order of their first raw vertex.
fn number_wedges(raw: &RawMesh, group_of: &[u32], groups: usize, corners: &[[u32; 3]]) -> Wedges {
    let n = group_of.len();
    let mut used = vec![false; n];
    for t in corners {
        for &v in t {
            used[v as usize] = true;
        }
    }
    // The used raw vertices of each group, in raw order (a counting sort by group).
    let mut start = vec![0u32; groups + 1];
    for (i, &g) in group_of.iter().enumerate() {
        start[g as usize + 1] += used[i] as u32;
    }
    for g in 0..groups {
        start[g + 1] += start[g];
    }
    let mut fill = start.clone();
    let mut members = vec![0u32; start[groups] as usize];
    for (i, &g) in group_of.iter().enumerate() {
        if used[i] {
            members[fill[g as usize] as usize] = i as u32;
            fill[g as usize] += 1;
        }
    }
    drop(fill);
    drop(used);
    let attributes = raw.normals.is_some() || raw.colors.is_some() || raw.uvs.is_some();
    let mut wedge_of = vec![u32::MAX; n];
    let mut first_raw: Vec<u32> = Vec::with_capacity(members.len().min(n));
    let mut vertices = 0;
    let mut keyed: Vec<([u32; 6], u32)> = Vec::new();
    for g in 0..groups {
        let group = &members[start[g] as usize..start[g + 1] as usize];
        let Some(&first) = group.first() else {
            continue;
        };
        vertices += 1;
        let one_wedge = !attributes || {
            let key = attribute_key(raw, first as usize);
            group[1..]
                .iter()
                .all(|&i| attribute_key(raw, i as usize) == key)
        };
        if one_wedge {
            for &i in group {
                wedge_of[i as usize] = first_raw.len() as u32;
            }
            first_raw.push(first);
            continue;
        }
        // Distinct attribute keys, each at its first raw vertex, in raw order.
        keyed.clear();
        keyed.extend(group.iter().map(|&i| (attribute_key(raw, i as usize), i)));
        keyed.sort_unstable();
        let mut firsts: Vec<u32> = keyed
            .chunk_by(|a, b| a.0 == b.0)
            .map(|run| run[0].1)
            .collect();
        firsts.sort_unstable();
        let base = first_raw.len() as u32;
        first_raw.extend_from_slice(&firsts);
        for run in keyed.chunk_by(|a, b| a.0 == b.0) {
            let wedge = base + firsts.binary_search(&run[0].1).expect("a run's first") as u32;
            for &(_, i) in run {
                wedge_of[i as usize] = wedge;
            }
        }
    }
    Wedges {
        wedge_of,
        first_raw,
        vertices,
    }
}

fn pick_attr<T: Copy>(attr: &Option<Vec<T>>, kept: &[u32]) -> Option<Vec<T>> {
    attr.as_ref()
        .map(|a| kept.iter().map(|&i| a[i as usize]).collect())
}

/// Bits of a coordinate with `-0.0` folded onto `0.0`.
#[inline]
pub(crate) fn canonical_bits(x: f64) -> u64 {
    if x == 0.0 {
        0
    } else {
        x.to_bits()
    }
}

#[inline]
fn fmix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 33)).wrapping_mul(0xff51_afd7_ed55_8ccd);
    z = (z ^ (z >> 33)).wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    z ^ (z >> 33)
}

/// Groups bit-identical positions: returns each vertex's group and each group's first vertex,
/// groups numbered in order of their first vertex. An open-addressing table of vertex ids
/// (4 bytes a slot) keeps this cache-friendly for millions of vertices.
fn group_positions(positions: &[[f64; 3]]) -> (Vec<u32>, Vec<u32>) {
    const EMPTY: u32 = u32::MAX;
    let n = positions.len();
    let slots = (2 * n).next_power_of_two().max(16);
    let mask = slots - 1;
    let mut table = vec![EMPTY; slots]; // first vertex of a group
    let mut group_of: Vec<u32> = Vec::with_capacity(n);
    let mut first_of_group: Vec<u32> = Vec::with_capacity(n);
    for (i, p) in positions.iter().enumerate() {
        let key = p.map(canonical_bits);
        let h = fmix64(
            key[0].wrapping_mul(0x9e37_79b9_7f4a_7c15)
                ^ key[1].rotate_left(21).wrapping_mul(0xc2b2_ae3d_27d4_eb4f)
                ^ key[2].rotate_left(42).wrapping_mul(0x1656_67b1_9e37_79f9),
        );
        let mut slot = h as usize & mask;
        loop {
            let first = table[slot];
            if first == EMPTY {
                table[slot] = i as u32;
                group_of.push(first_of_group.len() as u32);
                first_of_group.push(i as u32);
                break;
            }
            if positions[first as usize].map(canonical_bits) == key {
                group_of.push(group_of[first as usize]);
                break;
            }
            slot = (slot + 1) & mask;
        }
    }
    (group_of, first_of_group)
}

/// Removes triangles over the same vertex set as an earlier one, keeping the first (in order),
/// and the same entries of `beside` (one a triangle). Triangles are bucketed by their smallest
/// vertex id (a counting sort), so only triangles sharing that vertex are compared. Returns
/// how many were removed.
fn remove_duplicates<T>(
    triangles: &mut Vec<[u32; 3]>,
    vertices: usize,
    beside: &mut Vec<T>,
) -> usize {
    let sorted = |t: &[u32; 3]| {
        let mut k = *t;
        k.sort_unstable();
        k
    };
    // Bucket boundaries.
    let mut start = vec![0u32; vertices + 1];
    for t in triangles.iter() {
        start[sorted(t)[0] as usize + 1] += 1;
    }
    for v in 0..vertices {
        start[v + 1] += start[v];
    }
    // Stable fill: within a bucket, triangles stay in input order. Entries hold the other two
    // (sorted) ids and the triangle's index.
    let mut fill = start.clone();
    let mut entries = vec![(0u64, 0u32); triangles.len()];
    for (j, t) in triangles.iter().enumerate() {
        let k = sorted(t);
        let at = &mut fill[k[0] as usize];
        entries[*at as usize] = ((k[1] as u64) << 32 | k[2] as u64, j as u32);
        *at += 1;
    }
    drop(fill);
    let mut duplicate = vec![false; triangles.len()];
    let mut count = 0;
    for v in 0..vertices {
        let bucket = &mut entries[start[v] as usize..start[v + 1] as usize];
        if bucket.len() <= 16 {
            for x in 1..bucket.len() {
                if bucket[..x].iter().any(|e| e.0 == bucket[x].0) {
                    duplicate[bucket[x].1 as usize] = true;
                    count += 1;
                }
            }
        } else {
            bucket.sort_unstable(); // by key, then by index: the first of each run is kept
            for x in 1..bucket.len() {
                if bucket[x].0 == bucket[x - 1].0 {
                    duplicate[bucket[x].1 as usize] = true;
                    count += 1;
                }
            }
        }
    }
    if count > 0 {
        let mut j = 0;
        triangles.retain(|_| {
            j += 1;
            !duplicate[j - 1]
        });
        let mut j = 0;
        beside.retain(|_| {
            j += 1;
            !duplicate[j - 1]
        });
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_zero_welds_with_zero() {
        let raw = RawMesh {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [-0.0, 0.0, -0.0],
            ],
            triangles: vec![[0, 1, 2], [3, 2, 1]],
            ..Default::default()
        };
        let r = weld(raw);
        assert_eq!(r.welded_vertices, 1);
        assert_eq!(r.duplicate_triangles, 1);
        assert_eq!(r.mesh.triangles, vec![[0, 1, 2]]);
    }

    /// Corners at one position with different attributes stay apart as consecutive wedges;
    /// equal ones weld; degenerate and duplicate triangles are judged by position.
    #[test]
    fn corners_that_differ_in_attributes_stay_wedges_of_one_vertex() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
        ];
        let raw = RawMesh {
            // Raw 4 is position 1 again with another uv, raw 5 position 2 with raw 2's uv,
            // raw 6 position 0 with a third uv.
            positions: vec![p[0], p[1], p[2], p[3], p[1], p[2], p[0]],
            triangles: vec![
                [0, 1, 2],
                [4, 3, 5],
                [6, 4, 5], // the first triangle again by position: a duplicate
                [0, 6, 3], // two corners at position 0: degenerate
            ],
            uvs: Some(vec![
                [0.0, 0.0],
                [0.5, 0.0],
                [0.0, 0.5],
                [1.0, 1.0],
                [0.7, 0.0],
                [0.0, 0.5],
                [0.9, 0.9],
            ]),
            ..Default::default()
        };
        let r = weld(raw);
        assert_eq!((r.duplicate_triangles, r.degenerate_triangles), (1, 1));
        assert_eq!(r.welded_vertices, 3);
        assert_eq!(r.unreferenced_vertices, 0);
        let m = &r.mesh;
        // Vertex 0 (one wedge: raw 6 is only in dropped triangles), vertex 1 (raw 1, raw 4),
        // vertex 2 (raw 2 and 5 weld), vertex 3.
        assert_eq!(m.positions, vec![p[0], p[1], p[1], p[2], p[3]]);
        assert_eq!(
            m.uvs.as_deref().unwrap(),
            &[[0.0, 0.0], [0.5, 0.0], [0.7, 0.0], [0.0, 0.5], [1.0, 1.0]]
        );
        assert_eq!(m.triangles, vec![[0, 1, 3], [2, 4, 3]]);
        let starts = m.vertex_starts();
        let canon: Vec<u32> = (0..5).map(|w| starts.canonical(w)).collect();
        assert_eq!(canon, vec![0, 1, 1, 3, 4]);
    }

    /// Without attributes, or with equal ones, the weld is the weld by position.
    #[test]
    fn equal_attributes_weld_as_positions_do() {
        let raw = RawMesh {
            positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]],
            triangles: vec![[0, 1, 2], [2, 3, 0]],
            normals: Some(vec![[0.0, 0.0, 1.0]; 4]),
            ..Default::default()
        };
        let r = weld(raw);
        assert_eq!(r.mesh.positions.len(), 3);
        assert_eq!(r.mesh.triangles, vec![[0, 1, 2]]);
        assert_eq!(r.duplicate_triangles, 1);
    }
}
