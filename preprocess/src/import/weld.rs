//! Welding and cleaning, applied to every imported mesh: merge bit-identical positions, drop
//! degenerate and duplicate triangles, drop unreferenced vertices.

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
/// - vertices with bit-identical positions (`-0.0` equal to `0.0`) become one, with the
///   attributes of the first of them;
/// - triangles that use one welded vertex twice are dropped (degenerate);
/// - triangles over the same three welded vertices as an earlier one, in any order or
///   orientation, are dropped (duplicate); the first keeps its winding;
/// - vertices no remaining triangle uses are dropped; the kept ones keep their relative order.
///
/// Non-manifold configurations are kept as they are. The result may have no triangles.
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

    // Remap triangles, dropping degenerate and then duplicate ones.
    let mut triangles = Vec::with_capacity(raw.triangles.len());
    for t in &raw.triangles {
        let m = t.map(|v| group_of[v as usize]);
        if m[0] != m[1] && m[1] != m[2] && m[0] != m[2] {
            triangles.push(m);
        }
    }
    let degenerate = raw.triangles.len() - triangles.len();
    let duplicate = remove_duplicates(&mut triangles, groups);

    // Compact: keep referenced groups in order.
    let mut new_id = vec![u32::MAX; groups];
    for t in &triangles {
        for &v in t {
            new_id[v as usize] = 0;
        }
    }
    let mut kept: Vec<u32> = Vec::new(); // raw index of each kept vertex
    for (g, id) in new_id.iter_mut().enumerate() {
        if *id == 0 {
            *id = kept.len() as u32;
            kept.push(first_of_group[g]);
        }
    }
    for t in &mut triangles {
        *t = t.map(|v| new_id[v as usize]);
    }

    let mesh = InputMesh {
        positions: kept.iter().map(|&i| raw.positions[i as usize]).collect(),
        triangles,
        normals: pick_attr(&raw.normals, &kept),
        colors: pick_attr(&raw.colors, &kept),
        uvs: pick_attr(&raw.uvs, &kept),
    };
    ImportReport {
        raw_vertices: n,
        raw_triangles: raw.triangles.len(),
        welded_vertices: n - groups,
        degenerate_triangles: degenerate,
        duplicate_triangles: duplicate,
        unreferenced_vertices: groups - kept.len(),
        mesh,
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

/// Removes triangles over the same vertex set as an earlier one, keeping the first (in order).
/// Triangles are bucketed by their smallest vertex id (a counting sort), so only triangles
/// sharing that vertex are compared. Returns how many were removed.
fn remove_duplicates(triangles: &mut Vec<[u32; 3]>, vertices: usize) -> usize {
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
}
