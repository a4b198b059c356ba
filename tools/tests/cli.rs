//! The CLI contract pipeline scripts rely on: JSON keys, exit codes, no partial outputs.

mod cli_support;
use cli_support::{build_bunny, bunny, json, tessera};

use std::path::Path;
use std::process::Command;

/// A closed octahedron, subdivided a few times so the hierarchy has levels.
fn write_octahedron_off(path: &Path) {
    let v = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let f = [
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    let mut verts: Vec<[f64; 3]> = v.to_vec();
    let mut faces: Vec<[usize; 3]> = f.to_vec();
    for _ in 0..5 {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        for t in &faces {
            let mut m = [0; 3];
            for k in 0..3 {
                let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
                m[k] = *mid.entry((a, b)).or_insert_with(|| {
                    let p: Vec<f64> = (0..3).map(|i| 0.5 * (verts[a][i] + verts[b][i])).collect();
                    let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                    verts.push([p[0] / l, p[1] / l, p[2] / l]);
                    verts.len() - 1
                });
            }
            next.extend([
                [t[0], m[0], m[2]],
                [t[1], m[1], m[0]],
                [t[2], m[2], m[1]],
                m,
            ]);
        }
        faces = next;
    }
    let mut s = format!("OFF\n{} {} 0\n", verts.len(), faces.len());
    for p in &verts {
        s += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    for t in &faces {
        s += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    std::fs::write(path, s).unwrap();
}

#[test]
fn build_info_check_speak_json_and_exit_zero() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("octa.off");
    let repo = dir.path().join("octa.tsr");
    write_octahedron_off(&input);
    let out = tessera(&[
        "build",
        input.to_str().unwrap(),
        "-o",
        repo.to_str().unwrap(),
        "--leaf-triangles",
        "64",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let b = json(&out);
    for key in [
        "input_triangles",
        "input_vertices",
        "tetrahedra",
        "diamonds",
        "depth",
        "seconds",
        "repository_bytes",
        "position_step",
        "quantisation_error",
    ] {
        assert!(b.get(key).is_some(), "build --json lacks {key}: {b}");
    }
    assert_eq!(b["input_triangles"], 8 * 1024);
    // Half the step's diagonal, and counted in the stored errors (the root's among them).
    let step: Vec<f64> = (0..3)
        .map(|i| b["position_step"][i].as_f64().unwrap())
        .collect();
    let quantisation = b["quantisation_error"].as_f64().unwrap();
    let half_diagonal = 0.5 * step.iter().map(|s| s * s).sum::<f64>().sqrt();
    assert!(quantisation > 0.0 && (quantisation - half_diagonal).abs() <= 1e-12 * half_diagonal);
    assert!(b["root_error"].as_f64().unwrap() >= quantisation, "{b}");
    assert_eq!(
        b["repository_bytes"].as_u64().unwrap(),
        std::fs::metadata(&repo).unwrap().len()
    );

    let out = tessera(&["info", repo.to_str().unwrap(), "--json"]);
    assert!(out.status.success());
    assert_eq!(json(&out)["tetrahedra"], b["tetrahedra"]);

    let out = tessera(&[
        "check",
        repo.to_str().unwrap(),
        "--views",
        "8",
        "--tolerances",
        "0.5,2,8",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let c = json(&out);
    assert_eq!(c["cuts_checked"], 24);
    for key in [
        "cracks",
        "nonmanifold_introduced",
        "monotonicity_violations",
    ] {
        assert_eq!(c[key], 0, "{c}");
    }
    assert!(c["min_triangles"].as_u64().unwrap() > 0);

    // Every GPU command takes --backend and reports the backend it used, on both backends CI
    // installs (lavapipe for Vulkan, Mesa's EGL for GL).
    for backend in ["vulkan", "gl"] {
        let png = dir.path().join(format!("octa-{backend}.png"));
        let out = tessera(&[
            "render",
            repo.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--size",
            "160x120",
            "--backend",
            backend,
            "--json",
        ]);
        assert!(
            out.status.success(),
            "render --backend {backend}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let r = json(&out);
        assert_eq!(r["backend"], backend, "{r}");
        assert!(r["adapter"].as_str().unwrap().contains(backend), "{r}");
        assert!(r["triangles"].as_u64().unwrap() > 0, "{r}");
        let out = tessera(&[
            "check",
            repo.to_str().unwrap(),
            "--views",
            "4",
            "--tolerances",
            "2",
            "--gpu",
            "--size",
            "160x120",
            "--backend",
            backend,
            "--json",
        ]);
        assert!(
            out.status.success(),
            "check --gpu --backend {backend}: {}",
            String::from_utf8_lossy(&out.stdout)
        );
        let c = json(&out);
        assert_eq!(c["backend"], backend, "{c}");
        assert_eq!(c["gpu"]["backend"], backend, "{c}");
        assert_eq!(c["flag_pixels"], 0, "{c}");
        assert_eq!(c["gpu"]["selection_mismatches"], 0, "{c}");
    }
}

#[test]
fn bad_inputs_exit_two_with_a_message_and_leave_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let cases: &[(&str, &[u8], &str)] = &[
        ("missing_header.ply", b"not a ply file\n", "ply"),
        ("bad_index.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "7"),
        ("nan.off", b"OFF\n3 1 0\nnan 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "nan"),
        ("truncated.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n", "truncat"),
        ("empty.off", b"OFF\n0 0 0\n", "empty"),
        ("huge.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n", "huge.ply"),
        ("unknown.xyz", b"1 2 3\n", "xyz"),
    ];
    for (name, bytes, needle) in cases {
        let input = dir.path().join(name);
        std::fs::write(&input, bytes).unwrap();
        let output = dir.path().join(format!("{name}.tsr"));
        let out = tessera(&[
            "build",
            input.to_str().unwrap(),
            "-o",
            output.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr).to_lowercase();
        assert_eq!(out.status.code(), Some(2), "{name}: {stderr}");
        assert!(
            stderr.contains(name),
            "{name}: message does not name the file: {stderr}"
        );
        assert!(
            stderr.contains(needle),
            "{name}: message does not say '{needle}': {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
        assert!(!output.exists(), "{name}: an output file was left behind");
        let leftovers: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
            .collect();
        assert!(
            leftovers.is_empty(),
            "{name}: temporary files left: {leftovers:?}"
        );
    }
    let out = tessera(&[
        "build",
        dir.path().join("nope.ply").to_str().unwrap(),
        "-o",
        "x.tsr",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope.ply"));
}

#[test]
fn corrupt_repositories_are_rejected_with_exit_two() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("octa.off");
    let repo = dir.path().join("octa.tsr");
    write_octahedron_off(&input);
    assert!(tessera(&[
        "build",
        input.to_str().unwrap(),
        "-o",
        repo.to_str().unwrap()
    ])
    .status
    .success());
    let bytes = std::fs::read(&repo).unwrap();
    let opened = tessera_core::repository::Repository::open(&repo).unwrap();
    let section = |kind| {
        opened
            .sections()
            .iter()
            .find(|s| s.kind == kind)
            .unwrap()
            .offset as usize
    };
    let (tets, patches) = (
        section(tessera_core::repository::format::SECTION_TETS),
        // The patch blob, whichever codec the default build writes.
        opened
            .sections()
            .iter()
            .find(|s| tessera_core::repository::format::PATCH_SECTIONS.contains(&s.kind))
            .unwrap()
            .offset as usize,
    );
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("truncated", bytes[..bytes.len() / 2].to_vec()),
        ("flipped", {
            let mut b = bytes.clone();
            b[tets + 20] ^= 0x40;
            b
        }),
        ("version", {
            let mut b = bytes.clone();
            b[8] = 99;
            b
        }),
        ("empty", Vec::new()),
    ];
    for (name, data) in cases {
        let path = dir.path().join(format!("{name}.tsr"));
        std::fs::write(&path, data).unwrap();
        for cmd in ["info", "check"] {
            let out = tessera(&[cmd, path.to_str().unwrap()]);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{cmd} {name}: {stderr}");
            assert!(stderr.contains("error"), "{cmd} {name}: {stderr}");
            assert!(!stderr.contains("panicked"), "{cmd} {name}: {stderr}");
        }
    }
    // A damaged patch: `info` reads no patch and succeeds; `check` names the patch.
    let mut damaged = bytes.clone();
    damaged[patches + 3] ^= 0x40;
    let path = dir.path().join("damaged-patch.tsr");
    std::fs::write(&path, damaged).unwrap();
    assert!(tessera(&["info", path.to_str().unwrap()]).status.success());
    let out = tessera(&["check", path.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("patch of tet 0 is damaged"), "{stderr}");
}

/// Runs tessera and checks exit code 2 with a message containing every needle, no panic.
fn check_bad_usage(args: &[&str], needles: &[&str]) {
    let out = tessera(args);
    let stderr = String::from_utf8_lossy(&out.stderr).to_lowercase();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    for needle in needles {
        assert!(
            stderr.contains(&needle.to_lowercase()),
            "{args:?}: message does not say '{needle}': {stderr}"
        );
    }
    assert!(out.stdout.is_empty(), "{args:?}: printed a report anyway");
}

#[test]
fn bench_render_refuses_bad_input_with_exit_two() {
    let dir = tempfile::tempdir().unwrap();
    let repo = build_bunny(dir.path());
    let repo = repo.to_str().unwrap();
    let octa = dir.path().join("octa.off");
    write_octahedron_off(&octa);
    let missing = dir.path().join("nope.tsr");
    // A backend this platform cannot have.
    let absent = if cfg!(target_os = "macos") {
        "dx12"
    } else {
        "metal"
    };
    let absent_message = format!("no adapter on the {absent} backend");
    let cases: &[(&[&str], &[&str])] = &[
        // A repository that is not there.
        (
            &["bench", "render", missing.to_str().unwrap()],
            &["nope.tsr"],
        ),
        // A source that is not there, and one that is not the repository's.
        (
            &["bench", "render", repo, "--source", "/nonexistent/mesh.ply"],
            &["mesh.ply"],
        ),
        (
            &["bench", "render", repo, "--source", octa.to_str().unwrap()],
            &["octa.off", "not its source"],
        ),
        // Bad numbers.
        (
            &["bench", "render", repo, "--size", "0x240"],
            &["size", "positive"],
        ),
        (
            &["bench", "render", repo, "--size", "big"],
            &["size", "widthxheight"],
        ),
        (&["bench", "render", repo, "--frames", "0"], &["--frames"]),
        (
            &["bench", "render", repo, "--tolerances", "1,-2"],
            &["tolerance -2"],
        ),
        (
            &["bench", "render", repo, "--orbit", "30,20,0"],
            &["--orbit"],
        ),
        // No adapter of that name.
        (
            &["bench", "render", repo, "--adapter", "no-such-gpu"],
            &["no adapter", "no-such-gpu"],
        ),
        // No such backend, and a backend this machine does not have.
        (
            &["bench", "render", repo, "--backend", "glide"],
            &["glide", "vulkan, gl, metal or dx12"],
        ),
        (
            &["render", repo, "-o", "/tmp/never.png", "--backend", absent],
            &[&absent_message],
        ),
    ];
    for (args, needles) in cases {
        check_bad_usage(args, needles);
    }
}

#[test]
fn bench_render_measures_ours_and_the_full_resolution_peer() {
    let dir = tempfile::tempdir().unwrap();
    let repo = build_bunny(dir.path());
    let frames = dir.path().join("frames");
    let out = tessera(&[
        "bench",
        "render",
        repo.to_str().unwrap(),
        "--source",
        bunny().to_str().unwrap(),
        "--tolerances",
        "0,4",
        "--frames",
        "2",
        "--size",
        "320x240",
        "--save-frames",
        frames.to_str().unwrap(),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = json(&out);
    for key in [
        "adapter",
        "backend",
        "size",
        "camera",
        "full_resolution",
        "rows",
    ] {
        assert!(v.get(key).is_some(), "bench render --json lacks {key}: {v}");
    }
    assert!(
        ["vulkan", "gl", "metal", "dx12"].contains(&v["backend"].as_str().unwrap()),
        "{v}"
    );
    assert_eq!(v["size"]["width"], 320);
    assert_eq!(v["size"]["height"], 240);
    let full = &v["full_resolution"];
    assert_eq!(full["triangles"], v["model_triangles"], "{v}");
    for key in [
        "gpu_ms_median",
        "gpu_ms_p90",
        "wall_ms_median",
        "cpu_ms_median",
    ] {
        assert!(full.get(key).is_some(), "full_resolution lacks {key}: {v}");
    }
    assert!(full["wall_ms_median"].as_f64().unwrap() > 0.0);
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    let model_triangles = v["model_triangles"].as_u64().unwrap();
    for (row, tau) in rows.iter().zip([0.0, 4.0]) {
        assert_eq!(row["tolerance"], tau);
        for key in [
            "patches",
            "triangles",
            "gpu_ms_median",
            "gpu_ms_p90",
            "wall_ms_median",
            "cpu_ms_median",
            "speedup_vs_full",
        ] {
            assert!(row.get(key).is_some(), "row lacks {key}: {row}");
        }
        assert!(row["patches"].as_u64().unwrap() > 0, "{row}");
        let triangles = row["triangles"].as_u64().unwrap();
        assert!(triangles > 0 && triangles <= 2 * model_triangles, "{row}");
        // GPU timings and the speed-up exist exactly where the adapter has timestamps.
        assert_eq!(
            row["gpu_ms_median"].is_null(),
            row["speedup_vs_full"].is_null(),
            "{row}"
        );
        if let Some(s) = row["speedup_vs_full"].as_f64() {
            assert!(s.is_finite() && s > 0.0, "{row}");
        }
    }
    // The coarser cut draws no more than the finer one.
    assert!(rows[1]["triangles"].as_u64() <= rows[0]["triangles"].as_u64());
    // Same camera, same shading: at τ = 0 our cut is the input mesh (positions quantised on
    // the 2^21 grid), so the peer's picture and ours agree but for a few edge pixels.
    let full = image::open(frames.join("full.png")).unwrap().to_rgba8();
    let ours = image::open(frames.join("tau-0.png")).unwrap().to_rgba8();
    let background = full.get_pixel(0, 0).0;
    let covered = full.pixels().filter(|p| p.0 != background).count();
    let differing = full
        .pixels()
        .zip(ours.pixels())
        .filter(|(a, b)| (0..3).any(|c| a.0[c].abs_diff(b.0[c]) > 8))
        .count();
    assert!(covered > 1000, "the bunny covers {covered} pixels");
    assert!(
        differing * 50 < covered,
        "{differing} of {covered} pixels differ between the peer and τ = 0"
    );
    assert!(frames.join("tau-4.png").exists());

    // Without --source: our rows only, no peer, no speed-up.
    let out = tessera(&[
        "bench",
        "render",
        repo.to_str().unwrap(),
        "--tolerances",
        "2",
        "--frames",
        "1",
        "--size",
        "160x120",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = json(&out);
    assert!(v["full_resolution"].is_null(), "{v}");
    assert_eq!(v["rows"].as_array().unwrap().len(), 1);
    assert!(v["rows"][0]["speedup_vs_full"].is_null());
    assert!(v["rows"][0]["patches"].as_u64().unwrap() > 0);
}

#[test]
fn demo_renders_frames_or_says_why_not() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    let out = tessera(&[
        "demo",
        "--subdivisions",
        "5",
        "--views",
        "2",
        "--frame-size",
        "320x240",
        "--frames-dir",
        frames.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("CLEAN"), "{stdout}");
    for name in [
        "lit-tau-1.png",
        "lit-tau-4.png",
        "lit-tau-16.png",
        "patches-tau-1.png",
    ] {
        let path = frames.join(name);
        assert!(path.exists(), "{name} not written: {stdout}");
        assert!(stdout.contains(name), "{name} not reported: {stdout}");
    }
    assert!(
        stdout.contains("patches,") && stdout.contains("GPU"),
        "{stdout}"
    );
    // The trade-off table: a row per τ with triangles, measured error, frame time.
    assert!(
        stdout.contains("trade-off") && stdout.contains("p99 px") && stdout.contains("wall ms"),
        "{stdout}"
    );

    // No usable adapter: the build and the check still run and decide the exit code.
    let skipped = dir.path().join("skipped");
    let out = Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args([
            "demo",
            "--subdivisions",
            "4",
            "--views",
            "2",
            "--frames-dir",
            skipped.to_str().unwrap(),
        ])
        .env("TESSERA_ADAPTER", "no-such-gpu")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("CLEAN"), "{stdout}");
    assert!(
        stdout.contains("rendering skipped") && stdout.contains("no-such-gpu"),
        "{stdout}"
    );
    assert_eq!(std::fs::read_dir(&skipped).unwrap().count(), 0);

    // A frames directory that cannot be made is bad input, found before the build.
    let file = dir.path().join("a-file");
    std::fs::write(&file, b"").unwrap();
    let inside = file.join("frames");
    check_bad_usage(
        &[
            "demo",
            "--subdivisions",
            "3",
            "--frames-dir",
            inside.to_str().unwrap(),
        ],
        &["--frames-dir"],
    );
}

/// The row keys pipeline scripts parse from `tessera bench REPO --source INPUT --json`.
const TRADE_ROW_KEYS: [&str; 10] = [
    "tolerance",
    "patches",
    "triangles",
    "cpu_ms",
    "gpu_ms",
    "error_max_px",
    "error_p99_px",
    "error_mean_px",
    "pixels_differing",
    "psnr",
];

#[test]
fn bench_trade_off_measures_ours_and_the_peers() {
    let dir = tempfile::tempdir().unwrap();
    let repo = build_bunny(dir.path());
    let plots = dir.path().join("plots");
    let out = tessera(&[
        "bench",
        repo.to_str().unwrap(),
        "--source",
        bunny().to_str().unwrap(),
        "--views",
        "2",
        "--error-views",
        "2",
        "--tolerances",
        "0.5,2,8",
        "--size",
        "320x240",
        "--samples",
        "2000",
        "--frames",
        "1",
        "--plot",
        plots.to_str().unwrap(),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = json(&out);
    let model_triangles = v["model_triangles"].as_f64().unwrap();
    let check_rows = |name: &str, rows: &serde_json::Value| {
        let rows = rows
            .as_array()
            .unwrap_or_else(|| panic!("{name}: no rows: {v}"));
        assert_eq!(rows.len(), 3, "{name}");
        for (row, tau) in rows.iter().zip([0.5, 2.0, 8.0]) {
            for key in TRADE_ROW_KEYS {
                assert!(row.get(key).is_some(), "{name} row lacks {key}: {row}");
            }
            assert_eq!(row["tolerance"], tau, "{name}");
            let triangles = row["triangles"].as_f64().unwrap();
            assert!(
                triangles > 0.0 && triangles <= model_triangles,
                "{name}: {row}"
            );
            let (max, p99, mean) = (
                row["error_max_px"].as_f64().unwrap(),
                row["error_p99_px"].as_f64().unwrap(),
                row["error_mean_px"].as_f64().unwrap(),
            );
            assert!(
                0.0 <= mean && mean <= p99 && p99 <= max && max.is_finite(),
                "{name}: {row}"
            );
            let differing = row["pixels_differing"].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&differing), "{name}: {row}");
            let psnr = row["psnr"].as_f64().unwrap();
            assert!(psnr > 10.0 && psnr <= 99.0, "{name}: {row}");
            assert!(row["cpu_ms"].as_f64().unwrap() >= 0.0, "{name}: {row}");
            assert!(row["gpu_ms"].is_null() || row["gpu_ms"].as_f64().unwrap() >= 0.0);
        }
    };
    check_rows("ours", &v["rows"]);
    // The metric is stated, and every row keeps its sample count.
    assert_eq!(v["metric"]["distance"], "euclidean");
    assert_eq!(v["metric"]["sides"], "two-sided");
    assert_eq!(v["metric"]["visible_only"], true);
    assert_eq!(v["metric"]["image_pixels"], "model");
    // One face rule for every subject and the measurement: back faces culled by default.
    assert!(
        v["metric"]["faces"].as_str().unwrap().starts_with("front"),
        "{}",
        v["metric"]
    );
    for r in v["rows"].as_array().unwrap() {
        // Both directions measured; the pooled columns are theirs together.
        let side = |key: &str, field: &str| r[key][field].as_f64().unwrap();
        let (forward, backward) = (
            side("error_to_original", "samples"),
            side("error_to_cut", "samples"),
        );
        assert!(forward > 0.0 && backward > 0.0, "{r}");
        assert_eq!(r["error_samples"].as_f64(), Some(forward + backward), "{r}");
        let max = r["error_max_px"].as_f64().unwrap();
        assert_eq!(
            max,
            side("error_to_original", "max_px").max(side("error_to_cut", "max_px")),
            "{r}"
        );
        // A closed mesh seen from outside hides at least half of itself (a convex one
        // exactly half, from afar): hidden samples are counted, not measured.
        let hidden = r["hidden_samples"].as_f64().unwrap();
        let share = hidden / (hidden + forward + backward);
        assert!((0.45..0.85).contains(&share), "{share}: {r}");
    }
    let peers = v["peers"].as_object().unwrap();
    for name in ["full_resolution", "discrete_lod", "cluster_dag"] {
        check_rows(name, &peers[name]);
    }
    // The full resolution: all of the mesh, error 0 by definition, its own picture.
    for row in peers["full_resolution"].as_array().unwrap() {
        assert_eq!(row["triangles"].as_f64(), Some(model_triangles), "{row}");
        assert_eq!(row["error_max_px"].as_f64(), Some(0.0));
        assert_eq!(row["pixels_differing"].as_f64(), Some(0.0));
        assert_eq!(row["psnr"].as_f64(), Some(99.0));
    }
    // The coarser cut draws no more than the finer one, and ours measured something.
    let ours = v["rows"].as_array().unwrap();
    assert!(ours[2]["triangles"].as_f64() <= ours[0]["triangles"].as_f64());
    assert!(ours[0]["error_p99_px"].as_f64().unwrap() > 0.0, "{v}");
    // Nine levels by default, halving from the source (`--lod-fractions`).
    assert_eq!(v["discrete_lod_levels"].as_array().unwrap().len(), 9);
    assert!(v["cluster_dag"]["clusters"].as_u64().unwrap() > 0);
    // The DAG's per-frame upload is charged apart from its CPU ms; ours uploads nothing per
    // frame.
    for row in peers["cluster_dag"].as_array().unwrap() {
        assert!(row["upload_ms"].as_f64().unwrap() > 0.0, "{row}");
    }
    for row in ours {
        assert_eq!(row["upload_ms"].as_f64(), Some(0.0), "{row}");
    }
    assert_eq!(v["verdict"].as_array().unwrap().len(), 3);
    // At equal max error too, each level one of our rows' pooled max.
    let at_max = v["verdict_max"].as_array().unwrap();
    assert_eq!(at_max.len(), 3, "{v}");
    for (level, row) in at_max.iter().zip(ours) {
        assert_eq!(level["statistic"], "max");
        assert_eq!(level["error_max_px"], row["error_max_px"], "{level}");
        assert!(level["triangles"]["cluster_dag"]["value"].as_f64().unwrap() > 0.0);
    }
    for name in [
        "triangles_vs_tau.png",
        "error_vs_tau.png",
        "frame_time_vs_tau.png",
        "triangles_vs_max_error.png",
    ] {
        let png = image::open(plots.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(png.width() > 100 && png.height() > 100, "{name}");
    }

    // The other forms of `bench` still parse: `bench build` with its measured column.
    let out = tessera(&[
        "bench",
        "build",
        bunny().to_str().unwrap(),
        "--sweep",
        "1024",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let b = json(&out);
    let p99 = b["sweep"][0]["measured_1px_error_p99_px"].as_f64().unwrap();
    assert!(p99 > 0.0 && p99.is_finite(), "{b}");
}

#[test]
fn bench_trade_off_refuses_bad_input_with_exit_two() {
    let dir = tempfile::tempdir().unwrap();
    let repo = build_bunny(dir.path());
    let repo = repo.to_str().unwrap();
    let source = bunny();
    let source = source.to_str().unwrap();
    let octa = dir.path().join("octa.off");
    write_octahedron_off(&octa);
    let missing = dir.path().join("nope.tsr");
    let file = dir.path().join("a-file");
    std::fs::write(&file, b"").unwrap();
    let inside_file = file.join("plots");
    let cases: &[(&[&str], &[&str])] = &[
        // Missing arguments.
        (&["bench", repo], &["--source"]),
        (&["bench", "--source", source], &["repository"]),
        // A repository that is not there; a source that is not its source.
        (
            &["bench", missing.to_str().unwrap(), "--source", source],
            &["nope.tsr"],
        ),
        (
            &["bench", repo, "--source", octa.to_str().unwrap()],
            &["octa.off", "not its source"],
        ),
        // Bad numbers.
        (
            &["bench", repo, "--source", source, "--views", "0"],
            &["--views"],
        ),
        (
            &["bench", repo, "--source", source, "--samples", "0"],
            &["--samples"],
        ),
        (
            &["bench", repo, "--source", source, "--tolerances", "1,-2"],
            &["tolerance -2"],
        ),
        (
            &["bench", repo, "--source", source, "--size", "0x240"],
            &["size", "positive"],
        ),
        // Cluster DAG settings it does not know or cannot use.
        (
            &["bench", repo, "--source", source, "--dag", "leaves=3"],
            &["--dag", "unknown key"],
        ),
        (
            &["bench", repo, "--source", source, "--dag", "triangles=512"],
            &["--dag", "triangles=512"],
        ),
        (
            &[
                "bench",
                repo,
                "--source",
                source,
                "--lod-fractions",
                "0.5,0.25",
            ],
            &["--lod-fractions", "first level"],
        ),
        (
            &[
                "bench",
                repo,
                "--source",
                source,
                "--lod-fractions",
                "1,0.25,0.5",
            ],
            &["--lod-fractions", "decrease"],
        ),
        // A plot directory that cannot be made.
        (
            &[
                "bench",
                repo,
                "--source",
                source,
                "--plot",
                inside_file.to_str().unwrap(),
            ],
            &["--plot"],
        ),
    ];
    for (args, needles) in cases {
        check_bad_usage(args, needles);
    }
}

/// `gen terrain` writes a grid `build` reads as a height field (2D hierarchy, `grid` in its
/// JSON), and `check --gpu` checks it from above and below; bad terrain parameters and DEM
/// options exit 2 and leave nothing behind.
#[test]
fn gen_terrain_builds_as_a_height_field_and_checks_clean() {
    let dir = tempfile::tempdir().unwrap();
    let grid = dir.path().join("t.json");
    let repo = dir.path().join("t.tsr");
    let out = tessera(&[
        "gen",
        "terrain",
        "-o",
        grid.to_str().unwrap(),
        "--levels",
        "7",
        "--seed",
        "3",
        "--regions",
        "MP,HW",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = tessera(&[
        "build",
        grid.to_str().unwrap(),
        "-o",
        repo.to_str().unwrap(),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let b = json(&out);
    assert_eq!(b["domain"], "heightfield", "{b}");
    assert_eq!(b["grid"]["columns"], 129);
    assert_eq!(b["input_triangles"], 2 * 128 * 128);
    let out = tessera(&["info", repo.to_str().unwrap(), "--json"]);
    assert_eq!(json(&out)["dimension"], 2);
    let out = tessera(&[
        "check",
        repo.to_str().unwrap(),
        "--gpu",
        "--views",
        "6",
        "--tolerances",
        "1,4",
        "--json",
    ]);
    let c = json(&out);
    assert!(out.status.success(), "{c}");
    assert_eq!(c["gpu"]["flag_pixels"], 0, "{c}");
    assert!(c["gpu"]["covered_pixels"].as_u64().unwrap() > 0, "{c}");

    let bad = dir.path().join("bad.tsr");
    for args in [
        vec!["gen", "terrain", "-o", bad.to_str().unwrap()],
        vec![
            "gen",
            "terrain",
            "-o",
            grid.to_str().unwrap(),
            "--regions",
            "MQ",
        ],
        vec![
            "gen",
            "terrain",
            "-o",
            grid.to_str().unwrap(),
            "--levels",
            "20",
        ],
        vec![
            "build",
            grid.to_str().unwrap(),
            "-o",
            bad.to_str().unwrap(),
            "--spacing",
            "0",
        ],
        vec![
            "build",
            grid.to_str().unwrap(),
            "-o",
            bad.to_str().unwrap(),
            "--exaggeration",
            "nan",
        ],
    ] {
        let out = tessera(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(!String::from_utf8_lossy(&out.stderr).is_empty());
        assert!(!bad.exists(), "{args:?} left an output");
    }
}

/// `bench terrain`: one JSON object with a row set per method (`roam`, `rustic` per cluster
/// size, `tessera`), each row at its budget, errors measured, and the three plots.
#[test]
fn bench_terrain_measures_roam_rustic_and_tessera() {
    let dem =
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../testdata/dem/volcano.json");
    assert!(dem.exists(), "run tools/fetch-testdata.sh first");
    let dir = tempfile::tempdir().unwrap();
    let plots = dir.path().join("plots");
    let out = tessera(&[
        "bench",
        "terrain",
        dem.to_str().unwrap(),
        "--budgets",
        "500,2000,1000000",
        "--cluster-sizes",
        "16,64",
        "--views",
        "2",
        "--frames",
        "2",
        "--size",
        "320x180",
        "--json",
        "--plot",
        plots.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = json(&out);
    let rows = |name: &str| {
        v[name]
            .as_array()
            .unwrap_or_else(|| panic!("no {name}: {v}"))
            .clone()
    };
    assert_eq!(
        rows("roam").len(),
        2,
        "the budget over the full grid is left out: {v}"
    );
    assert_eq!(rows("tessera").len(), 2);
    assert_eq!(rows("rustic").len(), 4, "two budgets × two cluster sizes");
    for name in ["roam", "rustic", "tessera"] {
        for r in rows(name) {
            let budget = r["budget"].as_f64().unwrap();
            let triangles = r["triangles"].as_f64().unwrap();
            // RUSTiC's counts move in whole clusters.
            let granularity = 8.0 * r["cluster_size"].as_f64().unwrap_or(0.0);
            assert!(
                (triangles - budget).abs() <= 0.35 * budget + granularity,
                "{name}: {r}"
            );
            let (max, mean) = (
                r["error_max_m"].as_f64().unwrap(),
                r["error_mean_m"].as_f64().unwrap(),
            );
            assert!(max >= mean && mean > 0.0, "{name}: {r}");
            for key in ["cpu_ms", "frame_ms"] {
                assert!(r[key].as_f64().unwrap() > 0.0, "{name}: {r}");
            }
        }
        let (coarse, fine) = (&rows(name)[0], &rows(name)[1]);
        assert!(
            fine["error_mean_m"].as_f64() < coarse["error_mean_m"].as_f64(),
            "{name}: more triangles, less error: {v}"
        );
    }
    for file in [
        "error_vs_triangles.png",
        "cpu_vs_triangles.png",
        "frame_time_vs_triangles.png",
    ] {
        assert!(plots.join(file).exists(), "{file}");
    }
    let out = tessera(&["bench", "terrain", dem.to_str().unwrap(), "--frames", "1"]);
    assert_eq!(out.status.code(), Some(2));
}

/// `build --no-compress` stores the patches as drawn, the default packs them (`info` says
/// which, and the per-level sizes), `repack` turns either into the other byte for byte, and
/// both draw the same pixels: the packed patches decode, on the loader thread and on upload,
/// to exactly the raw bytes.
#[test]
fn packed_and_raw_repositories_draw_the_same_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let packed = build_bunny(dir.path());
    let raw = dir.path().join("bunny-raw.tsr");
    let out = tessera(&[
        "build",
        bunny().to_str().unwrap(),
        "-o",
        raw.to_str().unwrap(),
        "--no-compress",
    ]);
    assert!(out.status.success());
    let mut infos = Vec::new();
    for (repo, codec) in [(&packed, "coded"), (&raw, "raw")] {
        let info = json(&tessera(&["info", repo.to_str().unwrap(), "--json"]));
        assert_eq!(info["patch_codec"], codec, "{info}");
        let levels = info["levels"].as_array().unwrap();
        let stored: u64 = levels
            .iter()
            .map(|l| l["stored_bytes"].as_u64().unwrap())
            .sum();
        assert_eq!(stored, info["patch_blob_bytes"].as_u64().unwrap(), "{info}");
        infos.push(info);
    }
    assert_eq!(
        infos[0]["patch_decoded_bytes"],
        infos[1]["patch_decoded_bytes"]
    );
    assert_eq!(
        infos[1]["patch_decoded_bytes"],
        infos[1]["patch_stored_bytes"]
    );
    assert!(infos[0]["repository_bytes"].as_u64() < infos[1]["repository_bytes"].as_u64());
    // `repack` turns one into the other, byte for byte, without a rebuild.
    for (from, to, flags) in [
        (&raw, &packed, vec![]),
        (&packed, &raw, vec!["--no-compress"]),
    ] {
        let out_path = dir.path().join("repacked.tsr");
        let mut args = vec![
            "repack",
            from.to_str().unwrap(),
            "-o",
            out_path.to_str().unwrap(),
        ];
        args.extend(flags);
        let out = tessera(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(std::fs::read(&out_path).unwrap() == std::fs::read(to).unwrap());
    }
    // A damaged source is refused (exit 2) and nothing is written.
    let mut damaged = std::fs::read(&raw).unwrap();
    let last_patch_byte = damaged.len() - infos[1]["id_blob_bytes"].as_u64().unwrap() as usize - 9;
    damaged[last_patch_byte] ^= 0x10;
    let damaged_path = dir.path().join("damaged.tsr");
    std::fs::write(&damaged_path, damaged).unwrap();
    let out_path = dir.path().join("never.tsr");
    let out = tessera(&[
        "repack",
        damaged_path.to_str().unwrap(),
        "-o",
        out_path.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("damaged") && !stderr.contains("panicked"),
        "{stderr}"
    );
    assert!(!out_path.exists());
    // Nor may the output be the input.
    let out = tessera(&["repack", raw.to_str().unwrap(), "-o", raw.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    // The whole-model upload (`render`) and the streaming one (`render --gpu-budget`).
    for budget in [None, Some("2")] {
        let mut images = Vec::new();
        for repo in [&packed, &raw] {
            let png = dir.path().join("frame.png");
            let mut args = vec![
                "render",
                repo.to_str().unwrap(),
                "-o",
                png.to_str().unwrap(),
                "--size",
                "200x150",
            ];
            if let Some(mib) = budget {
                args.extend(["--gpu-budget", mib]);
            }
            let out = tessera(&args);
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            images.push(std::fs::read(&png).unwrap());
        }
        assert!(
            images[0] == images[1],
            "budget {budget:?}: the pictures differ"
        );
    }
}
