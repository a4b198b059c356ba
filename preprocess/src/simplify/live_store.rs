//! The live patches (the current mesh's), by simplex: in memory, or under a memory budget in
//! a temporary file with only an index in memory (issue 12). Workers read patches in
//! parallel (`pread`); the simplification's main thread adds and removes them. The file is
//! append-only; a removed patch's bytes are given back to the file system once nothing needs
//! them (`holes::punch`): at the end of each level for an unnamed file, and for a build's
//! checkpoint only after a later commit no longer names them, so a resumed build always finds
//! the records its checkpoint names. The file is never rewritten: rewriting it held a copy of
//! the live patches beside the old file the checkpoint still named. Its records are
//! `live_record.rs`'s, each with its CRC-32 in the index (a file with holes has no whole-file
//! checksum that stays true).

use std::borrow::Cow;
use std::fs::File;
use std::io;
use std::os::unix::fs::{FileExt, MetadataExt};
use std::path::Path;

use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;
use tessera_core::leb::SimplexKey;

use super::live_record::{decode_patch, decode_triangles, encode_patch, triangle_bytes, HEAD};
use super::positions::SimplifierScale;
use crate::external::temp_usage::{Charge, TempKind};
use crate::packed_key::PackedKey;
use crate::vertex_table::LivePatch;

pub(super) enum LiveStore {
    Memory(HashMap<SimplexKey, LivePatch>),
    Disk(DiskStore),
}

pub(super) struct DiskStore {
    file: File,
    /// Where each live patch's record is, its size, triangle count and CRC-32.
    index: HashMap<PackedKey, Record>,
    end: u64,
    charge: Charge,
    /// Whether the file is a build's checkpoint's (`LIVE_FILE`).
    named: bool,
    /// The records the checkpoint's last commit names, (offset, bytes) by offset: their bytes
    /// stay until a later commit names others.
    committed: Vec<(u64, u32)>,
    /// Records removed whose bytes may still be on disk.
    dead: Vec<(u64, u32)>,
    /// The records the last `checkpoint` gave a commit, by offset: the commit's once it is
    /// done (`release_dead` is called only then).
    asked: std::sync::Mutex<Option<Vec<(u64, u32)>>>,
    /// The simplifier's positions its records leave out are computed with this.
    scale: SimplifierScale,
}

/// Where a checkpointed store's records are: the file's valid length, and each live patch's
/// record (key, offset, bytes, triangles, CRC-32).
pub(super) struct StoreCheckpoint {
    pub end: u64,
    pub records: Vec<(PackedKey, u64, u32, u32, u32)>,
}

/// The name of a checkpointed store's file in its checkpoint directory.
pub(super) const LIVE_FILE: &str = "live-patches.bin";

#[derive(Clone, Copy)]
struct Record {
    at: u64,
    bytes: u32,
    triangles: u32,
    crc: u32,
}

/// Records `insert_all` encodes in parallel and writes at once.
const INSERT_CHUNK: usize = 64;

fn damaged(what: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, what)
}

impl LiveStore {
    /// An empty store in memory, or in an unnamed file in `spill_dir` (its records' simplifier
    /// positions computed with `scale` where they can be).
    pub(super) fn new(spill_dir: Option<&Path>, scale: SimplifierScale) -> io::Result<LiveStore> {
        let Some(dir) = spill_dir else {
            return Ok(LiveStore::Memory(HashMap::default()));
        };
        Ok(LiveStore::Disk(DiskStore::on(
            tempfile::tempfile_in(dir)?,
            false,
            scale,
        )))
    }

    /// An empty store in the file `LIVE_FILE` of a build's checkpoint directory.
    pub(super) fn new_named(dir: &Path, scale: SimplifierScale) -> io::Result<LiveStore> {
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(dir.join(LIVE_FILE))?;
        Ok(LiveStore::Disk(DiskStore::on(file, true, scale)))
    }

    /// A checkpointed store again: its file cut back to the checkpoint's length, every record
    /// it names checked against its CRC-32, and the space of any other record given back.
    pub(super) fn reopen(
        dir: &Path,
        at: StoreCheckpoint,
        scale: SimplifierScale,
    ) -> io::Result<LiveStore> {
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(dir.join(LIVE_FILE))?;
        file.set_len(at.end)?;
        let mut store = DiskStore::on(file, true, scale);
        store.end = at.end;
        let mut bytes = Vec::new();
        for &(key, at, size, triangles, crc) in &at.records {
            bytes.resize(size as usize, 0);
            store.file.read_exact_at(&mut bytes, at)?;
            if crc32fast::hash(&bytes) != crc {
                return Err(damaged(format!(
                    "{LIVE_FILE}: the record at {at} does not match its CRC-32"
                )));
            }
            let record = Record {
                at,
                bytes: size,
                triangles,
                crc,
            };
            store.index.insert(key, record);
        }
        store.committed = store.records_by_offset();
        // Whatever lies between the named records is dead (merged before the commit, or
        // after it by the build that was killed).
        let mut from = 0;
        for &(at, bytes) in &store.committed {
            crate::external::holes::punch(&store.file, from, at);
            from = at + bytes as u64;
        }
        crate::external::holes::punch(&store.file, from, store.end);
        store.charge_allocated()?;
        Ok(LiveStore::Disk(store))
    }

    /// Where a checkpointed store's records are (its file is synced by the checkpoint);
    /// `None` for a store that is not in a checkpoint. Asked for by a commit: from then on
    /// the records named here are kept, and those the previous commit named may go
    /// (`release_dead`, once the commit is done).
    pub(super) fn checkpoint(&self) -> Option<StoreCheckpoint> {
        let LiveStore::Disk(store) = self else {
            return None;
        };
        if !store.named {
            return None;
        }
        let mut records: Vec<(PackedKey, u64, u32, u32, u32)> = store
            .index
            .iter()
            .map(|(k, r)| (*k, r.at, r.bytes, r.triangles, r.crc))
            .collect();
        records.sort_unstable_by_key(|r| r.0);
        *store.asked.lock().unwrap_or_else(|e| e.into_inner()) = Some(store.records_by_offset());
        Some(StoreCheckpoint {
            end: store.end,
            records,
        })
    }

    /// The patch of `key`, if live.
    pub(super) fn get(&self, key: &SimplexKey) -> io::Result<Option<Cow<'_, LivePatch>>> {
        match self {
            LiveStore::Memory(map) => Ok(map.get(key).map(Cow::Borrowed)),
            LiveStore::Disk(store) => match store.index.get(&PackedKey::of_hierarchy(*key)) {
                None => Ok(None),
                Some(record) => store.read(record).map(|p| Some(Cow::Owned(p))),
            },
        }
    }

    /// The triangles of `key`'s patch, if live (without its vertices).
    pub(super) fn triangles(&self, key: &SimplexKey) -> io::Result<Option<Cow<'_, [[u32; 3]]>>> {
        match self {
            LiveStore::Memory(map) => Ok(map.get(key).map(|p| Cow::Borrowed(&p.triangles[..]))),
            LiveStore::Disk(store) => match store.index.get(&PackedKey::of_hierarchy(*key)) {
                None => Ok(None),
                Some(record) => {
                    let mut head = [0u8; HEAD];
                    store.file.read_exact_at(&mut head, record.at)?;
                    let mut bytes = vec![0u8; triangle_bytes(&head)];
                    store.file.read_exact_at(&mut bytes, record.at)?;
                    Ok(Some(Cow::Owned(decode_triangles(&bytes)?)))
                }
            },
        }
    }

    /// Makes room for `patches` patches in all.
    pub(super) fn reserve(&mut self, patches: usize) {
        match self {
            LiveStore::Memory(map) => map.reserve(patches.saturating_sub(map.len())),
            LiveStore::Disk(store) => store
                .index
                .reserve(patches.saturating_sub(store.index.len())),
        }
    }

    /// Inserts `patches`: on disk, their records encoded in parallel and appended in order, a
    /// chunk at a time.
    pub(super) fn insert_all(&mut self, patches: Vec<(SimplexKey, LivePatch)>) -> io::Result<()> {
        match self {
            LiveStore::Memory(map) => {
                map.extend(patches);
                Ok(())
            }
            LiveStore::Disk(store) => {
                for chunk in patches.chunks(INSERT_CHUNK) {
                    let scale = store.scale;
                    let records: Vec<Vec<u8>> = chunk
                        .par_iter()
                        .map(|(_, p)| encode_patch(p, &scale))
                        .collect();
                    let mut bytes = Vec::with_capacity(records.iter().map(Vec::len).sum());
                    for ((key, patch), record) in chunk.iter().zip(&records) {
                        let old = store.index.insert(
                            PackedKey::of_hierarchy(*key),
                            Record {
                                at: store.end + bytes.len() as u64,
                                bytes: u32::try_from(record.len()).expect("a live record < 4 GiB"),
                                triangles: patch.triangles.len() as u32,
                                crc: crc32fast::hash(record),
                            },
                        );
                        if let Some(old) = old {
                            store.dead.push((old.at, old.bytes));
                        }
                        bytes.extend_from_slice(record);
                    }
                    store.write_at_end(&bytes)?;
                }
                Ok(())
            }
        }
    }

    pub(super) fn remove(&mut self, key: &SimplexKey) -> io::Result<()> {
        match self {
            LiveStore::Memory(map) => {
                map.remove(key);
                Ok(())
            }
            LiveStore::Disk(store) => {
                if let Some(record) = store.index.remove(&PackedKey::of_hierarchy(*key)) {
                    store.dead.push((record.at, record.bytes));
                }
                Ok(())
            }
        }
    }

    /// Whether removed records wait for a commit (their bytes stay on disk until one no longer
    /// names them): a level's checkpoint is then due whatever its pacing, else they pile up
    /// level after level (at 2 M triangles, 1.65x the input against 1.51x; at 100 M the
    /// commits after every level cost 2.4 s of 155).
    pub(super) fn holds_dead_records(&self) -> bool {
        match self {
            LiveStore::Memory(_) => false,
            LiveStore::Disk(store) => !store.dead.is_empty(),
        }
    }

    /// Gives back the space of the removed records that neither the live patches nor the
    /// checkpoint's last commit name. Call it only when the commit a `checkpoint` was asked
    /// for is done (or none was asked for since the last call).
    pub(super) fn release_dead(&mut self) -> io::Result<()> {
        match self {
            LiveStore::Memory(_) => Ok(()),
            LiveStore::Disk(store) => {
                let asked = store.asked.get_mut().unwrap_or_else(|e| e.into_inner());
                if let Some(records) = asked.take() {
                    store.committed = records;
                }
                store.release_all_dead_ranges()
            }
        }
    }
}

impl DiskStore {
    fn on(file: File, named: bool, scale: SimplifierScale) -> DiskStore {
        DiskStore {
            file,
            index: HashMap::default(),
            end: 0,
            charge: Charge::new(TempKind::LiveStore),
            named,
            committed: Vec::new(),
            dead: Vec::new(),
            asked: Default::default(),
            scale,
        }
    }

    /// The live records' (offset, bytes), by offset.
    fn records_by_offset(&self) -> Vec<(u64, u32)> {
        let mut records: Vec<(u64, u32)> = self.index.values().map(|r| (r.at, r.bytes)).collect();
        records.sort_unstable();
        records
    }

    /// Punches out every gap between kept records (the live ones and those the last commit
    /// names) that holds a dead record; a dead record the commit still names waits. The
    /// charge is then the file's allocated bytes.
    fn release_all_dead_ranges(&mut self) -> io::Result<()> {
        if self.dead.is_empty() {
            return Ok(());
        }
        let mut kept = self.records_by_offset();
        kept.extend_from_slice(&self.committed);
        kept.sort_unstable();
        kept.dedup();
        let named_by_commit = |d: &(u64, u32)| self.committed.binary_search(d).is_ok();
        let (waiting, dead): (Vec<_>, Vec<_>) =
            self.dead.iter().copied().partition(named_by_commit);
        let mut gaps: Vec<(u64, u64)> = dead
            .iter()
            .map(|&(at, _)| {
                // The kept records before and after `at` bound its gap.
                let next = kept.partition_point(|&(k, _)| k < at);
                let start = next
                    .checked_sub(1)
                    .map_or(0, |i| kept[i].0 + kept[i].1 as u64);
                let end = kept.get(next).map_or(self.end, |&(k, _)| k);
                (start.min(at), end)
            })
            .collect();
        gaps.sort_unstable();
        gaps.dedup();
        for (start, end) in gaps {
            crate::external::holes::punch(&self.file, start, end);
        }
        self.dead = waiting;
        self.charge_allocated()
    }

    /// Sets the charge to the file's allocated bytes.
    fn charge_allocated(&mut self) -> io::Result<()> {
        let allocated = self.file.metadata()?.blocks() * 512;
        let charged = self.charge.bytes();
        if allocated < charged {
            self.charge.shrink(charged - allocated);
        } else {
            self.charge.grow(allocated - charged);
        }
        Ok(())
    }

    /// Appends records (already in the index) to the file.
    fn write_at_end(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.file.write_all_at(bytes, self.end)?;
        self.end += bytes.len() as u64;
        self.charge.grow(bytes.len() as u64);
        Ok(())
    }

    /// One `pread` of the whole record.
    fn read(&self, record: &Record) -> io::Result<LivePatch> {
        let mut bytes = vec![0u8; record.bytes as usize];
        self.file.read_exact_at(&mut bytes, record.at)?;
        decode_patch(&bytes, &self.scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simplify::live_record::tests::{patch, scale};
    use tessera_core::leb::Simplex;

    /// `n` keys of simplices (roots and their descendants).
    fn keys(n: usize) -> Vec<SimplexKey> {
        let mut simplices: Vec<Simplex> = Simplex::roots(3, 10);
        let mut next = 0;
        while simplices.len() < n {
            let [a, b] = simplices[next].children();
            simplices.extend([a, b]);
            next += 1;
        }
        simplices.iter().take(n).map(|s| s.key).collect()
    }

    fn disk(store: &LiveStore) -> &DiskStore {
        let LiveStore::Disk(disk) = store else {
            unreachable!()
        };
        disk
    }

    fn allocated(store: &LiveStore) -> u64 {
        disk(store).file.metadata().unwrap().blocks() * 512
    }

    fn content(store: &LiveStore, keys: &[SimplexKey]) -> Vec<Option<LivePatch>> {
        keys.iter()
            .map(|k| store.get(k).unwrap().map(Cow::into_owned))
            .collect()
    }

    #[test]
    fn a_disk_store_gives_back_what_it_was_given_and_the_space_of_what_was_removed() {
        let dir = tempfile::tempdir().unwrap();
        // Enough records for many of `insert_all`'s chunks and many blocks.
        let keys = keys(64 * INSERT_CHUNK);
        for attributes in [false, true] {
            let mut store = LiveStore::new(Some(dir.path()), scale()).unwrap();
            let all: Vec<(SimplexKey, LivePatch)> = keys
                .iter()
                .enumerate()
                .map(|(i, k)| (*k, patch(i as u32, attributes)))
                .collect();
            // Two calls: records from both sit side by side.
            let (first, second) = all.split_at(5);
            store.insert_all(first.to_vec()).unwrap();
            store.insert_all(second.to_vec()).unwrap();
            // The first half goes (one long run of dead records), then every third.
            let half = keys.len() / 2;
            for k in keys[..half].iter().chain(keys[half..].iter().step_by(3)) {
                store.remove(k).unwrap();
            }
            let before = allocated(&store);
            store.release_dead().unwrap();
            let after = allocated(&store);
            // Where the file system punches holes, the first half's blocks are gone.
            let punches = after < before;
            if punches {
                assert!(after <= before / 2 + 4096, "{before} → {after}");
            }
            assert_eq!(disk(&store).charge.bytes(), after);
            for (i, got) in content(&store, &keys).into_iter().enumerate() {
                let gone = i < half || (i - half).is_multiple_of(3);
                assert_eq!(got, (!gone).then(|| patch(i as u32, attributes)), "{i}");
                let triangles = store.triangles(&keys[i]).unwrap().map(Cow::into_owned);
                assert_eq!(triangles, got_triangles(gone, i as u32, attributes));
            }
        }
    }

    fn got_triangles(gone: bool, seed: u32, attributes: bool) -> Option<Vec<[u32; 3]>> {
        (!gone).then(|| patch(seed, attributes).triangles)
    }

    #[test]
    fn a_commit_keeps_what_it_names_until_a_later_commit_is_done() {
        let dir = tempfile::tempdir().unwrap();
        let keys = keys(32 * INSERT_CHUNK);
        let half = keys.len() / 2;
        let all: Vec<(SimplexKey, LivePatch)> = keys
            .iter()
            .enumerate()
            .map(|(i, k)| (*k, patch(i as u32, true)))
            .collect();
        let mut store = LiveStore::new_named(dir.path(), scale()).unwrap();
        store.insert_all(all[..half].to_vec()).unwrap();
        // A commit names the first half.
        let first_commit = store.checkpoint().unwrap();
        store.release_dead().unwrap();
        // A level replaces it with the second half; no commit yet: nothing may go.
        for k in &keys[..half] {
            store.remove(k).unwrap();
        }
        store.insert_all(all[half..].to_vec()).unwrap();
        let before = allocated(&store);
        store.release_dead().unwrap();
        assert_eq!(allocated(&store), before);
        // (Reopening would cut the file back: a resumed build's, not this one's.)
        assert!(intact(dir.path(), &first_commit));
        // A second commit names the second half: once it is done the first half's space goes.
        let second_commit = store.checkpoint().unwrap();
        store.release_dead().unwrap();
        let after = allocated(&store);
        drop(store);
        let reopened = LiveStore::reopen(dir.path(), second_commit, scale()).unwrap();
        let expected: Vec<Option<LivePatch>> = (0..keys.len())
            .map(|i| (i >= half).then(|| patch(i as u32, true)))
            .collect();
        assert_eq!(content(&reopened, &keys), expected);
        if after < before {
            // The first commit's records are holes now.
            assert!(!intact(dir.path(), &first_commit));
        }
    }

    /// Whether every record `commit` names is whole in the checkpoint's file.
    fn intact(dir: &Path, commit: &StoreCheckpoint) -> bool {
        let bytes = std::fs::read(dir.join(LIVE_FILE)).unwrap();
        commit.records.iter().all(|&(_, at, n, _, crc)| {
            crc32fast::hash(&bytes[at as usize..at as usize + n as usize]) == crc
        })
    }

    #[test]
    fn a_damaged_record_is_refused_when_the_store_is_reopened() {
        let dir = tempfile::tempdir().unwrap();
        let keys = keys(8);
        let mut store = LiveStore::new_named(dir.path(), scale()).unwrap();
        let all: Vec<(SimplexKey, LivePatch)> = keys
            .iter()
            .enumerate()
            .map(|(i, k)| (*k, patch(i as u32, false)))
            .collect();
        store.insert_all(all).unwrap();
        let commit = store.checkpoint().unwrap();
        drop(store);
        let path = dir.path().join(LIVE_FILE);
        let mut bytes = std::fs::read(&path).unwrap();
        let at = commit.records[3].1 as usize + HEAD;
        bytes[at] ^= 1;
        std::fs::write(&path, bytes).unwrap();
        let error = LiveStore::reopen(dir.path(), commit, scale()).err();
        assert_eq!(error.unwrap().kind(), io::ErrorKind::InvalidData);
    }
}
