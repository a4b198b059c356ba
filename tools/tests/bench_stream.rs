//! `tessera bench stream`: the JSON contract, both runs, a stream that goes quiet, refusals.

mod cli_support;
use cli_support::tessera;

use std::path::Path;

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
    // A copy, not fsynced: its pages are dirty for a while (a build fsyncs its output), which
    // the cold run must flush before it can drop them.
    let copy = dir.path().join("copied.tsr");
    std::fs::copy(&repo, &copy).unwrap();
    let repo = copy;
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
        // Wall-clock time from the start to each frame's end, and to the settled cut: what a
        // user waits (the cold run's reads from the disk included).
        let at: Vec<f64> = frames
            .iter()
            .map(|f| f["at_ms"].as_f64().unwrap())
            .collect();
        assert!(at[0] > 0.0 && at.windows(2).all(|w| w[0] <= w[1]), "{at:?}");
        let to_settle = s["seconds_to_settle"].as_f64().expect("settled, so timed");
        // (serde_json's float parsing may be an ulp off the printed value.)
        let at_settled = at[settled as usize] / 1e3;
        assert!(
            (to_settle - at_settled).abs() <= 1e-12 * at_settled.max(1.0),
            "{to_settle} against {at_settled}"
        );
        assert!(to_settle <= s["seconds"].as_f64().unwrap(), "{s}");
        // The cold run starts with the file out of the page cache (flushed, then dropped),
        // except on a file system that lives in it.
        if run["mode"] == "cold" && !on_tmpfs(repo) {
            assert_eq!(s["page_cache_share_before"], 0.0, "{s}");
        }
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

/// Whether `path` lies on a tmpfs, whose pages cannot leave the page cache.
fn on_tmpfs(path: &Path) -> bool {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(path.as_os_str().as_bytes()).unwrap();
    // SAFETY: a valid C string and a zeroed statfs to fill.
    let mut fs: libc::statfs = unsafe { std::mem::zeroed() };
    let rc = unsafe { libc::statfs(c.as_ptr(), &mut fs) };
    const TMPFS_MAGIC: i64 = 0x0102_1994;
    rc == 0 && fs.f_type as i64 == TMPFS_MAGIC
}

/// The soak run of issue 11, scaled down: a camera path flown three times on the GPU renderer
/// under a budget smaller than the path's working set (but holding its last view), each
/// loop's last camera held until the stream settles. Every loop settles on the first loop's
/// cut, the resident bytes never pass the residency's budget nor the GPU allocations
/// `--gpu-budget`, and loads go on (evictions in every loop, loads after them). On llvmpipe
/// GL the process's RssAnon stays flat after the first loop; on lavapipe (Vulkan) it is not
/// asserted: its driver keeps about a quarter of a megabyte per submitted frame until the
/// device is dropped (BENCHMARKS.md, "Out of core", the soak run), whatever tessera does.
#[test]
fn a_looped_path_on_the_gpu_settles_on_the_same_cut_every_loop_within_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let repo = dir.path().join("bunny.tsr");
    let out = tessera(&[
        "build",
        bunny().to_str().unwrap(),
        "-o",
        repo.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    // A path around the bunny: in from 3 radii, then a full turn at 0.9 radii.
    let info: serde_json::Value =
        serde_json::from_slice(&tessera(&["info", repo.to_str().unwrap(), "--json"]).stdout)
            .unwrap();
    let corner = |k: &str| -> Vec<f64> {
        info[k]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let (lo, hi) = (corner("bbox_min"), corner("bbox_max"));
    let centre: Vec<f64> = (0..3).map(|i| (lo[i] + hi[i]) / 2.0).collect();
    let radius = (0..3).map(|i| (hi[i] - lo[i]).powi(2)).sum::<f64>().sqrt() / 2.0;
    let eye = |azimuth: f64, distance: f64| {
        let (a, e) = (azimuth.to_radians(), 15f64.to_radians());
        vec![
            centre[0] + distance * radius * e.cos() * a.sin(),
            centre[1] + distance * radius * e.sin(),
            centre[2] + distance * radius * e.cos() * a.cos(),
        ]
    };
    let keyframes: Vec<_> = [
        (0.0, 3.0),
        (90.0, 0.9),
        (180.0, 0.9),
        (270.0, 0.9),
        (360.0, 0.9),
    ]
    .iter()
    .map(|&(az, d)| serde_json::json!({"eye": eye(az, d), "target": centre}))
    .collect();
    let path = dir.path().join("path.json");
    std::fs::write(
        &path,
        serde_json::json!({"keyframes": keyframes, "frames_between": 25, "pause_frames": 20})
            .to_string(),
    )
    .unwrap();

    let loops = 3;
    let soak = |backend: &str, budget_mib: &str| -> serde_json::Value {
        let out = tessera(&[
            "bench",
            "stream",
            repo.to_str().unwrap(),
            "--gpu",
            "--backend",
            backend,
            "--loops",
            &loops.to_string(),
            "--path",
            path.to_str().unwrap(),
            "--size",
            "160x90",
            "--tolerance",
            "0.5",
            "--gpu-budget",
            budget_mib,
            "--json",
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
        serde_json::from_slice(&out.stdout).unwrap()
    };
    // The path's working set: what an unlimited budget loads, with no eviction.
    let unlimited = soak("vulkan", "64");
    let working_set = unlimited["runs"][0]["summary"]["peak_resident_bytes"]
        .as_u64()
        .unwrap();
    assert_eq!(unlimited["runs"][0]["summary"]["evictions"], 0);

    for backend in ["vulkan", "gl"] {
        let v = soak(backend, "0.9");
        assert_eq!(v["traversal"], "gpu");
        assert_eq!(v["backend"], backend);
        let budget = v["budget_bytes"].as_u64().unwrap();
        for run in v["runs"].as_array().unwrap() {
            let s = &run["summary"];
            eprintln!("{backend} {}: {s}", run["mode"]);
            let resident_budget = s["resident_budget_bytes"].as_u64().unwrap();
            assert!(resident_budget < working_set, "{s}: no pressure");
            assert!(
                s["peak_resident_bytes"].as_u64().unwrap() <= resident_budget,
                "{s}"
            );
            assert!(s["gpu_bytes"].as_u64().unwrap() <= budget, "{s}");
            assert_eq!(s["every_loop_settled"], true, "{s}");
            assert_eq!(s["cuts_equal_first_loop"], true, "{s}");
            // The last view fits: its settled cut is what τ asks for.
            assert!(s["max_error_over_tau_last"].as_f64().unwrap() <= 1.0, "{s}");
            let per_loop = run["loops"].as_array().unwrap();
            assert_eq!(per_loop.len(), loops);
            for l in per_loop {
                assert!(l["cut_patches"].as_u64().unwrap() > 0, "{l}");
                assert!(l["peak_resident_bytes"].as_u64().unwrap() <= resident_budget);
                // Loading never stalls: every loop evicts and loads again.
                assert!(l["evictions"].as_u64().unwrap() > 0, "{l}");
                assert!(l["loads"].as_u64().unwrap() > 0, "{l}");
            }
            if backend == "gl" {
                let growth = s["rss_anon_growth_after_first_loop"].as_i64().unwrap();
                assert!(
                    growth <= 4 << 20,
                    "RssAnon grew {growth} B after loop 1: {s}"
                );
            }
        }
    }
}
