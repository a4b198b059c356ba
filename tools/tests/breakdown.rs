//! `bench breakdown` from the command line (issue 13, item 7): on a real scan, every level's
//! diamonds keep about the share of their gathered triangles the simplifier aims at, the
//! per-level figures add up to the repository's, and both projections select non-empty cuts
//! whose measured two-sided errors come with their sample counts.

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
fn breakdown_measures_both_projections_and_every_level() {
    let lion = Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/lion-head.off");
    assert!(lion.exists(), "run tools/fetch-testdata.sh first");
    let dir = tempfile::tempdir().unwrap();
    let repo = dir.path().join("lion.tsr");
    let (lion, repo) = (lion.to_str().unwrap(), repo.to_str().unwrap());
    let build = run(&["build", lion, "-o", repo, "--json"]);
    let b = run(&[
        "bench",
        "breakdown",
        repo,
        "--source",
        lion,
        "--tolerances",
        "1,8",
        "--views",
        "3",
        "--samples",
        "3000",
        "--json",
    ]);
    assert_eq!(b["metric"]["sides"], "two-sided", "{b}");

    let rows = b["projection"].as_array().unwrap();
    assert_eq!(rows.len(), 2, "{b}");
    for row in rows {
        for rule in ["sphere", "box"] {
            let r = &row[rule];
            assert!(r["triangles"].as_f64().unwrap() > 0.0, "{rule}: {row}");
            assert!(r["error_samples"].as_u64().unwrap() > 0, "{rule}: {row}");
            let (max, p99) = (
                r["error_max_px"].as_f64().unwrap(),
                r["error_p99_px"].as_f64().unwrap(),
            );
            assert!(max.is_finite() && p99 <= max, "{rule}: {row}");
        }
    }
    // A coarser τ draws fewer triangles under either rule.
    for rule in ["sphere", "box"] {
        let t = |i: usize| rows[i][rule]["triangles"].as_f64().unwrap();
        assert!(t(1) < t(0), "{rule}: {b}");
    }

    // Every split diamond is counted once, and the kept triangles of all levels are the
    // patches' triangles above the leaves.
    let levels = b["levels"].as_array().unwrap();
    let sum = |key: &str| -> u64 { levels.iter().map(|l| l[key].as_u64().unwrap()).sum() };
    assert_eq!(sum("diamonds"), build["diamonds"].as_u64().unwrap(), "{b}");
    assert!(sum("kept_on_border") <= sum("kept"), "{b}");
    for l in levels {
        let (gathered, kept) = (l["gathered"].as_u64().unwrap(), l["kept"].as_u64().unwrap());
        // The simplifier aims at half (SimplifySettings::keep); a level far off it would be
        // a simplifier that stopped short (locks) or overshot.
        if gathered >= 1000 {
            let share = kept as f64 / gathered as f64;
            assert!((0.4..=0.6).contains(&share), "level {l}: kept {share:.3}");
        }
        assert!(l["saturated"].as_u64().unwrap() <= l["diamonds"].as_u64().unwrap());
    }
}
