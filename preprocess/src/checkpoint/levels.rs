//! Stages `leaves` and `level-N`: the simplification's state before its first level and after
//! each. Files: `hierarchy.bin` (the frame and the split diamonds, written once: the hierarchy
//! is rebuilt by splitting them again in (level, id) order), `state-N.bin` (the use counts,
//! the live simplices and the indexes of the live and finished patches, `LevelState::encode`),
//! and the append-only files those indexes point into (`live-patches.bin`, `finished-*.bin`),
//! recorded at their length and CRC-32 when the stage was committed (the live patches' file
//! has holes where removed patches were: its records are checked by their own CRC-32s). What the build knew of its
//! input (bounding box, counts, attributes) is in the stage's values.

use std::io;

use super::hierarchy::{
    decode_hierarchy, encode_hierarchy, invalid, write_file, write_streamed, HIERARCHY,
};
use super::{Checkpoint, Dec, FileRecord, InputFacts, StageRecord};
use crate::finished_patches::FinishedPatches;
use crate::hierarchy::Hierarchy;
use crate::simplify::LevelState;

/// A build's state between two levels, read back from its checkpoint.
pub(crate) struct LevelsCheckpoint {
    pub facts: InputFacts,
    pub hierarchy: Hierarchy,
    pub state: LevelState,
    pub finished: FinishedPatches,
    /// The part files of the next level saved so far (`save_level_part`), in order.
    pub parts: Vec<std::path::PathBuf>,
}

/// A part file's name: `part-L-K.bin`, the K-th part of the level after L levels.
fn part_name(levels_done: usize, k: usize) -> String {
    format!("part-{levels_done}-{k}.bin")
}

/// Saves a part of the level after `state`'s (`simplify/partial_level.rs`: results that
/// `write` encodes, `diamonds` of the level's done with it) as a stage naming the last
/// stage's files and the level's parts so far. Only when a part is due
/// (`Checkpoint::part_due`) and the last stage is `state`'s; says where it saved them.
pub(crate) fn save_level_part(
    checkpoint: &mut Checkpoint,
    state: &LevelState,
    diamonds: usize,
    write: &dyn Fn(&mut crate::checkpoint::Enc) -> io::Result<()>,
) -> io::Result<Option<std::path::PathBuf>> {
    if !checkpoint.part_due() {
        return Ok(None);
    }
    let start = std::time::Instant::now();
    let Some(last) = checkpoint
        .last_stage()
        .filter(|s| s.name == "leaves" || s.name.starts_with("level-"))
        .cloned()
    else {
        return Ok(None);
    };
    let done = state.levels_done() as u64;
    if last.values.get("levels_done") != Some(&done) {
        // The level before was not committed (its pacing): a part would not follow it.
        return Ok(None);
    }
    let k = last
        .files
        .iter()
        .filter(|f| f.name.starts_with("part-"))
        .count();
    let name = part_name(state.levels_done(), k);
    let file = write_streamed(checkpoint, &name, write)?;
    let mut stage = last;
    // `level-L.part-K`: of the levels' kind (it replaces the last level's stage), but not a
    // level for `--stop-after` or a resume's report.
    stage.name = format!("level-{done}.part-{}", k + 1);
    stage.files.push(file);
    stage.values.insert("part_diamonds".into(), diamonds as u64);
    checkpoint.level_saved(start);
    checkpoint.commit(stage)?;
    Ok(Some(checkpoint.path(&name)))
}

/// Saves the state after `state.levels_done()` levels and commits stage `leaves` (none yet)
/// or `level-N` — after a level only when one is due (`Checkpoint::level_due`) or the live
/// store holds removed patches (`LevelState::checkpoint_wanted`: they stay on disk until a
/// commit no longer names them), so in practice after every level: levels merged since the
/// last checkpoint are merged again by a resumed build.
pub(crate) fn save_levels(
    checkpoint: &mut Checkpoint,
    facts: &InputFacts,
    hierarchy: &Hierarchy,
    state: &LevelState,
    finished: &mut FinishedPatches,
) -> io::Result<()> {
    if state.levels_done() > 0 && !checkpoint.level_due() && !state.checkpoint_wanted() {
        return Ok(());
    }
    let start = std::time::Instant::now();
    let mut files = Vec::new();
    // The hierarchy once; later stages name the same file.
    let written = checkpoint
        .last_stage()
        .and_then(|s| s.files.iter().find(|f| f.name == HIERARCHY))
        .cloned();
    files.push(match written {
        Some(record) => record,
        None => write_file(checkpoint, HIERARCHY, &encode_hierarchy(hierarchy))?,
    });
    let done = state.levels_done();
    // Streamed to its file: the use counts alone are 4 bytes a vertex.
    let mut finished_files = Vec::new();
    let state_file = write_streamed(checkpoint, &format!("state-{done}.bin"), |e| {
        state.encode(e)?;
        finished_files = finished.encode_checkpoint(e)?;
        Ok(())
    })?;
    files.extend(finished_files);
    let (name, bytes) = state
        .store_file()
        .ok_or_else(|| io::Error::other("the live patches are not in the checkpoint"))?;
    files.push(FileRecord {
        name,
        bytes,
        crc32: 0,
        sparse: true,
    });
    files.push(state_file);
    let mut values = facts.values();
    values.insert("levels_done".into(), done as u64);
    checkpoint.level_saved(start);
    checkpoint.commit(StageRecord {
        name: if done == 0 {
            "leaves".into()
        } else {
            format!("level-{done}")
        },
        files,
        values,
    })
}

/// Commits the last stage again without the level's part files, if it has any (the level is
/// about to merge: its results' payloads are read from the parts, still open, and their disk
/// space given back as they are taken). Returns the parts' bytes. A build killed from then
/// on until the level's commit simplifies the whole level again.
pub(crate) fn drop_level_parts(checkpoint: &mut Checkpoint) -> io::Result<u64> {
    let Some(last) = checkpoint.last_stage().cloned() else {
        return Ok(0);
    };
    let (parts, files): (Vec<_>, Vec<_>) =
        (last.files.into_iter()).partition(|f| f.name.starts_with("part-"));
    if parts.is_empty() {
        return Ok(0);
    }
    let mut values = last.values;
    let done = values
        .remove("part_diamonds")
        .map(|_| ())
        .and_then(|()| values.get("levels_done").copied());
    let done = done.ok_or_else(|| invalid("a level's part in a stage of no level"))?;
    checkpoint.commit(StageRecord {
        // Of the levels' kind, but not a level for `--stop-after` (it was reached before).
        name: format!("level-{done}.merging"),
        files,
        values,
    })?;
    Ok(parts.iter().map(|f| f.bytes).sum())
}

/// The state of a checkpoint whose last stage is `leaves` or `level-N`.
pub(crate) fn load_levels(checkpoint: &Checkpoint) -> io::Result<Option<LevelsCheckpoint>> {
    let Some(stage) = checkpoint
        .last_stage()
        .filter(|s| s.name == "leaves" || s.name.starts_with("level-"))
    else {
        return Ok(None);
    };
    let facts = InputFacts::from_values(&stage.values)?;
    let done = *stage
        .values
        .get("levels_done")
        .ok_or_else(|| invalid("no levels_done"))?;
    let hierarchy = decode_hierarchy(&std::fs::read(checkpoint.path(HIERARCHY))?)?;
    let bytes = std::fs::read(checkpoint.path(&format!("state-{done}.bin")))?;
    let mut d = Dec::new(&bytes);
    let state = LevelState::decode(&mut d, checkpoint.dir(), &hierarchy.frame)?;
    let finished = FinishedPatches::decode_checkpoint(&mut d, checkpoint.dir(), &stage.files)?;
    d.finish()?;
    if state.levels_done() as u64 != done {
        return Err(invalid("the state is not the stage's"));
    }
    let part_files = stage.files.iter().filter(|f| f.name.starts_with("part-"));
    let parts = part_files
        .enumerate()
        .map(|(k, f)| {
            if f.name != part_name(done as usize, k) {
                return Err(invalid("a level's part out of order"));
            }
            Ok(checkpoint.path(&f.name))
        })
        .collect::<io::Result<Vec<_>>>()?;
    Ok(Some(LevelsCheckpoint {
        facts,
        hierarchy,
        state,
        finished,
        parts,
    }))
}
