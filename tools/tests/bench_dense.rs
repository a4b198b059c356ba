//! The dense error of `tessera bench` (issue 46): every subject's cut measured as `check
//! --errors` measures ours (`surface::measure_screen_surface`), so equal max error means the
//! same for all.
//!
//! - the general measure reproduces `measure_screen_cut`, and the code it replaced, exactly;
//! - it sees a hole and a displaced triangle, and nothing in the leaves against themselves;
//! - the bench's JSON has dense figures for every subject, ours equal to `check --errors`'s,
//!   the same in the `--two-sided` arm, and the front-to-front verdict against each peer.

mod cli_support;
use cli_support::{build_bunny, bunny, json, tessera};

use tessera_core::cut::{diamond_rhos, select_stateless};
use tessera_core::hausdorff::sampled_directed_weighted;
use tessera_core::metric::{eye_local, ScreenSpaceMetric};
use tessera_core::repository::surface::{
    leaf_surface, measure_screen_cut, measure_screen_surface, patch_surface, quantisation_error,
    PatchSurface,
};
use tessera_core::repository::Repository;
use tessera_runtime::geometric_check::{check_metric, CheckConfig};
use tessera_runtime::views::check_views;

const STEPS: (usize, usize) = (4, 2);

/// `measure_screen_cut` as it was written before it went through `measure_screen_surface`
/// (2026-12-07): the reference the general measure must reproduce to the bit. (The sampler
/// under both, `sampled_directed_weighted`, is checked against brute force in core's
/// `hausdorff::tests::weighed_sampling_is_exact`.)
fn screen_cut_as_before(
    repo: &Repository,
    leaves: &PatchSurface,
    eye: [f64; 3],
    metric: &ScreenSpaceMetric,
    tau: f32,
) -> (usize, f64, u64) {
    let h = repo.header();
    let q = 0.5 * h.position_step.iter().map(|s| s * s).sum::<f64>().sqrt();
    let rhos = diamond_rhos(repo.diamonds(), eye_local(eye, h.origin), metric);
    let drawn = select_stateless(repo.tets(), &rhos, tau);
    let cut = patch_surface(repo, drawn.iter().map(|&t| t as usize)).unwrap();
    let (k, near) = (metric.k as f64, metric.near as f64);
    let from_eye = |p: [f64; 3]| {
        let d = [0, 1, 2].map(|i| p[i] - eye[i]);
        (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
    };
    let offset = cut.positions.len() as u32;
    let positions: Vec<[f64; 3]> = cut
        .positions
        .iter()
        .chain(&leaves.positions)
        .copied()
        .collect();
    let leaf_indices: Vec<u32> = leaves.indices.iter().map(|i| i + offset).collect();
    let forward = sampled_directed_weighted(
        &positions,
        &cut.indices,
        &leaf_indices,
        STEPS.0,
        |p, d| match d.is_finite() {
            true => (d - q).max(0.0) * k / from_eye(p).max(near),
            false => f64::INFINITY,
        },
    );
    let reverse = sampled_directed_weighted(
        &positions,
        &leaf_indices,
        &cut.indices,
        STEPS.1,
        |p, d| match d.is_finite() {
            true => (d - q).max(0.0) * k / (from_eye(p) + d).max(near),
            false => f64::INFINITY,
        },
    );
    let samples = cut.triangle_count() as u64 * 15 + leaves.triangle_count() as u64 * 6;
    (cut.triangle_count(), forward.max(reverse), samples)
}

/// The general measure through ours is `measure_screen_cut`, which is the code it replaced.
#[test]
fn the_general_measure_reproduces_the_check() {
    let dir = tempfile::tempdir().unwrap();
    let repo = Repository::open(build_bunny(dir.path())).unwrap();
    let h = *repo.header();
    let leaves = leaf_surface(&repo).unwrap();
    let metric = check_metric(&h, &CheckConfig::default());
    let q = quantisation_error(&repo);
    let mut coarse_seen = false;
    for eye in check_views(h.bbox_min, h.bbox_max, 8)
        .into_iter()
        .step_by(7)
    {
        for tau in [0.5f32, 4.0] {
            let m = measure_screen_cut(&repo, &leaves, eye, &metric, tau, STEPS).unwrap();
            let before = screen_cut_as_before(&repo, &leaves, eye, &metric, tau);
            assert_eq!(
                (m.triangles, m.max_px, m.samples),
                before,
                "eye {eye:?}, τ {tau}"
            );
            let rhos = diamond_rhos(repo.diamonds(), eye_local(eye, h.origin), &metric);
            let drawn = select_stateless(repo.tets(), &rhos, tau);
            let cut = patch_surface(&repo, drawn.iter().map(|&t| t as usize)).unwrap();
            let general = measure_screen_surface(&cut, &leaves, eye, &metric, q, STEPS);
            assert_eq!(
                (general.triangles, general.max_px, general.samples),
                before,
                "eye {eye:?}, τ {tau}"
            );
            assert!(m.max_px >= 0.0 && m.max_px.is_finite(), "{m:?}");
            coarse_seen |= m.max_px > 0.0;
        }
    }
    assert!(coarse_seen, "some cut is coarser than the leaves");
}

/// The leaves against themselves measure 0; with a hole, or one triangle moved off the
/// surface, more; an empty surface, infinitely more.
#[test]
fn the_general_measure_sees_holes_and_displaced_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let repo = Repository::open(build_bunny(dir.path())).unwrap();
    let h = *repo.header();
    let leaves = leaf_surface(&repo).unwrap();
    let metric = check_metric(&h, &CheckConfig::default());
    let q = quantisation_error(&repo);
    let eye = check_views(h.bbox_min, h.bbox_max, 2)[0];
    let measure = |s: &PatchSurface| measure_screen_surface(s, &leaves, eye, &metric, q, STEPS);
    assert_eq!(measure(&leaves).max_px, 0.0);
    // Without the quantisation allowance the leaves still sit on themselves.
    let exact = measure_screen_surface(&leaves, &leaves, eye, &metric, 0.0, STEPS);
    assert!(exact.max_px < 1e-9, "{exact:?}");

    // A hole: the triangles around one vertex and their neighbours dropped (a single
    // triangle's 6 leaf samples all lie on its neighbours' edges).
    let corner = |t: usize, k: usize| leaves.positions[leaves.indices[3 * t + k] as usize];
    let centre = corner(leaves.triangle_count() / 2, 0);
    let near = |t: usize| {
        (0..3).any(|k| {
            let p = corner(t, k);
            (0..3)
                .map(|i| (p[i] - centre[i]).powi(2))
                .sum::<f64>()
                .sqrt()
                < 2e-3
        })
    };
    let kept: Vec<usize> = (0..leaves.triangle_count()).filter(|&t| !near(t)).collect();
    assert!(
        kept.len() + 4 < leaves.triangle_count(),
        "the hole is a few triangles"
    );
    let holed = PatchSurface {
        positions: leaves.positions.clone(),
        indices: kept
            .iter()
            .flat_map(|&t| leaves.indices[3 * t..3 * t + 3].iter().copied())
            .collect(),
    };
    let hole = measure(&holed);
    assert!(
        hole.max_px > 0.0,
        "a hole measures more than nothing: {hole:?}"
    );

    // One triangle moved 1 mm off the surface (the bunny is about 0.15 units across).
    let mut displaced = leaves.clone();
    let t = leaves.triangle_count() / 3;
    let moved: Vec<u32> = (0..3)
        .map(|k| {
            let mut p = corner(t, k);
            p[1] += 1e-3;
            displaced.positions.push(p);
            (displaced.positions.len() - 1) as u32
        })
        .collect();
    displaced.indices[3 * t..3 * t + 3].copy_from_slice(&moved);
    let off = measure(&displaced);
    // At least the triangle's own distance off the surface in pixels at the farthest eye
    // distance it can have: its corner moved by 1e-3 along y, its normal not along y.
    assert!(
        off.max_px > 0.0,
        "a displaced triangle measures more: {off:?}"
    );
    assert!(off.max_px > hole.max_px.min(1e-3), "{off:?}");

    let empty = measure(&PatchSurface::default());
    assert_eq!(empty.max_px, f64::INFINITY);
}

/// The bench measures every subject densely, ours exactly as `check --errors` does, the same
/// in both arms, and reads the verdict front to front.
#[test]
fn the_bench_measures_every_subject_densely() {
    let dir = tempfile::tempdir().unwrap();
    let repo = build_bunny(dir.path());
    let repo = repo.to_str().unwrap();
    let source = bunny();
    let bench = |error_views: &str, extra: &[&str]| {
        let mut args = vec![
            "bench",
            repo,
            "--source",
            source.to_str().unwrap(),
            "--views",
            "1",
            "--tolerances",
            "1,4",
            // τ in pixels of a 1080-pixel height, as `check --errors`.
            "--size",
            "96x1080",
            "--samples",
            "500",
            "--frames",
            "1",
            "--error-views",
            error_views,
            "--json",
        ];
        args.extend_from_slice(extra);
        let out = tessera(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        json(&out)
    };
    let v = bench("2", &[]);
    assert_eq!(v["dense"]["views"], 2, "{}", v["dense"]);
    assert_eq!(v["dense"]["metric"]["visible_only"], false);
    assert_eq!(v["dense"]["metric"]["steps"], serde_json::json!([4, 2]));
    let model = v["model_triangles"].as_f64().unwrap();
    let dense_rows = |name: &str| -> Vec<serde_json::Value> {
        let rows = match name {
            "ours" => &v["rows"],
            peer => &v["peers"][peer],
        };
        rows.as_array()
            .unwrap()
            .iter()
            .map(|r| r["dense"].clone())
            .collect()
    };
    for name in ["ours", "cluster_dag", "discrete_lod"] {
        let rows = dense_rows(name);
        assert_eq!(rows.len(), 2, "{name}");
        for d in &rows {
            let max = d["max_px"]
                .as_f64()
                .unwrap_or_else(|| panic!("{name}: {d}"));
            assert!(max > 0.0 && max.is_finite(), "{name}: {d}");
            let t = d["triangles"].as_f64().unwrap();
            assert!(t > 0.0 && t <= model, "{name}: {d}");
            assert_eq!(d["max_px_per_view"].as_array().unwrap().len(), 2, "{name}");
            let worst = d["worst_view"].as_u64().unwrap() as usize;
            assert_eq!(
                d["max_px_per_view"][worst].as_f64(),
                Some(max),
                "{name}: {d}"
            );
            assert!(d["samples"].as_u64().unwrap() > 0, "{name}: {d}");
        }
    }
    for d in dense_rows("full_resolution") {
        assert_eq!(d["max_px"].as_f64(), Some(0.0), "{d}");
        assert_eq!(d["triangles"].as_f64(), Some(model), "{d}");
    }
    // Ours is what `check --errors` measures at the same eyes and τ.
    let out = tessera(&[
        "check",
        repo,
        "--errors",
        "--views",
        "2",
        "--tolerances",
        "1,4",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let check = json(&out)["errors"].clone();
    let ours = dense_rows("ours");
    let largest = ours
        .iter()
        .map(|d| d["max_px"].as_f64().unwrap())
        .fold(0.0, f64::max);
    assert_eq!(check["error_max_px"].as_f64(), Some(largest), "{check}");
    let samples: u64 = ours.iter().map(|d| d["samples"].as_u64().unwrap()).sum();
    assert_eq!(check["samples"].as_u64(), Some(samples), "{check}");
    // The verdict: ours against each peer, front to front, from 0.5 px.
    let verdict = v["verdict_dense"].as_array().unwrap();
    let peers: Vec<&str> = verdict
        .iter()
        .map(|c| c["peer"].as_str().unwrap())
        .collect();
    assert_eq!(
        peers,
        ["cluster_dag", "discrete_lod"],
        "{}",
        v["verdict_dense"]
    );
    for c in verdict {
        for level in c["levels"].as_array().unwrap() {
            assert!(level["error_px"].as_f64().unwrap() >= 0.5, "{level}");
            let (o, p, r) = (
                level["ours"]["value"].as_f64().unwrap(),
                level["peer"]["value"].as_f64().unwrap(),
                level["ratio"]["value"].as_f64().unwrap(),
            );
            assert!((r - o / p).abs() < 1e-9 * r, "{level}");
        }
    }
    // The two-sided arm culls differently, but the dense error never culls.
    let both = bench("2", &["--two-sided"]);
    assert_eq!(both["verdict_dense"], v["verdict_dense"]);
    for name in ["ours", "cluster_dag", "discrete_lod"] {
        let rows = |v: &serde_json::Value| match name {
            "ours" => v["rows"].clone(),
            peer => v["peers"][peer].clone(),
        };
        let dense = |v: &serde_json::Value| -> Vec<serde_json::Value> {
            rows(v)
                .as_array()
                .unwrap()
                .iter()
                .map(|r| r["dense"].clone())
                .collect()
        };
        assert_eq!(dense(&both), dense(&v), "{name}");
    }
    // The cluster DAG's settings are stated, and --dag changes them.
    let settings = &v["cluster_dag"]["settings"];
    assert_eq!(settings["max_triangles"], v["cluster_dag"]["max_triangles"]);
    let other = bench("1", &["--dag", "triangles=16;partition=4"]);
    let other_settings = &other["cluster_dag"]["settings"];
    assert_eq!(other_settings["max_triangles"], 16, "{other_settings}");
    assert_eq!(other_settings["partition_size"], 4, "{other_settings}");
    for key in ["permissive", "fallback_sloppy", "ratio", "edge_limit"] {
        assert_eq!(other_settings[key], settings[key], "{key}");
    }
    assert!(
        other["cluster_dag"]["clusters"].as_u64() > v["cluster_dag"]["clusters"].as_u64(),
        "smaller clusters, more of them"
    );
    // Without the dense pass, no dense figures; without `--phases`, no phases.
    let none = bench("0", &[]);
    assert!(none["dense"].is_null() && none["rows"][0]["dense"].is_null());
    assert_eq!(none["verdict_dense"], serde_json::json!([]));
    assert!(none["rows"][0]["select_ms"].is_null() && none["rows"][0]["raster_ms"].is_null());
}

/// `bench --phases`: every subject's frame again with its selection and its raster waited
/// for apart, both times in every row (the full resolution chooses nothing).
#[test]
fn the_bench_times_selection_and_raster_apart() {
    let dir = tempfile::tempdir().unwrap();
    let repo = build_bunny(dir.path());
    let source = bunny();
    let out = tessera(&[
        "bench",
        repo.to_str().unwrap(),
        "--source",
        source.to_str().unwrap(),
        "--views",
        "1",
        "--tolerances",
        "1,4",
        "--size",
        "160x120",
        "--samples",
        "200",
        "--frames",
        "3",
        "--error-views",
        "0",
        "--phases",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = json(&out);
    for (name, rows) in [
        ("ours", &v["rows"]),
        ("cluster_dag", &v["peers"]["cluster_dag"]),
        ("discrete_lod", &v["peers"]["discrete_lod"]),
        ("full_resolution", &v["peers"]["full_resolution"]),
    ] {
        for r in rows.as_array().unwrap() {
            let select = r["select_ms"]
                .as_f64()
                .unwrap_or_else(|| panic!("{name}: {r}"));
            let raster = r["raster_ms"]
                .as_f64()
                .unwrap_or_else(|| panic!("{name}: {r}"));
            assert!(raster > 0.0 && raster.is_finite(), "{name}: {r}");
            match name {
                "full_resolution" => assert_eq!(select, 0.0, "{r}"),
                // Ours waits for a GPU traversal; the DAG for its upload.
                "ours" | "cluster_dag" => assert!(select > 0.0 && select.is_finite(), "{r}"),
                _ => assert!(select >= 0.0 && select.is_finite(), "{r}"),
            }
        }
    }
}
