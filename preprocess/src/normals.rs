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
//! Creases are not split: a vertex has one normal (wedges, which a crease needs, are the
//! appearance issue's next step).

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
}
