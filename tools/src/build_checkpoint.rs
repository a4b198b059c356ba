//! `build`'s checkpoint (`--resume`): where it is, whether this build keeps one, and what to do
//! with one that is there. The checkpoint itself is `tessera_preprocess::checkpoint`.
//!
//! - A build keeps a checkpoint when it stages its input (a mesh file or standard input with
//!   `--memory`); for a height field it keeps none and `--resume` is refused. Standard input is
//!   fingerprinted as the import reads it (size, CRC-32 of every byte); `--resume` from
//!   standard input reads it to its end to check it, when the checkpoint has a stage to
//!   resume (else it is imported as usual).
//! - Without `--resume`, a checkpoint left by an earlier build of the same output is removed
//!   (said on stderr) and the build starts over.
//! - With `--resume`, a checkpoint made by another build (input, flags, version) is refused,
//!   naming the difference (exit 2, nothing written, the checkpoint left as it is); none at all
//!   starts the build from the beginning.
//! - A build holds its checkpoint locked (`flock`): a second build of the same output at the
//!   same time is refused rather than remove the first one's files.
//! - On success the checkpoint is removed. On failure it is kept only when it can serve a
//!   resume: the failure was the file system's (disk full, a temporary file refused) and some
//!   stage is complete; a failure of the input or of the build's checks would recur, so the
//!   checkpoint is removed.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use tessera_preprocess::checkpoint::{checkpoint_dir, Checkpoint, Fingerprint, Manifest};
use tessera_preprocess::BuildError;

/// Environment variable of the tests' faults: `kill-after-stage:NAME` kills the build (SIGKILL)
/// once stage NAME is committed (`NAME*`: the first stage whose name starts with NAME).
pub const FAULT_VAR: &str = "TESSERA_BUILD_FAULT";

/// Environment variable: `1` checkpoints after every level (the tests', so that a fault can
/// name a level), instead of when one is due.
pub const EVERY_LEVEL_VAR: &str = "TESSERA_CHECKPOINT_EVERY_LEVEL";

/// `build --stop-after STAGE`: the stage after whose commit the process ends (exit 0, the
/// checkpoint kept for `--resume`), so that a build runs as several processes, one or more
/// stages each.
#[derive(Clone, Debug, PartialEq)]
pub enum StopAfter {
    Staged,
    Hierarchy,
    Leaves,
    /// The first level checkpoint with at least this many levels merged (level checkpoints are
    /// taken when due, not after every level).
    Levels(u64),
}

impl StopAfter {
    /// `staged`, `hierarchy`, `leaves` or `level-N` (N ≥ 1).
    pub fn parse(text: &str) -> Result<StopAfter, String> {
        match text {
            "staged" => Ok(StopAfter::Staged),
            "hierarchy" => Ok(StopAfter::Hierarchy),
            "leaves" => Ok(StopAfter::Leaves),
            _ => match text.strip_prefix("level-").map(str::parse::<u64>) {
                Some(Ok(n)) if n >= 1 => Ok(StopAfter::Levels(n)),
                _ => Err(format!(
                    "`{text}`: a stage is staged, hierarchy, leaves or level-N (N ≥ 1)"
                )),
            },
        }
    }

    /// Whether the committed stage `name` is this one (or, for levels, past it).
    fn reached_by(&self, name: &str) -> bool {
        match self {
            StopAfter::Staged => name == "staged",
            StopAfter::Hierarchy => name == "hierarchy",
            StopAfter::Leaves => name == "leaves",
            StopAfter::Levels(n) => name
                .strip_prefix("level-")
                .and_then(|m| m.parse::<u64>().ok())
                .is_some_and(|m| m >= *n),
        }
    }
}

/// Opens or creates the build's checkpoint, or removes a stale one. `manifest`: what the
/// build's input and flags make the checkpoint's manifest (a resume must match it).
/// `checkpointable`: the build stages a mesh (a file or standard input) under a memory budget.
/// `stop_after`: `--stop-after` and whether `--json` was given.
pub fn prepare(
    input: &Path,
    output: &Path,
    temp_dir: Option<&Path>,
    manifest: &dyn Fn(Fingerprint) -> Manifest,
    checkpointable: bool,
    resume: bool,
    stop_after: Option<(StopAfter, bool)>,
) -> anyhow::Result<Option<Prepared>> {
    let is_stdin = crate::input::is_stdin(input);
    if resume {
        if temp_dir.is_none() {
            bail!(
                "--resume continues a build made with --memory: only a build under a memory \
                 budget keeps a checkpoint"
            );
        }
        if !checkpointable {
            bail!("--resume continues a mesh build: a height field's build keeps no checkpoint");
        }
    }
    let dir = checkpoint_dir(output, &default_dir(output, temp_dir));
    // Another build of the same output holds its checkpoint locked: neither removes the other's.
    let held = lock(&dir, output)?;
    if !resume && dir.exists() {
        std::fs::remove_dir_all(&dir)
            .with_context(|| format!("removing the stale checkpoint {}", dir.display()))?;
        eprintln!(
            "removed the checkpoint an earlier build of {} left at {} (--resume continues one)",
            output.display(),
            dir.display()
        );
    }
    if !checkpointable {
        if stop_after.is_some() {
            bail!("--stop-after needs a build that keeps a checkpoint: a mesh under --memory");
        }
        return Ok(None);
    }
    let fingerprint = if is_stdin {
        stdin_fingerprint(&dir, resume)?
    } else {
        match Fingerprint::of(input) {
            Ok(f) => f,
            // The import names the problem with the input.
            Err(_) if !resume => return Ok(None),
            Err(e) => return Err(e).with_context(|| format!("reading {}", input.display())),
        }
    };
    let manifest = manifest(fingerprint);
    let mut resumed = false;
    let mut checkpoint = match resume.then(|| Checkpoint::open(&dir, manifest.clone())) {
        Some(Ok(Some(c))) => {
            let stage = c.last_stage().map_or("none", |s| s.name.as_str());
            eprintln!("resuming from {} (last stage: {stage})", dir.display());
            resumed = true;
            c
        }
        Some(Err(e)) => return Err(e.into()),
        Some(Ok(None)) | None => {
            if resume {
                eprintln!(
                    "no checkpoint at {}: building from the start",
                    dir.display()
                );
            }
            Checkpoint::create(&dir, manifest)?
        }
    };
    // The lock taken above when the directory is the same; a new directory's otherwise (a
    // second lock of the same directory by this process would conflict with the first).
    let lock = match held {
        Some(file) if resumed => file,
        _ => lock(&dir, output)?.context("the checkpoint directory vanished")?,
    };
    if std::env::var(EVERY_LEVEL_VAR).is_ok_and(|v| v == "1") {
        checkpoint.every_level();
    }
    let dir_shown = dir.display().to_string();
    checkpoint.on_commit(move |stage| {
        if let Some((stop, json)) = &stop_after {
            if stop.reached_by(stage) {
                stop_after_commit(stage, &dir_shown, *json);
            }
        }
        let fault = std::env::var(FAULT_VAR).unwrap_or_default();
        let matches = match fault.strip_prefix("kill-after-stage:") {
            Some(name) => match name.strip_suffix('*') {
                Some(prefix) => stage.starts_with(prefix),
                None => name == stage,
            },
            None => false,
        };
        if matches {
            // A kill -9 at a stage boundary, for the tests.
            unsafe { libc::kill(libc::getpid(), libc::SIGKILL) };
        }
    });
    Ok(Some(Prepared { checkpoint, lock }))
}

/// Ends the process after stage `stage` is committed (`--stop-after`): the checkpoint at
/// `dir` holds everything a `--resume` needs; said on stderr, and with `--json` as one object
/// on stdout. The unnamed temporary files go with the process, the checkpoint's lock too.
fn stop_after_commit(stage: &str, dir: &str, json: bool) -> ! {
    use std::io::Write;
    if json {
        println!(
            "{}",
            serde_json::json!({"stopped_after": stage, "checkpoint": dir})
        );
        let _ = std::io::stdout().flush();
    }
    eprintln!("stopped after stage {stage} (--stop-after): --resume continues from {dir}");
    std::process::exit(0)
}

/// Standard input's fingerprint: read to its end when `resume` finds a stage to resume in the
/// checkpoint at `dir` (it is checked against the checkpoint's), else the unread one (the
/// import fingerprints the stream as it stages it).
fn stdin_fingerprint(dir: &Path, resume: bool) -> anyhow::Result<Fingerprint> {
    let resumable = resume && Checkpoint::read_manifest(dir)?.is_some_and(|m| !m.stages.is_empty());
    if !resumable {
        return Ok(Fingerprint::stream_unread());
    }
    use std::io::IsTerminal;
    if std::io::stdin().is_terminal() {
        bail!("standard input is a terminal: pipe the PLY mesh of the killed build into `-`");
    }
    eprintln!("reading standard input to its end, to check it against the checkpoint's");
    Fingerprint::of_stream(std::io::stdin()).context("reading standard input")
}

/// A build's checkpoint, locked (`flock`) for as long as the build holds it.
pub struct Prepared {
    pub checkpoint: Checkpoint,
    /// Held until the build ends.
    pub lock: std::fs::File,
}

/// Locks the checkpoint directory `dir` if there is one (an exclusive `flock` on the
/// directory, released when the process ends, killed or not); an error when another build
/// holds it.
fn lock(dir: &Path, output: &Path) -> anyhow::Result<Option<std::fs::File>> {
    use std::os::fd::AsRawFd;
    let file = match std::fs::File::open(dir) {
        Ok(file) => file,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e).with_context(|| format!("opening {}", dir.display())),
    };
    // SAFETY: flock on a descriptor this function owns.
    if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
        bail!(
            "another build of {} is running: it holds {} (wait for it, or stop it)",
            output.display(),
            dir.display()
        );
    }
    Ok(Some(file))
}

/// Where the checkpoint goes: `--temp`, or the output's directory.
/// Where the checkpoint of a build of `output` with `--temp temp_dir` lives.
pub fn dir_for(output: &Path, temp_dir: Option<&Path>) -> PathBuf {
    checkpoint_dir(output, &default_dir(output, temp_dir))
}

fn default_dir(output: &Path, temp_dir: Option<&Path>) -> PathBuf {
    match (temp_dir, output.parent()) {
        (Some(dir), _) => dir.to_path_buf(),
        (None, Some(dir)) if !dir.as_os_str().is_empty() => dir.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// After a failed build: keeps the checkpoint when it can serve a resume (see the module
/// comment), removes it otherwise.
pub fn after_failure(checkpoint: Checkpoint, error: &anyhow::Error) {
    let io_failure = error.chain().any(|c| {
        matches!(
            c.downcast_ref::<BuildError>(),
            Some(BuildError::Temporary { .. })
        )
    });
    if io_failure && checkpoint.last_stage().is_some() {
        eprintln!(
            "the checkpoint {} is kept: once the cause is fixed, rerun with --resume",
            checkpoint.dir().display()
        );
    } else {
        let _ = checkpoint.remove();
    }
}
