//! A mesh staged on disk for the out-of-core build: flat files of fixed-size records in a
//! temporary directory, written as the input streams in, welded by external sorts
//! (`weld.rs`), read back in order or by ranges.
//!
//! Files (little-endian, records back to back):
//! `positions` per vertex (`[f32; 3]` where every one is an f32, else `[f64; 3]`:
//! `position_file.rs`), `triangles` `[u32; 3]` per triangle, and where the
//! input has them `normals` `[f32; 3]`, `colors` `[u8; 4]`, `uvs` `[f32; 2]` per vertex. All
//! files are unnamed temporaries (`tempfile::tempfile_in`): nothing is left behind when the
//! build ends, fails or is killed.

use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Write};
use std::marker::PhantomData;
use std::path::{Path, PathBuf};

use bytemuck::Pod;

use super::chunk_reader::{ChunkReader, ConsumingChunks};
use super::file_io::{keep_unnamed_at, ReadAt};
use super::position_file::{PositionFile, PositionWriter};
pub use super::staged_mesh::StagedMesh;
use super::temp_usage::{Charge, TempKind};

/// Buffer size of the record readers and writers.
pub(super) const IO_BUFFER: usize = 1 << 20;

/// A file of fixed-size records, written once then read from the start (any number of times).
pub struct RecordFile<T: Pod> {
    /// `None` once a checkpoint's file is discarded: closing it lets the disk space go when
    /// the checkpoint removes the name.
    file: std::sync::Mutex<Option<File>>,
    records: u64,
    charge: Charge,
    /// A checkpoint's file (`open_kept`): `discard` leaves it alone.
    kept: bool,
    _record: PhantomData<T>,
}

impl<T: Pod> RecordFile<T> {
    /// A new empty file in `dir`.
    pub fn create(dir: &Path) -> io::Result<RecordWriter<T>> {
        let file = tempfile::tempfile_in(dir)?;
        Ok(RecordWriter {
            writer: BufWriter::with_capacity(IO_BUFFER, file),
            records: 0,
            charge: Charge::new(TempKind::StagedMesh),
            uncharged: 0,
            _record: PhantomData,
        })
    }

    /// Number of records.
    pub fn len(&self) -> u64 {
        self.records
    }

    pub fn is_empty(&self) -> bool {
        self.records == 0
    }

    /// Bytes on disk.
    pub fn bytes(&self) -> u64 {
        self.records * std::mem::size_of::<T>() as u64
    }

    /// Empties the file (its disk space is freed; the records are gone, reading fails). A
    /// checkpoint's file is only closed: the checkpoint removes it when it no longer needs it,
    /// and then nothing holds its space.
    pub fn discard(&self) -> io::Result<()> {
        let mut file = self.file.lock().unwrap_or_else(|e| e.into_inner());
        if self.kept {
            *file = None;
            return Ok(());
        }
        if let Some(file) = file.as_ref() {
            file.set_len(0)?;
        }
        self.charge.release();
        Ok(())
    }

    /// A reader of the records from the first, with an offset of its own: readers on other
    /// threads do not move it.
    fn reader_at_start(&self) -> io::Result<ReadAt> {
        Ok(ReadAt {
            file: self.handle()?,
            at: 0,
        })
    }

    /// Another handle on the file (it shares the offset: read it with `ReadAt`).
    fn handle(&self) -> io::Result<File> {
        match self.file.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            Some(file) => file.try_clone(),
            None => Err(io::Error::other(
                "a staged file was read after it was discarded",
            )),
        }
    }

    /// Streams every record from the first.
    pub fn read(&self) -> io::Result<RecordReader<T>> {
        Ok(RecordReader {
            reader: BufReader::with_capacity(IO_BUFFER, self.reader_at_start()?),
            left: self.records,
            _record: PhantomData,
        })
    }

    /// Streams the records in chunks of at most `records` (at least one), for passes that
    /// work on many records at once.
    pub fn read_chunks(&self, records: usize) -> io::Result<ChunkReader<T>> {
        Ok(ChunkReader {
            file: self.reader_at_start()?,
            left: self.records,
            chunk: records.max(1),
            _record: PhantomData,
        })
    }

    /// `read_chunks` for a pass that replaces the file: the disk space of what was read is
    /// given back as it goes (`holes::punch`; a checkpoint's file is only read).
    pub fn consume_chunks(self, records: usize) -> io::Result<ConsumingChunks<T>> {
        Ok(ConsumingChunks {
            reader: self.read_chunks(records)?,
            file: self,
            freed: 0,
        })
    }

    /// Gives back the disk space of the whole blocks in `start..end` (records already read
    /// by a pass that replaces the file); a checkpoint's file is left whole.
    pub(super) fn free_range(&self, start: u64, end: u64) {
        if self.kept {
            return;
        }
        let file = self.file.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(file) = file.as_ref() {
            self.charge.shrink(super::holes::punch(file, start, end));
        }
    }

    /// Names the records `path` (a checkpoint's file) and hands them to the checkpoint: from
    /// then on `discard` leaves them and their bytes are the checkpoint's, not this file's
    /// (the charge is given back). The unnamed file itself is linked at `path` where the file
    /// system allows it (`O_TMPFILE` on Linux), so the records are on disk once and nothing
    /// is copied; elsewhere they are copied and the unnamed file closed. Returns the
    /// records' CRC-32.
    pub(crate) fn keep_at(&mut self, path: &Path) -> io::Result<u32> {
        let (crc32, copy) = keep_unnamed_at(&self.handle()?, self.bytes(), path)?;
        if let Some(copy) = copy {
            *self.file.lock().unwrap_or_else(|e| e.into_inner()) = Some(copy);
        }
        self.charge.release();
        self.kept = true;
        Ok(crc32)
    }

    /// A file of `records` records that is gone (a checkpoint's, read into another form):
    /// its length is known, reading it is an error.
    pub(crate) fn vacant(records: u64) -> RecordFile<T> {
        RecordFile {
            file: std::sync::Mutex::new(None),
            records,
            charge: Charge::new(TempKind::StagedMesh),
            kept: true,
            _record: PhantomData,
        }
    }

    /// The records of a checkpoint's file (`keep_at`'s) of `bytes` bytes, opened read-only.
    pub(crate) fn open_kept(path: &Path, bytes: u64) -> io::Result<RecordFile<T>> {
        let size = std::mem::size_of::<T>() as u64;
        if !bytes.is_multiple_of(size) || File::open(path)?.metadata()?.len() != bytes {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!("{}: not {bytes} bytes of records", path.display()),
            ));
        }
        Ok(RecordFile {
            file: std::sync::Mutex::new(Some(File::open(path)?)),
            records: bytes / size,
            charge: Charge::new(TempKind::StagedMesh),
            kept: true,
            _record: PhantomData,
        })
    }

    /// Every record, in memory.
    pub fn read_all(&self) -> io::Result<Vec<T>> {
        let mut out = Vec::with_capacity(self.records as usize);
        for r in self.read()? {
            out.push(r?);
        }
        Ok(out)
    }
}

/// Appends records to a new `RecordFile`.
pub struct RecordWriter<T: Pod> {
    writer: BufWriter<File>,
    records: u64,
    charge: Charge,
    /// Bytes pushed but not yet charged (`CHARGE_BATCH`).
    uncharged: u64,
    _record: PhantomData<T>,
}

/// Bytes a writer pushes one record at a time before it charges them to the temporary
/// accounting: a charge is a few atomic operations, which at one a record were a tenth of a
/// large import's time. The accounting lags the file by less than this (its writer's buffer
/// lags the disk as much).
const CHARGE_BATCH: u64 = 256 << 10;

impl<T: Pod> RecordWriter<T> {
    pub fn push(&mut self, record: &T) -> io::Result<()> {
        self.records += 1;
        self.uncharged += std::mem::size_of::<T>() as u64;
        if self.uncharged >= CHARGE_BATCH {
            self.charge.grow(std::mem::take(&mut self.uncharged));
        }
        self.writer.write_all(bytemuck::bytes_of(record))
    }

    /// Appends `records` in one write.
    pub fn push_all(&mut self, records: &[T]) -> io::Result<()> {
        let bytes: &[u8] = bytemuck::cast_slice(records);
        self.records += records.len() as u64;
        self.uncharged += bytes.len() as u64;
        if self.uncharged >= CHARGE_BATCH {
            self.charge.grow(std::mem::take(&mut self.uncharged));
        }
        self.writer.write_all(bytes)
    }

    /// The records written so far.
    pub fn len(&self) -> u64 {
        self.records
    }

    pub fn is_empty(&self) -> bool {
        self.records == 0
    }

    /// Flushes and hands the file over for reading.
    pub fn finish(self) -> io::Result<RecordFile<T>> {
        self.charge.grow(self.uncharged);
        let file = self.writer.into_inner().map_err(|e| e.into_error())?;
        Ok(RecordFile {
            file: std::sync::Mutex::new(Some(file)),
            records: self.records,
            charge: self.charge,
            kept: false,
            _record: PhantomData,
        })
    }
}

/// Streams a `RecordFile`'s records.
pub struct RecordReader<T: Pod> {
    reader: BufReader<ReadAt>,
    left: u64,
    _record: PhantomData<T>,
}

impl<T: Pod> Iterator for RecordReader<T> {
    type Item = io::Result<T>;

    fn next(&mut self) -> Option<io::Result<T>> {
        if self.left == 0 {
            return None;
        }
        self.left -= 1;
        let mut record = T::zeroed();
        Some(
            self.reader
                .read_exact(bytemuck::bytes_of_mut(&mut record))
                .map(|()| record),
        )
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.left as usize, Some(self.left as usize))
    }
}

/// Per-vertex attribute files, where the input has them.
pub struct VertexAttributes {
    pub normals: Option<RecordFile<[f32; 3]>>,
    pub colors: Option<RecordFile<[u8; 4]>>,
    pub uvs: Option<RecordFile<[f32; 2]>>,
}

/// Normals, colours and UVs read into memory, where the mesh has them.
pub type LoadedAttributes = (
    Option<Vec<[f32; 3]>>,
    Option<Vec<[u8; 4]>>,
    Option<Vec<[f32; 2]>>,
);

impl VertexAttributes {
    /// Reads every attribute file whole.
    pub fn read_all(&self) -> io::Result<LoadedAttributes> {
        Ok((
            self.normals
                .as_ref()
                .map(RecordFile::read_all)
                .transpose()?,
            self.colors.as_ref().map(RecordFile::read_all).transpose()?,
            self.uvs.as_ref().map(RecordFile::read_all).transpose()?,
        ))
    }
}

/// A mesh as read from a file, before welding, staged on disk.
pub struct RawStaged {
    pub positions: PositionFile,
    pub triangles: RecordFile<[u32; 3]>,
    pub attributes: VertexAttributes,
    /// (triangle, colour as `u32::from_le_bytes`) of every triangle with a face colour,
    /// ascending; the weld first puts them on corners of their own (`face_colors.rs`).
    pub face_colors: Option<RecordFile<[u32; 2]>>,
}

impl RawStaged {
    /// Stages a mesh already in memory.
    pub fn from_raw(raw: &crate::import::RawMesh, dir: &Path) -> io::Result<RawStaged> {
        let mut stager = RawStager::new(
            dir,
            raw.normals.is_some(),
            raw.colors.is_some(),
            raw.uvs.is_some(),
        )?;
        for (i, &position) in raw.positions.iter().enumerate() {
            stager.push_vertex(&RawVertex {
                position,
                normal: raw.normals.as_ref().map_or([0.0; 3], |n| n[i]),
                color: raw.colors.as_ref().map_or([0; 4], |c| c[i]),
                uv: raw.uvs.as_ref().map_or([0.0; 2], |u| u[i]),
            })?;
        }
        for &t in &raw.triangles {
            stager.push_triangle(t)?;
        }
        stager.finish()
    }
}

/// Writes a mesh as it is read: vertices (with the attributes the input declared) and
/// triangles, in any interleaving.
pub struct RawStager {
    dir: PathBuf,
    positions: PositionWriter,
    triangles: RecordWriter<[u32; 3]>,
    normals: Option<RecordWriter<[f32; 3]>>,
    colors: Option<RecordWriter<[u8; 4]>>,
    uvs: Option<RecordWriter<[f32; 2]>>,
    /// (triangle, colour) of the triangles with a face colour, once one has.
    face_colors: Option<RecordWriter<[u32; 2]>>,
}

/// One vertex as an importer reads it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RawVertex {
    pub position: [f64; 3],
    pub normal: [f32; 3],
    pub color: [u8; 4],
    pub uv: [f32; 2],
}

impl RawStager {
    /// Stages into `dir`; `normals`, `colors`, `uvs`: which attributes the input has (every
    /// vertex then carries them).
    pub fn new(dir: &Path, normals: bool, colors: bool, uvs: bool) -> io::Result<Self> {
        Ok(RawStager {
            dir: dir.to_path_buf(),
            positions: PositionFile::create(dir)?,
            triangles: RecordFile::create(dir)?,
            normals: normals.then(|| RecordFile::create(dir)).transpose()?,
            colors: colors.then(|| RecordFile::create(dir)).transpose()?,
            uvs: uvs.then(|| RecordFile::create(dir)).transpose()?,
            face_colors: None,
        })
    }

    pub fn push_vertex(&mut self, v: &RawVertex) -> io::Result<()> {
        self.positions.push(&v.position)?;
        if let Some(n) = &mut self.normals {
            n.push(&v.normal)?;
        }
        if let Some(c) = &mut self.colors {
            c.push(&v.color)?;
        }
        if let Some(u) = &mut self.uvs {
            u.push(&v.uv)?;
        }
        Ok(())
    }

    pub fn push_triangle(&mut self, t: [u32; 3]) -> io::Result<()> {
        self.triangles.push(&t)
    }

    /// `push_triangle` of each, in one write.
    pub fn push_triangles(&mut self, t: &[[u32; 3]]) -> io::Result<()> {
        self.triangles.push_all(t)
    }

    /// The last `triangles` triangles (one face's) have the face colour `color`: their corners
    /// become vertices of that colour when the mesh is welded (`face_colors.rs`).
    pub fn face_color(&mut self, triangles: usize, color: [u8; 4]) -> io::Result<()> {
        let dir = &self.dir;
        let file = match &mut self.face_colors {
            Some(file) => file,
            None => self.face_colors.insert(RecordFile::create(dir)?),
        };
        let end = self.triangles.len();
        for t in end.saturating_sub(triangles as u64)..end {
            file.push(&[t as u32, u32::from_le_bytes(color)])?;
        }
        Ok(())
    }

    /// Drops the colours staged so far and stages no more (their file goes).
    pub fn forget_colors(&mut self) {
        self.colors = None;
    }

    /// The directory it stages into.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    pub fn finish(self) -> io::Result<RawStaged> {
        Ok(RawStaged {
            positions: self.positions.finish()?,
            triangles: self.triangles.finish()?,
            attributes: VertexAttributes {
                normals: self.normals.map(RecordWriter::finish).transpose()?,
                colors: self.colors.map(RecordWriter::finish).transpose()?,
                uvs: self.uvs.map(RecordWriter::finish).transpose()?,
            },
            face_colors: self.face_colors.map(RecordWriter::finish).transpose()?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn readers_of_one_file_keep_their_own_place() {
        let dir = tempfile::tempdir().unwrap();
        let mut writer = RecordFile::<[u32; 3]>::create(dir.path()).unwrap();
        for i in 0..100_000u32 {
            writer.push(&[i, i, i]).unwrap();
        }
        let file = writer.finish().unwrap();
        // Interleaved, as the use counts and the barycentres' join read the triangles.
        let mut a = file.read().unwrap();
        let mut b = file.read_chunks(777).unwrap();
        let mut next = 0u32;
        let mut chunk = Vec::new();
        while b.read_into(&mut chunk).unwrap() {
            for r in &chunk {
                assert_eq!(*r, [next; 3]);
                assert_eq!(a.next().unwrap().unwrap(), [next; 3]);
                next += 1;
            }
        }
        assert_eq!(next, 100_000);
        assert!(a.next().is_none());
    }

    #[test]
    fn a_discarded_file_gives_back_its_disk_and_cannot_be_read() {
        let dir = tempfile::tempdir().unwrap();
        let mut writer = RecordFile::<[u32; 3]>::create(dir.path()).unwrap();
        for i in 0..1000u32 {
            writer.push(&[i, i + 1, i + 2]).unwrap();
        }
        let file = writer.finish().unwrap();
        assert_eq!(file.handle().unwrap().metadata().unwrap().len(), 12_000);
        assert_eq!(file.charge.bytes(), 12_000);
        assert_eq!(file.read_all().unwrap()[999], [999, 1000, 1001]);
        file.discard().unwrap();
        assert_eq!(file.handle().unwrap().metadata().unwrap().len(), 0);
        assert_eq!(file.charge.bytes(), 0);
        assert!(
            file.read_all().is_err(),
            "a discarded file read as if whole"
        );
    }
}
