//! `build --resume` (issue 12, "resumable, crash-safe"): a build killed (SIGKILL) after each stage
//! boundary or mid-stage leaves nothing at the output path, and `--resume` then gives the bytes
//! of an uninterrupted build, whatever the thread count; a checkpoint of another build is
//! refused, naming the difference; a damaged one is refused; without `--resume` a leftover
//! checkpoint is removed and the build starts over.

use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const TESSERA: &str = env!("CARGO_BIN_EXE_tessera");

/// Runs `tessera ARGS` with the environment `env`.
fn run(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut command = Command::new(TESSERA);
    command.args(args).envs(env.iter().copied());
    command.output().expect("run tessera")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The run was refused: exit 2, its message naming `needle`.
fn assert_refused(out: &Output, needle: &str) {
    assert_eq!(out.status.code(), Some(2), "{}", stderr(out));
    assert!(stderr(out).contains(needle), "{}", stderr(out));
}

/// A generated mesh of `triangles` triangles in `dir`, its vertices shuffled.
fn generate(dir: &Path, triangles: u32) -> PathBuf {
    let path = dir.join("mesh.ply");
    let n = triangles.to_string();
    let out = run(
        &[
            "gen",
            "mesh",
            "--triangles",
            &n,
            "--shuffle-vertices",
            "-o",
            path.to_str().unwrap(),
        ],
        &[],
    );
    assert!(out.status.success(), "gen mesh: {}", stderr(&out));
    path
}

/// `build INPUT -o OUTPUT` and `extra` (with `--memory 64M` unless `extra` gives a budget).
fn build(input: &Path, output: &Path, extra: &[&str], env: &[(&str, &str)]) -> Output {
    let (i, o) = (input.to_str().unwrap(), output.to_str().unwrap());
    let budget: &[&str] = if extra.contains(&"--memory") {
        &[]
    } else {
        &["--memory", "64M"]
    };
    run(&[&["build", i, "-o", o], budget, extra].concat(), env)
}

/// The uninterrupted build's bytes.
fn reference(input: &Path, dir: &Path) -> Vec<u8> {
    let output = dir.join("reference.tsr");
    let out = build(input, &output, &["--threads", "2"], &[]);
    assert!(out.status.success(), "reference build: {}", stderr(&out));
    std::fs::read(output).unwrap()
}

fn checkpoint_of(output: &Path) -> PathBuf {
    let name = output.file_name().unwrap().to_str().unwrap();
    output.with_file_name(format!(".{name}.tessera-build"))
}

/// A build stopped by SIGKILL once stage `stage` is committed: nothing at the output, a
/// checkpoint beside it.
fn kill_after(input: &Path, output: &Path, stage: &str) {
    let _ = std::fs::remove_file(output);
    let fault = format!("kill-after-stage:{stage}");
    let out = build(
        input,
        output,
        &["--threads", "2"],
        &[
            ("TESSERA_BUILD_FAULT", &fault),
            ("TESSERA_CHECKPOINT_EVERY_LEVEL", "1"),
        ],
    );
    assert_eq!(
        out.status.signal(),
        Some(9),
        "the build was not killed after {stage}: {:?} {}",
        out.status,
        stderr(&out)
    );
    assert!(!output.exists(), "a killed build left {}", output.display());
    assert!(checkpoint_of(output).join("manifest.json").exists());
}

/// `--resume` gives `expected` and removes the checkpoint.
fn resume_to(input: &Path, output: &Path, threads: &str, expected: &[u8], after: &str) {
    let out = build(input, output, &["--resume", "--threads", threads], &[]);
    assert!(
        out.status.success(),
        "resume after {after}: {}",
        stderr(&out)
    );
    assert!(
        stderr(&out).contains("resuming from"),
        "did not resume: {}",
        stderr(&out)
    );
    // From the stage the build was killed after (a part of a level included).
    if after.starts_with("level-") {
        assert!(
            stderr(&out).contains(&format!("last stage: {after})")),
            "did not resume from {after}: {}",
            stderr(&out)
        );
    }
    assert!(
        std::fs::read(output).unwrap() == expected,
        "resumed after {after}: other bytes than the uninterrupted build"
    );
    assert!(
        !checkpoint_of(output).exists(),
        "the checkpoint outlived the build"
    );
}

#[test]
fn a_build_killed_after_each_stage_resumes_to_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let input = generate(dir.path(), 150_000);
    let expected = reference(&input, dir.path());
    let output = dir.path().join("out.tsr");
    let stages = [
        ("staged", "1"),
        ("hierarchy", "3"),
        ("leaves", "3"),
        // Inside the first level: the leaves' patches finished again on resume.
        ("level-0.part-1", "2"),
        ("level-2", "1"),
        // Inside level 4: two parts of its diamonds' results saved, the rest not yet made.
        ("level-3.part-2", "3"),
        // Level 4 merging: its parts dropped from the checkpoint, the level made again.
        ("level-3.merging", "1"),
        ("level-5", "2"),
    ];
    for (stage, threads) in stages {
        kill_after(&input, &output, stage);
        resume_to(&input, &output, threads, &expected, stage);
    }
}

#[test]
fn a_real_kill_9_mid_build_resumes_to_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let input = generate(dir.path(), 400_000);
    let expected = reference(&input, dir.path());
    let output = dir.path().join("out.tsr");
    let (i, o) = (input.to_str().unwrap(), output.to_str().unwrap());
    let mut child = Command::new(TESSERA)
        .args(["build", i, "-o", o, "--memory", "64M", "--threads", "2"])
        .env("TESSERA_CHECKPOINT_EVERY_LEVEL", "1")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Kill -9 once the simplification's first level is checkpointed (a level's stage, not a
    // part of one: merges have appended to the live store since), mid-level.
    let manifest = checkpoint_of(&output).join("manifest.json");
    let start = Instant::now();
    loop {
        let text = std::fs::read_to_string(&manifest).unwrap_or_default();
        let last = serde_json::from_str::<serde_json::Value>(&text)
            .ok()
            .and_then(|m| {
                m["stages"].as_array()?.last()?["name"]
                    .as_str()
                    .map(String::from)
            })
            .unwrap_or_default();
        if last.starts_with("level-") && !last.contains(".part-") {
            break;
        }
        assert!(child.try_wait().unwrap().is_none(), "the build ended first");
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no level checkpoint"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.signal(), Some(9));
    assert!(!output.exists(), "a killed build left {}", output.display());
    resume_to(&input, &output, "1", &expected, "a kill -9 mid-level");
}

#[test]
fn a_checkpoint_of_another_build_or_a_damaged_one_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let input = generate(dir.path(), 100_000);
    let expected = reference(&input, dir.path());
    let output = dir.path().join("out.tsr");
    kill_after(&input, &output, "leaves");
    // Other flags: refused, naming the flag; nothing written, the checkpoint kept.
    let out = build(
        &input,
        &output,
        &["--resume", "--leaf-triangles", "512"],
        &[],
    );
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("flag construction")
            && stderr(&out).contains("was made by another build"),
        "{}",
        stderr(&out)
    );
    assert!(!output.exists());
    assert!(checkpoint_of(&output).join("manifest.json").exists());
    // Another input at the same path: refused, naming what differs.
    let other = dir.path().join("other.ply");
    std::fs::copy(&input, &other).unwrap();
    let out = build(&other, &output, &["--resume"], &[]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("input path"), "{}", stderr(&out));
    assert!(!output.exists());
    // Made by another tessera: refused.
    let manifest = checkpoint_of(&output).join("manifest.json");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let other_version = text.replace("\"tessera_version\": \"", "\"tessera_version\": \"0.0.1 ");
    assert_ne!(other_version, text);
    std::fs::write(&manifest, other_version).unwrap();
    let out = build(&input, &output, &["--resume"], &[]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("tessera version"), "{}", stderr(&out));
    std::fs::write(&manifest, text).unwrap();
    // A damaged file of the last stage: refused.
    let hierarchy = checkpoint_of(&output).join("hierarchy.bin");
    let mut bytes = std::fs::read(&hierarchy).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&hierarchy, bytes).unwrap();
    let out = build(&input, &output, &["--resume"], &[]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("is damaged"), "{}", stderr(&out));
    assert!(!stderr(&out).contains("panicked"), "{}", stderr(&out));
    assert!(!output.exists());
    // Without --resume: the checkpoint is removed, said so, and the build starts over.
    let out = build(&input, &output, &[], &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("removed the checkpoint"),
        "{}",
        stderr(&out)
    );
    assert!(std::fs::read(&output).unwrap() == expected);
    assert!(!checkpoint_of(&output).exists());
}

/// The name of the last stage the checkpoint of `output` committed.
fn last_stage(output: &Path) -> String {
    let text = std::fs::read_to_string(checkpoint_of(output).join("manifest.json")).unwrap();
    let manifest: serde_json::Value = serde_json::from_str(&text).unwrap();
    let stages = manifest["stages"].as_array().unwrap();
    stages.last().unwrap()["name"].as_str().unwrap().to_string()
}

#[test]
fn a_build_run_as_several_processes_with_stop_after_gives_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let input = generate(dir.path(), 150_000);
    let expected = reference(&input, dir.path());
    let output = dir.path().join("out.tsr");
    let every_level = [("TESSERA_CHECKPOINT_EVERY_LEVEL", "1")];
    // One process a stage or more: each ends once its stage is committed, exit 0, nothing at
    // the output, the checkpoint's last stage the one asked for.
    for (i, stage) in ["staged", "hierarchy", "level-3"].into_iter().enumerate() {
        let resume: &[&str] = if i == 0 { &[] } else { &["--resume"] };
        let out = build(
            &input,
            &output,
            &[resume, &["--stop-after", stage, "--json"]].concat(),
            &every_level,
        );
        assert!(out.status.success(), "{stage}: {}", stderr(&out));
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(json["stopped_after"], stage, "{json}");
        assert!(
            !output.exists(),
            "a stopped build wrote {}",
            output.display()
        );
        assert_eq!(last_stage(&output), stage);
    }
    // A stage the build has passed or never reaches lets it finish.
    resume_to(&input, &output, "2", &expected, "level-3");
    let out = build(&input, &output, &["--stop-after", "level-99"], &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(std::fs::read(&output).unwrap() == expected);
    // A stage that does not exist, or a build with no checkpoint: refused, exit 2.
    for (args, needle) in [
        (
            &["--stop-after", "level-0"][..],
            "a stage is staged, hierarchy",
        ),
        (
            &["--stop-after", "tables"][..],
            "a stage is staged, hierarchy",
        ),
    ] {
        assert_refused(&build(&input, &output, args, &[]), needle);
    }
    let (i, o) = (input.to_str().unwrap(), output.to_str().unwrap());
    let out = run(&["build", i, "-o", o, "--stop-after", "leaves"], &[]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("--memory"), "{}", stderr(&out));
    // A height field keeps no checkpoint: refused, nothing written.
    let grid = dir.path().join("grid.json");
    std::fs::write(
        &grid,
        r#"{"width": 3, "height": 3, "values": [0,1,2,1,2,3,2,3,4]}"#,
    )
    .unwrap();
    let _ = std::fs::remove_file(&output);
    let out = build(&grid, &output, &["--stop-after", "hierarchy"], &[]);
    assert_refused(&out, "--stop-after needs a build that keeps a checkpoint");
    assert!(!output.exists());
}

/// `build - -o OUTPUT --memory 64M` and `extra`, `input` piped into its standard input.
fn build_from_stdin(input: &Path, output: &Path, extra: &[&str], env: &[(&str, &str)]) -> Output {
    Command::new(TESSERA)
        .args(
            [
                &[
                    "build",
                    "-",
                    "-o",
                    output.to_str().unwrap(),
                    "--memory",
                    "64M",
                ],
                extra,
            ]
            .concat(),
        )
        .envs(env.iter().copied())
        .stdin(std::fs::File::open(input).unwrap())
        .output()
        .unwrap()
}

#[test]
fn a_build_from_standard_input_resumes_when_the_same_stream_is_piped_again() {
    let dir = tempfile::tempdir().unwrap();
    let input = generate(dir.path(), 100_000);
    let expected = reference(&input, dir.path());
    let output = dir.path().join("out.tsr");
    for stage in ["staged", "hierarchy", "level-3"] {
        let _ = std::fs::remove_file(&output);
        let fault = format!("kill-after-stage:{stage}");
        let out = build_from_stdin(
            &input,
            &output,
            &[],
            &[
                ("TESSERA_BUILD_FAULT", &fault),
                ("TESSERA_CHECKPOINT_EVERY_LEVEL", "1"),
            ],
        );
        assert_eq!(out.status.signal(), Some(9), "{stage}: {}", stderr(&out));
        assert!(!output.exists(), "a killed build left {}", output.display());
        let out = build_from_stdin(&input, &output, &["--resume"], &[]);
        assert!(
            out.status.success(),
            "resume after {stage}: {}",
            stderr(&out)
        );
        assert!(stderr(&out).contains("resuming from"), "{}", stderr(&out));
        assert!(
            std::fs::read(&output).unwrap() == expected,
            "resumed from standard input after {stage}: other bytes than the file's build"
        );
        assert!(!checkpoint_of(&output).exists());
    }
    // Another stream: refused, naming the difference; nothing written, the checkpoint kept,
    // and the same stream then resumes.
    let _ = std::fs::remove_file(&output);
    let out = build_from_stdin(
        &input,
        &output,
        &[],
        &[("TESSERA_BUILD_FAULT", "kill-after-stage:leaves")],
    );
    assert_eq!(out.status.signal(), Some(9), "{}", stderr(&out));
    let bytes = std::fs::read(&input).unwrap();
    let other = dir.path().join("other.ply");
    let mut changed = bytes.clone();
    let last = changed.len() - 1;
    changed[last] ^= 1; // the same size, one bit of the last face's index differs
    std::fs::write(&other, changed).unwrap();
    let out = build_from_stdin(&other, &output, &["--resume"], &[]);
    assert_refused(&out, "input contents (CRC-32 of every byte)");
    assert!(!output.exists());
    assert!(checkpoint_of(&output).join("manifest.json").exists());
    let out = build_from_stdin(&input, &output, &["--resume"], &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(std::fs::read(&output).unwrap() == expected);
}

#[test]
fn resume_needs_a_memory_budget() {
    let dir = tempfile::tempdir().unwrap();
    let input = generate(dir.path(), 2_000);
    let output = dir.path().join("out.tsr");
    let (i, o) = (input.to_str().unwrap(), output.to_str().unwrap());
    let out = run(&["build", i, "-o", o, "--resume"], &[]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("--resume continues a build made with --memory"),
        "{}",
        stderr(&out)
    );
    // A build that fails on its input removes its checkpoint (a resume would fail alike).
    let broken = dir.path().join("broken.ply");
    let bytes = std::fs::read(&input).unwrap();
    std::fs::write(&broken, &bytes[..bytes.len() - 100]).unwrap();
    let out = build(&broken, &output, &[], &[]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(!output.exists() && !checkpoint_of(&output).exists());
    // --resume with no checkpoint builds from the start.
    let out = build(&input, &output, &["--resume"], &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("building from the start"),
        "{}",
        stderr(&out)
    );
    assert!(output.exists() && !checkpoint_of(&output).exists());
}

/// A grid with normals, colours and uvs (every attribute the staged mesh and the live patches
/// carry), as an ASCII PLY.
fn attributed_grid(path: &Path) {
    use std::fmt::Write as _;
    let n = 90usize;
    let mut text = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n\
         property float u\nproperty float v\nelement face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        n * n,
        2 * (n - 1) * (n - 1)
    );
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
            let z = 0.1 * (7.0 * x).sin() * (5.0 * y).cos();
            let (r, g) = ((i * 3) % 256, (j * 5) % 256);
            writeln!(
                text,
                "{x} {y} {z} {} {} 1 {r} {g} 7 255 {x} {y}",
                x - 0.5,
                y - 0.5
            )
            .unwrap();
        }
    }
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let v = j * n + i;
            writeln!(
                text,
                "3 {} {} {}\n3 {} {} {}",
                v,
                v + 1,
                v + n + 1,
                v,
                v + n + 1,
                v + n
            )
            .unwrap();
        }
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn a_mesh_with_every_attribute_resumes_to_the_same_bytes_under_another_budget() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("attributed.ply");
    attributed_grid(&input);
    let small = ["--leaf-triangles", "64"];
    let reference = dir.path().join("reference.tsr");
    let out = build(&input, &reference, &small, &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    let expected = std::fs::read(reference).unwrap();
    let output = dir.path().join("out.tsr");
    // The budget changes no byte: a resume may have another.
    let stages = [
        ("staged", "64M"),
        ("hierarchy", "16M"),
        ("leaves", "64M"),
        ("level-3", "16M"),
    ];
    for (stage, budget) in stages {
        let _ = std::fs::remove_file(&output);
        let fault = format!("kill-after-stage:{stage}");
        let env = [
            ("TESSERA_BUILD_FAULT", fault.as_str()),
            ("TESSERA_CHECKPOINT_EVERY_LEVEL", "1"),
        ];
        let out = build(&input, &output, &small, &env);
        assert_eq!(out.status.signal(), Some(9), "{stage}: {}", stderr(&out));
        assert!(!output.exists());
        let resume = [&small[..], &["--resume", "--memory", budget]].concat();
        let out = build(&input, &output, &resume, &[]);
        assert!(out.status.success(), "{stage}: {}", stderr(&out));
        assert!(
            std::fs::read(&output).unwrap() == expected,
            "resumed after {stage}: other bytes"
        );
    }
}

#[test]
fn a_second_build_of_the_same_output_is_refused_while_the_first_runs() {
    let dir = tempfile::tempdir().unwrap();
    let input = generate(dir.path(), 300_000);
    let output = dir.path().join("out.tsr");
    let (i, o) = (input.to_str().unwrap(), output.to_str().unwrap());
    let mut first = Command::new(TESSERA)
        .args(["build", i, "-o", o, "--memory", "64M"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let manifest = checkpoint_of(&output).join("manifest.json");
    let start = Instant::now();
    while !manifest.exists() {
        assert!(first.try_wait().unwrap().is_none(), "the build ended first");
        assert!(start.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(2));
    }
    // (The lock is taken just after the manifest is first written.)
    std::thread::sleep(Duration::from_millis(50));
    for extra in [&[][..], &["--resume"][..]] {
        let out = build(&input, &output, extra, &[]);
        assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
        assert!(
            stderr(&out).contains("another build of"),
            "{}",
            stderr(&out)
        );
    }
    assert!(first.wait().unwrap().success(), "the first build failed");
    assert!(output.exists() && !checkpoint_of(&output).exists());
}
