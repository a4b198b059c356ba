//! The build's checkpoint (issue 12, `build --resume`): a directory beside the output (or in
//! `--temp`), `.OUT.tessera-build/`, holding the files a killed build can continue from and a
//! manifest (`manifest.rs`) naming them, rewritten atomically after each completed stage.
//!
//! Stages, each a task with files in and out:
//! - `staged`: the welded mesh's record files (`external/staged.rs`), the import's unnamed
//!   temporaries linked into the checkpoint (`staged.rs` here);
//! - `hierarchy`: the hierarchy with its leaves' triangle lists and the use counts
//!   (`hierarchy.rs`; the staged mesh's files stay, the leaves are made from them);
//! - `leaves`: the hierarchy (its split diamonds), the current mesh's use counts, the leaves'
//!   live patches and their finished (encoded) patches — the simplification's state before its
//!   first level (`levels.rs`);
//! - `level-N`: the same state after N levels are merged. The live patches and the finished
//!   patches are append-only files named in the checkpoint, so a level's checkpoint writes only
//!   the small state (indexes, counts) and records how far the big files were valid;
//! - `level-N.part-K`: `level-N`'s files and K part files of the next level's results, made
//!   before any of them merged (`simplify/partial_level.rs`), which a resumed build takes
//!   instead of simplifying those diamonds again; `level-N.merging`: `level-N`'s files again
//!   once the next level starts merging (its parts' bytes are then freed as they are taken).
//!
//! Whatever a killed build wrote after its last manifest (a longer append-only file, a file
//! no manifest names) is cut back or removed when the checkpoint is opened. Once a stage is
//! committed, the files of the stages it supersedes are removed.

mod bytes;
mod hierarchy;
mod levels;
pub mod manifest;
mod staged;

#[cfg(test)]
pub(crate) use bytes::write_atomic_with;
pub(crate) use bytes::{Dec, Enc};
pub(crate) use hierarchy::{load_hierarchy, save_hierarchy, HierarchyCheckpoint, InputFacts};
pub(crate) use levels::{
    drop_level_parts, load_levels, save_level_part, save_levels, LevelsCheckpoint,
};
pub use manifest::{
    FileRecord, Fingerprint, Manifest, StageRecord, StreamFingerprint, CHECKPOINT_FORMAT,
};
pub use staged::{open_staged, save_staged};

use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::external::temp_usage::{Charge, TempKind};
use crate::BuildConfig;

/// The checkpoint directory of a build of `output` whose temporary files go to `temp_dir`.
pub fn checkpoint_dir(output: &Path, temp_dir: &Path) -> PathBuf {
    let name = output
        .file_name()
        .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    temp_dir.join(format!(".{name}.tessera-build"))
}

const MANIFEST: &str = "manifest.json";

/// Why a checkpoint cannot be resumed from.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error(
        "the checkpoint {} was made by another build: {what} was {made}, now {now} \
         (rerun without --resume to start over)", dir.display()
    )]
    Mismatch {
        dir: PathBuf,
        what: String,
        made: String,
        now: String,
    },
    #[error(
        "the checkpoint {} is damaged: {reason} (rerun without --resume to start over)",
        dir.display()
    )]
    Damaged { dir: PathBuf, reason: String },
    #[error("checkpoint {}: {source}", dir.display())]
    Io {
        dir: PathBuf,
        #[source]
        source: io::Error,
    },
}

/// What is told each committed stage's name.
type OnCommit = Box<dyn Fn(&str) + Send + Sync>;

/// An open checkpoint directory and its manifest.
pub struct Checkpoint {
    dir: PathBuf,
    manifest: Manifest,
    on_commit: Option<OnCommit>,
    /// When the last level's checkpoint ended and what it cost (`level_due`).
    last_level: Option<(Instant, Duration)>,
    /// The least time between level checkpoints and the factor of their cost.
    pacing: (Duration, u32),
    /// The listed files' bytes in `temp_bytes_peak`, but for the live and finished patches'
    /// (their stores count them).
    held: Charge,
}

/// The least time between two level checkpoints, and how many times its own cost a checkpoint
/// waits after the last one: a level's checkpoint fsyncs the live and finished patches' files,
/// which after every level of a 5 M-triangle build cost a quarter of its simplification.
const LEVEL_INTERVAL: Duration = Duration::from_secs(1);
const LEVEL_COST_FACTOR: u32 = 10;

/// The manifest of a build of `input` with `config`, before any stage.
pub fn manifest_for(input: Fingerprint, config: &BuildConfig) -> Manifest {
    let mut flags = BTreeMap::new();
    let mut flag = |name: &str, value: String| flags.insert(name.to_string(), value);
    flag("construction", format!("{:?}", config.construction));
    flag("domain", format!("{:?}", config.domain));
    flag("lattice_bits", config.lattice_bits.to_string());
    // The finished patches in the checkpoint are stored as this codec says.
    flag("codec", format!("{:?}", config.codec));
    flag("position_bits", config.position_bits.to_string());
    // The pages are made from the textures' bytes when the file is written: a resume with
    // other textures would not give the bytes its checkpoint's build began.
    if let Some(textures) = &config.textures {
        flag("textures", crate::texture::fingerprint(textures));
    }
    let s = &config.simplify;
    flag("simplify.keep", s.keep.to_string());
    flag("simplify.normal_weight", s.normal_weight.to_string());
    flag("simplify.colour_weight", s.colour_weight.to_string());
    flag("simplify.uv_weight", s.uv_weight.to_string());
    flag("simplify.keep_borders", s.keep_borders.to_string());
    flag("simplify.bounded_errors", s.bounded_errors.to_string());
    flag(
        "simplify.fault_ignore_locks",
        s.fault_ignore_locks.to_string(),
    );
    Manifest {
        format: CHECKPOINT_FORMAT,
        tessera_version: version(),
        input,
        flags,
        stages: Vec::new(),
    }
}

/// The crate's version and the running executable's size and modification time: a rebuilt
/// tessera (whose algorithms may give other bytes) does not resume another's checkpoint.
fn version() -> String {
    let exe = std::env::current_exe().and_then(std::fs::metadata);
    let identity = exe.ok().and_then(|m| {
        let modified = m
            .modified()
            .ok()?
            .duration_since(std::time::UNIX_EPOCH)
            .ok()?;
        Some(format!(
            "executable {} bytes, modified {} ns",
            m.len(),
            modified.as_nanos()
        ))
    });
    format!(
        "{} ({})",
        env!("CARGO_PKG_VERSION"),
        identity.as_deref().unwrap_or("executable unknown")
    )
}

impl Checkpoint {
    /// A fresh checkpoint at `dir` (whatever was there is removed) with no stage done.
    pub fn create(dir: &Path, manifest: Manifest) -> Result<Checkpoint, CheckpointError> {
        let io_at = |source| CheckpointError::Io {
            dir: dir.to_path_buf(),
            source,
        };
        if dir.exists() {
            std::fs::remove_dir_all(dir).map_err(io_at)?;
        }
        std::fs::create_dir_all(dir).map_err(io_at)?;
        let checkpoint = Checkpoint {
            dir: dir.to_path_buf(),
            manifest,
            on_commit: None,
            last_level: None,
            pacing: (LEVEL_INTERVAL, LEVEL_COST_FACTOR),
            held: Charge::new(TempKind::Checkpoint),
        };
        checkpoint.write_manifest().map_err(io_at)?;
        Ok(checkpoint)
    }

    /// The checkpoint at `dir` if it has a manifest: an error when it was made by another
    /// build than `expected` describes, or when a file it lists is missing or damaged.
    /// What the killed build wrote after its last manifest is cut back or removed.
    pub fn open(dir: &Path, expected: Manifest) -> Result<Option<Checkpoint>, CheckpointError> {
        let damaged = |reason: String| CheckpointError::Damaged {
            dir: dir.to_path_buf(),
            reason,
        };
        let Some(manifest) = Checkpoint::read_manifest(dir)? else {
            return Ok(None);
        };
        if let Some((what, made, now)) = manifest::first_mismatch(&manifest, &expected) {
            return Err(CheckpointError::Mismatch {
                dir: dir.to_path_buf(),
                what,
                made,
                now,
            });
        }
        for f in manifest.stages.iter().flat_map(|s| &s.files) {
            let path = dir.join(&f.name);
            let len = std::fs::metadata(&path)
                .map_err(|e| damaged(format!("{}: {e}", f.name)))?
                .len();
            if len < f.bytes {
                return Err(damaged(format!(
                    "{} has {len} bytes, the manifest says {}",
                    f.name, f.bytes
                )));
            }
            if len > f.bytes {
                // An append-only file the killed build went on writing.
                let file = std::fs::OpenOptions::new().write(true).open(&path);
                file.and_then(|file| file.set_len(f.bytes))
                    .map_err(|e| damaged(format!("{}: {e}", f.name)))?;
            }
            if f.sparse {
                continue;
            }
            let crc = manifest::crc_of_prefix(&path, f.bytes)
                .map_err(|e| damaged(format!("{}: {e}", f.name)))?;
            if crc != f.crc32 {
                return Err(damaged(format!(
                    "{}: CRC-32 {crc:08x}, the manifest says {:08x}",
                    f.name, f.crc32
                )));
            }
        }
        let checkpoint = Checkpoint {
            dir: dir.to_path_buf(),
            manifest,
            on_commit: None,
            last_level: None,
            pacing: (LEVEL_INTERVAL, LEVEL_COST_FACTOR),
            held: Charge::new(TempKind::Checkpoint),
        };
        checkpoint
            .remove_unlisted()
            .map_err(|source| CheckpointError::Io {
                dir: dir.to_path_buf(),
                source,
            })?;
        Ok(Some(checkpoint))
    }

    /// The manifest of the checkpoint at `dir`, if it has one, checked against nothing (what
    /// `open` then checks it against may depend on it: standard input is read to its end only
    /// to resume a stage).
    pub fn read_manifest(dir: &Path) -> Result<Option<Manifest>, CheckpointError> {
        let text = match std::fs::read_to_string(dir.join(MANIFEST)) {
            Ok(text) => text,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
            Err(source) => {
                return Err(CheckpointError::Io {
                    dir: dir.to_path_buf(),
                    source,
                })
            }
        };
        serde_json::from_str(&text)
            .map(Some)
            .map_err(|e| CheckpointError::Damaged {
                dir: dir.to_path_buf(),
                reason: format!("{MANIFEST} does not parse ({e})"),
            })
    }

    /// Names the input once it is known (standard input, fingerprinted as the import read it);
    /// only before the first stage is committed.
    pub fn set_input(&mut self, input: Fingerprint) -> io::Result<()> {
        if !self.manifest.stages.is_empty() {
            return Err(io::Error::other(
                "a checkpoint's input is named before its first stage",
            ));
        }
        self.manifest.input = input;
        self.write_manifest()
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// The last completed stage.
    pub fn last_stage(&self) -> Option<&StageRecord> {
        self.manifest.stages.last()
    }

    /// Called with each stage's name once it is committed (progress, and the tests' faults).
    pub fn on_commit(&mut self, f: impl Fn(&str) + Send + Sync + 'static) {
        self.on_commit = Some(Box::new(f));
    }

    /// Whether a level's checkpoint is due: at least `LEVEL_INTERVAL` and ten times the last
    /// one's cost since it ended (the work a kill loses stays small, the checkpoints' cost
    /// within about a tenth of the build).
    pub(crate) fn level_due(&self) -> bool {
        let (interval, factor) = self.pacing;
        self.last_level
            .is_none_or(|(end, cost)| end.elapsed() >= interval.max(cost * factor))
    }

    /// Whether a part of a level is worth saving (`save_level_part`): as `level_due` with
    /// 1.5 times the interval and factor. A part's save costs about what a level's does, and
    /// a build has more of them (up to eight a level). At 10 M triangles (`--memory 1G` and
    /// 256M), three rounds each: at the levels' own pacing the parts cost about 1 s of a 24 s
    /// build (out-of-core ratio 0.690-0.728); at twice it, a kill at 75 % of a build lost 2 s
    /// more (resumed in 60 % of a build); at 1.5 times it, 0.720-0.751 and 36-38 %.
    pub(crate) fn part_due(&self) -> bool {
        let (interval, factor) = self.pacing;
        self.last_level.is_none_or(|(end, cost)| {
            end.elapsed() >= (3 * interval / 2).max(cost * 3 * factor / 2)
        })
    }

    /// Checkpoints after every level (the tests', to stop at a given level).
    pub fn every_level(&mut self) {
        self.pacing = (Duration::ZERO, 0);
    }

    /// Records that a level's checkpoint started at `start` ended now.
    pub(crate) fn level_saved(&mut self, start: Instant) {
        self.last_level = Some((Instant::now(), start.elapsed()));
    }

    pub(crate) fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// Records `stage` as completed: its files (already written) are fsynced, the earlier
    /// stages' files are dropped from the manifest (the new stage holds all a resume needs), a
    /// stage of the same kind (`level-`) is replaced, the manifest is rewritten atomically and
    /// the files it no longer names are removed.
    pub(crate) fn commit(&mut self, stage: StageRecord) -> io::Result<()> {
        self.commit_keeping(stage, &|_| false)
    }

    /// `commit`, keeping the earlier stages' files whose names `keep_earlier` keeps.
    pub(crate) fn commit_keeping(
        &mut self,
        stage: StageRecord,
        keep_earlier: &dyn Fn(&str) -> bool,
    ) -> io::Result<()> {
        for f in &stage.files {
            std::fs::File::open(self.path(&f.name))?.sync_data()?;
        }
        // Until the files the manifest no longer names are removed, the new stage's files are
        // on disk beside them: charged now, so the peak sees both (the live store and the
        // finished patches carry their own charges).
        let listed = self.listed_names();
        let new_bytes: u64 = stage
            .files
            .iter()
            .filter(|f| !charged_elsewhere(&f.name) && !listed.contains(&f.name.as_str()))
            .map(|f| f.bytes)
            .sum();
        self.held.grow(new_bytes);
        let kind = |name: &str| name.split('-').next().unwrap_or_default().to_string();
        let new_kind = kind(&stage.name);
        self.manifest.stages.retain(|s| kind(&s.name) != new_kind);
        for s in &mut self.manifest.stages {
            s.files.retain(|f| keep_earlier(&f.name));
        }
        let name = stage.name.clone();
        self.manifest.stages.push(stage);
        self.write_manifest()?;
        self.remove_unlisted()?;
        if let Some(f) = &self.on_commit {
            f(&name);
        }
        Ok(())
    }

    fn write_manifest(&self) -> io::Result<()> {
        let text = serde_json::to_string_pretty(&self.manifest).map_err(io::Error::other)?;
        bytes::write_atomic(&self.path(MANIFEST), text.as_bytes())
    }

    /// Removes every file the manifest does not name (and charges the ones it names to the
    /// temporary bytes).
    fn remove_unlisted(&self) -> io::Result<()> {
        let charged = self
            .manifest
            .stages
            .iter()
            .flat_map(|s| &s.files)
            .filter(|f| !charged_elsewhere(&f.name))
            .map(|f| f.bytes)
            .sum();
        self.held.release();
        self.held.grow(charged);
        let listed = self.listed_names();
        for entry in std::fs::read_dir(&self.dir)? {
            let entry = entry?;
            let name = entry.file_name();
            let name = name.to_string_lossy();
            if name != MANIFEST && !listed.contains(&name.as_ref()) {
                std::fs::remove_file(entry.path())?;
            }
        }
        Ok(())
    }

    /// The names of every file the manifest lists.
    fn listed_names(&self) -> Vec<&str> {
        self.manifest
            .stages
            .iter()
            .flat_map(|s| s.files.iter().map(|f| f.name.as_str()))
            .collect()
    }

    /// Removes the directory (the build succeeded, or its checkpoint cannot serve).
    pub fn remove(self) -> io::Result<()> {
        std::fs::remove_dir_all(&self.dir)
    }
}

/// Files whose bytes the build charges as it writes them (the live store's, the finished
/// patches' spills), not the checkpoint.
fn charged_elsewhere(name: &str) -> bool {
    name.starts_with("live-") || name.starts_with("finished-")
}
