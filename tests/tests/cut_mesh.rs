//! The cut a view draws, exported as one welded mesh (`repository::cut_mesh`, issue 14): every
//! drawn triangle once, vertices welded by global id into a watertight mesh where the input is
//! closed, with the input's borders where it is open, and the same attributes in every patch.

use std::collections::HashMap;

use tessera_core::metric::{eye_local, ScreenSpaceMetric};
use tessera_core::repository::cut_mesh::{cut_mesh, unculled_cut, CutMesh};
use tessera_core::repository::format::{dequantize_position, oct_decode_normal};
use tessera_core::repository::reader::Repository;
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::{BuildConfig, Construction};
use tessera_tests::{build, testdata};

const TAUS: [f32; 4] = [0.0, 1.0, 8.0, 1e9];

/// Uses of each undirected edge (smaller id first).
fn edge_uses(indices: &[u32]) -> HashMap<(u32, u32), u32> {
    let mut uses = HashMap::new();
    for t in indices.chunks_exact(3) {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    uses
}

/// The cut of `repo` at `tau` for an eye at `eye` (model coordinates), as drawn simplices and
/// their welded mesh; checks the triangle count and that no triangle repeats a vertex.
fn cut_at(repo: &Repository, eye: [f64; 3], tau: f32) -> (Vec<u32>, CutMesh) {
    let metric = ScreenSpaceMetric::new(720, 45.0, 1e-3);
    let tets = unculled_cut(repo, eye_local(eye, repo.header().origin), &metric, tau);
    let mesh = cut_mesh(repo, &tets).unwrap();
    let expected: usize = tets
        .iter()
        .map(|&t| repo.tets()[t as usize].triangle_count as usize)
        .sum();
    assert_eq!(mesh.triangle_count(), expected, "τ = {tau}: triangle count");
    assert_eq!(mesh.indices.len() % 3, 0);
    for t in mesh.indices.chunks_exact(3) {
        assert!(
            t[0] != t[1] && t[1] != t[2] && t[0] != t[2],
            "τ = {tau}: degenerate triangle {t:?}"
        );
        assert!(t.iter().all(|&i| (i as usize) < mesh.vertex_count()));
    }
    (tets, mesh)
}

/// Every vertex of every drawn patch has, in the welded mesh, the position and attributes that
/// patch stores (vertices are numbered in order of first use over `tets`).
fn assert_patches_agree(repo: &Repository, tets: &[u32], mesh: &CutMesh) {
    let h = repo.header();
    let mut welded: HashMap<u32, usize> = HashMap::new();
    for &t in tets {
        let patch = repo.patch(t as usize).unwrap();
        let view = patch.view();
        for (v, id) in view.global_ids().enumerate() {
            let next = welded.len();
            let i = *welded.entry(id).or_insert(next);
            assert_eq!(
                mesh.positions[i],
                dequantize_position(view.position(v), h.bbox_min, h.position_step),
                "global vertex {id}: position differs between patches"
            );
            if let Some(n) = &mesh.normals {
                assert_eq!(n[i], oct_decode_normal(view.normals().unwrap()[v]));
            }
            if let Some(c) = &mesh.colors {
                assert_eq!(c[i], view.colors().unwrap()[v]);
            }
            if let Some(uv) = &mesh.uvs {
                assert_eq!(uv[i], view.uvs().unwrap()[v]);
            }
        }
    }
    assert_eq!(welded.len(), mesh.vertex_count());
}

#[test]
fn a_closed_model_exports_watertight_at_every_tolerance() {
    let mesh = tessera_tests::attributed_demo_mesh(4);
    let built = build(
        &mesh,
        &BuildConfig {
            construction: Construction::LeafTriangles(64),
            ..Default::default()
        },
    );
    let repo = &built.repo;
    let mut counts = Vec::new();
    for tau in TAUS {
        let (tets, cut) = cut_at(repo, [0.3, 0.2, 3.0], tau);
        assert!(cut.normals.is_some() && cut.colors.is_some() && cut.uvs.is_some());
        assert_eq!(cut.normals.as_ref().unwrap().len(), cut.vertex_count());
        assert_eq!(cut.colors.as_ref().unwrap().len(), cut.vertex_count());
        assert_eq!(cut.uvs.as_ref().unwrap().len(), cut.vertex_count());
        assert_patches_agree(repo, &tets, &cut);
        let uses = edge_uses(&cut.indices);
        let open: Vec<_> = uses.iter().filter(|(_, &u)| u != 2).take(5).collect();
        assert!(
            open.is_empty(),
            "τ = {tau}: edges not used by exactly two triangles, e.g. {open:?}"
        );
        // Closed and oriented: each directed edge once.
        let mut directed = HashMap::new();
        for t in cut.indices.chunks_exact(3) {
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0u32) += 1;
            }
        }
        assert!(
            directed.values().all(|&u| u == 1),
            "τ = {tau}: inconsistent winding"
        );
        // Euler characteristic of a sphere.
        let euler = cut.vertex_count() as i64 - uses.len() as i64 + cut.triangle_count() as i64;
        assert_eq!(euler, 2, "τ = {tau}: not a sphere");
        eprintln!(
            "τ = {tau}: {} simplices, {} triangles, {} vertices",
            tets.len(),
            cut.triangle_count(),
            cut.vertex_count()
        );
        counts.push(cut.triangle_count());
    }
    assert_eq!(counts[0], mesh.triangles.len(), "τ = 0 draws the input");
    assert!(
        counts.windows(2).all(|w| w[0] >= w[1]),
        "coarser with τ: {counts:?}"
    );
    assert!(counts[3] < counts[0], "τ = 1e9 is coarser: {counts:?}");
}

/// A scan's cuts: the finest is the input, with its borders; where the input is closed (every
/// edge used twice) every cut is too.
fn scan_cuts(name: &str) {
    let input = load_mesh(&testdata(name)).unwrap().mesh;
    // In front of the model along z, 1.5 bounding-box diagonals from its centre.
    let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
    for p in &input.positions {
        for k in 0..3 {
            (lo[k], hi[k]) = (lo[k].min(p[k]), hi[k].max(p[k]));
        }
    }
    let diagonal = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let eye = [centre[0], centre[1], centre[2] + 1.5 * diagonal];
    let built = build(&input, &BuildConfig::default());
    let repo = &built.repo;
    let input_indices: Vec<u32> = input.triangles.iter().flatten().copied().collect();
    let input_edges = edge_uses(&input_indices);
    let input_border = input_edges.values().filter(|&&u| u == 1).count();
    let closed = input_edges.values().all(|&u| u == 2);
    for tau in TAUS {
        let (tets, cut) = cut_at(repo, eye, tau);
        assert_patches_agree(repo, &tets, &cut);
        let edges = edge_uses(&cut.indices);
        let cut_border = edges.values().filter(|&&u| u == 1).count();
        eprintln!(
            "{name} τ = {tau}: {} triangles, {cut_border} border edges (input {input_border}), \
             {} edges used more than twice",
            cut.triangle_count(),
            edges.values().filter(|&&u| u > 2).count()
        );
        if tau == 0.0 {
            assert_eq!(cut.triangle_count(), input.triangles.len());
            assert_eq!(cut.vertex_count(), input.positions.len());
            assert_eq!(
                cut_border, input_border,
                "{name}: the finest cut has the input's borders"
            );
        }
        if closed {
            assert!(
                edges.values().all(|&u| u == 2),
                "{name} τ = {tau}: the input is closed, the cut is not"
            );
        }
    }
}

#[test]
fn a_closed_scan_exports_watertight() {
    scan_cuts("mesh/bunny00.off");
}

#[test]
fn an_open_scan_keeps_its_borders() {
    scan_cuts("mesh/lion-head.off");
}
