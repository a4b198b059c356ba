//! `render` streams: under a budget far below the repository it settles on a partial cut and
//! reports what it kept resident; with room for the view it draws the same image as with an
//! unlimited budget; a budget below the fixed allocations is refused with both numbers
//! (exit 2); `check --gpu --gpu-budget` runs the pixel check under partial residency.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn tessera(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(args)
        .output()
        .expect("run tessera")
}

fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

fn bunny() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/bunny00.off")
}

fn render(repo: &Path, png: &Path, budget_mib: &str) -> Output {
    tessera(&[
        "render",
        repo.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--size",
        "320x200",
        "--orbit",
        "30,20,0.8",
        "--tolerance",
        "0.5",
        "--gpu-budget",
        budget_mib,
        "--json",
    ])
}

#[test]
fn render_streams_within_the_budget_and_settles() {
    let dir = tempfile::tempdir().unwrap();
    let repo = dir.path().join("bunny.tsr");
    let out = tessera(&[
        "build",
        bunny().to_str().unwrap(),
        "-o",
        repo.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let size = std::fs::metadata(&repo).unwrap().len();

    let (full_png, small_png) = (dir.path().join("full.png"), dir.path().join("small.png"));
    let full = json(&render(&repo, &full_png, "2048"));
    let small = json(&render(&repo, &small_png, "1.1"));
    eprintln!("repository {size} B\nunlimited {full}\n2 MiB {small}");
    for r in [&full, &small] {
        assert!(r["resident_bytes"].as_u64().unwrap() <= r["budget_bytes"].as_u64().unwrap());
        assert!(r["frames_to_converge"].as_u64().is_some(), "{r}");
        assert!(r["resident_patches"].as_u64().unwrap() > 0);
        assert!(r["loaded_bytes"].as_u64().unwrap() > 0);
        assert_eq!(r["backend"], "vulkan");
    }
    // Unlimited: nothing evicted, nothing left wanted, the cut is what τ asks for.
    assert_eq!(full["evictions"], 0);
    assert_eq!(full["pending_units"], 0);
    assert!(full["max_error_over_tau"].as_f64().unwrap() <= 1.0);
    // 1.1 MiB: a pool far smaller than what the view wants; it settles coarser.
    assert!(small["pool_bytes"].as_u64().unwrap() * 4 < size, "{small}");
    assert!(small["pending_units"].as_u64().unwrap() > 0, "{small}");
    assert!(
        small["max_error_over_tau"].as_f64().unwrap() > 1.0,
        "{small}"
    );
    assert!(small["triangles"].as_u64().unwrap() < full["triangles"].as_u64().unwrap());

    // The pixel check under partial residency: every streamed frame checked.
    let out = tessera(&[
        "check",
        repo.to_str().unwrap(),
        "--gpu",
        "--gpu-budget",
        "1.1",
        "--views",
        "4",
        "--tolerances",
        "0.5,1",
        "--size",
        "320x200",
        "--json",
    ]);
    let c = json(&out);
    eprintln!("check under 1.1 MiB: {c}");
    assert_eq!(c["gpu"]["frames"], 4 * 2 * 4, "{c}");
    assert_eq!(c["flag_pixels"], 0, "{c}");
    assert_eq!(c["gpu"]["selection_mismatches"], 0, "{c}");
    assert!(c["gpu"]["covered_pixels"].as_u64().unwrap() > 0);
    assert!(c["resident_bytes"].as_u64().unwrap() <= c["budget_bytes"].as_u64().unwrap());
    assert!(c["pool_bytes"].as_u64().unwrap() * 4 < size, "{c}");

    let out = render(&repo, &small_png, "0.5");
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("524288") && err.contains("fixed allocations"),
        "{err}"
    );
}
