//! The real DEMs of the test data through the height-field readers (issue 5).

use tessera_preprocess::dem::{load_dem, DemOptions, TerrainOptions, METRES_PER_DEGREE};
use tessera_tests::testdata;

#[test]
fn etopo20_and_etopo5_from_netcdf() {
    let g = load_dem(&testdata("dem/etopo20.cdf"), &DemOptions::default()).unwrap();
    assert_eq!((g.columns, g.rows), (1081, 540));
    assert!(g.geographic);
    assert!((g.spacing[0] - 1.0 / 3.0).abs() < 1e-6, "{:?}", g.spacing);
    assert!((g.origin[0] - 20.1667).abs() < 1e-3, "{:?}", g.origin);
    let (lo, hi) = g
        .heights
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &h| (a.min(h), b.max(h)));
    assert!(lo < -9000.0 && hi > 6000.0, "{lo}..{hi}");
    assert_eq!(g.valid_samples(), 1081 * 540);

    let g = load_dem(&testdata("dem/etopo5.cdf"), &DemOptions::default()).unwrap();
    assert_eq!((g.columns, g.rows), (4320, 2161));
    assert!(g.geographic);
    assert_eq!(g.origin, [0.0, -90.0], "row 0 is 90°S, lon 0");
    // 5 arc-minutes; the f32 longitudes round the last one (359.9167) by ~3e-5°.
    assert!(
        g.spacing.iter().all(|s| (s - 1.0 / 12.0).abs() < 1e-6),
        "{:?}",
        g.spacing
    );
    let (lo, hi) = g
        .heights
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &h| (a.min(h), b.max(h)));
    assert_eq!((lo, hi), (-10376.0, 7833.0));
}

#[test]
fn jacksboro_from_npz() {
    let g = load_dem(
        &testdata("dem/jacksboro_fault_dem.npz"),
        &DemOptions::default(),
    )
    .unwrap();
    assert_eq!((g.columns, g.rows), (403, 344));
    assert!(g.geographic);
    assert!((g.origin[0] + 84.41375).abs() < 1e-9);
    assert!(
        (g.origin[1] - 36.73291666666667).abs() < 1e-9,
        "row 0 is the north edge"
    );
    assert!(g.spacing[1] < 0.0);
    assert_eq!(g.heights[0], 483.0);
    let (lo, hi) = g
        .heights
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &h| (a.min(h), b.max(h)));
    assert!(
        (236.0..=240.0).contains(&lo) && (1070.0..=1076.0).contains(&hi),
        "{lo}..{hi}"
    );
    let mesh = g.to_mesh(&TerrainOptions::default());
    assert_eq!(mesh.triangles.len(), 2 * 402 * 343);
    // 3 arc-seconds of longitude in metres at the equator.
    let dx = mesh.positions[1][0] - mesh.positions[0][0];
    assert!((dx - METRES_PER_DEGREE / 1200.0).abs() < 1e-6, "{dx}");
}

#[test]
fn volcano_from_json() {
    let g = load_dem(&testdata("dem/volcano.json"), &DemOptions::default()).unwrap();
    assert_eq!((g.columns, g.rows), (87, 61));
    assert!(!g.geographic);
    assert_eq!(g.heights[0], 103.0);
}

/// The Jacksboro DEM as a height field: 2D hierarchy, every cut closed where the grid is.
#[test]
fn jacksboro_builds_on_the_2d_hierarchy_and_checks_clean() {
    use tessera_preprocess::{BuildConfig, Domain};
    use tessera_runtime::geometric_check::{check_cuts, decode_all_patches, CheckConfig};
    let grid = load_dem(
        &testdata("dem/jacksboro_fault_dem.npz"),
        &DemOptions::default(),
    )
    .unwrap();
    let mesh = grid.to_mesh(&TerrainOptions::default());
    let built = tessera_tests::build(&mesh, &BuildConfig::for_domain(Domain::HeightField));
    assert_eq!(built.repo.header().dimension, 2);
    let patches = decode_all_patches(&built.repo).unwrap();
    let report = check_cuts(&built.repo, &patches, &CheckConfig::default());
    eprintln!("{:?}\n{report:?}", built.summary);
    assert!(report.is_clean(), "{report:?}");
    assert!(report.min_triangles < report.max_triangles / 10);
}
