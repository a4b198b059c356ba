//! `build --bounded-errors` from the command line: the JSON says which errors were stored,
//! bounds are larger than estimates, the repository still checks crack-free, and `bench
//! errors` and `check --errors` measure its cuts within their stored errors and tolerances.

use std::path::Path;
use std::process::Command;

fn run(args: &[&str]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(args)
        .output()
        .expect("run tessera");
    assert!(
        out.status.success(),
        "tessera {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

#[test]
fn bounded_errors_are_stored_larger_and_the_repository_checks_clean() {
    let lion = Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/lion-head.off");
    assert!(lion.exists(), "run tools/fetch-testdata.sh first");
    let dir = tempfile::tempdir().unwrap();
    let build = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec!["build", lion.to_str().unwrap(), "-o", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        args.push("--json");
        (run(&args), out)
    };
    let (estimated, _) = build("estimated.tsr", &[]);
    let (bounded, repo) = build("bounded.tsr", &["--bounded-errors"]);
    assert_eq!(estimated["bounded_errors"], false);
    assert_eq!(bounded["bounded_errors"], true);
    let root = |v: &serde_json::Value| v["root_error"].as_f64().unwrap();
    assert!(
        root(&bounded) > root(&estimated),
        "{bounded} vs {estimated}"
    );
    let check = run(&["check", repo.to_str().unwrap(), "--json"]);
    assert_eq!(check["cracks"], 0, "{check}");
    // `bench errors`: every cut of the bounded build stays within its largest stored error
    // of the leaves (the leaves stand within the quantisation of the input, too).
    let quantisation = bounded["quantisation_error"].as_f64().unwrap();
    let written = dir.path().join("cuts");
    let measured = run(&[
        "bench",
        "errors",
        repo.to_str().unwrap(),
        "--cuts",
        "5",
        "--write-cuts",
        written.to_str().unwrap(),
        "--json",
    ]);
    let cuts = measured["cuts"].as_array().unwrap();
    assert_eq!(cuts.len(), 5, "{measured}");
    // The cuts and the leaves written for an independent tool: one PLY each, as many faces as
    // measured.
    let faces = |name: &str| -> u64 {
        let bytes = std::fs::read(written.join(name)).unwrap();
        let header = String::from_utf8_lossy(&bytes[..bytes.len().min(512)]).to_string();
        let line = header
            .lines()
            .find(|l| l.starts_with("element face "))
            .unwrap_or_else(|| panic!("{name}: {header}"));
        line["element face ".len()..].parse().unwrap()
    };
    assert_eq!(
        faces("leaves.ply"),
        measured["leaf_triangles"].as_u64().unwrap()
    );
    for (k, cut) in cuts.iter().enumerate() {
        assert_eq!(
            faces(&format!("cut-{k}.ply")),
            cut["triangles"].as_u64().unwrap()
        );
    }
    for cut in cuts {
        let distance = cut["sampled_distance"].as_f64().unwrap();
        let largest = cut["largest_drawn_error"].as_f64().unwrap();
        assert!(cut["samples"].as_u64().unwrap() > 0, "{cut}");
        assert!(distance <= largest + quantisation, "{cut}");
    }
    // `check --errors`: the screen-space cuts the check draws, measured against the leaves
    // both ways, stay within their τ (f32 rounding of ρ aside).
    let checked = run(&[
        "check",
        repo.to_str().unwrap(),
        "--errors",
        "--views",
        "8",
        "--json",
    ]);
    let errors = &checked["errors"];
    assert_eq!(errors["cuts"], 8 * 5, "{checked}");
    assert!(errors["samples"].as_u64().unwrap() > 0, "{checked}");
    let over = errors["error_max_over_tolerance"].as_f64().unwrap();
    assert!(over > 0.0 && over <= 1.0 + 1e-4, "{checked}");
    // Coarser cuts draw fewer triangles.
    let triangles: Vec<u64> = cuts
        .iter()
        .map(|c| c["triangles"].as_u64().unwrap())
        .collect();
    assert!(triangles.windows(2).all(|w| w[0] >= w[1]), "{triangles:?}");
}
