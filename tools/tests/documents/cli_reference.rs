//! docs/cli.md against the binary's own `--help`, for every command and subcommand.
//!
//! The commands are discovered, not listed: `tessera --help`, then `tessera A --help` for each
//! name in the "Commands:" section of the help before it, recursively (clap's own `help`
//! subcommand aside), so a new command or subcommand cannot be forgotten. Each command's long
//! flags are the `--name`s that start a line of its "Options:" section.
//!
//! How the document is read:
//! - A command `tessera A B` is documented by its section: a level-2 heading that is exactly
//!   `## tessera A B`, up to the next `#` or `##` heading (its `###` subsections included). A
//!   `## tessera ...` heading that names no command is a mismatch. Text before the first
//!   section or under another level-2 heading (exit codes, the environment) belongs to no
//!   command.
//! - A flag is a `--name` anywhere in a section (prose, code spans, fenced blocks), not preceded
//!   by a letter, digit or `-`. It is attributed to the section's command, except inside a code
//!   span, or a line of a fenced block, that starts with a command path (optionally after
//!   `tessera`): `bench stream --path` is attributed to `bench stream` wherever it is written.
//!   Within a span, each later `tessera` starts a new attribution (`tessera gen mesh ... |
//!   tessera build ...`). A span that starts with another program (`cargo`, `python3`,
//!   `xvfb-run`, or a path such as `tools/bench-trade.py`) is that program's command line: its
//!   flags before a `tessera` are not checked. A fenced line that starts with white space
//!   continues the line above it. Outside every section, a flag attributed to no command must
//!   exist in some command.
//!
//! The checks, every mismatch reported at once:
//! - (a) every long flag in a command's `--help` is written in that command's section,
//!   attributed to that command;
//! - (b) every flag written in the document exists in the `--help` of the command it is
//!   attributed to (`--help` and `--version` always do);
//! - (c) every command has a section (the top level only if it defines flags of its own).

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

/// A command as the words after `tessera` (empty: the top level).
type CommandPath = Vec<String>;

/// Flags every command accepts without documenting them.
const ALWAYS: [&str; 2] = ["help", "version"];

fn help_text(path: &[String]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(path)
        .arg("--help")
        .output()
        .expect("run tessera --help");
    assert!(
        out.status.success(),
        "tessera {} --help failed: {}",
        path.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("--help is UTF-8")
}

/// The lines of a help section ("Commands:", "Options:"): from its header to the next line that
/// is not indented (another header).
fn help_section<'a>(help: &'a str, header: &str) -> Vec<&'a str> {
    help.lines()
        .skip_while(|l| l.trim_end() != header)
        .skip(1)
        .take_while(|l| l.trim().is_empty() || l.starts_with(' '))
        .collect()
}

/// Subcommand names under "Commands:" (clap's `help` left out).
fn subcommands(help: &str) -> Vec<String> {
    help_section(help, "Commands:")
        .into_iter()
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(str::to_string)
        .collect()
}

/// Long flags under "Options:": lines `  -o, --output <X>` or `      --json` (at most six
/// spaces in; the long help's descriptions are indented further).
fn long_flags(help: &str) -> BTreeSet<String> {
    let mut flags = BTreeSet::new();
    for line in help_section(help, "Options:") {
        let text = line.trim_start();
        if line.len() - text.len() > 6 {
            continue;
        }
        let rest = if let Some(rest) = text.strip_prefix("--") {
            rest
        } else {
            let b = text.as_bytes();
            if b.len() > 6 && b[0] == b'-' && b[1].is_ascii_alphanumeric() && &text[2..6] == ", --"
            {
                &text[6..]
            } else {
                continue;
            }
        };
        let name: String = rest
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
            .collect();
        if !name.is_empty() {
            flags.insert(name);
        }
    }
    flags
}

/// Every command, recursively, with its long flags.
fn discover() -> BTreeMap<CommandPath, BTreeSet<String>> {
    let mut found = BTreeMap::new();
    let mut todo: Vec<CommandPath> = vec![Vec::new()];
    while let Some(path) = todo.pop() {
        let help = help_text(&path);
        for sub in subcommands(&help) {
            let mut child = path.clone();
            child.push(sub);
            todo.push(child);
        }
        found.insert(path, long_flags(&help));
    }
    found
}

/// The `--name`s in a piece of text.
fn flags_in(text: &str) -> Vec<String> {
    let chars: Vec<char> = text.chars().collect();
    let mut flags = Vec::new();
    let mut i = 0;
    while i + 2 < chars.len() {
        let starts = chars[i] == '-'
            && chars[i + 1] == '-'
            && chars[i + 2].is_ascii_alphanumeric()
            && (i == 0 || !(chars[i - 1].is_alphanumeric() || chars[i - 1] == '-'));
        if starts {
            let mut j = i + 2;
            while j < chars.len() && (chars[j].is_ascii_alphanumeric() || chars[j] == '-') {
                j += 1;
            }
            let name: String = chars[i + 2..j].iter().collect();
            flags.push(name.trim_end_matches('-').to_string());
            i = j;
        } else {
            i += 1;
        }
    }
    flags
}

/// A command line of another program: `cargo`, `python3`, `xvfb-run`, or a path
/// (`tools/bench-trade.py`).
fn is_other_program(word: &str) -> bool {
    ["cargo", "python3", "xvfb-run"].contains(&word) || word.contains('/')
}

/// The longest command path at the start of `words`, and how many words it took.
fn command_at(
    words: &[&str],
    commands: &BTreeMap<CommandPath, BTreeSet<String>>,
) -> (CommandPath, usize) {
    let mut path = CommandPath::new();
    for word in words {
        let mut longer = path.clone();
        longer.push(word.to_string());
        if !commands.contains_key(&longer) {
            break;
        }
        path = longer;
    }
    let n = path.len();
    (path, n)
}

/// A flag written in the document: which command it is attributed to (None: no command, outside
/// every section) and where (the section's heading, for the report).
struct Written {
    flag: String,
    command: Option<CommandPath>,
    section: String,
}

/// Attributes the flags of one code span or fenced line. `default` is the section's command;
/// returns the command the span's last part was attributed to (for continued fenced lines).
fn attribute_span(
    span: &str,
    default: &Option<CommandPath>,
    commands: &BTreeMap<CommandPath, BTreeSet<String>>,
    section: &str,
    out: &mut Vec<Written>,
) -> Option<CommandPath> {
    let words: Vec<&str> = span.split_whitespace().collect();
    let mut current = default.clone();
    let mut i = 0;
    if let Some(&first) = words.first() {
        if first == "tessera" {
            let (path, n) = command_at(&words[1..], commands);
            current = Some(path);
            i = 1 + n;
        } else if is_other_program(first) {
            // Another program's command line: its flags are not tessera's.
            i = words
                .iter()
                .position(|w| *w == "tessera")
                .unwrap_or(words.len());
        } else {
            let (path, n) = command_at(&words, commands);
            if n > 0 {
                current = Some(path);
                i = n;
            }
        }
    }
    while i < words.len() {
        if words[i] == "tessera" {
            let (path, n) = command_at(&words[i + 1..], commands);
            current = Some(path);
            i += 1 + n;
            continue;
        }
        for flag in flags_in(words[i]) {
            out.push(Written {
                flag,
                command: current.clone(),
                section: section.to_string(),
            });
        }
        i += 1;
    }
    current
}

/// Attributes the flags of one section's text (or of the text outside every section).
fn attribute_section(
    text: &str,
    default: &Option<CommandPath>,
    commands: &BTreeMap<CommandPath, BTreeSet<String>>,
    section: &str,
    out: &mut Vec<Written>,
) {
    let mut prose = String::new();
    let mut fenced = false;
    let mut continued: Option<CommandPath> = default.clone();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continued = default.clone();
            continue;
        }
        if fenced {
            let base = if line.starts_with(char::is_whitespace) {
                &continued
            } else {
                default
            };
            continued = attribute_span(line, base, commands, section, out);
        } else {
            prose.push_str(line);
            prose.push('\n');
        }
    }
    // Code spans alternate with the text between them.
    for (k, piece) in prose.split('`').enumerate() {
        if k % 2 == 1 {
            attribute_span(piece, default, commands, section, out);
        } else {
            for flag in flags_in(piece) {
                out.push(Written {
                    flag,
                    command: default.clone(),
                    section: section.to_string(),
                });
            }
        }
    }
}

fn show(path: &[String]) -> String {
    if path.is_empty() {
        "tessera".to_string()
    } else {
        format!("tessera {}", path.join(" "))
    }
}

#[test]
fn cli_md_documents_every_flag_of_every_command_and_no_other() {
    let commands = discover();
    // The discovery itself works: the commands every user meets are found, with flags.
    for known in [
        &["build"][..],
        &["bench", "stream"],
        &["gen", "mesh"],
        &["view"],
    ] {
        let path: CommandPath = known.iter().map(|s| s.to_string()).collect();
        assert!(
            commands
                .get(&path)
                .is_some_and(|f| f.contains("help") && f.len() > 1),
            "{} not discovered with its flags: {:?}",
            show(&path),
            commands.keys().collect::<Vec<_>>()
        );
    }

    let doc_path = crate::repo_root().join("docs/cli.md");
    let doc = std::fs::read_to_string(&doc_path).expect("docs/cli.md");

    // Split into the text outside sections and each command's section.
    let mut mismatches = Vec::new();
    let mut outside = String::new();
    let mut sections: BTreeMap<CommandPath, String> = BTreeMap::new();
    let mut current: Option<CommandPath> = None;
    let mut fenced = false;
    for line in doc.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        }
        let heading = !fenced && (line.starts_with("# ") || line.starts_with("## "));
        if heading {
            current = None;
            if let Some(title) = line.strip_prefix("## ") {
                let words: Vec<&str> = title.split_whitespace().collect();
                if words.first() == Some(&"tessera") {
                    let path: CommandPath = words[1..].iter().map(|s| s.to_string()).collect();
                    if !commands.contains_key(&path) {
                        mismatches.push(format!(
                            "docs/cli.md has a section `{line}` but there is no such command"
                        ));
                    } else if sections.contains_key(&path) {
                        mismatches.push(format!("docs/cli.md has `{line}` twice"));
                    } else {
                        sections.insert(path.clone(), String::new());
                        current = Some(path);
                    }
                    continue;
                }
            }
        }
        match &current {
            Some(path) => {
                let text = sections.get_mut(path).expect("section");
                text.push_str(line);
                text.push('\n');
            }
            None => {
                outside.push_str(line);
                outside.push('\n');
            }
        }
    }

    // (c) every command has a section.
    for (path, flags) in &commands {
        let own_flags = flags.iter().any(|f| !ALWAYS.contains(&f.as_str()));
        if !sections.contains_key(path) && (!path.is_empty() || own_flags) {
            mismatches.push(format!(
                "{} has no section in docs/cli.md (a heading `## {}`)",
                show(path),
                show(path)
            ));
        }
    }

    // Every flag written, attributed.
    let mut written = Vec::new();
    attribute_section(
        &outside,
        &None,
        &commands,
        "(outside every command's section)",
        &mut written,
    );
    for (path, text) in &sections {
        attribute_section(
            text,
            &Some(path.clone()),
            &commands,
            &format!("## {}", show(path)),
            &mut written,
        );
    }

    // (a) every flag of a command's --help is in its section.
    for (path, flags) in &commands {
        if !sections.contains_key(path) {
            continue;
        }
        let heading = format!("## {}", show(path));
        for flag in flags {
            if ALWAYS.contains(&flag.as_str()) {
                continue;
            }
            let documented = written.iter().any(|w| {
                w.section == heading && w.command.as_ref() == Some(path) && &w.flag == flag
            });
            if !documented {
                mismatches.push(format!(
                    "{} --{flag} (in its --help) is not documented in docs/cli.md's `{heading}`",
                    show(path)
                ));
            }
        }
    }

    // (b) every flag written exists.
    let mut reported = BTreeSet::new();
    for w in &written {
        if ALWAYS.contains(&w.flag.as_str()) {
            continue;
        }
        let exists = match &w.command {
            Some(path) => commands.get(path).is_some_and(|f| f.contains(&w.flag)),
            None => commands.values().any(|f| f.contains(&w.flag)),
        };
        let whose = w.command.as_deref().map_or("any command".to_string(), show);
        if !exists && reported.insert((w.section.clone(), whose.clone(), w.flag.clone())) {
            mismatches.push(format!(
                "docs/cli.md `{}` writes --{} for {whose}, which has no such flag",
                w.section, w.flag
            ));
        }
    }

    assert!(
        mismatches.is_empty(),
        "docs/cli.md and the --help of the commands differ ({} mismatches):\n  {}",
        mismatches.len(),
        mismatches.join("\n  ")
    );
}
