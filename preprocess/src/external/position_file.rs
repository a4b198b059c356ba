//! A staged mesh's positions: f32 records while every position written is exactly an f32
//! (a binary PLY's or an STL's always are: half the disk of f64), f64 from the first one that
//! is not (the f32 records written so far are widened then, once). Read back as f64 either
//! way, bit for bit what was written.

use std::io;
use std::path::{Path, PathBuf};

use super::chunk_reader::ChunkReader;
use super::cursor::Cursor;
use super::staged::{RecordFile, RecordReader, RecordWriter};

pub enum PositionFile {
    Narrow(RecordFile<[f32; 3]>),
    Wide(RecordFile<[f64; 3]>),
}

/// A checkpoint's names of the file: the record width is in them.
const NARROW_NAME: &str = "staged-positions-f32.bin";
const WIDE_NAME: &str = "staged-positions.bin";

/// Whether `p` is exactly an f32 position.
fn narrows(p: &[f64; 3]) -> bool {
    p.iter().all(|&x| (x as f32) as f64 == x)
}

impl PositionFile {
    /// A new empty file in `dir`.
    pub fn create(dir: &Path) -> io::Result<PositionWriter> {
        Ok(PositionWriter::Narrow {
            dir: dir.to_path_buf(),
            records: RecordFile::create(dir)?,
        })
    }

    /// Number of positions.
    pub fn len(&self) -> u64 {
        match self {
            PositionFile::Narrow(f) => f.len(),
            PositionFile::Wide(f) => f.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Bytes on disk.
    pub fn bytes(&self) -> u64 {
        match self {
            PositionFile::Narrow(f) => f.bytes(),
            PositionFile::Wide(f) => f.bytes(),
        }
    }

    /// `RecordFile::discard`.
    pub fn discard(&self) -> io::Result<()> {
        match self {
            PositionFile::Narrow(f) => f.discard(),
            PositionFile::Wide(f) => f.discard(),
        }
    }

    /// Streams every position from the first.
    pub fn read(&self) -> io::Result<PositionReader> {
        Ok(match self {
            PositionFile::Narrow(f) => PositionReader::Narrow(f.read()?),
            PositionFile::Wide(f) => PositionReader::Wide(f.read()?),
        })
    }

    /// Streams the positions in chunks of at most `records` (at least one), as f64.
    pub fn read_chunks(&self, records: usize) -> io::Result<PositionChunks> {
        Ok(match self {
            PositionFile::Narrow(f) => PositionChunks::Narrow(f.read_chunks(records)?, Vec::new()),
            PositionFile::Wide(f) => PositionChunks::Wide(f.read_chunks(records)?),
        })
    }

    /// Every position, in memory.
    pub fn read_all(&self) -> io::Result<Vec<[f64; 3]>> {
        self.read()?.collect()
    }

    /// The name a checkpoint gives the file.
    pub(crate) fn checkpoint_name(&self) -> &'static str {
        match self {
            PositionFile::Narrow(_) => NARROW_NAME,
            PositionFile::Wide(_) => WIDE_NAME,
        }
    }

    /// `RecordFile::keep_at`.
    pub(crate) fn keep_at(&mut self, path: &Path) -> io::Result<u32> {
        match self {
            PositionFile::Narrow(f) => f.keep_at(path),
            PositionFile::Wide(f) => f.keep_at(path),
        }
    }

    /// A checkpoint's file of `bytes` bytes named by `checkpoint_name` (`name`), opened
    /// read-only; `None` for another name.
    pub(crate) fn open_kept(name: &str, path: &Path, bytes: u64) -> io::Result<Option<Self>> {
        Ok(match name {
            NARROW_NAME => Some(PositionFile::Narrow(RecordFile::open_kept(path, bytes)?)),
            WIDE_NAME => Some(PositionFile::Wide(RecordFile::open_kept(path, bytes)?)),
            _ => None,
        })
    }
}

/// Appends positions to a new `PositionFile`.
pub enum PositionWriter {
    Narrow {
        dir: PathBuf,
        records: RecordWriter<[f32; 3]>,
    },
    Wide(RecordWriter<[f64; 3]>),
}

impl PositionWriter {
    pub fn push(&mut self, p: &[f64; 3]) -> io::Result<()> {
        if let PositionWriter::Narrow { records, .. } = self {
            if narrows(p) {
                return records.push(&p.map(|x| x as f32));
            }
            self.widen()?;
        }
        match self {
            PositionWriter::Wide(records) => records.push(p),
            PositionWriter::Narrow { .. } => unreachable!("widened"),
        }
    }

    /// Appends `positions`, as `push` would one by one: a run of them that all narrow to f32
    /// in one write.
    pub fn push_all(&mut self, positions: &[[f64; 3]]) -> io::Result<()> {
        let mut narrow: Vec<[f32; 3]> = Vec::new();
        for chunk in positions.chunks(1 << 16) {
            if let PositionWriter::Narrow { records, .. } = self {
                if chunk.iter().all(narrows) {
                    narrow.clear();
                    narrow.extend(chunk.iter().map(|p| p.map(|x| x as f32)));
                    records.push_all(&narrow)?;
                    continue;
                }
            }
            chunk.iter().try_for_each(|p| self.push(p))?;
        }
        Ok(())
    }

    /// Rewrites the f32 records written so far as f64 (the f32 file is removed).
    fn widen(&mut self) -> io::Result<()> {
        let PositionWriter::Narrow { dir, records } = self else {
            return Ok(());
        };
        let mut wide = RecordFile::<[f64; 3]>::create(dir)?;
        let narrow = std::mem::replace(records, RecordFile::create(dir)?).finish()?;
        for p in narrow.read()? {
            wide.push(&p?.map(f64::from))?;
        }
        *self = PositionWriter::Wide(wide);
        Ok(())
    }

    /// The positions written so far.
    pub fn len(&self) -> u64 {
        match self {
            PositionWriter::Narrow { records, .. } => records.len(),
            PositionWriter::Wide(records) => records.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Flushes and hands the file over for reading.
    pub fn finish(self) -> io::Result<PositionFile> {
        Ok(match self {
            PositionWriter::Narrow { records, .. } => PositionFile::Narrow(records.finish()?),
            PositionWriter::Wide(records) => PositionFile::Wide(records.finish()?),
        })
    }
}

/// Streams a `PositionFile`'s positions as f64.
pub enum PositionReader {
    Narrow(RecordReader<[f32; 3]>),
    Wide(RecordReader<[f64; 3]>),
}

impl Iterator for PositionReader {
    type Item = io::Result<[f64; 3]>;

    fn next(&mut self) -> Option<io::Result<[f64; 3]>> {
        match self {
            PositionReader::Narrow(r) => r.next().map(|p| p.map(|p| p.map(f64::from))),
            PositionReader::Wide(r) => r.next(),
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        match self {
            PositionReader::Narrow(r) => r.size_hint(),
            PositionReader::Wide(r) => r.size_hint(),
        }
    }
}

/// Reads positions a chunk at a time, as f64 (`PositionFile::read_chunks`).
pub enum PositionChunks {
    /// The reader and its f32 chunk, widened into the caller's.
    Narrow(ChunkReader<[f32; 3]>, Vec<[f32; 3]>),
    Wide(ChunkReader<[f64; 3]>),
}

impl PositionChunks {
    /// The next chunk into `positions` (cleared first); false at the end.
    pub fn read_into(&mut self, positions: &mut Vec<[f64; 3]>) -> io::Result<bool> {
        match self {
            PositionChunks::Narrow(reader, narrow) => {
                positions.clear();
                let more = reader.read_into(narrow)?;
                positions.extend(narrow.iter().map(|p| p.map(f64::from)));
                Ok(more)
            }
            PositionChunks::Wide(reader) => reader.read_into(positions),
        }
    }
}

/// Reads positions by ascending index a block at a time (`cursor.rs`), as f64.
pub(super) enum PositionCursor {
    Narrow(Cursor<[f32; 3]>),
    Wide(Cursor<[f64; 3]>),
}

/// A cursor's block allocations, handed from one cursor to the next (a fresh block each time
/// costs page faults).
#[derive(Default)]
pub(super) struct PositionBlocks {
    narrow: Vec<[f32; 3]>,
    wide: Vec<[f64; 3]>,
}

impl PositionCursor {
    /// A cursor at the first position, reading into `blocks` (`into_blocks` gives them back).
    pub(super) fn reusing(file: &PositionFile, blocks: &mut PositionBlocks) -> io::Result<Self> {
        Ok(match file {
            PositionFile::Narrow(f) => {
                PositionCursor::Narrow(Cursor::reusing(f, std::mem::take(&mut blocks.narrow))?)
            }
            PositionFile::Wide(f) => {
                PositionCursor::Wide(Cursor::reusing(f, std::mem::take(&mut blocks.wide))?)
            }
        })
    }

    pub(super) fn new(file: &PositionFile) -> io::Result<Self> {
        PositionCursor::reusing(file, &mut PositionBlocks::default())
    }

    /// The position of vertex `index`; indices must ascend (`Cursor::at`).
    pub(super) fn at(&mut self, index: u32) -> [f64; 3] {
        match self {
            PositionCursor::Narrow(c) => c.at(index).map(f64::from),
            PositionCursor::Wide(c) => c.at(index),
        }
    }

    /// The first read error, if any; the block goes back to `blocks`.
    pub(super) fn finish(self, blocks: &mut PositionBlocks) -> io::Result<()> {
        let error = match self {
            PositionCursor::Narrow(mut c) => {
                blocks.narrow = std::mem::take(&mut c.block);
                c.error
            }
            PositionCursor::Wide(mut c) => {
                blocks.wide = std::mem::take(&mut c.block);
                c.error
            }
        };
        error.map_or(Ok(()), Err)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn written(dir: &Path, positions: &[[f64; 3]]) -> PositionFile {
        let mut w = PositionFile::create(dir).unwrap();
        for p in positions {
            w.push(p).unwrap();
        }
        w.finish().unwrap()
    }

    #[test]
    fn positions_pushed_together_are_the_file_pushed_one_by_one() {
        let dir = tempfile::tempdir().unwrap();
        let mut many: Vec<[f64; 3]> = (0..200_000)
            .map(|i| [i as f64, 0.5, -(i as f64) * 0.25])
            .collect();
        for widened in [false, true] {
            if widened {
                many[150_001][2] = 0.1; // inside the third chunk of the second call
            }
            let one_by_one = written(dir.path(), &many);
            let mut w = PositionFile::create(dir.path()).unwrap();
            w.push_all(&many[..70_000]).unwrap();
            w.push_all(&many[70_000..]).unwrap();
            let together = w.finish().unwrap();
            assert_eq!(matches!(together, PositionFile::Wide(_)), widened);
            assert_eq!(together.bytes(), one_by_one.bytes());
            assert_eq!(together.read_all().unwrap(), many);
        }
    }

    #[test]
    fn positions_are_f32_records_until_one_is_not_and_read_back_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let f32s: Vec<[f64; 3]> = (0..1000)
            .map(|i| [i as f64 * 0.25, -(i as f64), f64::from(1e30f32)])
            .collect();
        let narrow = written(dir.path(), &f32s);
        assert!(matches!(narrow, PositionFile::Narrow(_)));
        assert_eq!(narrow.bytes(), 12 * 1000);
        assert_eq!(narrow.read_all().unwrap(), f32s);

        // One position that is not an f32, late: everything is widened, nothing lost.
        let mut mixed = f32s.clone();
        mixed[700][1] = 0.1;
        let wide = written(dir.path(), &mixed);
        assert!(matches!(wide, PositionFile::Wide(_)));
        assert_eq!(wide.bytes(), 24 * 1000);
        assert_eq!(wide.read_all().unwrap(), mixed);

        let mut blocks = PositionBlocks::default();
        for (file, expected) in [(&narrow, &f32s), (&wide, &mixed)] {
            let mut cursor = PositionCursor::reusing(file, &mut blocks).unwrap();
            for i in (0..1000).step_by(7) {
                assert_eq!(cursor.at(i), expected[i as usize]);
            }
            cursor.finish(&mut blocks).unwrap();
            let mut cursor = PositionCursor::new(file).unwrap();
            cursor.at(1000);
            assert!(cursor.finish(&mut blocks).is_err(), "past the end");
        }
    }
}
