//! ROAM's behaviour on small synthetic terrains: conforming meshes, the budget, coherence,
//! view dependence, and the levels `WedgieErrors` allows.

use std::collections::HashMap;

use tessera_preprocess::dem::{HeightGrid, TerrainOptions};
use tessera_preprocess::diamond_square::{generate, TerrainParams};
use tessera_runtime::camera::{Camera, Z_UP};

use super::*;
use crate::terrain::grid::{sample_triangle, vertical_error, VerticalError};

/// Diamond-square terrain, (2^levels + 1)² samples 30 m apart.
fn terrain(levels: u32, seed: u64) -> HeightGrid {
    generate(&TerrainParams {
        seed,
        levels,
        ..TerrainParams::default()
    })
    .unwrap()
}

/// A `columns` × `rows` corner of a terrain: the square gets padding that must not be drawn.
fn crop(g: &HeightGrid, columns: usize, rows: usize) -> HeightGrid {
    let heights = (0..rows)
        .flat_map(|r| (0..columns).map(move |c| (r, c)))
        .map(|(r, c)| g.heights[r * g.columns + c])
        .collect();
    HeightGrid {
        columns,
        rows,
        heights,
        ..g.clone()
    }
}

fn bin(g: &HeightGrid) -> BinGrid {
    BinGrid::new(g, &TerrainOptions::default())
}

fn orbit(grid: &BinGrid, azimuth: f64, elevation: f64, distance: f64) -> Camera {
    let (lo, hi) = grid.world_bounds();
    Camera::orbit(lo, hi, Z_UP, azimuth, elevation, distance)
}

/// High above the centre: the whole grid is in view.
fn overhead(grid: &BinGrid) -> RoamView {
    RoamView::from_camera(&orbit(grid, 30.0, 75.0, 2.5))
}

/// Low over one corner, looking across the grid towards the far corner.
fn low(grid: &BinGrid) -> Camera {
    let (lo, hi) = grid.world_bounds();
    let eye = [
        lo[0] + 0.1 * (hi[0] - lo[0]),
        lo[1] + 0.1 * (hi[1] - lo[1]),
        hi[2] + 0.05 * (hi[2] - lo[2]),
    ];
    let target = [
        lo[0] + 0.8 * (hi[0] - lo[0]),
        lo[1] + 0.8 * (hi[1] - lo[1]),
        lo[2],
    ];
    let mut cam = Camera::looking_at(eye, target, 1.0);
    cam.near = 0.1;
    cam
}

/// The camera moved sideways by `share` of its distance to the target.
fn sideways(cam: &Camera, share: f64) -> Camera {
    let mut moved = *cam;
    let b = cam.basis();
    let d = (0..3)
        .map(|i| (cam.target[i] - cam.eye[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    for i in 0..3 {
        moved.eye[i] += share * d * b.right[i];
        moved.target[i] += share * d * b.right[i];
    }
    moved
}

fn ops(s: &RoamFrameStats) -> usize {
    s.splits + s.forced_splits + s.merges
}

fn area2(t: &BinTri) -> i64 {
    let [a, b, c] = t.corners();
    (b[0] - a[0]) as i64 * (c[1] - a[1]) as i64 - (b[1] - a[1]) as i64 * (c[0] - a[0]) as i64
}

/// Everything a triangulation must be after a frame; panics with what is wrong.
fn check(roam: &mut Roam, grid: &BinGrid, view: &RoamView) {
    // Every priority of this frame, interior triangles included, for the monotony check.
    for n in 0..roam.tree.nodes.len() as u32 {
        if roam.tree.alive(n) {
            roam.key_of(grid, view, n);
        }
    }
    let split_keys: Vec<u32> = roam
        .tree
        .leaves
        .clone()
        .into_iter()
        .filter_map(|n| roam.split_entry(grid, view, n))
        .map(|e| e.0)
        .collect();
    let merge_keys: Vec<u32> = roam
        .tree
        .mergeable
        .clone()
        .into_iter()
        .map(|c| roam.merge_entry(grid, view, c).0 .0)
        .collect();
    let roam = &*roam;
    let tree = &roam.tree;
    let s = grid.side;
    let all: Vec<u32> = tree.leaves.clone();
    // Leaves tile the square: counter-clockwise areas sum to the square's.
    let area: i64 = all.iter().map(|&n| area2(&tree.node(n).tri)).sum();
    assert_eq!(
        area,
        2 * s as i64 * s as i64,
        "leaves do not tile the square"
    );
    assert!(all.iter().all(|&n| area2(&tree.node(n).tri) > 0));
    // No T-junction: every edge is shared by exactly two leaves with the same endpoints, or
    // lies on the square's boundary and belongs to one.
    let on_boundary = |a: [i32; 2], b: [i32; 2]| {
        (a[0] == b[0] && (a[0] == 0 || a[0] == s)) || (a[1] == b[1] && (a[1] == 0 || a[1] == s))
    };
    let edge = |a: [i32; 2], b: [i32; 2]| if a < b { (a, b) } else { (b, a) };
    let mut edges: HashMap<([i32; 2], [i32; 2]), usize> = HashMap::new();
    for &n in &all {
        let t = tree.node(n).tri;
        for (a, b) in [(t.apex, t.left), (t.left, t.right), (t.right, t.apex)] {
            *edges.entry(edge(a, b)).or_default() += 1;
        }
    }
    for (&(a, b), &k) in &edges {
        let ok = if on_boundary(a, b) { k == 1 } else { k == 2 };
        assert!(ok, "edge {a:?}–{b:?} has {k} leaves: a T-junction");
    }
    // Links: each leaf faces, across each edge, the leaf on the other side, which faces back.
    for &n in &all {
        let node = tree.node(n);
        let t = node.tri;
        let sides = [
            (node.base, t.left, t.right),
            (node.left, t.apex, t.left),
            (node.right, t.apex, t.right),
        ];
        for (m, a, b) in sides {
            if m == NONE {
                assert!(
                    on_boundary(a, b),
                    "node {n}: no neighbour across {a:?}–{b:?}"
                );
                continue;
            }
            let other = tree.node(m);
            assert!(tree.is_leaf(m), "node {n} links to interior node {m}");
            let u = other.tri;
            let back = [
                (other.base, u.left, u.right),
                (other.left, u.apex, u.left),
                (other.right, u.apex, u.right),
            ]
            .into_iter()
            .find(|&(_, c, d)| edge(c, d) == edge(a, b));
            assert_eq!(
                back.map(|x| x.0),
                Some(n),
                "node {n} ↔ {m} across {a:?}–{b:?}"
            );
        }
    }
    // The count, and what is drawn.
    let drawn = all.iter().filter(|&&n| tree.node(n).overlaps).count();
    assert_eq!(tree.count, drawn);
    assert_eq!(roam.leaves().len(), drawn);
    assert!(roam.leaves().iter().all(|t| grid.overlaps_grid(t)));
    // The merge list is exactly the split diamonds whose children are all leaves, and the
    // priorities are monotone down the tree.
    let mut expected = Vec::new();
    let mut stack = vec![0u32, 1];
    while let Some(n) = stack.pop() {
        let node = tree.node(n);
        if node.children == NONE {
            continue;
        }
        for c in [node.children, node.children + 1] {
            assert!(
                tree.node(c).key <= node.key,
                "priority grows from {n} to {c}"
            );
            assert_eq!(tree.node(c).parent, n);
            stack.push(c);
        }
        if tree.canonical(n) == n {
            let leafy = |x: u32| {
                x == NONE || {
                    let k = tree.node(x).children;
                    k != NONE && tree.is_leaf(k) && tree.is_leaf(k + 1)
                }
            };
            if leafy(n) && leafy(node.base) {
                expected.push(n);
            }
        }
    }
    let mut listed = tree.mergeable.clone();
    listed.sort_unstable();
    expected.sort_unstable();
    assert_eq!(listed, expected, "merge list");
    // The dual-queue condition: max split priority ≤ θ ≤ min merge priority.
    let max_split = split_keys.into_iter().max().unwrap_or(0);
    let min_merge = merge_keys.into_iter().min().unwrap_or(u32::MAX);
    assert!(
        max_split <= roam.theta && roam.theta <= min_merge,
        "split {} > merge {} (θ {})",
        f32::from_bits(max_split),
        f32::from_bits(min_merge),
        f32::from_bits(roam.theta)
    );
}

fn error_of(grid: &BinGrid, roam: &Roam) -> VerticalError {
    let tris: Vec<_> = roam
        .leaves()
        .iter()
        .map(|t| sample_triangle(grid, t.corners()))
        .collect();
    vertical_error(grid, &tris)
}

/// The budget guarantee of the module comment, or the reason it may not hold: no leaf left
/// that may split.
fn assert_budget(roam: &mut Roam, budget: usize) {
    let count = roam.triangle_count();
    if count < budget {
        assert!(
            roam.top_split().is_none(),
            "{count} < {budget} with splits left"
        );
    } else {
        assert!(
            count <= budget + roam.slack(),
            "{count} triangles for budget {budget} (slack {})",
            roam.slack()
        );
    }
}

#[test]
fn every_frame_is_conforming_and_tiles_the_square() {
    let full = terrain(6, 3);
    for g in [full.clone(), crop(&full, 45, 29)] {
        let grid = bin(&g);
        let mut roam = Roam::new(&grid, WedgieErrors::from_grid(&grid));
        check(&mut roam, &grid, &overhead(&grid));
        let budgets = [40, 700, 150, 3000, 10, 1200];
        for (i, &budget) in budgets.iter().enumerate() {
            for step in 0..4 {
                let cam = orbit(&grid, 40.0 * i as f64 + 9.0 * step as f64, 35.0, 1.2);
                let view = RoamView::from_camera(&cam);
                let stats = roam.update(&grid, &view, budget);
                check(&mut roam, &grid, &view);
                assert_budget(&mut roam, budget);
                assert_eq!(stats.triangles, roam.triangle_count());
            }
        }
        // A low view makes the deepest forced chains (the eye sits near the surface).
        let view = RoamView::from_camera(&low(&grid));
        let mut forced = 0;
        for budget in [500, 4000] {
            forced += roam.update(&grid, &view, budget).forced_splits;
            check(&mut roam, &grid, &view);
            assert_budget(&mut roam, budget);
        }
        assert!(forced > 0, "no forced split was exercised");
    }
}

#[test]
fn the_budget_is_met_within_the_slack_and_error_falls_as_it_grows() {
    let grid = bin(&terrain(6, 11));
    let errors = WedgieErrors::from_grid(&grid);
    let view = overhead(&grid);
    let full = 2 * (grid.columns - 1) * (grid.rows - 1);
    let mut previous: Option<(VerticalError, f32)> = None;
    for budget in [8, 30, 120, 500, 2000, full] {
        let mut roam = Roam::new(&grid, errors.clone());
        roam.update(&grid, &view, budget);
        check(&mut roam, &grid, &view);
        assert_budget(&mut roam, budget);
        if budget < full {
            assert!(roam.triangle_count() >= budget, "the whole grid is in view");
        }
        let e = error_of(&grid, &roam);
        assert_eq!(e.uncovered, 0);
        // The wedgie bound of the mesh can only fall: a larger budget refines the smaller one.
        let bound = roam
            .leaves()
            .iter()
            .map(|t| errors.get(t))
            .fold(0.0, f32::max);
        assert!(e.max <= bound as f64 + 1e-3, "{} > bound {bound}", e.max);
        if let Some((p, pb)) = previous {
            assert!(
                e.max <= p.max && e.mean <= p.mean,
                "{budget}: {e:?} after {p:?}"
            );
            assert!(e.max < p.max || e.mean < p.mean, "{budget}: no gain");
            assert!(bound <= pb);
        }
        previous = Some((e, bound));
    }
    // The full budget reaches the grid exactly (flat pairs may stay merged).
    let (e, _) = previous.unwrap();
    assert_eq!(e.max, 0.0);
    // The same budgets reached incrementally keep the guarantee.
    let mut roam = Roam::new(&grid, errors.clone());
    for budget in [500, 30, 2000, 120, 8, 900] {
        roam.update(&grid, &view, budget);
        check(&mut roam, &grid, &view);
        assert_budget(&mut roam, budget);
        assert!(roam.triangle_count() >= budget);
    }
}

#[test]
fn an_unchanged_view_costs_nothing_and_a_small_move_little() {
    let grid = bin(&terrain(7, 5));
    let errors = WedgieErrors::from_grid(&grid);
    let budget = 3000;
    let cam = orbit(&grid, 20.0, 30.0, 1.0);
    let mut roam = Roam::new(&grid, errors.clone());
    let first = roam.update(&grid, &RoamView::from_camera(&cam), budget);
    assert!(first.splits > 100);
    let again = roam.update(&grid, &RoamView::from_camera(&cam), budget);
    assert_eq!((again.splits, again.forced_splits, again.merges), (0, 0, 0));
    assert_eq!(again.triangles, first.triangles);
    let moved = sideways(&cam, 0.01);
    let view = RoamView::from_camera(&moved);
    let coherent = roam.update(&grid, &view, budget);
    check(&mut roam, &grid, &view);
    assert_budget(&mut roam, budget);
    let mut fresh = Roam::new(&grid, errors);
    let scratch = fresh.update(&grid, &view, budget);
    assert!(
        ops(&coherent) * 10 < ops(&scratch),
        "coherent {coherent:?} vs from scratch {scratch:?}"
    );
    assert!(
        ops(&coherent) > 0,
        "the move changed nothing: a useless test"
    );
}

#[test]
fn far_and_unseen_triangles_are_coarser() {
    let grid = bin(&terrain(7, 9));
    let cam = low(&grid);
    let view = RoamView::from_camera(&cam);
    let mut roam = Roam::new(&grid, WedgieErrors::from_grid(&grid));
    roam.update(&grid, &view, 4000);
    check(&mut roam, &grid, &view);
    let (lo, hi) = grid.world_bounds();
    let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let centre = |t: &BinTri| {
        let c = t.corners().map(|p| grid.world(p));
        [0, 1].map(|k| (c[0][k] + c[1][k] + c[2][k]) / 3.0)
    };
    let mean = |f: &dyn Fn(&BinTri) -> bool| {
        let picked: Vec<u32> = roam
            .leaves()
            .iter()
            .filter(|t| f(t))
            .map(|t| t.level())
            .collect();
        assert!(!picked.is_empty());
        picked.iter().sum::<u32>() as f64 / picked.len() as f64
    };
    let ahead = |t: &BinTri| {
        let b = cam.basis();
        let c = centre(t);
        (c[0] - cam.eye[0]) * b.forward[0] + (c[1] - cam.eye[1]) * b.forward[1] > 0.0
    };
    let distance = |t: &BinTri| {
        let c = centre(t);
        ((c[0] - cam.eye[0]).powi(2) + (c[1] - cam.eye[1]).powi(2)).sqrt()
    };
    let near = mean(&|t| ahead(t) && distance(t) < 0.2 * extent);
    let far = mean(&|t| ahead(t) && distance(t) > 0.6 * extent);
    let behind = mean(&|t| !ahead(t) && distance(t) > 0.05 * extent);
    assert!(near > far + 2.0, "near {near} vs far {far}");
    assert!(
        near > behind + 2.0,
        "seen {near} vs behind the eye {behind}"
    );
}

#[test]
fn from_values_levels_are_honoured_even_when_not_nested() {
    let grid = bin(&crop(&terrain(5, 2), 30, 21));
    let max_level = 6;
    assert!(grid.finest_level() > max_level);
    // Values unrelated to the terrain, larger below than above (saturation must fix that).
    let len = 1usize << (max_level + 2);
    let values: Vec<f32> = (0..len)
        .map(|id| {
            let level = 63 - (id.max(1) as u64).leading_zeros() - 1;
            (level * level) as f32 + ((id * 2654435761) % 97) as f32 / 10.0
        })
        .collect();
    let errors = WedgieErrors::from_values(max_level, values);
    let mut roam = Roam::new(&grid, errors);
    for (i, budget) in [50usize, 100_000, 300, 100_000].into_iter().enumerate() {
        let cam = orbit(&grid, 70.0 * i as f64, 50.0, 1.5);
        let view = RoamView::from_camera(&cam);
        roam.update(&grid, &view, budget);
        check(&mut roam, &grid, &view);
        assert_budget(&mut roam, budget);
        let deepest = roam.leaves().iter().map(|t| t.level()).max().unwrap();
        assert!(deepest <= max_level);
        if budget == 100_000 {
            assert_eq!(deepest, max_level, "a large budget reaches max_level");
        }
    }
}

/// The figures for the lead on the Jacksboro DEM (skipped without testdata): the wedgie
/// errors, updates from the roots to 10,000 and 100,000 triangles, and a coherent update after
/// a small move, each checked for its budget and for coherence.
#[test]
fn jacksboro_timings() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata/dem/jacksboro_fault_dem.npz");
    if !path.exists() {
        eprintln!("skipped: {} is missing", path.display());
        return;
    }
    let g = tessera_preprocess::dem::load_dem(&path, &Default::default()).unwrap();
    let grid = bin(&g);
    let t = Instant::now();
    let errors = WedgieErrors::from_grid(&grid);
    let wedgie_ms = t.elapsed().as_secs_f64() * 1e3;
    println!(
        "jacksboro {} × {} (square {}², {} levels): WedgieErrors::from_grid {wedgie_ms:.1} ms",
        grid.columns,
        grid.rows,
        grid.side + 1,
        grid.finest_level()
    );
    let cam = orbit(&grid, 30.0, 25.0, 0.8);
    let (lo, hi) = grid.world_bounds();
    println!("  world box {lo:?} – {hi:?}, eye {:?}", cam.eye);
    let view = RoamView::from_camera(&cam);
    for budget in [10_000, 100_000] {
        let mut roam = Roam::new(&grid, errors.clone());
        let s = roam.update(&grid, &view, budget);
        assert_budget(&mut roam, budget);
        println!(
            "  roots → {budget}: {:.2} ms ({} triangles; {} splits, {} forced, {} merges)",
            s.cpu_ms, s.triangles, s.splits, s.forced_splits, s.merges
        );
        let same = roam.update(&grid, &view, budget);
        assert_eq!(ops(&same), 0);
        println!("  same view again: {:.2} ms", same.cpu_ms);
        let moved = sideways(&cam, 0.01);
        let c = roam.update(&grid, &RoamView::from_camera(&moved), budget);
        assert_budget(&mut roam, budget);
        assert!(ops(&c) * 5 < ops(&s), "{c:?} vs {s:?}");
        println!(
            "  small move: {:.2} ms ({} splits, {} forced, {} merges)",
            c.cpu_ms, c.splits, c.forced_splits, c.merges
        );
    }
}
