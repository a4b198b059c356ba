//! Property tests of the LEB hierarchy and its diamond DAG (seed 001, table 1), in 2D and 3D.

use std::collections::HashMap;

use proptest::prelude::*;
use tessera_core::leb::{ConformingMesh, Diamond, LatticePoint, Simplex};

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
            let mut leaves: Vec<Simplex> = mesh.leaves().copied().collect();
            leaves.sort_by_key(|s| s.key);
            let leaf = leaves[(pick % leaves.len() as u64) as usize];
            if leaf.can_split() {
                let done = mesh.split(leaf.split_point(), &mut |_| ());
                prop_assert!(done);
            }
        }
        check_conforming(&mesh);
        let mut leaves: Vec<Simplex> = mesh.leaves().copied().collect();
        leaves.sort_by_key(|s| s.key);
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
