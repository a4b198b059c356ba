//! The geometric check is not a rubber stamp: a repository broken on purpose is caught.

use tessera_core::cut::{diamond_rhos, select_stateless};
use tessera_core::metric::{eye_local, ScreenSpaceMetric};
use tessera_core::repository::format::NO_INDEX;
use tessera_core::repository::global_ids::encode_global_ids;
use tessera_core::repository::reader::Repository;
use tessera_core::repository::writer::{write_repository_file, RepositoryContents};
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::{build_contents, BuildConfig};
use tessera_runtime::geometric_check::{check_cuts, decode_all_patches, CheckConfig, CheckReport};
use tessera_runtime::views::check_views;
use tessera_tests::testdata;

fn bunny_contents() -> RepositoryContents {
    let input = load_mesh(&testdata("mesh/bunny00.off")).unwrap().mesh;
    build_contents(&input, &BuildConfig::default(), &|_| {})
        .unwrap()
        .0
}

fn check(contents: &RepositoryContents, config: &CheckConfig) -> CheckReport {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.tsr");
    write_repository_file(&path, contents).unwrap();
    let repo = Repository::open(&path).unwrap();
    let patches = decode_all_patches(&repo).unwrap();
    check_cuts(&repo, &patches, config)
}

#[test]
fn an_intact_repository_is_clean() {
    let report = check(
        &bunny_contents(),
        &CheckConfig {
            views: 8,
            ..Default::default()
        },
    );
    assert!(report.is_clean(), "{report:?}");
}

#[test]
fn a_vertex_swapped_in_one_coarse_patch_is_a_crack() {
    let mut contents = bunny_contents();
    let config = CheckConfig {
        views: 8,
        ..Default::default()
    };
    // Pick an internal simplex that the first view's coarsest cut draws.
    let repo = Repository::from_bytes(to_bytes(&contents)).unwrap();
    let h = repo.header();
    let size = (0..3)
        .map(|i| (h.bbox_max[i] - h.bbox_min[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    let metric = ScreenSpaceMetric::new(config.viewport_height, config.fov_degrees, size * 1e-4);
    let eye = check_views(h.bbox_min, h.bbox_max, config.views)[0];
    let rhos = diamond_rhos(repo.diamonds(), eye_local(eye, h.origin), &metric);
    let tau = *config.tolerances.last().unwrap();
    let victim = select_stateless(repo.tets(), &rhos, tau)
        .into_iter()
        .find(|&i| {
            let t = &repo.tets()[i as usize];
            t.first_child != NO_INDEX && t.vertex_count > 8
        })
        .expect("the coarse cut draws an internal patch") as usize;
    // Point one of its border vertices at another vertex of the same patch's neighbourhood:
    // the triangles stay valid, the shared edges no longer match.
    let patch = repo.patch(victim).unwrap();
    let ids: Vec<u32> = patch.global_ids().collect();
    let mut local_edges = std::collections::HashMap::new();
    for t in patch.triangles() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *local_edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let border_vertex = local_edges
        .iter()
        .find(|(_, &n)| n == 1)
        .map(|((a, _), _)| *a as usize)
        .expect("a patch of a closed model has a border inside the cut");
    // Re-encode every patch's ids with the victim's border vertex renamed.
    let replacement = (0..u32::MAX).find(|g| !ids.contains(g)).unwrap();
    let mut all_ids: Vec<Vec<u32>> = (0..repo.tets().len())
        .map(|i| repo.patch(i).unwrap().global_ids().collect())
        .collect();
    drop(repo);
    all_ids[victim][border_vertex] = replacement;
    contents.id_blob.clear();
    for (tet, ids) in contents.tets.iter_mut().zip(&all_ids) {
        tet.id_offset = contents.id_blob.len() as u64;
        tet.id_bytes = encode_global_ids(ids, &mut contents.id_blob) as u32;
    }
    let report = check(&contents, &config);
    assert!(report.cracks > 0, "{report:?}");
    assert!(!report.is_clean());
}

#[test]
fn an_unsaturated_error_is_a_monotonicity_violation() {
    let mut contents = bunny_contents();
    // The root diamond's error below its children's.
    contents.diamonds[0].error = 1e-30;
    let report = check(
        &contents,
        &CheckConfig {
            views: 8,
            ..Default::default()
        },
    );
    assert!(report.monotonicity_violations > 0, "{report:?}");
}

fn to_bytes(contents: &RepositoryContents) -> Vec<u8> {
    let mut bytes = Vec::new();
    tessera_core::repository::writer::write_repository(&mut bytes, contents).unwrap();
    bytes
}
