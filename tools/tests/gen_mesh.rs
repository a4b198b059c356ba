//! `gen mesh` and `build -`: exact counts, the same bytes for the same parameters, constant
//! memory, a pipe into `build -` giving the repository a file gives, a crack-free build, and
//! exit 2 with a message for bad arguments.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn tessera(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(args)
        .output()
        .expect("run tessera")
}

fn ok(out: &Output) -> &Output {
    assert!(
        out.status.success(),
        "exit {:?}: {}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn json(bytes: &[u8]) -> serde_json::Value {
    serde_json::from_slice(bytes).unwrap_or_else(|e| {
        panic!(
            "not one JSON object ({e}): {}",
            String::from_utf8_lossy(bytes)
        )
    })
}

fn gen(out: &Path, triangles: &str, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["gen", "mesh", "--triangles", triangles, "-o"];
    args.push(out.to_str().unwrap());
    args.extend(extra);
    args.push("--json");
    json(&ok(&tessera(&args)).stdout)
}

/// `gen mesh ... -o -` into `tessera build - ...` (the mesh on standard input), with `--json`.
fn gen_piped_into_build(gen_args: &[&str], repo: &Path) -> (serde_json::Value, Vec<u8>) {
    let mut gen = Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(["gen", "mesh", "-o", "-", "--json"])
        .args(gen_args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let build = Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(["build", "-", "-o", repo.to_str().unwrap(), "--json"])
        .stdin(gen.stdout.take().unwrap())
        .output()
        .unwrap();
    let gen = gen.wait_with_output().unwrap();
    ok(&gen);
    (json(&ok(&build).stdout), gen.stderr)
}

#[test]
fn counts_are_exact_and_the_same_parameters_give_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, c) = (
        dir.path().join("a.ply"),
        dir.path().join("b.ply"),
        dir.path().join("c.ply"),
    );
    let ja = gen(&a, "20000", &["--seed", "5"]);
    assert_eq!(
        (ja["triangles"].as_u64(), ja["exact"].as_bool()),
        (Some(20_000), Some(true))
    );
    assert_eq!(ja["requested_triangles"], 20_000);
    let bytes = std::fs::read(&a).unwrap();
    assert_eq!(ja["bytes"], bytes.len() as u64);
    let v = ja["vertices"].as_u64().unwrap();
    assert_eq!(v, 10_002, "a closed genus-0 triangle mesh: V = F/2 + 2");
    assert!(ja["mb_per_s"].as_f64().unwrap() > 0.0 && ja["peak_rss_bytes"].as_u64().unwrap() > 0);
    gen(&b, "20000", &["--seed", "5"]);
    assert_eq!(bytes, std::fs::read(&b).unwrap(), "same seed, other bytes");
    gen(&c, "20000", &["--seed", "6"]);
    let other = std::fs::read(&c).unwrap();
    assert_eq!(bytes.len(), other.len());
    assert_ne!(bytes, other, "another seed, the same bytes");
    // An odd request gets one more triangle, and says so.
    let out = ok(&tessera(&[
        "gen",
        "mesh",
        "--triangles",
        "1001",
        "-o",
        c.to_str().unwrap(),
        "--json",
    ]))
    .clone();
    let j = json(&out.stdout);
    assert_eq!(
        (j["triangles"].as_u64(), j["exact"].as_bool()),
        (Some(1002), Some(false))
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("writing 1002"));
    // Standard output gets the same bytes as the file; the summary goes to stderr.
    let out = ok(&tessera(&[
        "gen",
        "mesh",
        "--triangles",
        "20000",
        "--seed",
        "5",
        "-o",
        "-",
    ]))
    .clone();
    assert_eq!(out.stdout, bytes);
    assert!(String::from_utf8_lossy(&out.stderr).contains("20000 triangles"));
}

/// The mesh piped into `build -` gives byte for byte the repository the same PLY gives from
/// a file; the build's JSON has the input's exact counts, peak memory and every stage.
#[test]
fn piped_into_build_equals_building_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let ply = dir.path().join("m.ply");
    let (from_file, from_pipe) = (dir.path().join("f.tsr"), dir.path().join("p.tsr"));
    let args = [
        "--triangles",
        "30000",
        "--shuffle-vertices",
        "--density-range",
        "50",
    ];
    let mut file_args = vec!["gen", "mesh", "-o", ply.to_str().unwrap()];
    file_args.extend(args);
    ok(&tessera(&file_args));
    let out = tessera(&[
        "build",
        ply.to_str().unwrap(),
        "-o",
        from_file.to_str().unwrap(),
        "--json",
    ]);
    let file_json = json(&ok(&out).stdout);
    let (pipe_json, gen_stderr) = gen_piped_into_build(&args, &from_pipe);
    let gen_json = json(&gen_stderr);
    assert_eq!(gen_json["output"], "standard output");
    assert_eq!(
        std::fs::read(&from_file).unwrap(),
        std::fs::read(&from_pipe).unwrap(),
        "the pipe built another repository"
    );
    for j in [&file_json, &pipe_json] {
        assert_eq!(j["input_triangles"], 30_000, "{j}");
        assert_eq!(j["input_vertices"], 15_002, "{j}");
        assert!(j["peak_rss_bytes"].as_u64().unwrap() > 1 << 20, "{j}");
        let stages: Vec<&str> = j["stages"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["stage"].as_str().unwrap())
            .collect();
        assert_eq!(
            stages,
            [
                "import",
                "hierarchy",
                "simplify",
                "saturate",
                "tables",
                "write"
            ],
            "{j}"
        );
    }
}

/// The writer holds blocks, not the mesh: 60 times the triangles, about the same peak memory
/// (the whole 3 M-triangle mesh would take 54 MB in memory).
#[test]
fn memory_does_not_grow_with_the_triangle_count() {
    let peak = |triangles: &str| {
        let out = Command::new(env!("CARGO_BIN_EXE_tessera"))
            .args(["gen", "mesh", "--triangles", triangles, "-o", "-", "--json"])
            .args(["--shuffle-vertices"])
            .stdout(Stdio::null())
            .output()
            .unwrap();
        json(&ok(&out).stderr)["peak_rss_bytes"].as_u64().unwrap()
    };
    let (small, large) = (peak("50000"), peak("3000000"));
    assert!(
        large < small + (8 << 20),
        "peak RSS {small} bytes for 50 K triangles, {large} for 3 M"
    );
}

/// A generated mesh (shuffled, uneven density) builds a repository whose cuts are crack-free.
#[test]
fn a_generated_mesh_builds_crack_free() {
    let dir = tempfile::tempdir().unwrap();
    let repo = dir.path().join("g.tsr");
    let args = [
        "--triangles",
        "60000",
        "--density-range",
        "100",
        "--shuffle-vertices",
    ];
    let (b, _) = gen_piped_into_build(&args, &repo);
    assert_eq!(b["input_triangles"], 60_000, "{b}");
    let out = tessera(&["check", repo.to_str().unwrap(), "--views", "4", "--json"]);
    let c = json(&ok(&out).stdout);
    assert_eq!(c["cracks"], 0, "{c}");
    assert_eq!(c["nonmanifold_introduced"], 0, "{c}");
    assert!(c["cuts_checked"].as_u64().unwrap() > 0, "{c}");
}

/// `--uv --colour`: texture coordinates with a chart a cube face, so the cube's edges are seams
/// (more wedges than vertices), and colours; it builds with both, `check` (and `check --gpu`,
/// a closed model) is clean, and the generator's memory still does not grow with the size.
#[test]
fn a_charted_coloured_mesh_has_seams_and_checks_clean() {
    let dir = tempfile::tempdir().unwrap();
    let ply = dir.path().join("uv.ply");
    let g = gen(&ply, "20000", &["--uv", "--colour", "--shuffle-vertices"]);
    assert_eq!(
        (g["uv"].as_bool(), g["colour"].as_bool()),
        (Some(true), Some(true))
    );
    let n = g["grid"].as_u64().unwrap();
    let mesh = tessera_preprocess::import::load_mesh(&ply).unwrap().mesh;
    let vertices = mesh.vertex_starts().vertex_count(mesh.positions.len());
    // A wedge a face at each point of the cube's edges: 12 (n - 1) points twice, 8 corners
    // thrice.
    assert_eq!(
        mesh.positions.len() - vertices,
        (12 * (n - 1) + 16) as usize
    );
    assert!(mesh.uvs.is_some() && mesh.colors.is_some());
    let repo = dir.path().join("uv.tsr");
    let repo = repo.to_str().unwrap();
    ok(&tessera(&["build", ply.to_str().unwrap(), "-o", repo]));
    let info = json(&ok(&tessera(&["info", repo, "--json"])).stdout);
    assert_eq!(info["attributes"]["uvs"], true, "{info}");
    assert_eq!(info["attributes"]["colors"], true, "{info}");
    let c = json(&ok(&tessera(&["check", repo, "--views", "8", "--json"])).stdout);
    assert_eq!(c["cracks"], 0, "{c}");
    let args = [
        "check", repo, "--gpu", "--views", "4", "--size", "320x180", "--json",
    ];
    let c = json(&ok(&tessera(&args)).stdout);
    assert_eq!(c["gpu"]["flag_pixels"], 0, "{c}");
    let peak = |triangles: &str| {
        let out = Command::new(env!("CARGO_BIN_EXE_tessera"))
            .args(["gen", "mesh", "--triangles", triangles, "-o", "-", "--json"])
            .args(["--uv", "--colour", "--shuffle-vertices"])
            .stdout(Stdio::null())
            .output()
            .unwrap();
        json(&ok(&out).stderr)["peak_rss_bytes"].as_u64().unwrap()
    };
    let (small, large) = (peak("50000"), peak("3000000"));
    assert!(
        large < small + (8 << 20),
        "peak RSS {small} bytes for 50 K triangles, {large} for 3 M"
    );
}

#[test]
fn bad_arguments_exit_two_with_a_message_and_leave_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("bad.ply");
    let out = out_path.to_str().unwrap();
    let missing_dir = dir.path().join("no/such/dir/m.ply");
    for (args, needle) in [
        (vec!["--triangles", "100", "-o", out], "at least 192"),
        (vec!["--triangles", "abc", "-o", out], "expected a count"),
        (vec!["--triangles", "-5", "-o", out], "--triangles"),
        (vec!["-o", out], "--triangles"),
        (vec!["--triangles", "5000000000", "-o", out], "4000000000"),
        (
            vec!["--triangles", "1000", "--density-range", "0.5", "-o", out],
            "--density-range",
        ),
        (
            vec!["--triangles", "1000", "--density-range", "nan", "-o", out],
            "--density-range",
        ),
        (
            vec!["--triangles", "1000", "-o", missing_dir.to_str().unwrap()],
            "cannot write",
        ),
    ] {
        let mut full = vec!["gen", "mesh"];
        full.extend(&args);
        let result = tessera(&full);
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
        assert!(!out_path.exists(), "{args:?} left a file");
    }
    // Garbage and a truncated mesh on standard input: exit 2, named, no repository, and under
    // a budget no checkpoint left (a resume would fail alike).
    let repo = dir.path().join("r.tsr");
    let checkpoint = dir.path().join(".r.tsr.tessera-build");
    let mut ply = Vec::new();
    let mesh = dir.path().join("m.ply");
    gen(&mesh, "1000", &[]);
    ply.extend(std::fs::read(&mesh).unwrap());
    ply.truncate(ply.len() - 5);
    let budgets: [&[&str]; 2] = [&[], &["--memory", "64M"]];
    for (input, budget) in [b"not a mesh\n".to_vec(), ply]
        .into_iter()
        .flat_map(|input| budgets.map(|b| (input.clone(), b)))
    {
        let mut build = Command::new(env!("CARGO_BIN_EXE_tessera"))
            .args(["build", "-", "-o", repo.to_str().unwrap()])
            .args(budget)
            .stdin(Stdio::piped())
            .stderr(Stdio::piped())
            .stdout(Stdio::null())
            .spawn()
            .unwrap();
        build.stdin.take().unwrap().write_all(&input).unwrap();
        let result = build.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains("standard input: "), "{stderr}");
        assert!(!repo.exists());
        assert!(!checkpoint.exists(), "{budget:?} left its checkpoint");
    }
}
