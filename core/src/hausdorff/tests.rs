use super::*;
use crate::vec3::{length, sub};
use proptest::prelude::*;

/// Points spread over a triangle: a barycentric lattice with `n` steps a side.
fn lattice_points(t: &[[f64; 3]; 3], n: usize) -> Vec<[f64; 3]> {
    let mut points = Vec::new();
    for i in 0..=n {
        for j in 0..=n - i {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            let w = 1.0 - u - v;
            points.push([0, 1, 2].map(|k| u * t[0][k] + v * t[1][k] + w * t[2][k]));
        }
    }
    points
}

fn triangles(positions: &[[f64; 3]], indices: &[u32]) -> Vec<[[f64; 3]; 3]> {
    indices
        .chunks_exact(3)
        .map(|t| [0, 1, 2].map(|k| positions[t[k] as usize]))
        .collect()
}

/// The directed distance sampled densely by brute force: a lower bound on the true one.
fn sampled_directed(positions: &[[f64; 3]], from: &[u32], to: &[u32], n: usize) -> f64 {
    let targets = triangles(positions, to);
    triangles(positions, from)
        .iter()
        .flat_map(|t| lattice_points(t, n))
        .map(|p| {
            targets
                .iter()
                .map(|t| point_triangle_distance(p, t))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

/// A square [0,1]² at height z, as two triangles over vertices `first..first + 4`.
fn square(positions: &mut Vec<[f64; 3]>, z: f64) -> Vec<u32> {
    let first = positions.len() as u32;
    positions.extend([[0.0, 0.0, z], [1.0, 0.0, z], [1.0, 1.0, z], [0.0, 1.0, z]]);
    vec![first, first + 1, first + 2, first, first + 2, first + 3]
}

#[test]
fn parallel_squares_are_their_gap_apart() {
    let mut positions = Vec::new();
    let low = square(&mut positions, 0.0);
    let high = square(&mut positions, 0.25);
    let h = two_sided_bound(&positions, &low, &high);
    assert!((0.25..=0.25 * (1.0 + SLACK)).contains(&h), "{h}");
}

#[test]
fn one_square_triangulated_two_ways_is_at_distance_zero() {
    // The same unit square cut along either diagonal: every piece of one triangulation that
    // crosses the other's diagonal is bounded on each side of it through its own triangle.
    let positions = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let one = [0, 1, 2, 0, 2, 3];
    let other = [0, 1, 3, 1, 2, 3];
    let h = two_sided_bound(&positions, &one, &other);
    assert!(h <= 1e-12, "{h}");
}

#[test]
fn identical_sets_are_at_distance_zero_and_empty_sets_are_infinitely_far() {
    let mut positions = Vec::new();
    let s = square(&mut positions, 0.0);
    assert_eq!(two_sided_bound(&positions, &s, &s), 0.0);
    assert_eq!(two_sided_bound(&positions, &[], &[]), 0.0);
    assert_eq!(two_sided_bound(&positions, &s, &[]), f64::INFINITY);
    assert_eq!(two_sided_bound(&positions, &[], &s), f64::INFINITY);
}

#[test]
fn a_tent_is_its_height_from_the_flat_square_and_less_the_other_way() {
    // The flat square, and the same square with its centre raised to height 0.3.
    let mut positions = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.5, 0.5, 0.3],
    ];
    let flat = vec![0, 1, 2, 0, 2, 3];
    let tent = vec![0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4];
    let up = directed_bound(&positions, &tent, &flat, 0.0);
    assert!((0.3..=0.3 * (1.0 + SLACK)).contains(&up), "{up}");
    let down = directed_bound(&positions, &flat, &tent, 0.0);
    let sampled = sampled_directed(&positions, &flat, &tent, 64);
    assert!(
        down >= sampled && down <= sampled * 1.05 + 1e-12,
        "{down} vs {sampled}"
    );
    assert!(down < 0.3);
    // Moving the apex never shrinks the bound below what sampling sees.
    positions[4] = [0.2, 0.7, -0.4];
    let both = two_sided_bound(&positions, &flat, &tent);
    let sampled = sampled_directed(&positions, &flat, &tent, 64)
        .max(sampled_directed(&positions, &tent, &flat, 64));
    assert!(
        both >= sampled && both <= sampled * 1.05 + 1e-12,
        "{both} vs {sampled}"
    );
}

#[test]
fn point_triangle_distance_matches_the_nearest_lattice_point() {
    let t = [[0.0, 0.0, 0.0], [2.0, 0.5, 0.0], [0.3, 1.5, 0.8]];
    let points = lattice_points(&t, 200);
    for p in [
        [0.5, 0.5, 1.0],
        [-1.0, -1.0, 0.0],
        [3.0, 0.5, 0.2],
        [0.1, 2.0, 2.0],
        [1.0, -0.5, -0.5],
    ] {
        let exact = point_triangle_distance(p, &t);
        let sampled = points
            .iter()
            .map(|&q| length(sub(p, q)))
            .fold(f64::INFINITY, f64::min);
        assert!(
            exact <= sampled + 1e-12 && exact >= sampled - 0.02,
            "{exact} vs {sampled}"
        );
    }
}

#[test]
fn degenerate_triangles_are_measured_as_segments() {
    let segment = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
    assert!((point_triangle_distance([1.5, 1.0, 0.0], &segment) - 1.0).abs() < 1e-12);
    // Two corners at one point: a segment, whichever corner repeats.
    for t in [
        [[0.0, 0.0, -0.2], [0.0, 0.0, -0.2], [0.0, 0.0, 0.0]],
        [[0.0, 0.0, 0.0], [0.0, 0.0, -0.2], [0.0, 0.0, -0.2]],
    ] {
        assert_eq!(point_triangle_distance([0.0, 0.0, 0.0], &t), 0.0);
        assert!((point_triangle_distance([0.0, 0.0, -0.1], &t)).abs() < 1e-15);
        assert!((point_triangle_distance([0.3, 0.0, -0.1], &t) - 0.3).abs() < 1e-12);
    }
    let point = [[1.0, 1.0, 1.0]; 3];
    assert!((point_triangle_distance([1.0, 1.0, 3.0], &point) - 2.0).abs() < 1e-12);
}

fn coordinate() -> impl Strategy<Value = f64> {
    -1.0f64..1.0
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// The bound is never below what dense sampling finds, and not far above it.
    #[test]
    fn the_bound_holds_against_dense_sampling(
        positions in prop::collection::vec([coordinate(), coordinate(), coordinate()], 6..12),
        picks in prop::collection::vec(0usize..1000, 6..24),
    ) {
        let n = positions.len();
        let indices: Vec<u32> = picks.iter().map(|&p| (p % n) as u32).collect();
        let split = (indices.len() / 3 / 2).max(1) * 3;
        let (a, b) = indices.split_at(split);
        let b = &b[..b.len() / 3 * 3];
        prop_assume!(!b.is_empty());
        let bound = directed_bound(&positions, a, b, 0.0);
        let sampled = sampled_directed(&positions, a, b, 24);
        prop_assert!(bound >= sampled - 1e-12, "bound {} below sampled {}", bound, sampled);
        // The slack, plus what 24 samples a side can miss of a unit-sized triangle.
        prop_assert!(bound <= sampled * (1.0 + SLACK) + 0.1, "bound {} vs sampled {}", bound, sampled);
        // The grid-backed sampler finds exactly what brute force does on the same points.
        let through_grid = super::sampled_directed(&positions, a, b, 24);
        prop_assert!((through_grid - sampled).abs() <= 1e-12, "{} vs {}", through_grid, sampled);
    }

    /// Weighed as `check --errors` weighs (the quantisation subtracted, over the distance from
    /// an eye): the sampler, which ends a sample's search once it cannot raise the largest,
    /// finds exactly what weighing every sample's exact distance does.
    #[test]
    fn weighed_sampling_is_exact(
        positions in prop::collection::vec([coordinate(), coordinate(), coordinate()], 6..12),
        picks in prop::collection::vec(0usize..1000, 6..24),
        eye in [coordinate(), coordinate(), coordinate()],
    ) {
        let n = positions.len();
        let indices: Vec<u32> = picks.iter().map(|&p| (p % n) as u32).collect();
        let split = (indices.len() / 3 / 2).max(1) * 3;
        let (a, b) = indices.split_at(split);
        let b = &b[..b.len() / 3 * 3];
        prop_assume!(!b.is_empty());
        let weigh = |p: [f64; 3], d: f64| (d - 0.05).max(0.0) * 1000.0 / (length(sub(p, eye)) + d).max(0.1);
        let targets = triangles(&positions, b);
        let brute = triangles(&positions, a)
            .iter()
            .flat_map(|t| lattice_points(t, 6))
            .map(|p| {
                let d = targets
                    .iter()
                    .map(|t| point_triangle_distance(p, t))
                    .fold(f64::INFINITY, f64::min);
                weigh(p, d)
            })
            .fold(0.0, f64::max);
        let through_grid = sampled_directed_weighted(&positions, a, b, 6, weigh);
        prop_assert_eq!(through_grid, brute);
    }
}
