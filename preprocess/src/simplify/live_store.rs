//! The live patches (the current mesh's), by simplex: in memory, or under a memory budget in
//! an unnamed temporary file with only an index in memory (issue 12). Workers read patches in
//! parallel (`pread`); the simplification's main thread adds and removes them. The file is
//! append-only and rewritten with only the live patches when the dead ones outweigh them.
//! Its records are `live_record.rs`'s.

use std::borrow::Cow;
use std::fs::File;
use std::io;
use std::os::unix::fs::FileExt;
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
    dir: std::path::PathBuf,
    /// Where each live patch's record is, its size and its triangle count: 32 bytes an
    /// entry (a `SimplexKey` and u64 sizes took 64).
    index: HashMap<PackedKey, Record>,
    end: u64,
    live_bytes: u64,
    charge: Charge,
    /// In a build's checkpoint: the directory and the file's generation (`live-G.bin`, a new
    /// one at each rewrite), and the CRC-32 of the bytes written so far.
    named: Option<(std::path::PathBuf, u32)>,
    crc: crc32fast::Hasher,
    committed: Committed,
    /// The simplifier's positions its records leave out are computed with this.
    scale: SimplifierScale,
}

/// What the checkpoint's last commit holds of a named store: its generation and length, and
/// the bytes of that generation's file kept while a newer one is current (a resumed build
/// reads it; the next commit removes it).
struct Committed {
    at: std::sync::Mutex<Option<(u32, u64)>>,
    retained: Charge,
}

impl Default for Committed {
    fn default() -> Self {
        Committed {
            at: Default::default(),
            retained: Charge::new(TempKind::Checkpoint),
        }
    }
}

/// Where a checkpointed store's records are: its file's name, valid length and CRC-32, and
/// each live patch's record (key, offset, bytes, triangles).
pub(super) struct StoreCheckpoint {
    pub generation: u32,
    pub end: u64,
    pub crc32: u32,
    pub records: Vec<(PackedKey, u64, u32, u32)>,
}

/// The name of a checkpointed store's file of `generation`.
pub(super) fn live_file_name(generation: u32) -> String {
    format!("live-{generation}.bin")
}

#[derive(Clone, Copy)]
struct Record {
    at: u64,
    bytes: u32,
    triangles: u32,
}

/// Records `insert_all` encodes in parallel and writes at once.
const INSERT_CHUNK: usize = 64;
/// Bytes of adjacent records a rewrite copies at once.
const COPY_BYTES: u64 = 1 << 20;

impl LiveStore {
    /// An empty store in memory, or in an unnamed file in `spill_dir` (its records' simplifier
    /// positions computed with `scale` where they can be).
    pub(super) fn new(spill_dir: Option<&Path>, scale: SimplifierScale) -> io::Result<LiveStore> {
        let Some(dir) = spill_dir else {
            return Ok(LiveStore::Memory(HashMap::default()));
        };
        Ok(LiveStore::Disk(DiskStore {
            file: tempfile::tempfile_in(dir)?,
            dir: dir.to_path_buf(),
            index: HashMap::default(),
            end: 0,
            live_bytes: 0,
            charge: Charge::new(TempKind::LiveStore),
            named: None,
            crc: crc32fast::Hasher::new(),
            committed: Committed::default(),
            scale,
        }))
    }

    /// An empty store in a named file of a build's checkpoint directory.
    pub(super) fn new_named(dir: &Path, scale: SimplifierScale) -> io::Result<LiveStore> {
        Ok(LiveStore::Disk(DiskStore::named(dir, 0, scale)?))
    }

    /// A checkpointed store again (its file cut back to the checkpoint's length).
    pub(super) fn reopen(
        dir: &Path,
        at: StoreCheckpoint,
        scale: SimplifierScale,
    ) -> io::Result<LiveStore> {
        let path = dir.join(live_file_name(at.generation));
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)?;
        file.set_len(at.end)?;
        let charge = Charge::new(TempKind::LiveStore);
        charge.grow(at.end);
        let index: HashMap<PackedKey, Record> = at
            .records
            .iter()
            .map(|&(key, at, bytes, triangles)| {
                (
                    key,
                    Record {
                        at,
                        bytes,
                        triangles,
                    },
                )
            })
            .collect();
        Ok(LiveStore::Disk(DiskStore {
            file,
            dir: dir.to_path_buf(),
            live_bytes: index.values().map(|r| r.bytes as u64).sum(),
            index,
            end: at.end,
            charge,
            named: Some((dir.to_path_buf(), at.generation)),
            crc: crc32fast::Hasher::new_with_initial_len(at.crc32, at.end),
            committed: Committed {
                at: std::sync::Mutex::new(Some((at.generation, at.end))),
                retained: Charge::new(TempKind::Checkpoint),
            },
            scale,
        }))
    }

    /// Where a checkpointed store's records are (its file written so far is synced by the
    /// checkpoint); `None` for a store that is not in a checkpoint.
    pub(super) fn checkpoint(&self) -> Option<StoreCheckpoint> {
        let LiveStore::Disk(store) = self else {
            return None;
        };
        let (_, generation) = store.named.as_ref()?;
        let mut records: Vec<(PackedKey, u64, u32, u32)> = store
            .index
            .iter()
            .map(|(k, r)| (*k, r.at, r.bytes, r.triangles))
            .collect();
        records.sort_unstable_by_key(|r| r.0);
        // Asked for by a commit: from then on the checkpoint names this file and length, and
        // no longer an older generation's.
        *store.committed.at.lock().unwrap_or_else(|e| e.into_inner()) =
            Some((*generation, store.end));
        store.committed.retained.release();
        Some(StoreCheckpoint {
            generation: *generation,
            end: store.end,
            crc32: store.crc.clone().finalize(),
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
                        store.index.insert(
                            PackedKey::of_hierarchy(*key),
                            Record {
                                at: store.end + bytes.len() as u64,
                                bytes: u32::try_from(record.len()).expect("a live record < 4 GiB"),
                                triangles: patch.triangles.len() as u32,
                            },
                        );
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
                    store.live_bytes -= record.bytes as u64;
                }
                Ok(())
            }
        }
    }

    /// Rewrites the file with only the live patches when the dead ones take more room.
    pub(super) fn compact(&mut self) -> io::Result<()> {
        let LiveStore::Disk(store) = self else {
            return Ok(());
        };
        if store.end > 2 * store.live_bytes.max(1 << 20) {
            store.rewrite()?;
        }
        Ok(())
    }
}

impl DiskStore {
    /// A new file with only the live records, in their order.
    fn rewrite(&mut self) -> io::Result<()> {
        let store = self;
        let mut fresh = match &store.named {
            Some((dir, generation)) => DiskStore::named(dir, generation + 1, store.scale)?,
            None => DiskStore {
                file: tempfile::tempfile_in(&store.dir)?,
                dir: store.dir.clone(),
                index: HashMap::default(),
                end: 0,
                live_bytes: 0,
                charge: Charge::new(TempKind::LiveStore),
                named: None,
                crc: crc32fast::Hasher::new(),
                committed: Committed::default(),
                scale: store.scale,
            },
        };
        let mut records: Vec<(PackedKey, Record)> =
            store.index.iter().map(|(k, r)| (*k, *r)).collect();
        records.sort_unstable_by_key(|(_, r)| r.at);
        // What the old file must keep: the prefix a checkpoint's last commit names (a resumed
        // build reads it until the next commit names the new file); the rest is freed behind
        // the copy (`holes::punch`), so the two files together hold about that prefix and the
        // live records, not the whole old file besides.
        let committed = *store.committed.at.lock().unwrap_or_else(|e| e.into_inner());
        let kept = match (&store.named, committed) {
            (Some((_, generation)), Some((g, end))) if g == *generation => Some(end),
            _ => None,
        };
        let mut freed_to = kept.unwrap_or(0);
        // Records are copied as they are, a run of adjacent ones (up to `COPY_BYTES`) a read.
        let mut buffer = Vec::new();
        let mut rest = &records[..];
        while let Some(&(_, first)) = rest.first() {
            let mut end = first.at + first.bytes as u64;
            let n = 1 + rest[1..]
                .iter()
                .take_while(|(_, r)| {
                    let adjacent = r.at == end && end - first.at < COPY_BYTES;
                    end += r.bytes as u64 * adjacent as u64;
                    adjacent
                })
                .count();
            buffer.resize((end - first.at) as usize, 0);
            store.file.read_exact_at(&mut buffer, first.at)?;
            for &(key, record) in &rest[..n] {
                let at = fresh.end + (record.at - first.at);
                fresh.index.insert(key, Record { at, ..record });
            }
            fresh.write_at_end(&buffer)?;
            rest = &rest[n..];
            if end > freed_to {
                let freed = crate::external::holes::punch(&store.file, freed_to, end);
                store.charge.shrink(freed);
                freed_to = end / 4096 * 4096;
            }
        }
        // The old file: cut back to the prefix a commit names, or removed if none does.
        store.charge.release();
        if let Some((dir, generation)) = &store.named {
            match kept {
                Some(kept) => {
                    store.file.set_len(kept)?;
                    store.committed.retained.grow(kept);
                }
                None => std::fs::remove_file(dir.join(live_file_name(*generation)))?,
            }
        }
        fresh.committed = std::mem::take(&mut store.committed);
        *store = fresh;
        Ok(())
    }

    /// An empty store in the checkpoint's file of `generation` (the older file stays until
    /// the checkpoint no longer names it).
    fn named(dir: &Path, generation: u32, scale: SimplifierScale) -> io::Result<DiskStore> {
        let path = dir.join(live_file_name(generation));
        Ok(DiskStore {
            file: std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(true)
                .open(path)?,
            dir: dir.to_path_buf(),
            index: HashMap::default(),
            end: 0,
            live_bytes: 0,
            charge: Charge::new(TempKind::LiveStore),
            named: Some((dir.to_path_buf(), generation)),
            crc: crc32fast::Hasher::new(),
            committed: Committed::default(),
            scale,
        })
    }

    /// Appends records (already in the index) to the file.
    fn write_at_end(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.file.write_all_at(bytes, self.end)?;
        self.crc.update(bytes);
        self.end += bytes.len() as u64;
        self.live_bytes += bytes.len() as u64;
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

    #[test]
    fn a_disk_store_gives_back_what_it_was_given_through_removals_and_compaction() {
        let dir = tempfile::tempdir().unwrap();
        let roots = Simplex::roots(3, 10);
        // Enough simplices for several of `insert_all`'s chunks.
        let mut simplices: Vec<Simplex> = roots.clone();
        let mut next = 0;
        while simplices.len() < 3 * INSERT_CHUNK {
            let [a, b] = simplices[next].children();
            simplices.extend([a, b]);
            next += 1;
        }
        let keys: Vec<SimplexKey> = simplices.iter().map(|s| s.key).collect();
        for attributes in [false, true] {
            let mut store = LiveStore::new(Some(dir.path()), scale()).unwrap();
            // One call, then another: records from two calls sit side by side.
            let all: Vec<(SimplexKey, LivePatch)> = keys
                .iter()
                .enumerate()
                .map(|(i, k)| (*k, patch(i as u32, attributes)))
                .collect();
            let (first, second) = all.split_at(5);
            store.insert_all(first.to_vec()).unwrap();
            store.insert_all(second.to_vec()).unwrap();
            for k in keys.iter().step_by(2) {
                store.remove(k).unwrap();
            }
            let LiveStore::Disk(disk) = &mut store else {
                unreachable!()
            };
            let before = disk.end;
            disk.rewrite().unwrap();
            assert!(disk.end < before, "{} → {}", before, disk.end);
            for (i, k) in keys.iter().enumerate() {
                let got = store.get(k).unwrap().map(Cow::into_owned);
                let triangles = store.triangles(k).unwrap().map(Cow::into_owned);
                if i % 2 == 0 {
                    assert_eq!(got, None);
                    assert_eq!(triangles, None);
                } else {
                    let expected = patch(i as u32, attributes);
                    assert_eq!(triangles.as_deref(), Some(&expected.triangles[..]));
                    assert_eq!(got, Some(expected));
                }
            }
        }
    }

    #[test]
    fn a_rewrite_keeps_of_the_old_file_only_what_the_last_commit_names() {
        let dir = tempfile::tempdir().unwrap();
        let keys: Vec<SimplexKey> = Simplex::roots(3, 10).iter().map(|s| s.key).collect();
        let mut store = LiveStore::new_named(dir.path(), scale()).unwrap();
        let all: Vec<(SimplexKey, LivePatch)> = keys
            .iter()
            .enumerate()
            .map(|(i, k)| (*k, patch(i as u32, true)))
            .collect();
        store.insert_all(all[..3].to_vec()).unwrap();
        let committed = store.checkpoint().unwrap();
        store.insert_all(all[3..].to_vec()).unwrap();
        for k in &keys[..4] {
            store.remove(k).unwrap();
        }
        let LiveStore::Disk(disk) = &mut store else {
            unreachable!()
        };
        disk.rewrite().unwrap();
        // Generation 0 is what the commit names, cut back to its length; 1 is current.
        let length =
            |g: u32| std::fs::metadata(dir.path().join(live_file_name(g))).map(|m| m.len());
        assert_eq!(length(0).unwrap(), committed.end);
        disk.rewrite().unwrap();
        // Generation 1 was never committed: gone.
        assert!(length(1).is_err());
        assert_eq!(length(0).unwrap(), committed.end);
        for (i, k) in keys.iter().enumerate() {
            let got = store.get(k).unwrap().map(Cow::into_owned);
            assert_eq!(got, (i >= 4).then(|| patch(i as u32, true)));
        }
        // The committed records are still whole in generation 0.
        let reopened = LiveStore::reopen(dir.path(), committed, scale()).unwrap();
        for (i, k) in keys[..3].iter().enumerate() {
            let got = reopened.get(k).unwrap().map(Cow::into_owned);
            assert_eq!(got, Some(patch(i as u32, true)));
        }
    }
}
