//! What the out-of-core import's tests check of a staged mesh: the in-memory import's mesh,
//! ids and counts, and nothing left in its directory once dropped.

use std::path::Path;

use tessera_preprocess::external::StagedMesh;
use tessera_preprocess::import::load_mesh;

pub fn assert_same_as_load_mesh(staged: StagedMesh, path: &Path, dir: &Path) {
    let expected = load_mesh(path).unwrap();
    assert_eq!(staged.load().unwrap(), expected.mesh, "{path:?}");
    assert_eq!(
        [
            staged.raw_vertices,
            staged.raw_triangles,
            staged.welded_vertices,
            staged.degenerate_triangles,
            staged.duplicate_triangles,
            staged.unreferenced_vertices,
        ],
        [
            expected.raw_vertices,
            expected.raw_triangles,
            expected.welded_vertices,
            expected.degenerate_triangles,
            expected.duplicate_triangles,
            expected.unreferenced_vertices,
        ]
        .map(|n| n as u64),
        "{path:?}"
    );
    drop(staged);
    assert_eq!(std::fs::read_dir(dir).unwrap().count(), 0, "files left");
}
