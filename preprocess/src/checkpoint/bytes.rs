//! The checkpoint's binary state files: little-endian fields appended to a buffer, read back
//! with every read checked against the buffer's end (a damaged file is an error, never a
//! panic), and written atomically (temporary name, fsync, rename).

use std::fs::File;
use std::io::{self, Write};
use std::path::Path;

use tessera_core::leb::SimplexKey;

/// Fields appended to a buffer ([`Enc::default`]), or streamed to a file through a small
/// buffer ([`write_atomic_with`]): a checkpoint's state at 100 M triangles runs to hundreds of
/// megabytes, which must not sit in memory beside the state it encodes.
#[derive(Default)]
pub(crate) struct Enc {
    buffer: Vec<u8>,
    sink: Option<FileSink>,
}

/// Where a streaming `Enc` writes: the file, the bytes written and their CRC-32, and the
/// first write error (later fields are dropped; `finish_file` returns it).
struct FileSink {
    file: File,
    crc: crc32fast::Hasher,
    written: u64,
    error: Option<io::Error>,
}

/// A streaming `Enc` writes its buffer out whenever it holds this much.
const SPILL_BYTES: usize = 1 << 20;

impl Enc {
    pub fn u8(&mut self, v: u8) {
        self.bytes(&[v]);
    }
    pub fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    pub fn i32(&mut self, v: i32) {
        self.bytes(&v.to_le_bytes());
    }
    pub fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }
    pub fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }
    /// A LEB128 varint: a byte for values below 128 (most use counts).
    pub fn varint(&mut self, v: u64) {
        crate::external::varint::put(&mut self.buffer, v);
        if self.sink.is_some() && self.buffer.len() >= SPILL_BYTES {
            self.spill();
        }
    }
    pub fn f64(&mut self, v: f64) {
        self.u64(v.to_bits());
    }
    pub fn key(&mut self, k: SimplexKey) {
        self.u8(k.root);
        self.u32(k.level as u32);
        self.u64(k.path as u64);
        self.u64((k.path >> 64) as u64);
    }
    /// A count, then `items` each by `f`.
    pub fn list<T>(&mut self, items: &[T], mut f: impl FnMut(&mut Enc, &T)) {
        self.u64(items.len() as u64);
        for item in items {
            f(self, item);
        }
    }
    /// Raw bytes, in chunks of at most `SPILL_BYTES` (a streaming `Enc`'s buffer stays small).
    pub fn bytes(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(SPILL_BYTES) {
            self.buffer.extend_from_slice(chunk);
            if self.sink.is_some() && self.buffer.len() >= SPILL_BYTES {
                self.spill();
            }
        }
    }
    /// Bytes encoded so far (written out and buffered).
    pub fn position(&self) -> u64 {
        self.sink.as_ref().map_or(0, |s| s.written) + self.buffer.len() as u64
    }
    /// The bytes of an in-memory `Enc`.
    pub fn into_bytes(self) -> Vec<u8> {
        assert!(self.sink.is_none(), "a streaming Enc keeps no bytes");
        self.buffer
    }
    fn spill(&mut self) {
        let Some(sink) = &mut self.sink else { return };
        if sink.error.is_none() {
            match sink.file.write_all(&self.buffer) {
                Ok(()) => {
                    sink.crc.update(&self.buffer);
                    sink.written += self.buffer.len() as u64;
                }
                Err(e) => sink.error = Some(e),
            }
        }
        self.buffer.clear();
    }
}

/// Fields read back from a buffer.
pub(crate) struct Dec<'a> {
    bytes: &'a [u8],
    at: usize,
}

fn damaged(what: &str) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, format!("damaged state: {what}"))
}

impl<'a> Dec<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Dec { bytes, at: 0 }
    }
    fn take<const N: usize>(&mut self) -> io::Result<[u8; N]> {
        let end = self.at.checked_add(N).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| damaged("truncated"))?;
        let out = self.bytes[self.at..end].try_into().expect("N bytes");
        self.at = end;
        Ok(out)
    }
    pub fn u8(&mut self) -> io::Result<u8> {
        Ok(self.take::<1>()?[0])
    }
    pub fn u32(&mut self) -> io::Result<u32> {
        Ok(u32::from_le_bytes(self.take()?))
    }
    pub fn i32(&mut self) -> io::Result<i32> {
        Ok(i32::from_le_bytes(self.take()?))
    }
    pub fn u64(&mut self) -> io::Result<u64> {
        Ok(u64::from_le_bytes(self.take()?))
    }
    pub fn varint(&mut self) -> io::Result<u64> {
        crate::external::varint::get(self.bytes, &mut self.at).ok_or_else(|| damaged("varint"))
    }
    pub fn f32(&mut self) -> io::Result<f32> {
        Ok(f32::from_bits(self.u32()?))
    }
    pub fn f64(&mut self) -> io::Result<f64> {
        Ok(f64::from_bits(self.u64()?))
    }
    pub fn key(&mut self) -> io::Result<SimplexKey> {
        let root = self.u8()?;
        let level = u16::try_from(self.u32()?).map_err(|_| damaged("simplex level"))?;
        let lo = self.u64()? as u128;
        let hi = self.u64()? as u128;
        Ok(SimplexKey {
            root,
            level,
            path: lo | hi << 64,
        })
    }
    /// A list written by `Enc::list`; its count is checked against the bytes left (each item
    /// takes at least `min_item_bytes`) before anything is allocated.
    pub fn list<T>(
        &mut self,
        min_item_bytes: usize,
        mut f: impl FnMut(&mut Dec<'a>) -> io::Result<T>,
    ) -> io::Result<Vec<T>> {
        let n = self.u64()?;
        let left = (self.bytes.len() - self.at) as u64;
        if n.saturating_mul(min_item_bytes.max(1) as u64) > left {
            return Err(damaged("a count larger than the file"));
        }
        (0..n).map(|_| f(self)).collect()
    }
    /// Fails unless every byte was read.
    pub fn finish(&self) -> io::Result<()> {
        if self.at == self.bytes.len() {
            Ok(())
        } else {
            Err(damaged("trailing bytes"))
        }
    }
}

/// Writes `bytes` to `path` under a temporary name, fsyncs it and renames it into place (then
/// fsyncs the directory): a reader sees the old file or the new one, never a part.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let tmp = temporary_name(path);
    let mut file = File::create(&tmp)?;
    file.write_all(bytes)?;
    file.sync_all()?;
    drop(file);
    std::fs::rename(&tmp, path)?;
    sync_dir(path.parent().unwrap_or(Path::new(".")))
}

/// `write_atomic` of what `encode` streams into an `Enc` (never all in memory): returns the
/// file's length and CRC-32. On an error the temporary file is removed.
pub(crate) fn write_atomic_with(
    path: &Path,
    encode: impl FnOnce(&mut Enc) -> io::Result<()>,
) -> io::Result<(u64, u32)> {
    let tmp = temporary_name(path);
    let written = (|| {
        let mut e = Enc {
            buffer: Vec::with_capacity(SPILL_BYTES),
            sink: Some(FileSink {
                file: File::create(&tmp)?,
                crc: crc32fast::Hasher::new(),
                written: 0,
                error: None,
            }),
        };
        encode(&mut e)?;
        e.spill();
        let sink = e.sink.take().expect("a streaming Enc");
        if let Some(error) = sink.error {
            return Err(error);
        }
        sink.file.sync_all()?;
        Ok((sink.written, sink.crc.finalize()))
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    let written = written?;
    std::fs::rename(&tmp, path)?;
    sync_dir(path.parent().unwrap_or(Path::new(".")))?;
    Ok(written)
}

fn temporary_name(path: &Path) -> std::path::PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    path.with_file_name(name)
}

/// fsync of a directory (its entries' creations and renames).
pub(crate) fn sync_dir(dir: &Path) -> io::Result<()> {
    File::open(dir)?.sync_all()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_streamed_encoding_writes_the_bytes_an_in_memory_one_holds() {
        // Fields past several spills of the buffer, and one slice longer than the buffer.
        let encode = |e: &mut Enc| {
            for i in 0..600_000u32 {
                e.u32(i);
                e.u8(i as u8);
            }
            e.bytes(&vec![7u8; 3 * SPILL_BYTES + 5]);
            e.key(SimplexKey {
                root: 1,
                level: 2,
                path: 3,
            });
        };
        let mut memory = Enc::default();
        encode(&mut memory);
        let expected = memory.into_bytes();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("state.bin");
        let (bytes, crc) = write_atomic_with(&path, |e| {
            encode(e);
            Ok(())
        })
        .unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), expected);
        assert_eq!(
            (bytes, crc),
            (expected.len() as u64, crc32fast::hash(&expected))
        );
        // An encoder's error leaves no file, not even the temporary one.
        let failed = write_atomic_with(&dir.path().join("other.bin"), |e| {
            encode(e);
            Err(io::Error::other("stop"))
        });
        assert!(failed.is_err());
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["state.bin"]);
    }

    #[test]
    fn fields_come_back_and_damage_is_an_error() {
        let mut e = Enc::default();
        let key = SimplexKey {
            root: 5,
            level: 61,
            path: (1u128 << 100) | 77,
        };
        e.key(key);
        e.f64(-0.1);
        e.list(&[3u32, 4], |e, &v| e.u32(v));
        let bytes = e.into_bytes();
        let mut d = Dec::new(&bytes);
        assert_eq!(d.key().unwrap(), key);
        assert_eq!(d.f64().unwrap().to_bits(), (-0.1f64).to_bits());
        assert_eq!(d.list(4, |d| d.u32()).unwrap(), vec![3, 4]);
        d.finish().unwrap();
        // Truncated anywhere: an error, never a panic.
        for cut in 0..bytes.len() {
            let mut d = Dec::new(&bytes[..cut]);
            let read = d
                .key()
                .and_then(|_| d.f64())
                .and_then(|_| d.list(4, |d| d.u32()));
            assert!(read.is_err(), "cut at {cut} read as whole");
        }
        // A count larger than the file allocates nothing.
        let mut huge = Enc::default();
        huge.u64(u64::MAX);
        assert!(Dec::new(&huge.into_bytes()).list(4, |d| d.u32()).is_err());
    }
}
