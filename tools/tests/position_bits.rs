//! `build --position-bits`: a coarser position grid makes a smaller repository whose stored
//! errors count the larger quantisation error, still crack-free; bits outside 1..=21 are
//! refused with exit 2 and nothing written.

mod cli_support;
use cli_support::tessera;

use std::path::Path;
use std::process::Output;

fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

#[test]
fn fewer_position_bits_give_a_smaller_repository_with_larger_errors() {
    let lion = Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/lion-head.off");
    assert!(lion.exists(), "run tools/fetch-testdata.sh first");
    let lion = lion.to_str().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let fine = json(&tessera(&[
        "build",
        lion,
        "-o",
        &path("21.tsr"),
        "--lossless",
        "--json",
    ]));
    let coarse = json(&tessera(&[
        "build",
        lion,
        "-o",
        &path("12.tsr"),
        "--position-bits",
        "12",
        "--json",
    ]));
    assert_eq!(
        (
            fine["position_bits"].as_u64(),
            coarse["position_bits"].as_u64()
        ),
        (Some(21), Some(12))
    );
    let q = |v: &serde_json::Value| v["quantisation_error"].as_f64().unwrap();
    // The step grows by (2^21 − 1) / (2^12 − 1) on every axis, and so does its half-diagonal.
    let ratio = ((1u64 << 21) - 1) as f64 / ((1u64 << 12) - 1) as f64;
    assert!(
        (q(&coarse) / q(&fine) / ratio - 1.0).abs() < 1e-9,
        "{fine} {coarse}"
    );
    let bytes = |v: &serde_json::Value| v["repository_bytes"].as_u64().unwrap();
    assert!(bytes(&coarse) < bytes(&fine), "{fine} {coarse}");
    // Every stored error counts the quantisation: the root's is at least it.
    assert!(coarse["root_error"].as_f64().unwrap() >= q(&coarse));
    for (name, bits) in [("21.tsr", 21), ("12.tsr", 12)] {
        let info = json(&tessera(&["info", &path(name), "--json"]));
        assert_eq!(info["position_bits"], bits, "{info}");
    }
    let check = json(&tessera(&["check", &path("12.tsr"), "--json"]));
    assert_eq!(check["cracks"], 0, "{check}");
    for bad in ["0", "22"] {
        let out = tessera(&[
            "build",
            lion,
            "-o",
            &path("bad.tsr"),
            "--position-bits",
            bad,
        ]);
        assert_eq!(out.status.code(), Some(2), "--position-bits {bad}");
        assert!(!dir.path().join("bad.tsr").exists());
    }
}
