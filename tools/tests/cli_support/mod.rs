//! What the command-line tests share: running the binary and reading its JSON.
#![allow(dead_code)] // each test file uses its own part

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `tessera` with `args` to completion.
pub fn tessera(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(args)
        .output()
        .expect("run tessera")
}

/// The one JSON object `out` printed on stdout (with both streams in the panic otherwise).
pub fn json(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not one JSON object ({e}): {}\nstderr: {}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        )
    })
}

/// The Stanford bunny of the fetched test data (a scan without normals).
pub fn bunny() -> PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/bunny00.off");
    assert!(
        path.exists(),
        "{} is missing: run tools/fetch-testdata.sh first (README.md, 'Tests')",
        path.display()
    );
    path
}

/// Builds the bunny into `dir` (default flags) and returns the repository's path.
pub fn build_bunny(dir: &Path) -> PathBuf {
    let repo = dir.join("bunny.tsr");
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
    repo
}
