//! No numbered work period used as a unit of time, anywhere in the sources and documents:
//! history is told by versions, dates and commits ("before commit 4fa9fc2 of 2026-12-03"),
//! never by an ordinal period of the team's own work, which means nothing outside it.
//!
//! The rule, on the words of every text file of the tree (letters, digits and hyphens; all
//! else, comment markers and line breaks included, separates words, so a phrase broken across
//! two comment lines is still one phrase):
//! - an ordinal word ("first" … "twentieth", "twenty-first" …, "21st") followed by "session",
//!   "round", "iteration", "turn" or "wave" (or their plurals) is refused;
//! - the word "session" is refused anywhere, except after a word of [`SESSION_ALLOWED_AFTER`]
//!   (a desktop login session is a real thing the viewer's messages speak of).
//!
//! Skipped: build outputs (`target/`), fetched data (`testdata/`), fuzz inputs
//! (`fuzz/corpus/`, `fuzz/artifacts/`), `.git/`, files that are not UTF-8 text, and this file
//! (whose examples break the rule on purpose).

use std::path::{Path, PathBuf};

/// Words after an ordinal that make it a work period.
const PERIOD_WORDS: &[&str] = &["session", "round", "iteration", "turn", "wave"];

/// The words before "session" that make it a real session, not a work period.
const SESSION_ALLOWED_AFTER: &[&str] = &["desktop", "login", "x11", "wayland", "ssh", "tmux"];

/// Directories (relative to the root, `/`-separated) that hold no sources or documents.
const SKIPPED_DIRS: &[&str] = &[
    ".git",
    "target",
    "testdata",
    "fuzz/corpus",
    "fuzz/artifacts",
    "fuzz/target",
    "fuzz/coverage",
    "tessera-demo-frames",
    "node_modules",
];

/// The files that state the rule (relative to the root).
const SKIPPED_FILES: &[&str] = &["tools/tests/documents/work_periods.rs"];

/// Extensions of the files read as text; files with another extension are skipped (images,
/// fuzz inputs), files without one are read when they are UTF-8 (`.ci/run`).
const TEXT_EXTENSIONS: &[&str] = &[
    "rs", "md", "py", "sh", "toml", "wgsl", "txt", "json", "yml", "yaml", "js", "html", "cfg",
];

const SMALL_ORDINALS: &[&str] = &[
    "first",
    "second",
    "third",
    "fourth",
    "fifth",
    "sixth",
    "seventh",
    "eighth",
    "ninth",
    "tenth",
    "eleventh",
    "twelfth",
    "thirteenth",
    "fourteenth",
    "fifteenth",
    "sixteenth",
    "seventeenth",
    "eighteenth",
    "nineteenth",
];
const TENS: &[&str] = &[
    "twenty", "thirty", "forty", "fifty", "sixty", "seventy", "eighty", "ninety",
];
const TENS_ORDINALS: &[&str] = &[
    "twentieth",
    "thirtieth",
    "fortieth",
    "fiftieth",
    "sixtieth",
    "seventieth",
    "eightieth",
    "ninetieth",
    "hundredth",
];

/// Whether `word` (lower case) is an ordinal: "third", "twenty-fourth", "24th", "last" is not.
fn is_ordinal(word: &str) -> bool {
    if SMALL_ORDINALS.contains(&word) || TENS_ORDINALS.contains(&word) {
        return true;
    }
    if let Some((tens, unit)) = word.split_once('-') {
        return TENS.contains(&tens) && SMALL_ORDINALS[..9].contains(&unit);
    }
    let digits = word.trim_end_matches(|c: char| c.is_ascii_alphabetic());
    let suffix = &word[digits.len()..];
    !digits.is_empty()
        && digits.bytes().all(|b| b.is_ascii_digit())
        && ["st", "nd", "rd", "th"].contains(&suffix)
}

fn is_period_word(word: &str) -> bool {
    PERIOD_WORDS
        .iter()
        .any(|p| word == *p || word.strip_suffix('s') == Some(p))
}

/// The phrases of `text` that break the rule, each with its line.
fn offences(text: &str) -> Vec<(usize, String)> {
    // Words with the line each starts on.
    let mut words: Vec<(usize, String)> = Vec::new();
    let mut line = 1;
    let mut current = String::new();
    let mut start = line;
    for c in text.chars() {
        if c.is_alphanumeric() || (c == '-' && !current.is_empty()) {
            if current.is_empty() {
                start = line;
            }
            current.extend(c.to_lowercase());
        } else {
            if !current.is_empty() {
                words.push((
                    start,
                    std::mem::take(&mut current).trim_end_matches('-').into(),
                ));
            }
            if c == '\n' {
                line += 1;
            }
        }
    }
    if !current.is_empty() {
        words.push((start, current));
    }
    let mut found = Vec::new();
    for (i, (line, word)) in words.iter().enumerate() {
        let before = i.checked_sub(1).map(|j| words[j].1.as_str());
        if is_period_word(word) && before.is_some_and(is_ordinal) {
            found.push((*line, format!("{} {word}", before.unwrap())));
        } else if (word == "session" || word == "sessions")
            && !before.is_some_and(|b| SESSION_ALLOWED_AFTER.contains(&b))
        {
            found.push((*line, format!("{} {word}", before.unwrap_or(""))));
        }
    }
    found
}

fn text_files(root: &Path, dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let relative = path
            .strip_prefix(root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        let Ok(kind) = entry.file_type() else {
            continue;
        };
        if kind.is_dir() {
            if !SKIPPED_DIRS.contains(&relative.as_str()) {
                text_files(root, &path, out);
            }
        } else if kind.is_file() {
            let wanted = match path.extension().and_then(|e| e.to_str()) {
                Some(ext) => TEXT_EXTENSIONS.contains(&ext),
                None => true,
            };
            if wanted && !SKIPPED_FILES.contains(&relative.as_str()) {
                out.push(path);
            }
        }
    }
}

#[test]
fn no_numbered_work_period_in_the_repository() {
    let root = crate::repo_root();
    let mut files = Vec::new();
    text_files(&root, &root, &mut files);
    files.sort();
    let mut report = Vec::new();
    let mut read = 0;
    for file in &files {
        let Ok(text) = std::fs::read_to_string(file) else {
            continue;
        };
        read += 1;
        for (line, phrase) in offences(&text) {
            let relative = file.strip_prefix(&root).unwrap().display();
            report.push(format!("{relative}:{line}: \"{phrase}\""));
        }
    }
    assert!(
        read > 100,
        "only {read} text files read under {}",
        root.display()
    );
    assert!(
        report.is_empty(),
        "{} numbered work period(s) used as a unit of time (say a date, a commit or a \
         version instead):\n{}",
        report.len(),
        report.join("\n")
    );
}

#[test]
fn the_rule_finds_what_it_must_and_spares_the_rest() {
    let bad = [
        // Split so that the project's own scan of the sources does not count the examples.
        concat!("the twelfth", " session"),
        concat!("Twenty-fourth", " session (the hierarchy"),
        "packed before the twelfth\n/// session, still read",
        concat!("as in the 21st", " round"),
        concat!("the third", " iteration of the plan"),
        "in this session",
        "the sessions' figures",
        concat!("first", " waves"),
    ];
    for text in bad {
        assert!(!offences(text).is_empty(), "missed: {text:?}");
    }
    let good = [
        "run it in a desktop session, or under xvfb-run",
        "splits made a wave at a time",
        concat!("the first", " round-trip of a float"),
        concat!("the last", " round of three"),
        "rounds alternating, run 3 of 5",
        "first, the wave's splits",
        "the third turned out slower",
    ];
    for text in good {
        assert!(
            offences(text).is_empty(),
            "false alarm: {text:?} {:?}",
            offences(text)
        );
    }
}
