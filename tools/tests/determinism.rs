//! The same input and flags give a byte-identical repository whatever the thread count and
//! with or without `--memory` (issue 12, "Determinism"): a mesh and a height field, 1, 2 and 7
//! threads; a generated 2 M-triangle mesh with shuffled vertices and 1000× varying density, a
//! scan and a height field with `--memory 64M` and a budget small enough that every
//! out-of-core stage spills; the same with `--bounded-errors`.

use std::path::Path;
use std::process::Command;

fn testdata(relative: &str) -> std::path::PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata")
        .join(relative);
    assert!(
        path.exists(),
        "{} is missing: run tools/fetch-testdata.sh first (README.md, 'Tests')",
        path.display()
    );
    path
}

fn build(input: &Path, output: &Path, threads: usize) -> Vec<u8> {
    build_with(input, output, &["--threads", &threads.to_string()])
}

fn build_with(input: &Path, output: &Path, flags: &[&str]) -> Vec<u8> {
    let (input, output) = (input.to_str().unwrap(), output.to_str().unwrap());
    tessera(&[&["build", input, "-o", output], flags].concat());
    std::fs::read(output).unwrap()
}

/// Runs `tessera ARGS`, which must succeed; returns its standard output.
fn tessera(args: &[&str]) -> Vec<u8> {
    let out = Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(args)
        .output()
        .expect("run tessera");
    assert!(
        out.status.success(),
        "tessera {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

/// `tessera build INPUT -o OUTPUT FLAGS --json`'s summary.
fn build_json(input: &Path, output: &Path, flags: &[&str]) -> serde_json::Value {
    let (input, output) = (input.to_str().unwrap(), output.to_str().unwrap());
    let stdout = tessera(&[&["build", input, "-o", output], flags, &["--json"]].concat());
    serde_json::from_slice(&stdout).unwrap()
}

/// `gen mesh --triangles 2000000 --shuffle-vertices FLAGS` into `dir/g2m.ply`.
fn generate_2m(dir: &Path, flags: &[&str]) -> std::path::PathBuf {
    let generated = dir.join("g2m.ply");
    let base = [
        "gen",
        "mesh",
        "--triangles",
        "2000000",
        "--shuffle-vertices",
    ];
    let out = ["-o", generated.to_str().unwrap()];
    tessera(&[&base[..], flags, &out[..]].concat());
    generated
}

#[test]
fn thread_count_does_not_change_a_byte() {
    let dir = tempfile::tempdir().unwrap();
    for input in [
        "mesh/dragon_vrip_res2.ply.gz",
        "dem/jacksboro_fault_dem.npz",
    ] {
        let input = testdata(input);
        let reference = build(&input, &dir.path().join("t1.tsr"), 1);
        for threads in [2, 7] {
            let other = build(&input, &dir.path().join(format!("t{threads}.tsr")), threads);
            assert!(
                other == reference,
                "{}: {threads} threads wrote other bytes than 1 thread",
                input.display()
            );
        }
    }
}

#[test]
fn a_memory_budget_does_not_change_a_byte() {
    let dir = tempfile::tempdir().unwrap();
    let generated = generate_2m(dir.path(), &["--density-range", "1000"]);
    let temp = dir.path().join("temp");
    std::fs::create_dir(&temp).unwrap();
    // A terrain as `.npy`: under a budget its rows are read and meshed one at a time
    // (`dem::stage_dem_by_rows`), the grid never held.
    let terrain = dir.path().join("t7.npy");
    tessera(&[
        "gen",
        "terrain",
        "--levels",
        "7",
        "-o",
        terrain.to_str().unwrap(),
    ]);
    let cases: [(std::path::PathBuf, &[&str]); 5] = [
        (generated, &["64M"]),
        (terrain, &["1M"]),
        (testdata("mesh/dragon_vrip_res2.ply.gz"), &["1M"]),
        // 1G: the weld in memory, the barycentres indexed, two allocator arenas.
        (testdata("mesh/bunny00.off"), &["1M", "1G"]),
        (testdata("dem/jacksboro_fault_dem.npz"), &["1M"]),
    ];
    for (input, budgets) in cases {
        let reference = build_with(&input, &dir.path().join("unlimited.tsr"), &[]);
        for budget in budgets {
            let flags = ["--memory", budget, "--temp", temp.to_str().unwrap()];
            let limited = build_with(&input, &dir.path().join("limited.tsr"), &flags);
            assert!(
                limited == reference,
                "{}: --memory {budget} wrote other bytes",
                input.display()
            );
            assert_eq!(
                std::fs::read_dir(&temp).unwrap().count(),
                0,
                "temporary files left in --temp"
            );
        }
    }
}

#[test]
fn bounded_errors_depend_neither_on_threads_nor_on_a_memory_budget() {
    let dir = tempfile::tempdir().unwrap();
    let temp = dir.path().join("temp");
    std::fs::create_dir(&temp).unwrap();
    for input in ["mesh/bunny00.off", "dem/jacksboro_fault_dem.npz"] {
        let input = testdata(input);
        let bounded = |name: &str, flags: &[&str]| {
            let flags = [&["--bounded-errors"], flags].concat();
            build_with(&input, &dir.path().join(name), &flags)
        };
        let reference = bounded("one.tsr", &["--threads", "1"]);
        let estimated = build_with(&input, &dir.path().join("estimated.tsr"), &[]);
        assert!(reference != estimated, "--bounded-errors changed nothing");
        let threads = bounded("two.tsr", &["--threads", "2"]);
        assert!(
            threads == reference,
            "{}: 2 threads differ",
            input.display()
        );
        let budget = ["--memory", "1M", "--temp", temp.to_str().unwrap()];
        let limited = bounded("limited.tsr", &budget);
        assert!(
            limited == reference,
            "{}: --memory 1M differs",
            input.display()
        );
    }
}

/// A mesh with every attribute and detail below f32 resolution, written as an ASCII PLY of
/// doubles: under `--memory` it is built from the staged files without being loaded (the
/// leaves' vertex tables and the simplifier's separated f32 positions come from joins,
/// `external/joins.rs`), and must give the bytes of the in-memory build.
fn attributed_ply_with_sub_f32_detail(path: &Path) {
    use std::fmt::Write as _;
    let n = 48usize; // grid vertices per side
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
            vertices.push([x, y, 0.1 * (7.0 * x).sin() * (5.0 * y).cos()]);
        }
    }
    let mut triangles: Vec<[usize; 3]> = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let v = j * n + i;
            triangles.push([v, v + 1, v + n + 1]);
            triangles.push([v, v + n + 1, v + n]);
        }
    }
    // Twenty vertices a few f64 ulps apart near the middle: one f32 position, distinct ids.
    let anchor = (n / 2) * n + n / 2;
    let first = vertices.len();
    for k in 0..20 {
        let [x, y, z] = vertices[anchor];
        vertices.push([x + 0.3 / n as f64 + k as f64 * 1e-13, y + 0.2 / n as f64, z]);
    }
    for k in 0..19 {
        triangles.push([first + k, first + k + 1, anchor]);
    }
    let mut text = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\n\
         property double z\nproperty float nx\nproperty float ny\nproperty float nz\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n\
         property float u\nproperty float v\nelement face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        vertices.len(),
        triangles.len()
    );
    for (i, p) in vertices.iter().enumerate() {
        let (a, b) = ((i % 7) as f32 * 0.1, (i % 5) as f32 * 0.2);
        writeln!(
            text,
            "{:.17e} {:.17e} {:.17e} {a} {b} 1 {} {} {} 255 {} {}",
            p[0],
            p[1],
            p[2],
            i % 256,
            (i * 7) % 256,
            (i * 13) % 256,
            p[0] as f32,
            p[1] as f32
        )
        .unwrap();
    }
    for t in &triangles {
        writeln!(text, "3 {} {} {}", t[0], t[1], t[2]).unwrap();
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn a_staged_mesh_with_attributes_and_sub_f32_detail_gives_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("attributed.ply");
    attributed_ply_with_sub_f32_detail(&input);
    let small_leaves = ["--leaf-triangles", "64"];
    let reference = build_with(&input, &dir.path().join("unlimited.tsr"), &small_leaves);
    let limited = build_with(
        &input,
        &dir.path().join("limited.tsr"),
        &[&small_leaves[..], &["--memory", "1M"]].concat(),
    );
    assert!(limited == reference, "--memory 1M wrote other bytes");
    let info = Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args([
            "info",
            dir.path().join("limited.tsr").to_str().unwrap(),
            "--json",
        ])
        .output()
        .unwrap();
    let info = String::from_utf8_lossy(&info.stdout);
    for attribute in ["\"colors\":true", "\"normals\":true", "\"uvs\":true"] {
        assert!(info.contains(attribute), "{attribute} missing: {info}");
    }
}

/// `--memory` is a bound on resident memory (issue 12: "Peak RSS (VmHWM) stays under SIZE"),
/// checked at the scale CI affords: 2 M triangles with shuffled vertices in 64 MiB, the whole
/// run's peak (`peak_rss_bytes`: VmHWM) within it. Without `--stage-peaks` the kernel's peak is
/// never reset (so `/usr/bin/time` sees the true peak too): each stage's figure is the peak so
/// far, never falling.
///
/// Run twice: the default build, which computes the vertex normals the generated mesh lacks,
/// and the geometry alone (`--no-computed-normals`), which issue 12's bound on temporary disk
/// is about (the normals are data the input does not hold: the repository itself grows by
/// 1.38×, and so do the live patches and finished patches on disk).
#[test]
fn a_2m_triangle_build_stays_within_64_mib() {
    let dir = tempfile::tempdir().unwrap();
    let generated = generate_2m(dir.path(), &[]);
    // 1.95× measured with the normals on 2026-12-07.
    for (flags, temp_bound) in [(&[][..], 2.1), (&["--no-computed-normals"][..], 1.45)] {
        let mut args = vec!["--memory", "64M"];
        args.extend(flags);
        let json = build_json(&generated, &dir.path().join("g2m.tsr"), &args);
        check_2m_budgets(&generated, &json, temp_bound);
    }
}

/// [`a_2m_triangle_build_stays_within_64_mib`]'s checks of one build's `json`: resident memory
/// within 64 MiB, the stages' figures consistent, temporary files within `temp_bound` × the
/// input.
fn check_2m_budgets(generated: &Path, json: &serde_json::Value, temp_bound: f64) {
    let budget = 64u64 << 20;
    let peak = json["peak_rss_bytes"]
        .as_u64()
        .expect("Linux reports VmHWM");
    assert!(
        peak <= budget,
        "the build peaked at {:.1} MiB, over --memory 64M: {json}",
        peak as f64 / (1 << 20) as f64
    );
    assert_eq!(json["stage_peaks_are_per_stage"], false, "{json}");
    let per_stage = |key: &str| -> Vec<u64> {
        let stages = json["stages"].as_array().unwrap();
        stages.iter().map(|s| s[key].as_u64().unwrap()).collect()
    };
    let stages = per_stage("peak_rss_bytes");
    assert!(stages.windows(2).all(|w| w[0] <= w[1]), "{json}");
    assert!(stages.last().is_some_and(|&last| last <= peak), "{json}");
    // Temporary disk: issue 12 asks for at most 1.5× the input. The build reached 1.39× here
    // with 147046b on 2026-12-05 and 1.372× with b09c978 on 2026-12-06 (BENCHMARKS.md,
    // "Temporary disk"; the hierarchy's buckets beside the staged mesh); on 2026-12-04 it was
    // 1.52× with 6bfa11d, 2.46× with e5233a6, 2.68× with 63da3b5, 3.31× with 58fd7a6 and 6.7×
    // with 766c6f2; the pin leaves a little room under the bound, so that a change
    // that puts more on disk fails here.
    let input = std::fs::metadata(generated).unwrap().len();
    let temp = json["temp_bytes_peak"].as_u64().unwrap();
    assert!(
        temp as f64 <= temp_bound * input as f64,
        "temporary files peaked at {temp} bytes, {:.2}× the {input}-byte input: {json}",
        temp as f64 / input as f64
    );
    // Where the peak is: the largest stage peak is the run's, and the kinds of file held at
    // each peak add up to it (up to what other threads wrote while it was taken).
    let stage_temp = per_stage("temp_bytes_peak");
    assert_eq!(stage_temp.iter().max(), Some(&temp), "{json}");
    let parts = |v: &serde_json::Value| -> u64 {
        v.as_object()
            .unwrap()
            .values()
            .map(|b| b.as_u64().unwrap())
            .sum()
    };
    let near = |sum: u64, peak: u64| sum.abs_diff(peak) <= 8 << 20;
    assert!(near(parts(&json["temp_bytes_at_peak"]), temp), "{json}");
    for stage in json["stages"].as_array().unwrap() {
        let peak = stage["temp_bytes_peak"].as_u64().unwrap();
        assert!(near(parts(&stage["temp_bytes_at_peak"]), peak), "{json}");
    }
}

/// `build --stage-peaks` resets the kernel's peak at each stage where the system allows it
/// (as this test's own process finds), so each stage's figure is its own; the run's peak is
/// still the largest of them.
#[test]
fn stage_peaks_are_per_stage_only_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let json = build_json(
        &testdata("mesh/bunny00.off"),
        &dir.path().join("bunny.tsr"),
        &["--stage-peaks"],
    );
    let resettable = std::fs::write("/proc/self/clear_refs", "5").is_ok();
    assert_eq!(json["stage_peaks_are_per_stage"], resettable, "{json}");
    let peak = json["peak_rss_bytes"].as_u64().unwrap();
    for stage in json["stages"].as_array().unwrap() {
        assert!(stage["peak_rss_bytes"].as_u64().unwrap() <= peak, "{json}");
    }
}
