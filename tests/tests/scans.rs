//! Real scans build and every checked cut is crack-free (issue 2, "Must show").

use tessera_preprocess::import::load_mesh;
use tessera_preprocess::BuildConfig;
use tessera_runtime::geometric_check::{check_cuts, decode_all_patches, CheckConfig, CheckReport};
use tessera_tests::{build, testdata};

/// Builds a scan with the default configuration and checks 64 views × 5 tolerances.
fn build_and_check(file: &str) -> CheckReport {
    let input = load_mesh(&testdata(file)).expect("import");
    let built = build(&input.mesh, &BuildConfig::default());
    let patches = decode_all_patches(&built.repo).expect("patches decode");
    let config = CheckConfig::default();
    assert!(config.views >= 64 && config.tolerances.len() >= 5);
    let report = check_cuts(&built.repo, &patches, &config);
    eprintln!("{file}: {:?} / {:?}", built.summary, report);
    assert_eq!(report.cuts_checked, config.views * config.tolerances.len());
    report
}

fn assert_clean(file: &str, r: &CheckReport) {
    assert_eq!(r.cracks, 0, "{file}: cracks in {:?}", r.worst);
    assert_eq!(r.nonmanifold_introduced, 0, "{file}");
    assert_eq!(r.monotonicity_violations, 0, "{file}");
    assert_eq!(r.traversal_mismatches, 0, "{file}");
    // The tolerances really select different resolutions.
    assert!(
        r.min_triangles < r.max_triangles,
        "{file}: every cut has the same size"
    );
}

#[test]
fn bunny_is_crack_free_at_every_checked_cut() {
    let r = build_and_check("mesh/bunny00.off");
    assert_clean("bunny00", &r);
}

#[test]
fn armadillo_is_crack_free_at_every_checked_cut() {
    let r = build_and_check("mesh/armadillo.off");
    assert_clean("armadillo", &r);
}

#[test]
fn full_dragon_with_holes_is_crack_free() {
    let r = build_and_check("mesh/dragon_vrip.ply.gz");
    assert_clean("dragon_vrip", &r);
}

#[test]
fn decimated_dragon_with_nonmanifold_edges_introduces_no_cracks() {
    let r = build_and_check("mesh/dragon_vrip_res2.ply.gz");
    assert_clean("dragon_vrip_res2", &r);
}
