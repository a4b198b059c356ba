//! The coarsest cut of a small scan (issue 46, item 2: "the coarsest cut holds ≤ 1 % of the
//! input"), and the levels above the model's cube that reach it leaving the finer ones as they
//! were (`LatticeFrame::with_headroom`, `SimplifySettings::coarsest_share`).

use std::collections::BTreeMap;

use tessera_core::cut::{diamond_rhos, select_stateless};
use tessera_core::metric::{eye_local, ScreenSpaceMetric};
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::{BuildConfig, InputMesh, SimplifySettings};
use tessera_runtime::geometric_check::{check_cuts, decode_all_patches, CheckConfig};
use tessera_tests::{build, testdata, Built};

/// The default build: the levels above a small model's cube and the top diamond's cap.
fn with_headroom() -> BuildConfig {
    let default = BuildConfig::default();
    assert_eq!(
        (default.headroom, default.simplify.coarsest_share),
        (1, tessera_preprocess::build::COARSEST_SHARE),
        "the default build has the levels above the model's cube"
    );
    default
}

/// The build as it was before them: no headroom, no cap.
fn without_headroom() -> BuildConfig {
    let default = BuildConfig::default();
    BuildConfig {
        headroom: 0,
        simplify: SimplifySettings {
            coarsest_share: 1.0,
            ..default.simplify
        },
        ..default
    }
}

/// Triangles the rule draws at τ = ∞ from a far eye: the roots' patches.
fn coarsest_triangles(built: &Built, mesh: &InputMesh) -> usize {
    let repo = &built.repo;
    let p = mesh.positions[0];
    let eye = [p[0] + 1e6, p[1], p[2]];
    let metric = ScreenSpaceMetric::new(1080, 60.0, 1e-6);
    let rhos = diamond_rhos(
        repo.diamonds(),
        eye_local(eye, repo.header().origin),
        &metric,
    );
    select_stateless(repo.tets(), &rhos, f32::MAX)
        .iter()
        .map(|&i| repo.tets()[i as usize].triangle_count as usize)
        .sum()
}

/// Each non-empty patch of a repository as its sorted triangles (global ids), with how many
/// simplices hold it, keyed by patch and level.
fn patches_by_level(built: &Built, level_shift: u32) -> BTreeMap<(u32, Vec<[u32; 3]>), usize> {
    let patches = decode_all_patches(&built.repo).unwrap();
    let mut by = BTreeMap::new();
    for (tet, mut patch) in built.repo.tets().iter().zip(patches) {
        if patch.is_empty() || tet.level < level_shift {
            continue;
        }
        patch.sort_unstable();
        *by.entry((tet.level - level_shift, patch)).or_insert(0) += 1;
    }
    by
}

#[test]
fn the_coarsest_cut_of_small_scans_holds_at_most_one_percent() {
    for scan in [
        "mesh/lion-head.off",
        "mesh/ChineseDragon-10kv.off",
        "mesh/bear.off",
        "mesh/armadillo.off",
    ] {
        let mesh = load_mesh(&testdata(scan)).unwrap().mesh;
        let built = build(&mesh, &with_headroom());
        let coarsest = coarsest_triangles(&built, &mesh);
        let input = mesh.triangles.len();
        assert!(
            coarsest * 100 <= input,
            "{scan}: the coarsest cut holds {coarsest} of {input} triangles, over 1 %"
        );
        assert!(coarsest > 0, "{scan}: the coarsest cut is empty");
        let patches = decode_all_patches(&built.repo).unwrap();
        let config = CheckConfig {
            views: 16,
            tolerances: vec![0.5, 2.0, 8.0, 32.0, 1e9],
            ..Default::default()
        };
        let report = check_cuts(&built.repo, &patches, &config);
        assert!(report.is_clean(), "{scan}: {report:?}");
    }
}

/// Every patch of the build without headroom or cap is in the default build, `dim` levels
/// deeper, the same triangles: the levels above the model's cube change no finer cut.
#[test]
fn the_levels_above_the_model_leave_the_finer_levels_as_they_were() {
    let mesh = load_mesh(&testdata("mesh/lion-head.off")).unwrap().mesh;
    let default = with_headroom();
    let without = without_headroom();
    let (with, without) = (build(&mesh, &default), build(&mesh, &without));
    assert_eq!(
        with.repo.header().lattice_bits,
        without.repo.header().lattice_bits + 1
    );
    let shift = 3 * default.headroom;
    let before = patches_by_level(&without, 0);
    let after = patches_by_level(&with, shift);
    let deepest = before.keys().map(|(l, _)| *l).max().unwrap();
    assert_eq!(
        after, before,
        "the patches at the levels of the model's cube (0..={deepest}) moved"
    );
    assert!(
        coarsest_triangles(&with, &mesh) * 8 < coarsest_triangles(&without, &mesh),
        "the levels above the roots keep less than an eighth of the roots"
    );
}
