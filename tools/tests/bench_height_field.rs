//! `tessera bench` with a height field as its source, from the command line.

mod cli_support;
use cli_support::{json, tessera};

use std::path::Path;

/// The trade bench on a height field (issue 13: "and on a terrain"): the source is meshed as
/// `build` meshes it, ours and the mesh peers measured on it; a height field built with other
/// options is refused as not the repository's source.
#[test]
fn bench_trade_off_reads_a_height_field_source() {
    let dir = tempfile::tempdir().unwrap();
    let volcano = Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/dem/volcano.json");
    assert!(volcano.exists(), "run tools/fetch-testdata.sh first");
    let volcano = volcano.to_str().unwrap();
    let repo = dir.path().join("volcano.tsr");
    let repo = repo.to_str().unwrap();
    let built = tessera(&["build", volcano, "-o", repo, "--json"]);
    assert!(
        built.status.success(),
        "{}",
        String::from_utf8_lossy(&built.stderr)
    );
    let bench = |repo: &str| {
        tessera(&[
            "bench",
            repo,
            "--source",
            volcano,
            "--views",
            "1",
            "--tolerances",
            "2",
            "--size",
            "160x120",
            "--samples",
            "500",
            "--frames",
            "1",
            "--json",
        ])
    };
    let out = bench(repo);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = json(&out);
    assert!(v["model_triangles"].as_u64() > Some(0), "{v}");
    assert_eq!(v["model_triangles"], json(&built)["input_triangles"], "{v}");
    for rows in [&v["rows"], &v["peers"]["cluster_dag"]] {
        let row = &rows[0];
        assert!(row["triangles"].as_f64().unwrap() > 0.0, "{v}");
        assert!(row["error_samples"].as_u64().unwrap() > 0, "{v}");
    }
    let steep = dir.path().join("steep.tsr");
    let steep = steep.to_str().unwrap();
    let built = tessera(&["build", volcano, "-o", steep, "--exaggeration", "3"]);
    assert!(
        built.status.success(),
        "{}",
        String::from_utf8_lossy(&built.stderr)
    );
    let out = bench(steep);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("not its source"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
