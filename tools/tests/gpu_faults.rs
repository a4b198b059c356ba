//! Device faults end every GPU command with a clear message and exit code 3, never a panic or
//! a hang (issue 11, item 5). The faults are injected through `TESSERA_GPU_FAULT`
//! (`runtime/src/gpu/device.rs`): `lost@N` destroys the device after the Nth submitted frame,
//! `oom@N` hands the device's error handler wgpu's out-of-memory error, `readback@N` destroys
//! the buffer of the first read-back after the Nth frame so its `map_async` fails. Limits:
//! a `--size` beyond the adapter's `max_texture_dimension_2d` is refused naming it (exit 2).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// Runs `tessera` with `TESSERA_GPU_FAULT=fault` (none when empty).
fn tessera(fault: &str, args: &[&str]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_tessera"));
    command.args(args);
    if fault.is_empty() {
        command.env_remove("TESSERA_GPU_FAULT");
    } else {
        command.env("TESSERA_GPU_FAULT", fault);
    }
    command.output().expect("run tessera")
}

fn build_bunny(dir: &Path) -> PathBuf {
    let bunny = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/bunny00.off");
    let repo = dir.join("bunny.tsr");
    let out = tessera(
        "",
        &[
            "build",
            bunny.to_str().unwrap(),
            "-o",
            repo.to_str().unwrap(),
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    repo
}

/// Every GPU command under every fault: exit 3, the failure named on stderr, no panic, within
/// a minute.
#[test]
fn device_lost_out_of_memory_and_failed_read_back_exit_three() {
    let dir = tempfile::tempdir().unwrap();
    let repo = build_bunny(dir.path());
    let repo = repo.to_str().unwrap();
    let png = dir.path().join("frame.png");
    let png = png.to_str().unwrap();
    let size = ["--size", "320x200"];
    let commands: Vec<(&str, Vec<&str>)> = vec![
        (
            "render (streaming)",
            [&["render", repo, "-o", png, "--gpu-budget", "8"][..], &size].concat(),
        ),
        (
            "check --gpu (resident)",
            [&["check", repo, "--gpu", "--views", "1"][..], &size].concat(),
        ),
        (
            "check --gpu --gpu-budget (streaming)",
            [
                &["check", repo, "--gpu", "--views", "1", "--gpu-budget", "8"][..],
                &size,
            ]
            .concat(),
        ),
        (
            "bench render",
            [&["bench", "render", repo, "--frames", "2"][..], &size].concat(),
        ),
    ];
    // The command works without a fault (so the faults below are what fails it).
    for (name, args) in &commands {
        let out = tessera("", args);
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let faults = [
        ("lost@1", "device lost"),
        ("lost@2", "device lost"),
        ("oom@1", "out of GPU memory"),
        ("readback@1", "reading back"),
    ];
    for (name, args) in &commands {
        for (fault, says) in faults {
            let started = Instant::now();
            let out = tessera(fault, args);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(3), "{name} with {fault}: {stderr}");
            assert!(
                stderr.contains("error: the GPU device failed") && stderr.contains(says),
                "{name} with {fault}: {stderr}"
            );
            assert!(
                !stderr.contains("panicked"),
                "{name} with {fault}: {stderr}"
            );
            assert!(
                started.elapsed() < Duration::from_secs(60),
                "{name} with {fault} took {:?}",
                started.elapsed()
            );
        }
    }
    // A malformed fault is refused as bad usage.
    let out = tessera("sideways", &commands[1].1);
    assert_eq!(out.status.code(), Some(2));
}

/// A target larger than the adapter's largest texture is refused naming the limit (exit 2),
/// by `render`, `check --gpu` and `bench render`.
#[test]
fn a_size_beyond_the_texture_limit_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let repo = build_bunny(dir.path());
    let repo = repo.to_str().unwrap();
    let png = dir.path().join("frame.png");
    let png = png.to_str().unwrap();
    // Beyond every adapter's max_texture_dimension_2d (lavapipe: 16,384; llvmpipe GL: 16,384).
    let size = ["--size", "1000000x100"];
    for args in [
        [
            &["render", repo, "-o", png, "--gpu-budget", "64"][..],
            &size,
        ]
        .concat(),
        [&["check", repo, "--gpu", "--views", "1"][..], &size].concat(),
        [&["bench", "render", repo, "--frames", "1"][..], &size].concat(),
    ] {
        let out = tessera("", &args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains("max_texture_dimension_2d") && stderr.contains("1000000×100"),
            "{args:?}: {stderr}"
        );
        assert!(!Path::new(png).exists());
    }
}
