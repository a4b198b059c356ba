//! ETOPO5 (4320 × 2161 samples, 18.7 M triangles), the largest DEM of the test data: it builds
//! on the 2D hierarchy with a peak resident set under 4 GiB, and both crack checks are clean.
//! Alone in its test binary, so the process's peak memory is this build's.

use tessera_preprocess::dem::{load_dem, DemOptions, TerrainOptions};
use tessera_preprocess::{BuildConfig, Domain};
use tessera_runtime::geometric_check::{check_cuts, decode_all_patches, CheckConfig};
use tessera_tests::{gpu, testdata};

/// The process's peak resident set (VmHWM), bytes; Linux only.
fn peak_rss_bytes() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status");
    let kb: u64 = status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1)?.parse().ok())
        .expect("VmHWM in /proc/self/status");
    kb * 1024
}

#[test]
fn etopo5_builds_under_4_gib_and_is_crack_free() {
    let grid = load_dem(&testdata("dem/etopo5.cdf"), &DemOptions::default()).unwrap();
    let mesh = grid.to_mesh(&TerrainOptions::default());
    drop(grid);
    assert_eq!(mesh.triangles.len(), 2 * 4319 * 2160);
    let config = BuildConfig::for_domain(Domain::HeightField);
    let built = tessera_tests::build(&mesh, &config);
    drop(mesh);
    let peak = peak_rss_bytes();
    eprintln!("{:?}\npeak RSS {} MiB", built.summary, peak >> 20);
    assert!(peak < 4 << 30, "peak RSS {} MiB", peak >> 20);

    let repo = &built.repo;
    let patches = decode_all_patches(repo).unwrap();
    let report = check_cuts(
        repo,
        &patches,
        &CheckConfig {
            views: 16,
            ..Default::default()
        },
    );
    eprintln!("{report:?}");
    assert!(report.is_clean(), "{report:?}");
    drop(patches);

    let ctx = gpu();
    let px = tessera_tests::check_pixels_small(&ctx, repo, 8);
    eprintln!("{px:?}");
    assert!(px.is_clean(), "{px:?}");
}
