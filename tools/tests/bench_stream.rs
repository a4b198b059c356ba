//! `tessera bench stream`: the JSON contract, both runs, a stream that goes quiet, refusals.

use std::path::Path;
use std::process::{Command, Output};

fn tessera(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(args)
        .output()
        .expect("run tessera")
}

fn bunny() -> std::path::PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/bunny00.off");
    assert!(
        path.exists(),
        "{} is missing: run tools/fetch-testdata.sh first (README.md, 'Tests')",
        path.display()
    );
    path
}

#[test]
fn bench_stream_reports_warm_and_cold_runs_that_settle_within_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let repo = dir.path().join("bunny.tsr");
    let out = tessera(&[
        "build",
        bunny().to_str().unwrap(),
        "-o",
        repo.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let plot = dir.path().join("plot");
    // 0.5 MiB is a third of the bunny's repository: the stream runs under pressure; 4 MiB
    // holds everything.
    for budget_mib in ["0.5", "4"] {
        check_run(&repo, budget_mib, &plot);
    }
    assert!(plot.join("stream.png").exists());

    // Refusals: exit 2 with the reason.
    for (args, expected) in [
        (vec!["--gpu-budget", "0"], "--gpu-budget"),
        (vec!["--gpu-budget", "0.0001"], "roots"),
        (vec!["--tolerance=-1"], "--tolerance"),
    ] {
        let mut all = vec!["bench", "stream", repo.to_str().unwrap()];
        all.extend(args);
        let out = tessera(&all);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains(expected), "{stderr}");
    }
}

fn check_run(repo: &Path, budget_mib: &str, plot: &Path) {
    let out = tessera(&[
        "bench",
        "stream",
        repo.to_str().unwrap(),
        "--gpu-budget",
        budget_mib,
        "--json",
        "--plot",
        plot.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["traversal"], "cpu");
    let budget = v["budget_bytes"].as_u64().unwrap();
    let fits = budget_mib == "4";
    assert_eq!(budget, if fits { 4 << 20 } else { 1 << 19 });
    let runs = v["runs"].as_array().unwrap();
    assert_eq!(
        runs.iter()
            .map(|r| r["mode"].as_str().unwrap())
            .collect::<Vec<_>>(),
        ["warm", "cold"]
    );
    for run in runs {
        let s = &run["summary"];
        assert!(s["peak_resident_bytes"].as_u64().unwrap() <= budget, "{s}");
        assert!(s["loads"].as_u64().unwrap() > 0, "{s}");
        let frames = run["per_frame"].as_array().unwrap();
        assert_eq!(frames.len(), s["frames"].as_u64().unwrap() as usize);
        for key in [
            "patches",
            "triangles",
            "resident_bytes",
            "loaded_bytes",
            "wanted_not_resident",
            "max_error_over_tau",
            "frame_ms",
        ] {
            assert!(frames[0].get(key).is_some(), "per-frame key {key}");
        }
        // The default path ends with 120 paused frames: the stream goes quiet before its
        // end; where the budget holds the view, the last cut is what τ asks for.
        let settled = s["settled_from_frame"].as_u64().expect("never settled");
        assert!(settled < frames.len() as u64 - 1);
        let last = frames.last().unwrap();
        if fits {
            assert_eq!(last["wanted_not_resident"], 0, "{s}");
            assert!(last["max_error_over_tau"].as_f64().unwrap() <= 1.0, "{s}");
            assert_eq!(s["evictions"], 0, "{s}");
        } else {
            assert!(s["evictions"].as_u64().unwrap() > 0, "{s}");
        }
    }
}
