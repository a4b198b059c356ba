//! Reading a `RecordFile` a chunk of records at a time (`ChunkReader`), and freeing what was
//! read behind the reader (`ConsumingChunks`) for passes that replace the file.

use std::io::{self, Read};
use std::marker::PhantomData;

use bytemuck::Pod;

use super::file_io::ReadAt;
use super::staged::RecordFile;

/// Streams a `RecordFile`'s records a chunk at a time.
pub struct ChunkReader<T: Pod> {
    pub(super) file: ReadAt,
    pub(super) left: u64,
    pub(super) chunk: usize,
    pub(super) _record: PhantomData<T>,
}

impl<T: Pod> ChunkReader<T> {
    /// Records in a full chunk.
    pub fn chunk_len(&self) -> usize {
        self.chunk
    }

    /// Reads the next chunk into `records` (its allocation reused); false at the end.
    pub fn read_into(&mut self, records: &mut Vec<T>) -> io::Result<bool> {
        records.clear();
        if self.left == 0 {
            return Ok(false);
        }
        let n = self.left.min(self.chunk as u64) as usize;
        self.left -= n as u64;
        records.resize(n, T::zeroed());
        self.file.read_exact(bytemuck::cast_slice_mut(records))?;
        Ok(true)
    }

    /// Passes over the next `records` records (at most those left) without reading them.
    pub fn skip_records(&mut self, records: u64) -> io::Result<()> {
        let records = records.min(self.left);
        let bytes = records * std::mem::size_of::<T>() as u64;
        self.file.at += bytes;
        self.left -= records;
        Ok(())
    }
}

impl<T: Pod> Iterator for ChunkReader<T> {
    type Item = io::Result<Vec<T>>;

    fn next(&mut self) -> Option<io::Result<Vec<T>>> {
        let mut records = Vec::new();
        self.read_into(&mut records)
            .map(|more| more.then_some(records))
            .transpose()
    }
}

/// A `ChunkReader` that frees what it has read (`RecordFile::consume_chunks`).
pub struct ConsumingChunks<T: Pod> {
    pub(super) reader: ChunkReader<T>,
    pub(super) file: RecordFile<T>,
    /// Bytes from the start already given back (a whole number of blocks).
    pub(super) freed: u64,
}

impl<T: Pod> ConsumingChunks<T> {
    /// `ChunkReader::read_into`, then the records read are freed.
    pub fn read_into(&mut self, records: &mut Vec<T>) -> io::Result<bool> {
        let more = self.reader.read_into(records)?;
        let read_to = self.reader.file.at;
        self.file.free_range(self.freed, read_to);
        self.freed = self.freed.max(read_to / 4096 * 4096);
        Ok(more)
    }
}
