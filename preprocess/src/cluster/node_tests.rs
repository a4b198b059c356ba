//! Tests of one node's simplification: fans of neighbouring nodes meet edge for edge.

use std::collections::HashMap;

use super::*;
use crate::cluster::layout::{self, Plain};

type Rec = <Plain as Layout>::Rec;

/// The surface of the cube [0, n]^3, each face an n × n grid of quads, oriented outwards,
/// vertices numbered by their lattice point.
fn cube_surface(n: u32) -> Vec<Rec> {
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    let mut out = Vec::new();
    for axis in 0..3 {
        for side in [0, n] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for i in 0..n {
                for j in 0..n {
                    let at = |a: u32, b: u32| {
                        let mut p = [0u32; 3];
                        p[axis] = side;
                        p[u] = a;
                        p[v] = b;
                        p
                    };
                    let quad = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                    let mut tris = [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]];
                    if side == 0 {
                        for t in &mut tris {
                            t.swap(1, 2);
                        }
                    }
                    for t in tris {
                        let mut tid = [0u32; 3];
                        for k in 0..3 {
                            let len = ids.len() as u32;
                            tid[k] = *ids.entry(t[k]).or_insert(len);
                        }
                        let words: [[u32; 3]; 3] = t.map(|p| p.map(|c| (c as f32).to_bits()));
                        out.push(layout::record::<Plain>(
                            0,
                            tid,
                            [&words[0], &words[1], &words[2]],
                        ));
                    }
                }
            }
        }
    }
    out
}

/// Directed edge counts of a set of triangles.
fn directed(triangles: &[Rec]) -> HashMap<(u32, u32), i64> {
    let mut e = HashMap::new();
    for r in triangles {
        let ids = layout::ids::<Plain>(r);
        for k in 0..3 {
            *e.entry((ids[k], ids[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    e
}

fn octants(n: u32) -> Vec<(Cube, Vec<Rec>)> {
    let half = n as f64 / 2.0;
    let mut nodes: Vec<(Cube, Vec<Rec>)> = (0..8)
        .map(|o| {
            let min = [o & 1, (o >> 1) & 1, (o >> 2) & 1].map(|b| b as f64 * half);
            (Cube { min, side: half }, Vec::new())
        })
        .collect();
    for r in cube_surface(n) {
        let c = [0, 1, 2].map(|axis| {
            (0..3)
                .map(|k| layout::position(layout::corner::<Plain>(&r, k))[axis] as f64)
                .sum::<f64>()
                / 3.0
        });
        let o =
            (c[0] > half) as usize | ((c[1] > half) as usize) << 1 | ((c[2] > half) as usize) << 2;
        nodes[o].1.push(r);
    }
    nodes
}

#[test]
fn fans_of_neighbouring_nodes_are_watertight_and_find_the_corners() {
    let n = 8;
    let frame = Frame {
        attributes: Attributes::default(),
        min: [0.0; 3],
        extent: n as f64,
    };
    let input: Vec<Rec> = octants(n).into_iter().flat_map(|o| o.1).collect();
    assert!(directed(&input)
        .iter()
        .all(|(&(a, b), &c)| c == 1 && directed(&input).get(&(b, a)) == Some(&1)));
    let mut output = Vec::new();
    for (o, (cube, triangles)) in octants(n).into_iter().enumerate() {
        let s = simplify::<Plain>(&triangles, cube, 10_000 + o as u32, o as u64, &frame);
        assert_eq!(s.outcome, Outcome::Fanned);
        assert!(
            !s.irregular,
            "an octant of a cube's surface has one boundary loop"
        );
        assert!(s.triangles.len() < triangles.len());
        // Three faces meet at the octant's corner of the cube: the quadric's optimum.
        let corner = cube.min.map(|m| if m > 0.0 { n as f64 } else { 0.0 });
        let fan_vertex = s
            .triangles
            .iter()
            .find_map(|r| {
                (0..3)
                    .find(|&k| layout::ids::<Plain>(r)[k] == 10_000 + o as u32)
                    .map(|k| layout::position(layout::corner::<Plain>(r, k)))
            })
            .unwrap();
        for k in 0..3 {
            assert!(
                (fan_vertex[k] as f64 - corner[k]).abs() < 1e-4,
                "{fan_vertex:?}"
            );
        }
        // The error there is 0: the corner lies on every plane.
        assert!(s.error < 1e-9, "{}", s.error);
        output.extend(s.triangles);
    }
    // Every directed edge is met by its reverse: closed and consistently oriented.
    let edges = directed(&output);
    for (&(a, b), &count) in &edges {
        assert_eq!(edges.get(&(b, a)), Some(&count), "edge {a}-{b} not matched");
    }
    // Each octant keeps its boundary loop: 6 runs of n/2 edges.
    assert_eq!(output.len() as u32, 8 * 6 * (n / 2));
}

#[test]
fn a_node_of_few_triangles_keeps_them_and_a_far_optimum_goes_to_the_centre() {
    let frame = Frame {
        attributes: Attributes::default(),
        min: [0.0; 3],
        extent: 8.0,
    };
    let one = &cube_surface(8)[..1];
    let cube = Cube {
        min: [0.0; 3],
        side: 4.0,
    };
    let s = simplify::<Plain>(one, cube, 99, 0, &frame);
    assert_eq!(s.outcome, Outcome::Kept);
    assert_eq!(s.triangles.len(), 1);
    // Two sheets 1 apart whose planes (z = 0, z = 1 + 0.1 x) meet at x = -10, far
    // outside the node [0, 4]^3: the seed's rule puts the vertex at the node's centre.
    let mut sheets = Vec::new();
    for (z0, tilt, base) in [(0.0f32, 0.0f32, 0u32), (1.0, 0.1, 100)] {
        let p = |a: u32, b: u32| [a as f32, b as f32, z0 + tilt * a as f32].map(f32::to_bits);
        let id = |a: u32, b: u32| base + 5 * a + b;
        for i in 0..4 {
            for j in 0..4 {
                let q = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
                for t in [[0, 1, 2], [0, 2, 3]] {
                    let w = t.map(|k| p(q[k].0, q[k].1));
                    sheets.push(layout::record::<Plain>(
                        0,
                        t.map(|k| id(q[k].0, q[k].1)),
                        [&w[0][..], &w[1][..], &w[2][..]],
                    ));
                }
            }
        }
    }
    let s = simplify::<Plain>(&sheets, cube, 1000, 0, &frame);
    assert_eq!(s.outcome, Outcome::Centred);
    assert!(s.irregular, "two boundary loops");
    assert_eq!(
        s.triangles.len(),
        32,
        "both sheets' 16 boundary edges fanned"
    );
    for r in &s.triangles {
        assert_eq!(layout::ids::<Plain>(r)[2], 1000);
        assert_eq!(
            layout::position(layout::corner::<Plain>(r, 2)),
            [2.0, 2.0, 2.0]
        );
    }
}
