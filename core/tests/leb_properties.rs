//! Property tests of the LEB hierarchy and its diamond DAG (seed 001, table 1), in 2D and 3D.

use std::collections::HashMap;

use proptest::prelude::*;
use tessera_core::leb::predicates::{
    orient2d_exact, orient2d_point, orient3d_exact, orient3d_point,
};
use tessera_core::leb::{ConformingMesh, Diamond, LatticePlane, LatticePoint, Simplex};

const BITS: u32 = 5;

/// The simplex reached from root `root` by following `path` for `level` steps.
fn descend(dim: u8, root: usize, path: u64, level: u16) -> Simplex {
    let roots = Simplex::roots(dim, BITS);
    let mut s = roots[root % roots.len()];
    for i in 0..level {
        s = s.children()[((path >> i) & 1) as usize];
    }
    s
}

fn random_diamond(dim: u8, root: usize, path: u64, level: u16) -> Diamond {
    // Deepest splittable level is dim·BITS − 1.
    let level = level % (dim as u16 * BITS as u16 - 1);
    let s = descend(dim, root, path, level);
    Diamond::find(dim, BITS, s.split_point()).expect("every split point is a diamond")
}

/// The (simplices, parents, children) counts of an interior diamond, by dimension and phase.
fn expected_counts(dim: u8, phase: u8) -> (usize, usize, usize) {
    match (dim, phase) {
        (3, 0) => (6, 3, 6),
        (3, 1) => (4, 2, 4),
        (3, 2) => (8, 4, 8),
        (2, _) => (2, 2, 4),
        _ => unreachable!(),
    }
}

/// Centroid of a simplex in f64 lattice coordinates.
fn centroid(s: &Simplex) -> [f64; 3] {
    let n = s.dim as f64 + 1.0;
    let mut q = [0.0; 3];
    for v in &s.vertices[..=s.dim as usize] {
        for i in 0..3 {
            q[i] += v[i] as f64 / n;
        }
    }
    q
}

/// A simplex of the hierarchy over `[0, 2^bits]^dim`, `level` steps down `path`.
fn descend_bits(dim: u8, bits: u32, root: usize, path: u128, level: u16) -> Simplex {
    let roots = Simplex::roots(dim, bits);
    let mut s = roots[root % roots.len()];
    for i in 0..level % (dim as u16 * bits as u16) {
        s = s.children()[((path >> (i % 128)) & 1) as usize];
    }
    s
}

/// The next f64 above (`up`) or below `x` (finite x).
fn ulp_step(x: f64, up: bool) -> f64 {
    if up {
        x.next_up()
    } else {
        x.next_down()
    }
}

/// Query points around the plane through `a, b, c` (2D: the line through `a, b`): exactly on it
/// (a dyadic combination of the points, exact in f64), within rounding of it (a real
/// combination rounded to f64), those two moved by one ulp in some coordinates, `a` itself and
/// an arbitrary point.
fn points_around(
    dim: u8,
    [a, b, c]: [LatticePoint; 3],
    (s, t): (f64, f64),
    ulps: u8,
    real: [f64; 3],
) -> Vec<[f64; 3]> {
    let f = |p: LatticePoint, i: usize| p[i] as f64;
    let t = if dim == 3 { t } else { 0.0 };
    let combination = |s: f64, t: f64| {
        [0, 1, 2].map(|i| f(a, i) + (f(b, i) - f(a, i)) * s + (f(c, i) - f(a, i)) * t)
    };
    let dyadic = |x: f64| (x * 64.0).round() / 64.0;
    let on = combination(dyadic(s), dyadic(t));
    let near = combination(s, t);
    let nudged = |p: [f64; 3], pattern: u8| {
        let mut p = p;
        for (i, x) in p.iter_mut().enumerate().take(dim as usize) {
            if pattern >> (2 * i) & 1 == 1 {
                *x = ulp_step(*x, pattern >> (2 * i + 1) & 1 == 1);
            }
        }
        p
    };
    let mut points = vec![on, near, [0, 1, 2].map(|i| f(a, i)), real];
    for r in 0..8 {
        let pattern = ulps.rotate_left(r);
        points.push(nudged(on, pattern));
        points.push(nudged(near, pattern));
        points.push(nudged(nudged(near, pattern), pattern));
    }
    points
}

proptest! {
    // Cheap cases, and a point within rounding of a plane defeats plain f64 evaluation only a
    // few times in a thousand: many cases.
    #![proptest_config(ProptestConfig::with_cases(4000))]

    #[test]
    fn filtered_plane_side_is_the_exact_side(
        dim in 2u8..=3, bits in prop::sample::select(vec![5u32, 20, 30]), root in 0usize..6,
        path: u128, level: u16, st in (-3.0f64..3.0, -3.0f64..3.0), ulps: u8,
        real in (0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0),
        arbitrary: [u32; 9],
    ) {
        let s = descend_bits(dim, bits, root, path, level);
        let side = (1u64 << bits) as f64;
        let real = [real.0 * side, real.1 * side, if dim == 3 { real.2 * side } else { 0.0 }];
        let n = dim as usize + 1;
        // Any lattice plane: normals with many significant bits, where plain f64 evaluation
        // gets signs wrong near the plane.
        let lattice = |i: usize| {
            let p = [0, 1, 2].map(|k| (arbitrary[3 * i + k] % ((1 << bits) + 1)) as i32);
            if dim == 3 { p } else { [p[0], p[1], 0] }
        };
        let mut planes = vec![[lattice(0), lattice(1), lattice(2)]];
        // Every facet plane and the bisecting plane of the simplex.
        planes.extend((0..n).map(|skip| {
            let face: Vec<LatticePoint> =
                (0..n).filter(|&i| i != skip).map(|i| s.vertices[i]).collect();
            [face[0], face[1], face[face.len() - 1]]
        }));
        if s.can_split() {
            let k = s.tag as usize;
            let others: Vec<LatticePoint> =
                (1..n).filter(|&i| i != k).map(|i| s.vertices[i]).collect();
            planes.push([s.split_point(), others[0], others[others.len() - 1]]);
        }
        for points in planes {
            let plane = LatticePlane::through(dim, points[0], points[1], points[2]);
            let exact = |q: [f64; 3]| {
                if dim == 3 {
                    -orient3d_point(points[0], points[1], points[2], q)
                } else {
                    orient2d_point(points[0], points[1], q)
                }
            };
            for q in points_around(dim, points, st, ulps, real) {
                prop_assert_eq!(plane.side_of_point(q), exact(q), "{:?} {:?}", points, q);
                prop_assert_eq!(plane.side_of_point_exact(q), exact(q));
            }
            for v in &s.vertices[..n] {
                let exact = if dim == 3 {
                    -orient3d_exact(points[0], points[1], points[2], *v)
                } else {
                    orient2d_exact(points[0], points[1], *v)
                };
                prop_assert_eq!(plane.side_of_lattice_point(*v), exact);
            }
        }
    }

    #[test]
    fn prepared_tests_match_the_exact_predicates(
        dim in 2u8..=3, bits in prop::sample::select(vec![5u32, 20, 30]), root in 0usize..6,
        path: u128, level: u16, st in (-3.0f64..3.0, -3.0f64..3.0), ulps: u8,
        real in (0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0),
    ) {
        let s = descend_bits(dim, bits, root, path, level);
        prop_assume!(s.can_split());
        let side = (1u64 << bits) as f64;
        let real = [real.0 * side, real.1 * side, if dim == 3 { real.2 * side } else { 0.0 }];
        let n = dim as usize + 1;
        let orient = |face: &[LatticePoint], q: [f64; 3]| {
            if dim == 3 { orient3d_point(face[0], face[1], face[2], q) } else { orient2d_point(face[0], face[1], q) }
        };
        let orient_lattice = |face: &[LatticePoint], p: LatticePoint| {
            if dim == 3 { orient3d_exact(face[0], face[1], face[2], p) } else { orient2d_exact(face[0], face[1], p) }
        };
        // The reference: the predicates applied directly, as point location always did.
        let reference = |q: [f64; 3], strict: bool| {
            (0..n).all(|skip| {
                let face: Vec<LatticePoint> =
                    (0..n).filter(|&i| i != skip).map(|i| s.vertices[i]).collect();
                let (s_q, s_o) = (orient(&face, q), orient_lattice(&face, s.vertices[skip]));
                s_q == s_o || (!strict && s_q == 0)
            })
        };
        let k = s.tag as usize;
        let others: Vec<LatticePoint> = (1..n).filter(|&i| i != k).map(|i| s.vertices[i]).collect();
        let z = s.split_point();
        let bisector = s.bisector();
        let prepared = s.prepared();
        let mut queries = points_around(dim, [z, others[0], others[others.len() - 1]], st, ulps, real);
        queries.extend(points_around(dim, [s.vertices[0], s.vertices[1], s.vertices[n - 1]], st, ulps, real));
        for q in queries {
            let side = orient(&[z, others[0], others[others.len() - 1]], q);
            let side_x0 = orient_lattice(&[z, others[0], others[others.len() - 1]], s.vertices[0]);
            let child = if side == 0 || side == side_x0 { 0 } else { 1 };
            prop_assert_eq!(bisector.child_index_of(q), child, "{:?}", q);
            prop_assert_eq!(prepared.contains_point(q), reference(q, false), "{:?}", q);
            prop_assert_eq!(prepared.strictly_contains_point(q), reference(q, true), "{:?}", q);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn interior_diamonds_have_the_table_counts(dim in 2u8..=3, root in 0usize..6, path: u64, level in 1u16..64) {
        let d = random_diamond(dim, root, path, level);
        prop_assume!(d.level > 0 && d.is_interior(BITS));
        let (simplices, parents, children) = expected_counts(dim, d.phase());
        prop_assert_eq!(d.simplices.len(), simplices, "{:?}", d.id);
        prop_assert_eq!(d.parents.len(), parents, "{:?}", d.id);
        prop_assert_eq!(d.children.len(), children, "{:?}", d.id);
    }

    #[test]
    fn diamond_relations_are_consistent(dim in 2u8..=3, root in 0usize..6, path: u64, level in 0u16..64) {
        let d = random_diamond(dim, root, path, level);
        // Every simplex of a diamond shares the split edge and the level.
        for s in &d.simplices {
            prop_assert_eq!(s.split_point(), d.id);
            prop_assert_eq!(s.level(), d.level);
        }
        // Parent and child links are mutual, one level apart.
        for p in &d.parents {
            let p = Diamond::find(dim, BITS, *p).unwrap();
            prop_assert_eq!(p.level + 1, d.level);
            prop_assert!(p.children.contains(&d.id));
        }
        for c in &d.children {
            let c = Diamond::find(dim, BITS, *c).unwrap();
            prop_assert_eq!(c.level, d.level + 1);
            prop_assert!(c.parents.contains(&d.id));
        }
    }

    #[test]
    fn children_tile_the_diamond_region(dim in 2u8..=3, root in 0usize..6, path: u64, level in 0u16..64) {
        let d = random_diamond(dim, root, path, level);
        let volume: i128 = d.simplices.iter().map(|s| s.scaled_volume()).sum();
        let children: Vec<Simplex> = d.simplices.iter().flat_map(|s| s.children()).collect();
        let child_volume: i128 = children.iter().map(|c| c.scaled_volume()).sum();
        prop_assert_eq!(volume, child_volume);
        // No overlap: each child's centroid is strictly inside that child only, and inside
        // the diamond.
        for c in &children {
            let q = centroid(c);
            let holders = children.iter().filter(|o| o.strictly_contains_point(q)).count();
            prop_assert_eq!(holders, 1);
            prop_assert!(d.simplices.iter().any(|s| s.contains_point(q)));
        }
    }

    #[test]
    fn conforming_refinement_and_point_location(
        dim in 2u8..=3,
        picks in prop::collection::vec(any::<u64>(), 1..40),
        queries in prop::collection::vec((any::<u32>(), any::<u32>(), any::<u32>(), 0u8..4), 1..64),
    ) {
        let mut mesh = ConformingMesh::new(dim, BITS);
        for pick in picks {
            // Split the diamond of a pseudo-randomly chosen leaf (forced splits included).
            let mut leaves: Vec<Simplex> = mesh.leaves().collect();
            leaves.sort_by_key(|s| s.key);
            let leaf = leaves[(pick % leaves.len() as u64) as usize];
            if leaf.can_split() {
                let done = mesh.split(leaf.split_point(), &mut |_| ());
                prop_assert!(done);
            }
        }
        check_conforming(&mesh);
        let mut leaves: Vec<Simplex> = mesh.leaves().collect();
        leaves.sort_by_key(|s| s.key);
        // The leaves are what the split diamonds make: each split simplex becomes two.
        prop_assert_eq!(leaves.len(), mesh.leaf_count());
        leaves.windows(2).for_each(|w| assert_ne!(w[0].key, w[1].key));
        for leaf in &leaves {
            prop_assert!(mesh.is_leaf(leaf.key) && mesh.contains_leaf(leaf));
            prop_assert_eq!(mesh.simplex(leaf.key), Some(*leaf));
            if leaf.can_split() {
                // Its children are not in the mesh; its parent is, and is not a leaf.
                for c in leaf.children() {
                    prop_assert!(!mesh.is_leaf(c.key) && !mesh.contains_leaf(&c));
                    prop_assert_eq!(mesh.simplex(c.key), None);
                }
            }
            if leaf.level() > 0 {
                let parent = leaf.key.ancestor(leaf.level() - 1);
                let split = mesh.simplex(parent);
                prop_assert!(split.is_some_and(|p| !mesh.contains_leaf(&p)) && !mesh.is_leaf(parent));
            }
        }
        let side = (1u64 << BITS) as f64;
        for (x, y, z, kind) in queries {
            // Leaf vertices, half-lattice points (on edges and facets), centroids, random reals.
            let q = match kind {
                0 => {
                    let s = leaves[x as usize % leaves.len()];
                    let v = s.vertices[y as usize % (dim as usize + 1)];
                    [v[0] as f64, v[1] as f64, v[2] as f64]
                }
                1 => {
                    let h = |v: u32| (v % (2 << BITS)) as f64 / 2.0;
                    [h(x), h(y), if dim == 3 { h(z) } else { 0.0 }]
                }
                2 => centroid(&leaves[x as usize % leaves.len()]),
                _ => {
                    let r = |v: u32| v as f64 / u32::MAX as f64 * side;
                    [r(x), r(y), if dim == 3 { r(z) } else { 0.0 }]
                }
            };
            let leaf = mesh.locate(q);
            prop_assert!(mesh.is_leaf(leaf.key));
            prop_assert!(leaf.contains_point(q), "{:?} located in {:?} which does not contain it", q, leaf.key);
            let strict: Vec<_> = leaves.iter().filter(|s| s.strictly_contains_point(q)).collect();
            prop_assert!(strict.len() <= 1);
            if let Some(s) = strict.first() {
                prop_assert_eq!(s.key, leaf.key);
            }
        }
    }
}

/// Every facet of every leaf is shared by exactly one other leaf, or lies on the cube's boundary.
fn check_conforming(mesh: &ConformingMesh) {
    let dim = mesh.dim() as usize;
    let side = 1i32 << mesh.bits();
    let mut facets: HashMap<Vec<LatticePoint>, usize> = HashMap::new();
    for s in mesh.leaves() {
        for skip in 0..=dim {
            let mut f: Vec<LatticePoint> = (0..=dim)
                .filter(|&i| i != skip)
                .map(|i| s.vertices[i])
                .collect();
            f.sort();
            *facets.entry(f).or_default() += 1;
        }
    }
    for (f, count) in facets {
        let on_boundary = (0..dim).any(|axis| {
            f.iter()
                .all(|v| v[axis] == f[0][axis] && (v[axis] == 0 || v[axis] == side))
        });
        let expected = if on_boundary { 1 } else { 2 };
        assert_eq!(
            count, expected,
            "facet {f:?} is used {count} times: hanging vertex"
        );
    }
}

#[test]
fn forced_splits_keep_a_deep_refinement_conforming() {
    for dim in [2u8, 3] {
        let target = [1.0, 2.0, if dim == 3 { 3.0 } else { 0.0 }];
        let mut mesh = ConformingMesh::new(dim, BITS);
        // Refine toward one point, as an adaptive build does around dense geometry.
        loop {
            let leaf = mesh.locate(target);
            if !leaf.can_split() {
                break;
            }
            assert!(mesh.split(leaf.split_point(), &mut |_| {}));
        }
        check_conforming(&mesh);
        assert_eq!(mesh.locate(target).level(), dim as u16 * BITS as u16);
    }
}

#[test]
fn split_reports_parents_before_children() {
    let mut mesh = ConformingMesh::new(3, BITS);
    let deep = descend(3, 2, 0b1011_0110_1101, 11);
    let mut order = Vec::new();
    assert!(mesh.split(deep.split_point(), &mut |d| order
        .push((d.id, d.parents.clone()))));
    for (i, (_, parents)) in order.iter().enumerate() {
        for p in parents {
            assert!(
                order[..i].iter().any(|(id, _)| id == p),
                "parent split after child"
            );
        }
    }
    assert_eq!(order.last().unwrap().0, deep.split_point());
}
