//! A procedural demo mesh: a closed, manifold, genus-0 "asteroid" with detail at every scale.
//!
//! An icosahedron is subdivided `s` times (each step splits every triangle into 4; midpoints are
//! shared through an edge hash map, so the mesh stays welded and watertight), projected onto the
//! unit sphere and displaced radially by deterministic multi-octave gradient noise (fBm plus a
//! ridged multifractal). Radial displacement of a sphere triangulation never folds it: every
//! triangle keeps the orientation of its spherical triangle (det(ra·a, rb·b, rc·c) =
//! ra·rb·rc·det(a, b, c) with r > 0), so the result has no self-intersection for any radius > 0.
//!
//! Vertices are appended level by level, so vertex `i` of `demo_mesh(s)` is vertex `i` of
//! `demo_mesh(s + 1)`, at the same position: the levels form a nested hierarchy.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use rayon::prelude::*;

use crate::mesh::InputMesh;
use tessera_core::vec3::{cross, dot, sub};

/// Subdivision level of the standard demo mesh: 20·4^8 = 1,310,720 triangles,
/// 10·4^8 + 2 = 655,362 vertices.
pub const DEMO_SUBDIVISIONS: u32 = 8;

/// Relative amplitude of the radial displacement (radius = 1 + DEMO_AMPLITUDE · h, |h| ≲ 1).
pub const DEMO_AMPLITUDE: f64 = 0.15;

/// Hard bounds on the radius; the noise stays well inside them, the clamp is only a guarantee.
pub const DEMO_MIN_RADIUS: f64 = 0.6;
/// See [`DEMO_MIN_RADIUS`].
pub const DEMO_MAX_RADIUS: f64 = 1.4;

const OCTAVES: u32 = 8;
const BASE_FREQUENCY: f64 = 1.7;
const LACUNARITY: f64 = 2.03;
const GAIN: f64 = 0.5;
const SEED: u32 = 0x7e55_e7a1;

/// Triangles of [`demo_mesh`]`(subdivisions)`.
pub const fn demo_triangle_count(subdivisions: u32) -> usize {
    20 << (2 * subdivisions)
}

/// Vertices of [`demo_mesh`]`(subdivisions)`.
pub const fn demo_vertex_count(subdivisions: u32) -> usize {
    (10 << (2 * subdivisions)) + 2
}

/// The procedural demo mesh at the given subdivision level (see the module docs).
/// Counter-clockwise seen from outside, with area-weighted per-vertex normals.
pub fn demo_mesh(subdivisions: u32) -> InputMesh {
    assert!(
        subdivisions <= 12,
        "demo_mesh: {subdivisions} subdivisions would overflow u32 ids"
    );
    let (mut positions, triangles) = subdivided_icosphere(subdivisions);
    positions.par_iter_mut().with_min_len(4096).for_each(|p| {
        let r = demo_radius(*p);
        *p = [p[0] * r, p[1] * r, p[2] * r];
    });
    let normals = vertex_normals(&positions, &triangles);
    InputMesh {
        positions,
        triangles,
        normals: Some(normals),
        colors: None,
        uvs: None,
    }
}

/// The demo mesh at `subdivisions`, then every triangle split flat into 4 `refine` times
/// (new vertices at edge midpoints, not displaced; normals averaged): 4^refine times the
/// triangles of `demo_mesh(subdivisions)` on exactly the same surface. Scaling benchmarks use
/// it: the model grows, the detail a view can see does not.
pub fn demo_mesh_refined(subdivisions: u32, refine: u32) -> InputMesh {
    assert!(
        subdivisions + refine <= 12,
        "demo_mesh_refined: {subdivisions} + {refine} subdivisions would overflow u32 ids"
    );
    let mut mesh = demo_mesh(subdivisions);
    let mut normals = mesh.normals.take().expect("the demo mesh has normals");
    for _ in 0..refine {
        let mut midpoints: EdgeMap = HashMap::with_capacity_and_hasher(
            mesh.triangles.len() * 3 / 2,
            BuildHasherDefault::default(),
        );
        let mut next = Vec::with_capacity(mesh.triangles.len() * 4);
        let positions = &mut mesh.positions;
        let mut midpoint = |a: u32, b: u32| -> u32 {
            let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
            *midpoints.entry(key).or_insert_with(|| {
                let (pa, pb) = (positions[a as usize], positions[b as usize]);
                let (na, nb) = (normals[a as usize], normals[b as usize]);
                positions.push([0, 1, 2].map(|i| 0.5 * (pa[i] + pb[i])));
                let n = [0, 1, 2].map(|i| f64::from(na[i] + nb[i]));
                normals.push(normalize(n).map(|x| x as f32));
                (positions.len() - 1) as u32
            })
        };
        for &[a, b, c] in &mesh.triangles {
            let ab = midpoint(a, b);
            let bc = midpoint(b, c);
            let ca = midpoint(c, a);
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        mesh.triangles = next;
    }
    mesh.normals = Some(normals);
    mesh
}

/// Radius of the demo surface in the direction `dir` (a unit vector), in
/// [`DEMO_MIN_RADIUS`, `DEMO_MAX_RADIUS`].
pub fn demo_radius(dir: [f64; 3]) -> f64 {
    relief_radius(dir, SEED)
}

/// The demo's relief with another noise seed (`gen mesh --seed`): the same look, another
/// surface. `relief_radius(dir, s)` for the demo's own seed is [`demo_radius`].
pub fn relief_radius(dir: [f64; 3], seed: u32) -> f64 {
    let mut freq = BASE_FREQUENCY;
    let mut amp = 1.0;
    let mut norm = 0.0;
    let mut fbm = 0.0;
    let mut ridged = 0.0;
    let mut weight = 1.0;
    for octave in 0..OCTAVES {
        // A per-octave offset keeps the lattices of the octaves from lining up.
        let o = octave as f64;
        let q = [
            dir[0] * freq + 17.31 * o,
            dir[1] * freq + 5.77 * o,
            dir[2] * freq + 11.13 * o,
        ];
        let n = gradient_noise(q, seed.wrapping_add(octave.wrapping_mul(0x9e37_79b9)));
        fbm += amp * n;
        // Ridged multifractal (Musgrave): sharp creases where the noise crosses zero, rougher
        // where the coarser octaves already made a ridge.
        let mut r = 1.0 - n.abs();
        r *= r;
        r *= weight;
        weight = (2.0 * r).clamp(0.0, 1.0);
        ridged += amp * r;
        norm += amp;
        freq *= LACUNARITY;
        amp *= GAIN;
    }
    let h = 0.6 * (fbm / norm) + 0.9 * (ridged / norm - 0.57);
    (1.0 + DEMO_AMPLITUDE * h).clamp(DEMO_MIN_RADIUS, DEMO_MAX_RADIUS)
}

/// Unit-sphere positions and CCW triangles of the icosahedron subdivided `s` times.
fn subdivided_icosphere(s: u32) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let base = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut positions: Vec<[f64; 3]> = Vec::with_capacity(demo_vertex_count(s));
    positions.extend(base.iter().map(|&p| normalize(p)));
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..s {
        // Each level has E = 3F/2 edges, one new vertex per edge.
        let mut midpoints: EdgeMap = HashMap::with_capacity_and_hasher(
            triangles.len() * 3 / 2,
            BuildHasherDefault::default(),
        );
        let mut next = Vec::with_capacity(triangles.len() * 4);
        let mut midpoint = |a: u32, b: u32| -> u32 {
            let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
            *midpoints.entry(key).or_insert_with(|| {
                let (pa, pb) = (positions[a as usize], positions[b as usize]);
                let id = positions.len() as u32;
                positions.push(normalize([pa[0] + pb[0], pa[1] + pb[1], pa[2] + pb[2]]));
                id
            })
        };
        for &[a, b, c] in &triangles {
            let ab = midpoint(a, b);
            let bc = midpoint(b, c);
            let ca = midpoint(c, a);
            next.push([a, ab, ca]);
            next.push([ab, b, bc]);
            next.push([ca, bc, c]);
            next.push([ab, bc, ca]);
        }
        triangles = next;
    }
    debug_assert_eq!(positions.len(), demo_vertex_count(s));
    debug_assert_eq!(triangles.len(), demo_triangle_count(s));
    (positions, triangles)
}

/// Area-weighted vertex normals of the displaced mesh.
fn vertex_normals(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let mut acc = vec![[0.0f64; 3]; positions.len()];
    for tri in triangles {
        let [a, b, c] = tri.map(|i| positions[i as usize]);
        // |cross| is twice the area: summing raw cross products weights by area.
        let n = cross(sub(b, a), sub(c, a));
        for &i in tri {
            let v = &mut acc[i as usize];
            v[0] += n[0];
            v[1] += n[1];
            v[2] += n[2];
        }
    }
    acc.par_iter()
        .with_min_len(4096)
        .zip(positions.par_iter())
        .map(|(n, p)| {
            let len = dot(*n, *n).sqrt();
            // Cannot happen on this mesh; fall back to the radial direction to stay finite.
            let n = if len > 0.0 {
                scale(*n, 1.0 / len)
            } else {
                normalize(*p)
            };
            [n[0] as f32, n[1] as f32, n[2] as f32]
        })
        .collect()
}

/// 3D gradient noise (Perlin's improved noise with a hash instead of the permutation table),
/// roughly in [-1, 1], zero on the integer lattice.
fn gradient_noise(p: [f64; 3], seed: u32) -> f64 {
    let fl = p.map(f64::floor);
    let [x0, y0, z0] = fl.map(|v| v as i32);
    let [fx, fy, fz] = [p[0] - fl[0], p[1] - fl[1], p[2] - fl[2]];
    let [u, v, w] = [fade(fx), fade(fy), fade(fz)];
    let g = |dx: i32, dy: i32, dz: i32| -> f64 {
        let h = lattice_hash(
            x0.wrapping_add(dx),
            y0.wrapping_add(dy),
            z0.wrapping_add(dz),
            seed,
        );
        grad(
            h,
            fx - f64::from(dx),
            fy - f64::from(dy),
            fz - f64::from(dz),
        )
    };
    let x00 = lerp(u, g(0, 0, 0), g(1, 0, 0));
    let x10 = lerp(u, g(0, 1, 0), g(1, 1, 0));
    let x01 = lerp(u, g(0, 0, 1), g(1, 0, 1));
    let x11 = lerp(u, g(0, 1, 1), g(1, 1, 1));
    lerp(w, lerp(v, x00, x10), lerp(v, x01, x11))
}

/// A fixed integer hash of a lattice point (lowbias32 finaliser over a linear combination).
fn lattice_hash(x: i32, y: i32, z: i32, seed: u32) -> u32 {
    let mut h = seed
        ^ (x as u32).wrapping_mul(0x8da6_b343)
        ^ (y as u32).wrapping_mul(0xd816_3841)
        ^ (z as u32).wrapping_mul(0xcb1a_b31f);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    h
}

/// Perlin's 12 edge gradients as 16 entries (4 repeated), by the hash's top 4 bits.
const GRADIENTS: [[f64; 3]; 16] = [
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [1.0, -1.0, 0.0],
    [-1.0, -1.0, 0.0],
    [1.0, 0.0, 1.0],
    [-1.0, 0.0, 1.0],
    [1.0, 0.0, -1.0],
    [-1.0, 0.0, -1.0],
    [0.0, 1.0, 1.0],
    [0.0, -1.0, 1.0],
    [0.0, 1.0, -1.0],
    [0.0, -1.0, -1.0],
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [0.0, -1.0, 1.0],
    [0.0, -1.0, -1.0],
];

/// Dot product with one of Perlin's 12 edge gradients: a table, not a `match`, because a
/// branch on a hash is mispredicted whenever neighbouring calls do not share lattice points
/// (`gen mesh --shuffle-vertices` ran 2.5× slower). Products with ±1 and 0 are exact, so the
/// values equal the sums and differences of Perlin's cases (tested against them).
fn grad(h: u32, x: f64, y: f64, z: f64) -> f64 {
    let g = GRADIENTS[(h >> 28) as usize];
    g[0] * x + g[1] * y + g[2] * z
}

fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(t: f64, a: f64, b: f64) -> f64 {
    a + t * (b - a)
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    scale(a, 1.0 / dot(a, a).sqrt())
}

/// Undirected edge (min id << 32 | max id) → midpoint vertex id.
type EdgeMap = HashMap<u64, u32, BuildHasherDefault<EdgeHasher>>;

/// SplitMix64 finaliser for the u64 edge keys: far cheaper than SipHash, and unlike a plain
/// multiply it mixes the high half (min id) into the low bits the table indexes with.
#[derive(Default)]
struct EdgeHasher(u64);

impl Hasher for EdgeHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(self.0.rotate_left(8) ^ u64::from(b));
        }
    }

    fn write_u64(&mut self, x: u64) {
        let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        self.0 = z ^ (z >> 31);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn counts() {
        for s in 0..=4 {
            let m = demo_mesh(s);
            assert_eq!(m.triangles.len(), 20 * 4usize.pow(s), "s = {s}");
            assert_eq!(m.positions.len(), 10 * 4usize.pow(s) + 2, "s = {s}");
            assert_eq!(m.triangles.len(), demo_triangle_count(s));
            assert_eq!(m.positions.len(), demo_vertex_count(s));
            assert_eq!(m.normals.as_ref().map(Vec::len), Some(m.positions.len()));
            assert!(m.colors.is_none() && m.uvs.is_none());
        }
        assert_eq!(demo_triangle_count(DEMO_SUBDIVISIONS), 1_310_720);
    }

    /// Every directed edge appears exactly once and its reverse exactly once: closed, manifold,
    /// consistently oriented; with V − E + F = 2 it is a sphere (genus 0).
    #[test]
    fn closed_manifold_oriented_genus0() {
        for s in 0..=5 {
            let m = demo_mesh(s);
            let mut directed = HashSet::new();
            for &[a, b, c] in &m.triangles {
                for e in [(a, b), (b, c), (c, a)] {
                    assert!(
                        directed.insert(e),
                        "s = {s}: directed edge {e:?} used twice"
                    );
                }
            }
            for &(a, b) in &directed {
                assert!(
                    directed.contains(&(b, a)),
                    "s = {s}: edge ({a}, {b}) is a border"
                );
            }
            let (v, e, f) = (m.positions.len(), directed.len() / 2, m.triangles.len());
            assert_eq!(
                v as i64 - e as i64 + f as i64,
                2,
                "s = {s}: Euler characteristic"
            );
            // Every vertex is used.
            let used: HashSet<u32> = m.triangles.iter().flatten().copied().collect();
            assert_eq!(used.len(), v);
        }
    }

    #[test]
    fn no_degenerate_and_outward() {
        for s in 0..=5 {
            let m = demo_mesh(s);
            let mut seen = HashSet::new();
            for &t in &m.triangles {
                let [a, b, c] = t;
                assert!(a != b && b != c && c != a, "s = {s}: repeated id in {t:?}");
                let mut key = t;
                key.sort_unstable();
                assert!(seen.insert(key), "s = {s}: duplicate triangle {t:?}");
                let [pa, pb, pc] = t.map(|i| m.positions[i as usize]);
                let n = cross(sub(pb, pa), sub(pc, pa));
                let area = 0.5 * dot(n, n).sqrt();
                assert!(
                    area > 1e-10,
                    "s = {s}: degenerate triangle {t:?} (area {area})"
                );
                let centroid = scale(
                    [
                        pa[0] + pb[0] + pc[0],
                        pa[1] + pb[1] + pc[1],
                        pa[2] + pb[2] + pc[2],
                    ],
                    1.0 / 3.0,
                );
                assert!(
                    dot(n, centroid) > 0.0,
                    "s = {s}: triangle {t:?} faces inwards"
                );
            }
        }
    }

    #[test]
    fn radii_within_bounds_and_detailed() {
        let m = demo_mesh(6);
        let radii: Vec<f64> = m.positions.iter().map(|&p| dot(p, p).sqrt()).collect();
        let (lo, hi) = radii
            .iter()
            .fold((f64::MAX, f64::MIN), |(lo, hi), &r| (lo.min(r), hi.max(r)));
        assert!(lo > 0.5 && hi < 1.5, "radius range [{lo}, {hi}]");
        // The clamp is a guarantee, not a shaping tool: it should never bite.
        assert!(
            lo > DEMO_MIN_RADIUS && hi < DEMO_MAX_RADIUS,
            "clamped: [{lo}, {hi}]"
        );
        // Real relief, not a sphere.
        assert!(hi - lo > 0.1, "too flat: [{lo}, {hi}]");
        // Fine detail: neighbouring vertices at level 6 still differ in radius.
        let mean_edge_dr = m
            .triangles
            .iter()
            .map(|t| (radii[t[0] as usize] - radii[t[1] as usize]).abs())
            .sum::<f64>()
            / m.triangles.len() as f64;
        assert!(mean_edge_dr > 1e-4, "no fine detail: {mean_edge_dr}");
        // Normals: unit length and mostly outward.
        let normals = m.normals.as_ref().unwrap();
        let mut outward = 0;
        for (n, p) in normals.iter().zip(&m.positions) {
            let n = n.map(f64::from);
            assert!((dot(n, n).sqrt() - 1.0).abs() < 1e-5);
            outward += usize::from(dot(n, *p) > 0.0);
        }
        assert!(
            outward * 100 >= normals.len() * 99,
            "{outward} of {}",
            normals.len()
        );
    }

    #[test]
    fn deterministic_and_nested() {
        let a = demo_mesh(4);
        assert_eq!(a, demo_mesh(4));
        // Level s is a prefix of level s + 1 (same vertex ids, bit-identical positions).
        let b = demo_mesh(5);
        assert_eq!(a.positions[..], b.positions[..a.positions.len()]);
        // A fixed value pins the noise itself (hash, gradients, octave layout, offsets).
        let r = demo_radius(normalize([0.3, -0.5, 0.8]));
        assert!(
            (r - 1.003_265_460_803_776_8).abs() < 1e-12,
            "noise changed: {r}"
        );
    }

    /// Perlin's cases as he wrote them, the reference for the table.
    fn grad_cases(h: u32, x: f64, y: f64, z: f64) -> f64 {
        match h >> 28 {
            0 | 12 => x + y,
            1 | 13 => -x + y,
            2 => x - y,
            3 => -x - y,
            4 => x + z,
            5 => -x + z,
            6 => x - z,
            7 => -x - z,
            8 => y + z,
            9 | 14 => -y + z,
            10 => y - z,
            _ => -y - z,
        }
    }

    #[test]
    fn gradient_table_equals_perlins_cases() {
        let mut h = 0x1234_5678u32;
        for i in 0..100_000u32 {
            h = lattice_hash(i as i32, 7, -3, h);
            let p = [0, 1, 2].map(|k| f64::from(lattice_hash(i as i32, k, 1, h)) / 1e9 - 2.0);
            assert_eq!(
                grad(h, p[0], p[1], p[2]),
                grad_cases(h, p[0], p[1], p[2]),
                "{h:x}"
            );
        }
    }
}
