//! `bench breakdown` from the command line (issue 13, item 7): on a real scan, every level's
//! diamonds keep about the share of their gathered triangles the simplifier aims at, the
//! per-level figures add up to the repository's, both projections select non-empty cuts
//! whose measured two-sided errors come with their sample counts, and the counterfactuals
//! (each diamond simplified again, locked and free) see what the build gathered and kept.

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

    // The counterfactuals: the same diamonds and gathered triangles per level; the locked arm
    // reproduces the build's own simplification (about its kept count, its own error: the
    // stored one is at least that at the median), the free arm is never worse at equal
    // error by more than meshoptimizer's greed allows.
    let locks = b["locks"].as_array().unwrap();
    let with = |l: &serde_json::Value, key: &str| l[key].as_u64().unwrap();
    for (lock, level) in locks.iter().zip(levels) {
        assert_eq!(lock["level"], level["level"], "{b}");
        assert_eq!(with(lock, "gathered"), with(level, "gathered"), "{b}");
        let (kept, locked) = (with(level, "kept"), with(lock, "kept_locked"));
        assert!(
            locked.abs_diff(kept) as f64 <= 0.02 * kept as f64 + 2.0,
            "level {}: the build kept {kept}, the locked arm {locked}",
            level["level"]
        );
        let free = with(lock, "kept_free_at_equal_error");
        assert!(free as f64 <= 1.1 * locked as f64 + 2.0, "{lock}");
        if let Some(raise) = lock["raise_median"].as_f64() {
            assert!(raise >= 0.9, "{lock}");
            assert!(lock["raise_p90"].as_f64().unwrap() >= raise, "{lock}");
        }
    }
    assert_eq!(locks.len(), levels.len(), "{b}");
}
