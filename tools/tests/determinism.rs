//! The same input and flags give a byte-identical repository whatever the thread count and
//! with or without `--memory` (issue 12, "Determinism"): a mesh and a height field, 1, 2 and 7
//! threads; a generated 2 M-triangle mesh with shuffled vertices and 1000× varying density, a
//! scan and a height field with `--memory 64M` and a budget small enough that every
//! out-of-core stage spills.

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

/// Runs `tessera ARGS`, which must succeed.
fn tessera(args: &[&str]) {
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
    let generated = dir.path().join("g2m.ply");
    tessera(&[
        "gen",
        "mesh",
        "--triangles",
        "2000000",
        "--shuffle-vertices",
        "--density-range",
        "1000",
        "-o",
        generated.to_str().unwrap(),
    ]);
    let temp = dir.path().join("temp");
    std::fs::create_dir(&temp).unwrap();
    let cases: [(std::path::PathBuf, &[&str]); 4] = [
        (generated, &["64M"]),
        (testdata("mesh/dragon_vrip_res2.ply.gz"), &["1M"]),
        (testdata("mesh/bunny00.off"), &["1M"]),
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
