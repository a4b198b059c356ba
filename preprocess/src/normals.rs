//! Vertex normals for a mesh whose input has none (most range scans): each vertex's normal is
//! the sum of its triangles' unit normals weighted by the triangle's angle at that vertex
//! (angle-weighted, as trimesh and Thürmer–Wüthrich compute them), normalised.
//!
//! One arithmetic for every path, so a build gives the same bytes in memory and out of core
//! (`external/vertex_normals.rs`): each corner's contribution is computed in f64 and rounded
//! to f32 ([`corner_contributions`]); a vertex sums its corners' contributions in f32, in
//! triangle order, corner by corner ([`accumulate`]); the sum is normalised in f64
//! ([`finish`]). A vertex whose triangles are all degenerate (or that no triangle uses) gets
//! the zero normal, which the renderer shades with the face normal.
//!
//! With a crease angle below 180° (`compute_missing_normals_creased`, in memory), a vertex's
//! corners are grouped across the edges whose faces meet at no more than that angle, and each
//! group is a wedge with its own normal (`mesh.rs`): hard edges stay hard. A texture seam is
//! no crease: wedges of one vertex are smoothed together where their faces are.

use crate::mesh::InputMesh;

/// The contribution of each corner of the triangle with corners `p`: its unit normal times
/// the triangle's angle at that corner (radians); zero for a degenerate triangle.
pub fn corner_contributions(p: [[f64; 3]; 3]) -> [[f32; 3]; 3] {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let (e01, e02, e12) = (sub(p[1], p[0]), sub(p[2], p[0]), sub(p[2], p[1]));
    let cross = [
        e01[1] * e02[2] - e01[2] * e02[1],
        e01[2] * e02[0] - e01[0] * e02[2],
        e01[0] * e02[1] - e01[1] * e02[0],
    ];
    let length = dot(cross, cross).sqrt();
    if !(length > 0.0 && length.is_finite()) {
        return [[0.0; 3]; 3];
    }
    let n = cross.map(|c| c / length);
    // The angle between two edge vectors from the same corner, robust near 0 and π.
    let angle = |a: [f64; 3], b: [f64; 3]| {
        let c = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        dot(c, c).sqrt().atan2(dot(a, b))
    };
    let neg = |a: [f64; 3]| a.map(|x| -x);
    let angles = [
        angle(e01, e02),
        angle(neg(e01), e12),
        angle(neg(e02), neg(e12)),
    ];
    angles.map(|theta| n.map(|x| (x * theta) as f32))
}

/// Adds a corner's contribution to its vertex's running sum.
#[inline]
pub fn accumulate(sum: &mut [f32; 3], contribution: [f32; 3]) {
    for k in 0..3 {
        sum[k] += contribution[k];
    }
}

/// The unit normal of a vertex's summed contributions (the zero normal for a zero sum).
pub fn finish(sum: [f32; 3]) -> [f32; 3] {
    let s = sum.map(f64::from);
    let length = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
    if length > 0.0 && length.is_finite() {
        s.map(|x| (x / length) as f32)
    } else {
        [0.0; 3]
    }
}

/// The angle-weighted vertex normals of `positions` and `triangles`, one per position.
pub fn vertex_normals(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> Vec<[f32; 3]> {
    use rayon::prelude::*;
    let mut sums = vec![[0.0f32; 3]; positions.len()];
    // Contributions in parallel, a block of triangles at a time; summed in triangle order.
    for block in triangles.chunks(1 << 16) {
        let contributions: Vec<[[f32; 3]; 3]> = block
            .par_iter()
            .map(|t| corner_contributions(t.map(|v| positions[v as usize])))
            .collect();
        for (t, c) in block.iter().zip(contributions) {
            for k in 0..3 {
                accumulate(&mut sums[t[k] as usize], c[k]);
            }
        }
    }
    sums.into_par_iter().map(finish).collect()
}

/// Gives `mesh` computed normals if it has none; says whether it did.
pub fn compute_missing_normals(mesh: &mut InputMesh) -> bool {
    if mesh.normals.is_some() {
        return false;
    }
    let starts = mesh.vertex_starts();
    if starts.is_identity() {
        mesh.normals = Some(vertex_normals(&mesh.positions, &mesh.triangles));
        return true;
    }
    // Smooth across seams: a vertex's normal from all its wedges' triangles, given to each
    // of its wedges (a texture seam is no crease).
    let by_vertex: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|w| starts.canonical(w)))
        .collect();
    let mut normals = vertex_normals(&mesh.positions, &by_vertex);
    for w in 0..normals.len() {
        normals[w] = normals[starts.canonical(w as u32) as usize];
    }
    mesh.normals = Some(normals);
    true
}

/// `compute_missing_normals` with the vertices' corners split into wedges at creases: edges
/// whose two triangles' normals differ by more than `crease_degrees` (and border and
/// non-manifold edges) separate the corners around a vertex, and each group of corners gets
/// its own angle-weighted normal. 180 or more: no crease, `compute_missing_normals` itself;
/// a mesh without a crease gets exactly its normals too. Says whether normals were computed.
pub fn compute_missing_normals_creased(mesh: &mut InputMesh, crease_degrees: f64) -> bool {
    if mesh.normals.is_some() {
        return false;
    }
    // (NaN too: no crease.)
    if crease_degrees.partial_cmp(&180.0) != Some(std::cmp::Ordering::Less) {
        return compute_missing_normals(mesh);
    }
    let starts = mesh.vertex_starts();
    let corners = Corners::grouped(mesh, &starts, crease_degrees.to_radians().cos());
    if !corners.splits {
        return compute_missing_normals(mesh);
    }
    // Each group's normal: its corners' contributions summed in triangle order.
    let mut sums = vec![[0.0f32; 3]; corners.group.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let c = corner_contributions(tri.map(|w| mesh.positions[w as usize]));
        for k in 0..3 {
            accumulate(&mut sums[corners.group[3 * t + k] as usize], c[k]);
        }
    }
    // The new wedges: the distinct (wedge, group) of every corner, by vertex, wedge, group.
    let mut order: Vec<(u32, u32, u32)> = (0..corners.group.len())
        .map(|c| {
            let w = mesh.triangles[c / 3][c % 3];
            (w, corners.group[c], c as u32)
        })
        .collect();
    order.sort_unstable();
    let mut new_of_corner = vec![0u32; order.len()];
    let mut old_of_new: Vec<u32> = Vec::new();
    let mut normals: Vec<[f32; 3]> = Vec::new();
    let mut last = None;
    for &(w, g, c) in &order {
        if last != Some((w, g)) {
            last = Some((w, g));
            old_of_new.push(w);
            normals.push(finish(sums[g as usize]));
        }
        new_of_corner[c as usize] = old_of_new.len() as u32 - 1;
    }
    fn pick<T: Copy>(v: &mut Vec<T>, old_of_new: &[u32]) {
        *v = old_of_new.iter().map(|&w| v[w as usize]).collect();
    }
    pick(&mut mesh.positions, &old_of_new);
    if let Some(c) = mesh.colors.as_mut() {
        pick(c, &old_of_new);
    }
    if let Some(uv) = mesh.uvs.as_mut() {
        pick(uv, &old_of_new);
    }
    for (t, tri) in mesh.triangles.iter_mut().enumerate() {
        *tri = [0, 1, 2].map(|k| new_of_corner[3 * t + k]);
    }
    mesh.normals = Some(normals);
    true
}

/// Every corner's group (`3 t + k`: corner `k` of triangle `t`): the smallest corner of its
/// vertex joined to it across smooth manifold edges.
struct Corners {
    group: Vec<u32>,
    /// Whether some vertex has more than one group.
    splits: bool,
}

impl Corners {
    fn grouped(mesh: &InputMesh, starts: &crate::mesh::VertexStarts, cos_crease: f64) -> Corners {
        let tris: Vec<[u32; 3]> = (mesh.triangles.iter())
            .map(|t| t.map(|w| starts.canonical(w)))
            .collect();
        let face: Vec<Option<[f64; 3]>> = tris
            .iter()
            .map(|t| unit_normal(t.map(|v| mesh.positions[v as usize])))
            .collect();
        // Every directed edge (key, triangle, corner at its start), sorted: an edge's uses
        // are a run.
        let mut edges: Vec<(u64, u32, u8)> = Vec::with_capacity(3 * tris.len());
        for (t, tri) in tris.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let key = (a.min(b) as u64) << 32 | a.max(b) as u64;
                edges.push((key, t as u32, k as u8));
            }
        }
        edges.sort_unstable();
        let mut parent: Vec<u32> = (0..3 * tris.len() as u32).collect();
        fn root(parent: &mut [u32], mut c: u32) -> u32 {
            while parent[c as usize] != c {
                parent[c as usize] = parent[parent[c as usize] as usize];
                c = parent[c as usize];
            }
            c
        }
        let join = |parent: &mut Vec<u32>, x: u32, y: u32| {
            let (x, y) = (root(parent, x), root(parent, y));
            // The smaller corner is the root: a group's label is its smallest corner.
            let (lo, hi) = (x.min(y), x.max(y));
            parent[hi as usize] = lo;
        };
        for run in edges.chunk_by(|a, b| a.0 == b.0) {
            let [(_, t1, k1), (_, t2, k2)] = run else {
                continue; // a border or a non-manifold edge
            };
            let smooth = match (face[*t1 as usize], face[*t2 as usize]) {
                (Some(n1), Some(n2)) => n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2] >= cos_crease,
                _ => true, // a degenerate triangle splits nothing
            };
            if !smooth {
                continue;
            }
            // The edge's two ends in each triangle: its start corner and the next.
            let corner = |t: u32, k: u8| 3 * t + k as u32;
            let next = |t: u32, k: u8| 3 * t + (k as u32 + 1) % 3;
            let (a1, b1) = (corner(*t1, *k1), next(*t1, *k1));
            let (a2, b2) = (corner(*t2, *k2), next(*t2, *k2));
            // Opposite directions (a consistently oriented edge): a1 meets b2; else a1 a2.
            let v = |c: u32| tris[c as usize / 3][c as usize % 3];
            let (a2, b2) = if v(a1) == v(b2) { (b2, a2) } else { (a2, b2) };
            join(&mut parent, a1, a2);
            join(&mut parent, b1, b2);
        }
        let group: Vec<u32> = (0..parent.len() as u32)
            .map(|c| root(&mut parent, c))
            .collect();
        // A vertex splits when two of its corners have different groups.
        let mut first_group = std::collections::HashMap::new();
        let splits = group.iter().enumerate().any(|(c, &g)| {
            let v = tris[c / 3][c % 3];
            *first_group.entry(v).or_insert(g) != g
        });
        Corners { group, splits }
    }
}

/// The unit normal of the triangle with corners `p`, if it has one.
pub(crate) fn unit_normal(p: [[f64; 3]; 3]) -> Option<[f64; 3]> {
    let u = [0, 1, 2].map(|i| p[1][i] - p[0][i]);
    let v = [0, 1, 2].map(|i| p[2][i] - p[0][i]);
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let length = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    (length > 0.0 && length.is_finite()).then(|| n.map(|x| x / length))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn angle_between(a: [f32; 3], b: [f64; 3]) -> f64 {
        let a = a.map(f64::from);
        let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let la = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        let lb = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
        (dot / (la * lb)).clamp(-1.0, 1.0).acos().to_degrees()
    }

    #[test]
    fn a_cube_corner_gets_the_diagonal_whatever_the_triangulation() {
        // A cube's corner has three faces, one of them split in two triangles there and the
        // others not: angle weighting gives the diagonal (area weighting would not).
        let positions = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 0.0],
        ];
        // Faces at the origin, outward normals −x, −y, −z; the −z face as two triangles.
        let triangles = vec![[0, 3, 2], [0, 1, 3], [0, 2, 4], [0, 4, 1]];
        let n = vertex_normals(&positions, &triangles);
        let want = [-1.0, -1.0, -1.0];
        assert!(angle_between(n[0], want) < 1e-5, "{:?}", n[0]);
    }

    #[test]
    fn a_sphere_s_normals_point_outwards() {
        let mesh = crate::procedural::demo_mesh(3);
        let n = vertex_normals(&mesh.positions, &mesh.triangles);
        let centre = {
            let mut c = [0.0f64; 3];
            for p in &mesh.positions {
                for k in 0..3 {
                    c[k] += p[k] / mesh.positions.len() as f64;
                }
            }
            c
        };
        let outward = mesh
            .positions
            .iter()
            .zip(&n)
            .filter(|(p, n)| {
                let r = [p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]];
                angle_between(**n, r) < 90.0
            })
            .count();
        assert!(outward * 100 >= 95 * n.len(), "{outward} of {}", n.len());
        for v in &n {
            let l = v.iter().map(|x| x * x).sum::<f32>().sqrt();
            assert!((l - 1.0).abs() < 1e-6, "{v:?}");
        }
    }

    #[test]
    fn degenerate_and_unused_vertices_get_the_zero_normal() {
        let positions = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [5.0, 5.0, 5.0],
        ];
        let n = vertex_normals(&positions, &[[0, 1, 2]]);
        assert_eq!(n, vec![[0.0; 3]; 4]);
    }

    #[test]
    fn a_mesh_with_normals_keeps_them() {
        let mut mesh = crate::procedural::demo_mesh(1);
        let had = mesh.normals.is_some();
        let before = mesh.normals.clone();
        let computed = compute_missing_normals(&mut mesh);
        assert_eq!(computed, !had);
        if had {
            assert_eq!(mesh.normals, before);
        }
        assert!(mesh.normals.is_some());
    }

    #[test]
    fn wedges_of_one_vertex_get_its_normal() {
        // A square of two triangles whose shared edge is a seam: vertices 1 and 2 each have a
        // second wedge (ids 2 and 4), used by the second triangle.
        let mut mesh = InputMesh {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.2],
            ],
            triangles: vec![[0, 1, 3], [4, 2, 5]],
            ..Default::default()
        };
        assert!(compute_missing_normals(&mut mesh));
        let n = mesh.normals.unwrap();
        assert_eq!(n[1], n[2]);
        assert_eq!(n[3], n[4]);
        // Both triangles count at the seam: not the first triangle's (0, 0, 1) alone.
        assert!(n[1][2] < 0.999 && n[1][2] > 0.9, "{:?}", n[1]);
    }

    /// A cube of 12 triangles without normals: split at 60° every corner has three wedges,
    /// one a face, each with its face's normal; at 180° one smooth normal a corner.
    #[test]
    fn a_crease_angle_splits_a_cube_s_corners_into_its_faces() {
        let p = |i: u32| [(i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2 & 1) as f64];
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let triangles: Vec<[u32; 3]> = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        let cube = InputMesh {
            positions: (0..8).map(p).collect(),
            triangles,
            uvs: Some((0..8).map(|i| [i as f32, 0.0]).collect()),
            ..Default::default()
        };
        let mut smooth = cube.clone();
        assert!(compute_missing_normals_creased(&mut smooth, 180.0));
        assert_eq!(smooth.positions.len(), 8);
        let mut hard = cube.clone();
        assert!(compute_missing_normals_creased(&mut hard, 60.0));
        assert_eq!(hard.positions.len(), 24, "three wedges a corner");
        assert_eq!(hard.vertex_starts().vertex_count(24), 8);
        let normals = hard.normals.as_ref().unwrap();
        for t in &hard.triangles {
            let corners = t.map(|w| hard.positions[w as usize]);
            let face = unit_normal(corners).unwrap();
            for &w in t {
                let n = normals[w as usize].map(f64::from);
                let dot = n[0] * face[0] + n[1] * face[1] + n[2] * face[2];
                assert!(dot > 0.999999, "wedge {w}: {n:?} on a face {face:?}");
            }
        }
        // The texture coordinates follow their wedges.
        let uvs = hard.uvs.as_ref().unwrap();
        for (uv, position) in uvs.iter().zip(&hard.positions) {
            let original = (0..8).find(|&i| p(i) == *position).unwrap();
            assert_eq!(*uv, [original as f32, 0.0]);
        }
        // At 91° a cube's faces (90° apart) are smooth.
        let mut ninety = cube.clone();
        compute_missing_normals_creased(&mut ninety, 91.0);
        assert_eq!(ninety.positions.len(), 8);
    }

    /// Without a crease over the angle, the normals are the smooth ones, bit for bit.
    #[test]
    fn a_smooth_mesh_gets_the_same_normals_at_any_crease_angle() {
        let mut mesh = crate::procedural::demo_mesh(4);
        mesh.normals = None;
        let mut smooth = mesh.clone();
        compute_missing_normals(&mut smooth);
        let mut creased = mesh.clone();
        assert!(compute_missing_normals_creased(&mut creased, 60.0));
        assert_eq!(creased, smooth);
    }
}
