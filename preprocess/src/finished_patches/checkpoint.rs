//! Finished patches in a build's checkpoint: the three spill files named in its directory
//! (append-only, so a checkpoint records how far they are valid and their CRC-32s); the
//! index is rebuilt from the records' file, whose records carry their keys.

use std::fs::{File, OpenOptions};
use std::io::{self, Read, Seek, SeekFrom, Write};
use std::path::Path;

use super::records::{self, Records, RECORD_BYTES};
use super::{FinishedPatches, Spill, Store};
use crate::checkpoint::{Dec, Enc, FileRecord};
use crate::packed_key::PackedKey;

const PATCHES: &str = "finished-patches.bin";
const IDS: &str = "finished-ids.bin";
const RECORDS: &str = "finished-records.bin";

fn open(path: &Path, truncate: bool) -> io::Result<File> {
    OpenOptions::new()
        .read(true)
        .write(true)
        .create(truncate)
        .truncate(truncate)
        .open(path)
}

impl FinishedPatches {
    /// An empty store in three named files of the checkpoint directory `dir`.
    pub fn new_named(dir: &Path) -> io::Result<FinishedPatches> {
        Ok(FinishedPatches {
            index: Vec::new(),
            sorted: true,
            records: Records::Disk(Spill::at_end(open(&dir.join(RECORDS), true)?, 0, 0)),
            store: Store::Disk {
                patches: Spill::at_end(open(&dir.join(PATCHES), true)?, 0, 0),
                ids: Spill::at_end(open(&dir.join(IDS), true)?, 0, 0),
            },
        })
    }

    /// Writes the record count to `e` and returns the files as far as they are valid
    /// (flushed; the checkpoint fsyncs them).
    pub(crate) fn encode_checkpoint(&mut self, e: &mut Enc) -> io::Result<Vec<FileRecord>> {
        let (Store::Disk { patches, ids }, Records::Disk(records)) =
            (&mut self.store, &mut self.records)
        else {
            return Err(io::Error::other(
                "finished patches in memory cannot be checkpointed",
            ));
        };
        let mut files = Vec::new();
        for (spill, name) in [(patches, PATCHES), (ids, IDS), (records, RECORDS)] {
            spill.writer.flush()?;
            files.push(FileRecord {
                name: name.into(),
                bytes: spill.bytes,
                crc32: spill.crc.clone().finalize(),
                sparse: false,
            });
        }
        e.u64(self.index.len() as u64);
        Ok(files)
    }

    /// The store `encode_checkpoint` described: its files in `dir` cut back to `files'`
    /// lengths, the index read back from the records.
    pub(crate) fn decode_checkpoint(
        d: &mut Dec,
        dir: &Path,
        files: &[FileRecord],
    ) -> io::Result<FinishedPatches> {
        let invalid = |what: &str| io::Error::new(io::ErrorKind::InvalidData, what.to_string());
        let file = |name: &str| -> io::Result<Spill> {
            let record = files
                .iter()
                .find(|f| f.name == name)
                .ok_or_else(|| invalid(&format!("no {name}")))?;
            let mut file = open(&dir.join(name), false)?;
            file.set_len(record.bytes)?;
            file.seek(SeekFrom::End(0))?;
            Ok(Spill::at_end(file, record.bytes, record.crc32))
        };
        let (patches, ids, records) = (file(PATCHES)?, file(IDS)?, file(RECORDS)?);
        let count = d.u64()?;
        if records.bytes != count.saturating_mul(RECORD_BYTES as u64) {
            return Err(invalid("the finished records are not the state's"));
        }
        let mut index = Vec::with_capacity(count as usize);
        let mut input = io::BufReader::with_capacity(1 << 20, records.writer.get_ref());
        input.seek(SeekFrom::Start(0))?;
        for row in 0..count as u32 {
            let mut bytes = [0u8; RECORD_BYTES];
            input.read_exact(&mut bytes)?;
            let (words, p) = records::decode(&bytes);
            let beyond = p.patch_at.saturating_add(p.patch_bytes as u64) > patches.bytes
                || p.id_at.saturating_add(p.id_bytes as u64) > ids.bytes;
            if beyond {
                return Err(invalid("a finished patch beyond its file"));
            }
            let key = PackedKey::from_words(words)
                .ok_or_else(|| invalid("a simplex key no hierarchy makes"))?;
            index.push((key, row));
        }
        drop(input);
        let mut finished = FinishedPatches {
            index,
            sorted: false,
            records: Records::Disk(records),
            store: Store::Disk { patches, ids },
        };
        if let Some(key) = finished.sort_index() {
            return Err(invalid(&format!("simplex {key:?} finished twice")));
        }
        Ok(finished)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::finished_patches::FinishedPatch;
    use tessera_core::bounds::{NormalCone, Sphere};
    use tessera_core::leb::SimplexKey;

    fn record(i: u32) -> FinishedPatch {
        FinishedPatch {
            sphere: Sphere {
                center: [i as f64, 0.5, -1.25],
                radius: 1.0 / (i + 1) as f64,
            },
            cone: NormalCone {
                axis: [0.0, 1.0, 0.0],
                cos: 0.5,
            },
            vertex_count: i,
            strip_index_count: 2 * i,
            triangle_count: 3 * i,
            patch_bytes: 1,
            id_bytes: 1,
            patch_checksum: 7 * i,
            patch_at: i as u64,
            id_at: i as u64,
        }
    }

    fn key(root: u8, level: u16, path: u128) -> SimplexKey {
        SimplexKey { root, level, path }
    }

    /// A named store holding `n` records (keys in reverse order) and a byte per patch and id.
    fn store(dir: &Path, n: u32) -> FinishedPatches {
        let mut f = FinishedPatches::new_named(dir).unwrap();
        for i in 0..n {
            let key = PackedKey::of(key((i % 6) as u8, 20, (n - i) as u128)).unwrap();
            let row = f.records.push(key, &record(i)).unwrap();
            f.index.push((key, row));
            f.sorted = false;
            let Store::Disk { patches, ids } = &mut f.store else {
                unreachable!()
            };
            patches.append(&[i as u8]).unwrap();
            ids.append(&[i as u8]).unwrap();
        }
        f
    }

    #[test]
    fn the_index_comes_back_from_the_records_and_damage_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let mut f = store(dir.path(), 50);
        let mut e = Enc::default();
        let files = f.encode_checkpoint(&mut e).unwrap();
        let state = e.into_bytes();
        // Appended after the checkpoint: cut off when it is read back.
        f.records
            .push(PackedKey::of(key(7, 1, 1)).unwrap(), &record(99))
            .unwrap();
        f.seal().unwrap();
        let expected: Vec<(SimplexKey, FinishedPatch)> = f
            .index
            .iter()
            .filter(|(_, row)| *row < 50)
            .map(|&(k, row)| (k.key(), f.record(row).unwrap()))
            .collect();
        drop(f);
        let back = |files: &[FileRecord]| {
            FinishedPatches::decode_checkpoint(&mut Dec::new(&state), dir.path(), files)
        };
        let mut back_f = back(&files).unwrap();
        back_f.seal().unwrap();
        assert_eq!(back_f.index.len(), 50);
        for (key, p) in &expected {
            let got = back_f.get(*key).unwrap();
            assert_eq!(format!("{got:?}"), format!("{p:?}"));
        }
        drop(back_f);
        // A key without its level's marker bit.
        let path = dir.path().join(RECORDS);
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[RECORD_BYTES * 3..RECORD_BYTES * 3 + 16].fill(0);
        std::fs::write(&path, &bytes).unwrap();
        let error = back(&files).err().expect("a damaged key is refused");
        assert!(error.to_string().contains("no hierarchy makes"), "{error}");
        // A record shorter than the state's count.
        let mut short = files.clone();
        short.iter_mut().find(|f| f.name == RECORDS).unwrap().bytes -= 1;
        let error = back(&short).err().expect("a short file is refused");
        assert!(error.to_string().contains("not the state's"), "{error}");
    }
}
