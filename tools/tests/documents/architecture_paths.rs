//! Every repository path ARCHITECTURE.md names exists in the tree.
//!
//! The rule, applied to each backticked token (the text between a pair of backticks):
//!
//! 1. It is a *path candidate* only if it consists of ASCII letters, digits and `_ . - /`
//!    alone. That leaves out commands and flags with arguments (spaces), Rust paths
//!    (`Repository::open`), URLs (`:`), glob patterns and placeholders written with
//!    `* ? [ ] { } < >`, and formulas.
//! 2. It is skipped if it starts with `-` (a flag such as `--memory`) or `/` (a path outside
//!    the repository), if it lies under `testdata/` (fetched by `tools/fetch-testdata.sh`,
//!    ignored by git), or if one of its components is a placeholder: a stem (leading dots
//!    dropped, up to the first `.`) written in capitals, as in `OUT.tsr` or
//!    `.OUT.tessera-build/`, unless the component is a `.md` document such as `README.md`.
//! 3. A candidate containing `/` must exist relative to the repository root (a trailing `/`:
//!    a folder). A candidate without `/` is checked only if it ends in one of `EXTENSIONS`
//!    (`.rs .md .py .sh .wgsl .toml`): a bare file name such as `conformity.rs`, which must be
//!    the name of some file in the tree (`.git` and `target` folders left out). Any other
//!    token (`Domain::HeightField`, `f32`, `manifest.json`) is not a path.
//!
//! Every missing path is reported in one failure message.

use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::Path;

/// The document checked, relative to the repository root.
const DOCUMENT: &str = "ARCHITECTURE.md";

/// Extensions that make a bare token (no `/`) a file name to check.
const EXTENSIONS: [&str; 6] = ["rs", "md", "py", "sh", "wgsl", "toml"];

/// Fewer checked paths than this means the extraction broke, not that the document is right.
const LEAST_CHECKED: usize = 50;

/// A backticked token that names something in the repository.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Named<'a> {
    /// Contains `/`: a file or folder relative to the repository root.
    Path(&'a str),
    /// A bare file name: some file of that name anywhere in the tree.
    FileName(&'a str),
}

/// The tokens between pairs of backticks.
fn backticked(text: &str) -> impl Iterator<Item = &str> {
    text.split('`').skip(1).step_by(2)
}

/// Whether a path component is a placeholder (`OUT.tsr`, `.OUT.tessera-build`, `DIR`).
fn is_placeholder(component: &str) -> bool {
    if component.ends_with(".md") {
        return false;
    }
    let stem = component.trim_start_matches('.');
    let stem = stem.split('.').next().unwrap_or("");
    stem.chars().any(|c| c.is_ascii_uppercase())
        && stem
            .chars()
            .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_')
}

/// What a token names under the rule of the module comment, if anything.
fn classify(token: &str) -> Option<Named<'_>> {
    let path_chars = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '-' | '/');
    if token.is_empty() || !token.chars().all(path_chars) {
        return None;
    }
    if token.starts_with('-') || token.starts_with('/') || token.starts_with("testdata/") {
        return None;
    }
    if token.split('/').any(is_placeholder) {
        return None;
    }
    if token.contains('/') {
        return Some(Named::Path(token));
    }
    let (stem, extension) = token.rsplit_once('.')?;
    (!stem.is_empty() && EXTENSIONS.contains(&extension)).then_some(Named::FileName(token))
}

/// The names of every file under `root`, `.git` and `target` folders left out.
fn file_names(root: &Path) -> BTreeSet<OsString> {
    let mut names = BTreeSet::new();
    let mut folders = vec![root.to_path_buf()];
    while let Some(folder) = folders.pop() {
        let entries = std::fs::read_dir(&folder)
            .unwrap_or_else(|e| panic!("cannot list {}: {e}", folder.display()));
        for entry in entries {
            let entry = entry.expect("a folder entry");
            let kind = entry.file_type().expect("an entry's type");
            if kind.is_dir() {
                if entry.file_name() != ".git" && entry.file_name() != "target" {
                    folders.push(entry.path());
                }
            } else {
                names.insert(entry.file_name());
            }
        }
    }
    names
}

/// The paths `text` names (each once, in order of first mention) and those of them missing
/// from the tree at `root`, whose file names are `names`.
fn check<'a>(root: &Path, text: &'a str, names: &BTreeSet<OsString>) -> (usize, Vec<&'a str>) {
    let mut seen = BTreeSet::new();
    let mut missing = Vec::new();
    for named in backticked(text).filter_map(classify) {
        if !seen.insert(named) {
            continue;
        }
        let present = match named {
            Named::Path(path) if path.ends_with('/') => root.join(path).is_dir(),
            Named::Path(path) => root.join(path).exists(),
            Named::FileName(name) => names.contains(&OsString::from(name)),
        };
        if !present {
            missing.push(match named {
                Named::Path(p) | Named::FileName(p) => p,
            });
        }
    }
    (seen.len(), missing)
}

#[test]
fn architecture_names_only_paths_that_exist() {
    let root = crate::repo_root();
    let text = std::fs::read_to_string(root.join(DOCUMENT))
        .unwrap_or_else(|e| panic!("cannot read {DOCUMENT}: {e}"));
    let (checked, missing) = check(&root, &text, &file_names(&root));
    assert!(
        missing.is_empty(),
        "{DOCUMENT} names {} of its {checked} paths that are not in the tree (a path with `/` \
         is relative to the repository root; a bare file name must be some file's name):\n  {}",
        missing.len(),
        missing.join("\n  ")
    );
    assert!(
        checked >= LEAST_CHECKED,
        "only {checked} paths found in {DOCUMENT}: the extraction no longer sees them"
    );
}

#[test]
fn the_rule_reports_missing_paths_and_skips_what_is_not_one() {
    let root = crate::repo_root();
    let text = "`core/src/cut.rs` `core/src/no_such_module.rs` `shaders/` `no_such_folder/` \
                `cut.rs` `no_such_file.rs` `README.md` `--memory` `build --memory SIZE` \
                `OUT.tsr` `.OUT.tessera-build/` `DIR/x.rs` `testdata/mesh/bunny.ply` \
                `https://example.org/a.rs` `fuzz/corpus/*` `ρ/τ` `Repository::open` \
                `manifest.json` `f32` `/proc/self/status` `core/src/cut.rs`";
    let (checked, missing) = check(&root, text, &file_names(&root));
    assert_eq!(
        missing,
        [
            "core/src/no_such_module.rs",
            "no_such_folder/",
            "no_such_file.rs"
        ]
    );
    assert_eq!(checked, 7, "each named path checked once");
}
