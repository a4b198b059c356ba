//! Finished patches in a build's checkpoint: the two spill files named in its directory
//! (append-only, so a checkpoint records how far they are valid and their CRC-32s) and the
//! index saved with each checkpoint's state.

use std::fs::{File, OpenOptions};
use std::io::{self, Seek, SeekFrom, Write};
use std::path::Path;

use tessera_core::bounds::{NormalCone, Sphere};

use super::{FinishedPatch, FinishedPatches, IndexKey, Spill, Store};
use crate::checkpoint::{Dec, Enc, FileRecord};

const PATCHES: &str = "finished-patches.bin";
const IDS: &str = "finished-ids.bin";

fn open(path: &Path, truncate: bool) -> io::Result<File> {
    OpenOptions::new()
        .read(true)
        .write(true)
        .create(truncate)
        .truncate(truncate)
        .open(path)
}

impl FinishedPatches {
    /// An empty store in two named files of the checkpoint directory `dir`.
    pub fn new_named(dir: &Path) -> io::Result<FinishedPatches> {
        Ok(FinishedPatches {
            index: Vec::new(),
            sorted: true,
            store: Store::Disk {
                patches: Spill::at_end(open(&dir.join(PATCHES), true)?, 0, 0),
                ids: Spill::at_end(open(&dir.join(IDS), true)?, 0, 0),
            },
        })
    }

    /// Writes the index to `e` and returns the files as far as they are valid (flushed; the
    /// checkpoint fsyncs them).
    pub(crate) fn encode_checkpoint(&mut self, e: &mut Enc) -> io::Result<Vec<FileRecord>> {
        let Store::Disk { patches, ids } = &mut self.store else {
            return Err(io::Error::other(
                "finished patches in memory cannot be checkpointed",
            ));
        };
        let mut files = Vec::new();
        for (spill, name) in [(patches, PATCHES), (ids, IDS)] {
            spill.writer.flush()?;
            files.push(FileRecord {
                name: name.into(),
                bytes: spill.bytes,
                crc32: spill.crc.clone().finalize(),
            });
        }
        // In key order (the packed keys sort as the keys do), as the hash map's entries were.
        self.seal();
        e.list(&self.index, |e, (k, p)| {
            e.key(k.key());
            p.sphere.center.iter().for_each(|&x| e.f64(x));
            e.f64(p.sphere.radius);
            p.cone.axis.iter().for_each(|&x| e.f32(x));
            e.f32(p.cone.cos);
            for x in [
                p.vertex_count,
                p.strip_index_count,
                p.triangle_count,
                p.patch_bytes,
                p.id_bytes,
                p.patch_checksum,
            ] {
                e.u32(x);
            }
            e.u64(p.patch_at);
            e.u64(p.id_at);
        });
        Ok(files)
    }

    /// The store `encode_checkpoint` described: its files in `dir` cut back to `files`' lengths.
    pub(crate) fn decode_checkpoint(
        d: &mut Dec,
        dir: &Path,
        files: &[FileRecord],
    ) -> io::Result<FinishedPatches> {
        let file = |name: &str| -> io::Result<Spill> {
            let record = files
                .iter()
                .find(|f| f.name == name)
                .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidData, format!("no {name}")))?;
            let mut file = open(&dir.join(name), false)?;
            file.set_len(record.bytes)?;
            file.seek(SeekFrom::End(0))?;
            Ok(Spill::at_end(file, record.bytes, record.crc32))
        };
        let (patches, ids) = (file(PATCHES)?, file(IDS)?);
        let entries = d.list(21 + 32 + 16 + 24 + 16, |d| {
            let key = d.key()?;
            let center = [d.f64()?, d.f64()?, d.f64()?];
            let radius = d.f64()?;
            let axis = [d.f32()?, d.f32()?, d.f32()?];
            let cos = d.f32()?;
            let p = FinishedPatch {
                sphere: Sphere { center, radius },
                cone: NormalCone { axis, cos },
                vertex_count: d.u32()?,
                strip_index_count: d.u32()?,
                triangle_count: d.u32()?,
                patch_bytes: d.u32()?,
                id_bytes: d.u32()?,
                patch_checksum: d.u32()?,
                patch_at: d.u64()?,
                id_at: d.u64()?,
            };
            let beyond = p.patch_at.saturating_add(p.patch_bytes as u64) > patches.bytes
                || p.id_at.saturating_add(p.id_bytes as u64) > ids.bytes;
            if beyond {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidData,
                    "a finished patch beyond its file",
                ));
            }
            let key = IndexKey::of(key).ok_or_else(|| {
                io::Error::new(
                    io::ErrorKind::InvalidData,
                    "a simplex key no hierarchy makes",
                )
            })?;
            Ok((key, p))
        })?;
        let mut finished = FinishedPatches {
            index: entries,
            sorted: false,
            store: Store::Disk { patches, ids },
        };
        if let Some(key) = finished.sort_index() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!("simplex {key:?} finished twice"),
            ));
        }
        Ok(finished)
    }
}
