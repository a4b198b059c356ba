//! The documents a newcomer reads stay true to the code: the command reference against every
//! `--help`, ARCHITECTURE.md's paths against the tree, and no numbered work period used as a
//! unit of time anywhere in the repository. One test binary for all of them (each binary links
//! the whole tool).

#[path = "documents/architecture_paths.rs"]
mod architecture_paths;
#[path = "documents/cli_reference.rs"]
mod cli_reference;
#[path = "documents/work_periods.rs"]
mod work_periods;

/// The repository's root (the workspace), from this crate's manifest directory.
pub fn repo_root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tools/ has a parent")
        .to_path_buf()
}

/// ARCHITECTURE.md stays a map a new engineer reads in ten minutes and README.md a page
/// (issue 45: at most 25 KB and 8 KB); what grows goes to docs/ or BENCHMARKS.md.
#[test]
fn the_map_and_the_readme_stay_short() {
    for (name, limit) in [("ARCHITECTURE.md", 25_000), ("README.md", 8_000)] {
        let bytes = std::fs::metadata(repo_root().join(name)).unwrap().len();
        assert!(bytes <= limit, "{name} is {bytes} bytes, over {limit}");
    }
}
