//! The temporary-file totals behind `build --json` `temp_bytes_peak` (one test in its own
//! binary: the totals are process-wide).

use std::path::Path;

use tessera_preprocess::external::temp_usage;
use tessera_preprocess::import::stage_mesh;

#[test]
fn temporary_bytes_are_counted_while_held_and_given_back() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/dragon_vrip_res2.ply.gz");
    let dir = tempfile::tempdir().unwrap();
    assert_eq!(temp_usage::current(), 0);
    temp_usage::reset_peak();
    // 256 KiB: the sorts spill runs and merge them.
    let staged = stage_mesh(&path, dir.path(), 256 << 10).unwrap();
    // Only the staged mesh's own files are left, and they are what is counted.
    assert_eq!(temp_usage::current(), staged.bytes());
    // On the way the raw files, the sort runs and the id maps were held too (1.44× the staged
    // mesh since step 1 sorts by windows of positions, its keys in memory; 1.70× since the
    // weld frees each triangle file behind the pass that replaces it; 2.6× before).
    assert!(
        temp_usage::peak() > 5 * staged.bytes() / 4,
        "peak {} for {} staged",
        temp_usage::peak(),
        staged.bytes()
    );
    drop(staged);
    assert_eq!(temp_usage::current(), 0);
}
