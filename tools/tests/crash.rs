//! kill -9 while `tessera build` writes: nothing ever appears at the output path but a complete
//! repository, and the next build of the same output removes what the killed one left.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// `testdata/mesh/dragon_vrip.ply.gz`: big enough (17 MB repository) that its write takes
/// long enough to be caught in the act.
fn dragon() -> PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/dragon_vrip.ply.gz");
    assert!(
        path.exists(),
        "{} is missing: run tools/fetch-testdata.sh first (README.md, 'Tests')",
        path.display()
    );
    path
}

/// Hidden temporary files in `dir` (the writer's `.NAME.tmp-PID`).
fn temporaries(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with('.') && n.contains(".tmp-"))
        })
        .collect()
}

#[test]
fn kill_during_the_write_leaves_nothing_at_the_output_and_the_next_build_cleans_up() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("dragon.tsr");
    let mut caught_writing = 0;
    for attempt in 0..3 {
        let mut child = Command::new(env!("CARGO_BIN_EXE_tessera"))
            .args(["build", dragon().to_str().unwrap(), "-o"])
            .arg(&output)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // Wait for the temporary file to appear, then kill at once: mid-write.
        let start = Instant::now();
        let mut seen = false;
        while start.elapsed() < Duration::from_secs(120) {
            if !temporaries(dir.path()).is_empty() {
                seen = true;
                break;
            }
            if child.try_wait().unwrap().is_some() {
                break;
            }
            std::thread::sleep(Duration::from_micros(200));
        }
        child.kill().unwrap(); // SIGKILL
        let status = child.wait().unwrap();
        if seen && !status.success() {
            caught_writing += 1;
            assert!(
                !output.exists(),
                "attempt {attempt}: a killed build left {}",
                output.display()
            );
            assert_eq!(temporaries(dir.path()).len(), 1, "attempt {attempt}");
        }
        // Whatever the kill left, the next build of the same output removes it.
        let out = Command::new(env!("CARGO_BIN_EXE_tessera"))
            .args(["build", dragon().to_str().unwrap(), "-o"])
            .arg(&output)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(temporaries(dir.path()).is_empty(), "attempt {attempt}");
        tessera_core::repository::Repository::open(&output).unwrap();
        std::fs::remove_file(&output).unwrap();
    }
    assert!(
        caught_writing > 0,
        "no kill landed while the repository was being written"
    );
}
