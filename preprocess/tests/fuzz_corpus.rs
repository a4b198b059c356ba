//! The fuzzers' corpora as a regression test: every file under `fuzz/corpus/<target>/` goes
//! through the same function as the fuzz target `<target>` (`tessera_preprocess::fuzzing`),
//! which panics if an importer panics, accepts something insane (non-finite positions, indices
//! out of range, ...) or gives an error that does not name the file. Crashes the fuzzers found
//! are in the corpora, so each fix stays fixed.

use std::path::{Path, PathBuf};

use tessera_preprocess::fuzzing::TARGETS;

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus")
}

fn files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| entry.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

#[test]
fn every_corpus_file_goes_through_its_target_without_a_panic() {
    let mut failures = Vec::new();
    for &(name, target) in TARGETS {
        let dir = corpus().join(name);
        let files = files(&dir);
        assert!(!files.is_empty(), "{}: no corpus files", dir.display());
        let (mut accepted, mut refused) = (0, 0);
        for file in &files {
            let data = std::fs::read(file).unwrap();
            match std::panic::catch_unwind(|| target(&data)) {
                Ok(true) => accepted += 1,
                Ok(false) => refused += 1,
                Err(_) => failures.push(file.display().to_string()),
            }
        }
        // Both paths are exercised: a corpus of only bad (or only good) files would test half.
        assert!(
            accepted > 0 && refused > 0,
            "{name}: {accepted} files accepted, {refused} refused; the corpus needs both"
        );
    }
    assert!(failures.is_empty(), "panics on: {failures:#?}");
}

#[test]
fn every_corpus_directory_is_a_target() {
    let names: Vec<&str> = TARGETS.iter().map(|t| t.0).collect();
    for entry in std::fs::read_dir(corpus()).unwrap() {
        let entry = entry.unwrap();
        let name = entry.file_name().into_string().unwrap();
        assert!(
            names.contains(&name.as_str()),
            "fuzz/corpus/{name} is not a target of tessera_preprocess::fuzzing::TARGETS"
        );
    }
    // And every target has a fuzz target file that calls it.
    let targets = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/fuzz_targets");
    for name in names {
        let source = std::fs::read_to_string(targets.join(format!("{name}.rs")))
            .unwrap_or_else(|e| panic!("fuzz/fuzz_targets/{name}.rs: {e}"));
        assert!(
            source.contains(&format!("tessera_preprocess::fuzzing::{name}(data)")),
            "fuzz/fuzz_targets/{name}.rs does not call fuzzing::{name}"
        );
    }
}
