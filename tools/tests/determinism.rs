//! The same input and flags give a byte-identical repository whatever the thread count
//! (issue 12, "Determinism"): a mesh and a height field, 1, 2 and 7 threads.

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
    let out = Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args([
            "build",
            input.to_str().unwrap(),
            "-o",
            output.to_str().unwrap(),
        ])
        .args(["--threads", &threads.to_string()])
        .output()
        .expect("run tessera");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::read(output).unwrap()
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
