//! A diamond's own attribute error: how far in colour, normal and texture coordinates the
//! patch it keeps strays from the wedges it gathers (issue 47; stored per diamond, saturated,
//! in the repository's attribute error table, `tessera_core::repository::attribute_errors`).
//!
//! Definition. For every wedge `w` of the gathered set that the kept set no longer uses, let
//! `d` be the distance from `w`'s position to the kept triangles (the positions meshopt saw),
//! and `T(w)` the kept triangles within `d + TIE` of it (`TIE` = 1e-6 of the model's size):
//! those touching the closest point. For each attribute the wedge's error is the smallest,
//! over `T(w)`, of the distance between `w`'s own value and the value the kept triangle
//! interpolates (barycentrically, over its wedges) at its point closest to `w`:
//! - colour: Euclidean distance of R, G, B in 8-bit units;
//! - normal: the angle in degrees between `w`'s normal and the interpolated one (180 where the
//!   interpolated normal vanishes; wedges without a normal, zero vectors, count 0);
//! - texture coordinates: Euclidean distance in UV units.
//!
//! The diamond's own error is the largest over those wedges (0 where the kept set uses every
//! wedge, or keeps nothing: then nothing is drawn with a wrong value). A kept wedge would
//! measure 0 (its own triangles interpolate its own value at itself), so it is skipped.
//!
//! Seams: where the closest point lies on a kept seam (an edge or vertex shared by triangles of
//! two charts, whose wedges differ there), `T(w)` holds the triangles of both sides and the
//! smaller error wins, so a wedge is compared with its own side of the seam, not charged the
//! jump across it. Where a curved seam was straightened, a wedge may find its closest point
//! inside the other chart's triangle: the error is then overstated, never understated.
//!
//! The same pass gives the largest `d`: the vertex-sampled distance from what the diamond
//! gathers to what it keeps, which stands for the geometric estimate where colours or texture
//! coordinates are weighed (meshopt's own estimate then mixes their error into the geometric
//! one: `simplify.rs`, `simplify_locked`).
//!
//! Cost: a uniform grid over the kept triangles (about 4 cells a triangle at most), each
//! removed wedge searching rings of cells outwards until the ring is farther than the best
//! distance found, bounded by the rings' box plus `p`'s distance to its own cell's faces (so
//! most searches end with `p`'s cell). On `bunny-astronaut.ply` (75,408 triangles), the build's
//! simplify stage, back to back on a loaded machine: 0.64 s for the same scan without colours,
//! 0.72-0.75 s with them (1.18-1.20 s when the bound was the rings' alone).

use crate::vertex_table::VertexTable;

/// One diamond's own attribute errors (see the module's definition). Every field ≥ 0.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AttributeError {
    /// Largest colour distance, 8-bit RGB units.
    pub colour: f32,
    /// Largest normal angle, degrees.
    pub normal_degrees: f32,
    /// Largest texture-coordinate distance, UV units.
    pub uv: f32,
}

impl AttributeError {
    /// The larger of each field.
    pub fn max(self, other: AttributeError) -> AttributeError {
        AttributeError {
            colour: self.colour.max(other.colour),
            normal_degrees: self.normal_degrees.max(other.normal_degrees),
            uv: self.uv.max(other.uv),
        }
    }
}

/// Triangles within this distance (model sizes) of the closest one touch the closest point.
const TIE: f64 = 1e-6;

/// What `measure` found.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Measured {
    pub error: AttributeError,
    /// The largest distance from a removed wedge to the kept triangles, in the units of the
    /// positions (model sizes); `None` where nothing is kept.
    pub distance: Option<f64>,
}

/// Measures the attribute error of keeping `kept` of `gathered` (local wedge indices, three a
/// triangle) over wedges at `positions` whose attributes are `vertices`' rows `rows`.
pub(super) fn measure(
    positions: &[[f32; 3]],
    rows: &[usize],
    vertices: &VertexTable,
    gathered: &[u32],
    kept: &[u32],
) -> Measured {
    debug_assert_eq!(positions.len(), rows.len());
    if kept.is_empty() {
        return Measured::default();
    }
    let p = |w: u32| positions[w as usize].map(f64::from);
    let mut is_kept = vec![false; positions.len()];
    for &w in kept {
        is_kept[w as usize] = true;
    }
    let mut removed = vec![false; positions.len()];
    for &w in gathered {
        removed[w as usize] = !is_kept[w as usize];
    }
    let triangles: Vec<[[f64; 3]; 3]> = kept
        .chunks_exact(3)
        .map(|t| [p(t[0]), p(t[1]), p(t[2])])
        .collect();
    let grid = Grid::new(positions, &triangles);
    let mut out = Measured {
        distance: Some(0.0),
        ..Measured::default()
    };
    let mut candidates = Vec::new();
    for w in (0..positions.len()).filter(|&w| removed[w]) {
        let q = p(w as u32);
        let best = grid.nearest(q, &triangles, &mut candidates);
        out.distance = out.distance.map(|d| d.max(best));
        let mut wedge = [f64::INFINITY; 3];
        for &(t, distance, bary) in &candidates {
            if distance > best + TIE {
                continue;
            }
            let corners = [0, 1, 2].map(|k| rows[kept[3 * t + k] as usize]);
            let e = errors_at(vertices, rows[w], corners, bary);
            for k in 0..3 {
                wedge[k] = wedge[k].min(e[k]);
            }
        }
        out.error = out.error.max(AttributeError {
            colour: wedge[0] as f32,
            normal_degrees: wedge[1] as f32,
            uv: wedge[2] as f32,
        });
    }
    out
}

/// The colour, normal and UV errors of the wedge at row `own` against the value interpolated
/// with barycentric weights `bary` over the rows `corners` (0 for an attribute absent).
fn errors_at(vertices: &VertexTable, own: usize, corners: [usize; 3], bary: [f64; 3]) -> [f64; 3] {
    let mut e = [0.0; 3];
    if let Some(c) = &vertices.colors {
        let at = |k: usize| -> f64 { (0..3).map(|r| bary[r] * c[corners[r]][k] as f64).sum() };
        e[0] = (0..3)
            .map(|k| (at(k) - c[own][k] as f64).powi(2))
            .sum::<f64>()
            .sqrt();
    }
    if let Some(n) = &vertices.normals {
        let m = n[own].map(f64::from);
        let i: [f64; 3] =
            [0, 1, 2].map(|k| (0..3).map(|r| bary[r] * n[corners[r]][k] as f64).sum());
        e[1] = angle_degrees(m, i);
    }
    if let Some(uv) = &vertices.uvs {
        let at = |k: usize| -> f64 { (0..3).map(|r| bary[r] * uv[corners[r]][k] as f64).sum() };
        e[2] = (0..2)
            .map(|k| (at(k) - uv[own][k] as f64).powi(2))
            .sum::<f64>()
            .sqrt();
    }
    e
}

/// The angle between `own` and `interpolated`, degrees: 0 where `own` is the zero vector (no
/// normal), 180 where the interpolated normal vanishes.
fn angle_degrees(own: [f64; 3], interpolated: [f64; 3]) -> f64 {
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    if dot(own, own) == 0.0 {
        return 0.0;
    }
    if dot(interpolated, interpolated) < 1e-24 {
        return 180.0;
    }
    let c = [
        own[1] * interpolated[2] - own[2] * interpolated[1],
        own[2] * interpolated[0] - own[0] * interpolated[2],
        own[0] * interpolated[1] - own[1] * interpolated[0],
    ];
    dot(c, c).sqrt().atan2(dot(own, interpolated)).to_degrees()
}

/// The closest point of triangle `t` to `p` (Ericson, "Real-Time Collision Detection",
/// 5.1.5): its distance and barycentric weights. A triangle without area is measured by its
/// nearest edge.
fn closest_point(p: [f64; 3], t: &[[f64; 3]; 3]) -> (f64, [f64; 3]) {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let at = |bary: [f64; 3]| -> (f64, [f64; 3]) {
        let q = [0, 1, 2].map(|k| (0..3).map(|r| bary[r] * t[r][k]).sum::<f64>());
        let d = sub(p, q);
        (dot(d, d).sqrt(), bary)
    };
    // On segment (i, j), the weights of the point closest to `p`.
    let segment = |i: usize, j: usize| {
        let e = sub(t[j], t[i]);
        let len2 = dot(e, e);
        let s = match len2 > 0.0 {
            true => (dot(sub(p, t[i]), e) / len2).clamp(0.0, 1.0),
            false => 0.0,
        };
        let mut bary = [0.0; 3];
        bary[i] = 1.0 - s;
        bary[j] += s;
        at(bary)
    };
    let [a, b, c] = *t;
    let (ab, ac) = (sub(b, a), sub(c, a));
    let n = [
        ab[1] * ac[2] - ab[2] * ac[1],
        ab[2] * ac[0] - ab[0] * ac[2],
        ab[0] * ac[1] - ab[1] * ac[0],
    ];
    if dot(n, n) <= 1e-20 * dot(ab, ab) * dot(ac, ac) {
        let edges = [segment(0, 1), segment(1, 2), segment(2, 0)];
        return edges
            .into_iter()
            .min_by(|x, y| x.0.total_cmp(&y.0))
            .expect("three edges");
    }
    let ap = sub(p, a);
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return at([1.0, 0.0, 0.0]);
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return at([0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return segment(0, 1);
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return at([0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return segment(0, 2);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return segment(1, 2);
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    at([1.0 - v - w, v, w])
}

/// A uniform grid of triangles (CSR: each cell's triangles in one list).
struct Grid {
    min: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    starts: Vec<u32>,
    members: Vec<u32>,
}

impl Grid {
    /// A grid over `positions`' box (every query point lies in it) with about one cell a
    /// triangle along a surface, at most 4 a triangle (+ 64), each triangle in every cell its
    /// box meets.
    fn new(positions: &[[f32; 3]], triangles: &[[[f64; 3]; 3]]) -> Grid {
        let mut min = [f64::INFINITY; 3];
        let mut max = [f64::NEG_INFINITY; 3];
        for p in positions {
            for k in 0..3 {
                min[k] = min[k].min(p[k] as f64);
                max[k] = max[k].max(p[k] as f64);
            }
        }
        let extent = [0, 1, 2].map(|k| (max[k] - min[k]).max(0.0));
        let longest = extent.iter().copied().fold(0.0, f64::max);
        let limit = 4 * triangles.len() + 64;
        let mut cell = match longest > 0.0 {
            true => longest / (triangles.len() as f64).sqrt().ceil().max(1.0),
            false => 1.0,
        };
        let dims_of = |cell: f64| extent.map(|e| ((e / cell).ceil() as usize).clamp(1, 1 << 10));
        while dims_of(cell).iter().product::<usize>() > limit {
            cell *= 1.26;
        }
        let dims = dims_of(cell);
        let mut grid = Grid {
            min,
            cell,
            dims,
            starts: vec![0; dims.iter().product::<usize>() + 1],
            members: Vec::new(),
        };
        // Two passes: count, then place.
        for pass in 0..2 {
            let mut fill = grid.starts.clone();
            for (i, t) in triangles.iter().enumerate() {
                let lo = grid.cell_of([0, 1, 2].map(|k| t[0][k].min(t[1][k]).min(t[2][k])));
                let hi = grid.cell_of([0, 1, 2].map(|k| t[0][k].max(t[1][k]).max(t[2][k])));
                for z in lo[2]..=hi[2] {
                    for y in lo[1]..=hi[1] {
                        for x in lo[0]..=hi[0] {
                            let c = grid.index([x, y, z]);
                            match pass {
                                0 => grid.starts[c + 1] += 1,
                                _ => {
                                    grid.members[fill[c] as usize] = i as u32;
                                    fill[c] += 1;
                                }
                            }
                        }
                    }
                }
            }
            if pass == 0 {
                for c in 1..grid.starts.len() {
                    grid.starts[c] += grid.starts[c - 1];
                }
                grid.members = vec![0; *grid.starts.last().expect("one cell") as usize];
            }
        }
        grid
    }

    fn cell_of(&self, p: [f64; 3]) -> [usize; 3] {
        [0, 1, 2].map(|k| {
            let c = ((p[k] - self.min[k]) / self.cell).floor();
            (c.max(0.0) as usize).min(self.dims[k] - 1)
        })
    }

    fn index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// The distance from `p` (inside the grid's box) to the nearest triangle; `candidates`
    /// gets every triangle looked at, with its distance and closest point's weights, which
    /// includes every triangle within `TIE` of the nearest.
    fn nearest(
        &self,
        p: [f64; 3],
        triangles: &[[[f64; 3]; 3]],
        candidates: &mut Vec<(usize, f64, [f64; 3])>,
    ) -> f64 {
        candidates.clear();
        let c = self.cell_of(p);
        // How far `p` is from the faces of its own cell (rounding may put it a hair outside).
        let inside = (0..3)
            .map(|k| {
                let lo = self.min[k] + c[k] as f64 * self.cell;
                (p[k] - lo).min(lo + self.cell - p[k]).max(0.0)
            })
            .fold(f64::INFINITY, f64::min);
        let mut best = f64::INFINITY;
        let widest = self.dims.iter().copied().max().expect("three axes");
        for r in 0..widest {
            let lo = c.map(|x| x.saturating_sub(r));
            let hi = [0, 1, 2].map(|k| (c[k] + r).min(self.dims[k] - 1));
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        let ring =
                            [x, y, z].iter().zip(&c).map(|(&a, &b)| a.abs_diff(b)).max() == Some(r);
                        if !ring {
                            continue;
                        }
                        let cell = self.index([x, y, z]);
                        let range = self.starts[cell] as usize..self.starts[cell + 1] as usize;
                        for &t in &self.members[range] {
                            let (d, bary) = closest_point(p, &triangles[t as usize]);
                            best = best.min(d);
                            candidates.push((t as usize, d, bary));
                        }
                    }
                }
            }
            // Any triangle in no cell looked at lies outside the box of the cells within `r`
            // of `p`'s cell, which holds the ball of radius `r` cells + `inside` around `p`.
            if best + TIE < r as f64 * self.cell + inside {
                break;
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat n × n grid of squares in [0, 1]², two triangles each, wedges row-major, coloured
    /// by `colour(x, y)`; and the same outline kept as two triangles.
    fn plane(
        n: u32,
        colour: impl Fn(f32, f32) -> [u8; 4],
    ) -> (Vec<[f32; 3]>, VertexTable, Vec<u32>, Vec<u32>) {
        let side = n + 1;
        let mut positions = Vec::new();
        for y in 0..side {
            for x in 0..side {
                positions.push([x as f32 / n as f32, y as f32 / n as f32, 0.0]);
            }
        }
        let at = |x: u32, y: u32| y * side + x;
        let mut gathered = Vec::new();
        for y in 0..n {
            for x in 0..n {
                gathered.extend([at(x, y), at(x + 1, y), at(x + 1, y + 1)]);
                gathered.extend([at(x, y), at(x + 1, y + 1), at(x, y + 1)]);
            }
        }
        let kept = vec![at(0, 0), at(n, 0), at(n, n), at(0, 0), at(n, n), at(0, n)];
        let vertices = VertexTable {
            ids: (0..positions.len() as u32).collect(),
            positions: positions.iter().map(|p| p.map(f64::from)).collect(),
            simplifier: positions.clone(),
            normals: Some(vec![[0.0, 0.0, 1.0]; positions.len()]),
            colors: Some(positions.iter().map(|p| colour(p[0], p[1])).collect()),
            uvs: Some(positions.iter().map(|p| [p[0], p[1]]).collect()),
        };
        (positions, vertices, gathered, kept)
    }

    fn check(colour: impl Fn(f32, f32) -> [u8; 4]) -> Measured {
        let (positions, vertices, gathered, kept) = plane(8, colour);
        let rows: Vec<usize> = (0..positions.len()).collect();
        measure(&positions, &rows, &vertices, &gathered, &kept)
    }

    #[test]
    fn a_uniform_plane_loses_nothing_and_a_colour_step_shows() {
        let uniform = check(|_, _| [200, 10, 10, 255]);
        assert_eq!(uniform.error, AttributeError::default());
        assert_eq!(uniform.distance, Some(0.0));
        // A step from black to white at x = 0.5: the kept corners are black at x = 0 and
        // white at x = 1, so the removed wedge at (0.5, 0.5) is interpolated to mid-grey while
        // it is white (x ≥ 0.5): 127.5 per channel, √3 × 127.5 = 220.8.
        let step = check(|x, _| match x >= 0.5 {
            true => [255, 255, 255, 255],
            false => [0, 0, 0, 255],
        });
        let grey = 3f32.sqrt() * 127.5;
        assert!((step.error.colour - grey).abs() < 1e-3, "{:?}", step.error);
        // The UVs are linear over the plane and the normals constant: nothing lost.
        assert!(
            step.error.uv < 1e-6 && step.error.normal_degrees < 1e-3,
            "{:?}",
            step.error
        );
    }

    #[test]
    fn a_seam_compares_a_wedge_with_its_own_side() {
        // Two squares side by side, their UV charts apart: the seam at x = 1 has a wedge of
        // each chart at each of its three points. The kept set keeps the squares' corners;
        // the seam's middle wedges lie on the kept seam edge, touching both charts'
        // triangles: each matches its own chart exactly.
        let p = |x: f32, y: f32| [x, y, 0.0];
        let positions = vec![
            p(0.0, 0.0),
            p(1.0, 0.0),
            p(1.0, 0.5),
            p(1.0, 1.0),
            p(0.0, 1.0), // chart A: 0..5
            p(1.0, 0.0),
            p(1.0, 0.5),
            p(1.0, 1.0),
            p(2.0, 0.0),
            p(2.0, 1.0), // chart B: 5..10
        ];
        let uv = |w: usize| -> [f32; 2] {
            let q = positions[w];
            match w < 5 {
                true => [q[0] * 0.25, q[1] * 0.25],
                false => [0.5 + (q[0] - 1.0) * 0.25, q[1] * 0.25],
            }
        };
        let vertices = VertexTable {
            ids: (0..10).collect(),
            positions: positions.iter().map(|p| p.map(f64::from)).collect(),
            simplifier: positions.clone(),
            normals: None,
            colors: None,
            uvs: Some((0..10).map(uv).collect()),
        };
        let gathered = vec![0, 1, 2, 0, 2, 4, 2, 3, 4, 5, 8, 6, 6, 8, 9, 6, 9, 7];
        let kept = vec![0, 1, 3, 0, 3, 4, 5, 8, 9, 5, 9, 7];
        let rows: Vec<usize> = (0..10).collect();
        let m = measure(&positions, &rows, &vertices, &gathered, &kept);
        assert!(m.error.uv < 1e-6, "{:?}", m.error);
        // Against the other chart only, chart A's wedges are 0.25 (on the seam) to 0.5 off in
        // u.
        let one_side = vec![5, 8, 9, 5, 9, 7];
        let m = measure(&positions, &rows, &vertices, &gathered, &one_side);
        assert!(m.error.uv >= 0.5, "{:?}", m.error);
    }

    #[test]
    fn closest_point_weights_reproduce_the_point_on_the_triangle() {
        let t = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]];
        for (p, d, bary) in [
            ([0.5, 0.5, 1.0], 1.0, [0.5, 0.25, 0.25]),
            ([-1.0, -1.0, 0.0], 2f64.sqrt(), [1.0, 0.0, 0.0]),
            ([1.0, -3.0, 0.0], 3.0, [0.5, 0.5, 0.0]),
        ] {
            let (got, w) = closest_point(p, &t);
            assert!((got - d).abs() < 1e-12, "{p:?}: {got}");
            assert!(
                w.iter().zip(bary).all(|(a, b)| (a - b).abs() < 1e-12),
                "{p:?}: {w:?}"
            );
        }
        assert!((angle_degrees([0.0, 0.0, 1.0], [1.0, 0.0, 1.0]) - 45.0).abs() < 1e-9);
        assert_eq!(angle_degrees([0.0, 0.0, 1.0], [0.0; 3]), 180.0);
    }
}
