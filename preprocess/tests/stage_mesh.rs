//! The out-of-core import (`import::stage_mesh`: streamed to disk, welded by external sorts)
//! gives the same mesh, ids and counts as the in-memory import, on real scans and at budgets
//! that make every step spill.

use std::path::{Path, PathBuf};

use tessera_preprocess::import::stage_mesh;

mod stage_support;

fn testdata(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata")
        .join(name)
}

fn same_as_load_mesh(name: &str, budget: usize) {
    let path = testdata(name);
    let dir = tempfile::tempdir().unwrap();
    let staged = stage_mesh(&path, dir.path(), budget).unwrap();
    stage_support::assert_same_as_load_mesh(staged, &path, dir.path());
}

#[test]
fn a_gzipped_binary_ply_stages_as_it_loads() {
    // 0.87 M triangles; 1 MiB: every sort spills runs and merges in passes.
    same_as_load_mesh("mesh/dragon_vrip.ply.gz", 1 << 20);
}

#[test]
fn an_off_scan_stages_as_it_loads() {
    same_as_load_mesh("mesh/bunny00.off", 64 << 10);
}

#[test]
fn a_broken_file_is_an_error_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.ply");
    std::fs::write(
        &bad,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
    )
    .unwrap();
    let temp = dir.path().join("temp");
    std::fs::create_dir(&temp).unwrap();
    let error = stage_mesh(&bad, &temp, 1 << 20)
        .err()
        .expect("an index out of range");
    let message = error.to_string();
    assert!(
        message.contains("bad.ply") && message.contains('7'),
        "{message}"
    );
    assert_eq!(std::fs::read_dir(&temp).unwrap().count(), 0, "files left");
}
