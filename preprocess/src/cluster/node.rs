//! One octree node simplified on its own (seed 004 sections 3.5.1 and 4.4.1): its interior
//! vertices collapse to the optimal vertex of its generalised quadric, and each of its
//! boundary edges is kept and fanned to that vertex.
//!
//! The boundary is the node's triangles' oriented boundary chain: each edge counted +1 for
//! every triangle using it from its lower id to its higher, -1 the other way; an edge whose
//! count m is not zero is a boundary edge and gets |m| fan triangles, oriented as its
//! triangles use it. On a consistently oriented manifold this is the seed's "edge used by one
//! triangle of the node"; anywhere it keeps the node's oriented boundary exactly, so the
//! nodes of any cut meet edge for edge and the simplified surface has the input's boundary
//! (no crack between nodes, whatever their levels). A boundary that is not one simple loop
//! (several loops, a vertex on more than two boundary edges, non-manifold input) is fanned
//! the same way: still watertight, the fan pinched at the vertex.
//!
//! Fallbacks: an optimal vertex far outside the node (beyond half its side from its cube:
//! nearly parallel sheets) or not finite goes to the node's centre, as the seed says (its
//! attributes then refitted at that position); a node whose fan would not have fewer
//! triangles than it holds keeps its triangles as they are (a node of a few triangles has
//! more boundary edges than triangles).

use rustc_hash::FxHashMap as HashMap;

use super::layout::{self, Attributes, Layout};
use super::quadric::{Quadric, MAX_DIM};

/// What every node's simplification shares.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub attributes: Attributes,
    /// The model box's minimum and largest extent (cubes are relative to the minimum).
    pub min: [f64; 3],
    pub extent: f64,
}

/// A node's cube, relative to the box's minimum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cube {
    pub min: [f64; 3],
    pub side: f64,
}

impl Cube {
    pub fn centre(&self) -> [f64; 3] {
        self.min.map(|m| m + self.side / 2.0)
    }

    /// Whether `p` lies within `margin` times the side of the cube.
    pub fn near(&self, p: [f64; 3], margin: f64) -> bool {
        (0..3).all(|k| {
            p[k] >= self.min[k] - margin * self.side
                && p[k] <= self.min[k] + (1.0 + margin) * self.side
        })
    }
}

/// How a node was simplified.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Outcome {
    /// Fanned to its optimal vertex.
    #[default]
    Fanned,
    /// Fanned to its cube's centre (the optimum lay far outside).
    Centred,
    /// Kept as it was (the fan would not have been smaller).
    Kept,
}

/// A simplified node.
pub struct Simplified<L: Layout> {
    pub triangles: Vec<L::Rec>,
    /// The quadric's error at the vertex chosen (area-weighted summed squared distance in
    /// the quadric's units: the model's extent is 1); 0 for a node kept as it was.
    pub error: f64,
    pub outcome: Outcome,
    /// The boundary is not one simple loop.
    pub irregular: bool,
}

/// Simplifies the triangles `input` of a node in `cube`; the new vertex gets id `new_id`
/// and every output triangle the key `key`.
pub fn simplify<L: Layout>(
    input: &[L::Rec],
    cube: Cube,
    new_id: u32,
    key: u64,
    frame: &Frame,
) -> Simplified<L> {
    let dims = frame.attributes.dims();
    let inv = 1.0 / frame.extent;
    let mut quadric = Quadric::new(dims);
    // Where each vertex's words are found: (record, corner).
    let mut corners: HashMap<u32, (u32, u8)> = HashMap::default();
    let mut net: HashMap<(u32, u32), i32> = HashMap::default();
    let mut x = [[0.0; MAX_DIM]; 3];
    for (i, r) in input.iter().enumerate() {
        let ids = layout::ids::<L>(r);
        for k in 0..3 {
            corners.entry(ids[k]).or_insert((i as u32, k as u8));
            layout::vector(
                layout::corner::<L>(r, k),
                frame.attributes,
                frame.min,
                inv,
                &mut x[k],
            );
            let (a, b) = (ids[k], ids[(k + 1) % 3]);
            if a < b {
                *net.entry((a, b)).or_insert(0) += 1;
            } else {
                *net.entry((b, a)).or_insert(0) -= 1;
            }
        }
        quadric.add_triangle(&x[0], &x[1], &x[2], area(&x[0], &x[1], &x[2]));
    }
    let mut boundary: Vec<((u32, u32), i32)> = net.into_iter().filter(|e| e.1 != 0).collect();
    boundary.sort_unstable();
    let fan: usize = boundary.iter().map(|e| e.1.unsigned_abs() as usize).sum();
    if fan >= input.len() {
        return Simplified {
            triangles: input
                .iter()
                .map(|r| {
                    let mut r = *r;
                    layout::set_key::<L>(&mut r, key);
                    r
                })
                .collect(),
            error: 0.0,
            outcome: Outcome::Kept,
            irregular: false,
        };
    }
    let mut v = quadric.optimum();
    let mut outcome = Outcome::Fanned;
    let position = [
        v[0] * frame.extent,
        v[1] * frame.extent,
        v[2] * frame.extent,
    ];
    if !position.iter().all(|c| c.is_finite()) || !cube.near(position, 0.5) {
        let centre = cube.centre();
        v = quadric.centroid();
        for k in 0..3 {
            v[k] = centre[k] * inv;
        }
        quadric.optimum_attributes(&mut v);
        outcome = Outcome::Centred;
    }
    let error = quadric.error(&v);
    let mut words = vec![0u32; L::VW];
    layout::from_vector(&v, frame.attributes, frame.min, frame.extent, &mut words);
    let words_of = |id: u32| {
        let (r, k) = corners[&id];
        layout::corner::<L>(&input[r as usize], k as usize)
    };
    let mut triangles = Vec::with_capacity(fan);
    for &((a, b), m) in &boundary {
        let (from, to) = if m > 0 { (a, b) } else { (b, a) };
        let t = layout::record::<L>(
            key,
            [from, to, new_id],
            [words_of(from), words_of(to), &words],
        );
        for _ in 0..m.unsigned_abs() {
            triangles.push(t);
        }
    }
    Simplified {
        triangles,
        error,
        outcome,
        irregular: !is_one_simple_loop(&boundary),
    }
}

/// Whether the boundary edges form one simple loop: every vertex on exactly two, each edge
/// once, and all connected.
fn is_one_simple_loop(boundary: &[((u32, u32), i32)]) -> bool {
    if boundary.iter().any(|e| e.1.abs() != 1) || boundary.is_empty() {
        return boundary.is_empty();
    }
    let mut next: HashMap<u32, Vec<u32>> = HashMap::default();
    for &((a, b), _) in boundary {
        next.entry(a).or_default().push(b);
        next.entry(b).or_default().push(a);
    }
    if next.values().any(|n| n.len() != 2) {
        return false;
    }
    // Walk the loop from the first vertex: one loop visits every vertex.
    let start = boundary[0].0 .0;
    let (mut previous, mut at, mut steps) = (start, next[&start][0], 1);
    while at != start {
        let n = &next[&at];
        let step = if n[0] == previous { n[1] } else { n[0] };
        previous = at;
        at = step;
        steps += 1;
    }
    steps == next.len()
}

/// The area of a triangle from the first three coordinates of its points.
pub fn area(a: &[f64], b: &[f64], c: &[f64]) -> f64 {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
}

#[cfg(test)]
#[path = "node_tests.rs"]
mod tests;
