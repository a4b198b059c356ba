//! The checkpoint's manifest (`manifest.json`): what build made the checkpoint (the input's
//! fingerprint, every flag that affects the bytes, the tessera version) and the stages it
//! completed, each with its files (size and CRC-32). A resumed build continues from the last
//! stage only when everything it was made by matches.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom};
use std::path::Path;

use serde::{Deserialize, Serialize};

/// Version of the checkpoint's files: a build of another version never resumes from them.
/// 3: the use counts in a level's state are varints (they were u32s). 4: a level's state and
/// its parts carry each diamond's attribute error (`simplify/attribute_error.rs`).
pub const CHECKPOINT_FORMAT: u32 = 4;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub format: u32,
    pub tessera_version: String,
    pub input: Fingerprint,
    /// Every setting that affects the repository's bytes, by name (the thread count and the
    /// memory budget do not).
    pub flags: BTreeMap<String, String>,
    /// Completed stages in order; the files of the last one are what a resume starts from
    /// (earlier stages' files are dropped once a later one holds everything needed).
    pub stages: Vec<StageRecord>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StageRecord {
    pub name: String,
    pub files: Vec<FileRecord>,
    /// Numbers the stage found (counts, a bounding box's f64 bits).
    pub values: BTreeMap<String, u64>,
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileRecord {
    /// A name inside the checkpoint directory.
    pub name: String,
    pub bytes: u64,
    pub crc32: u32,
    /// A file with holes where its dead records were (the live patches'): `crc32` is not
    /// its checksum; its reader checks each record it names against the record's own.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub sparse: bool,
}

/// What identifies an input file without reading all of it: its path, size, modification
/// time, and CRC-32s of its first and last MiB. Standard input (path `-`) is identified by its
/// size and the CRC-32 of every byte (`StreamFingerprint`), known once it is read to its end.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Fingerprint {
    pub path: String,
    pub bytes: u64,
    pub mtime_ns: u64,
    pub head_crc32: u32,
    pub tail_crc32: u32,
    /// Standard input's CRC-32 of every byte (`None` for a file, and for standard input not
    /// yet read to its end).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stream_crc32: Option<u32>,
}

const ENDS: u64 = 1 << 20;

impl Fingerprint {
    pub fn of(path: &Path) -> io::Result<Fingerprint> {
        let canonical = std::fs::canonicalize(path)?;
        let mut file = File::open(&canonical)?;
        let meta = file.metadata()?;
        let mtime_ns = meta
            .modified()?
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64);
        let bytes = meta.len();
        let mut crc_at = |at: u64| -> io::Result<u32> {
            file.seek(SeekFrom::Start(at))?;
            let mut buf = Vec::new();
            (&mut file).take(ENDS).read_to_end(&mut buf)?;
            Ok(crc32fast::hash(&buf))
        };
        Ok(Fingerprint {
            path: canonical.display().to_string(),
            bytes,
            head_crc32: crc_at(0)?,
            tail_crc32: crc_at(bytes.saturating_sub(ENDS))?,
            mtime_ns,
            stream_crc32: None,
        })
    }

    /// Standard input's, before it is read: what a checkpoint holds until the import has read
    /// the stream (no stage can be resumed before that).
    pub fn stream_unread() -> Fingerprint {
        Fingerprint {
            path: STDIN.into(),
            bytes: 0,
            mtime_ns: 0,
            head_crc32: 0,
            tail_crc32: 0,
            stream_crc32: None,
        }
    }

    /// The fingerprint of what `read` gives until its end.
    pub fn of_stream(read: impl Read) -> io::Result<Fingerprint> {
        let stream = StreamFingerprint::default();
        io::copy(&mut stream.reader(read), &mut io::sink())?;
        Ok(stream.fingerprint())
    }
}

/// The path a fingerprint of standard input names.
const STDIN: &str = "-";

/// The size and CRC-32 of a stream read through `reader`s (one or several in turn: the
/// import's, then one that reads what it left), and its fingerprint once read to its end.
#[derive(Clone, Default)]
pub struct StreamFingerprint {
    read: std::sync::Arc<std::sync::Mutex<(u64, crc32fast::Hasher)>>,
}

impl StreamFingerprint {
    /// `inner`, counted into this fingerprint as it is read.
    pub fn reader<R: Read>(&self, inner: R) -> FingerprintedReader<R> {
        FingerprintedReader {
            inner,
            into: self.clone(),
        }
    }

    /// The fingerprint of what was read (the stream's, once read to its end).
    pub fn fingerprint(&self) -> Fingerprint {
        let read = self.read.lock().unwrap_or_else(|e| e.into_inner());
        Fingerprint {
            bytes: read.0,
            stream_crc32: Some(read.1.clone().finalize()),
            ..Fingerprint::stream_unread()
        }
    }
}

/// A reader counted into a `StreamFingerprint`.
pub struct FingerprintedReader<R> {
    inner: R,
    into: StreamFingerprint,
}

impl<R: Read> Read for FingerprintedReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        let mut read = self.into.read.lock().unwrap_or_else(|e| e.into_inner());
        read.0 += n as u64;
        read.1.update(&buf[..n]);
        Ok(n)
    }
}

/// The first difference between what made a checkpoint and this build: (what, the
/// checkpoint's, this build's).
pub fn first_mismatch(made: &Manifest, now: &Manifest) -> Option<(String, String, String)> {
    let pair = |what: &str, a: String, b: String| (a != b).then(|| (what.to_string(), a, b));
    let (i, j) = (&made.input, &now.input);
    pair(
        "checkpoint format",
        made.format.to_string(),
        now.format.to_string(),
    )
    .or_else(|| {
        pair(
            "tessera version",
            made.tessera_version.clone(),
            now.tessera_version.clone(),
        )
    })
    .or_else(|| pair("input path", i.path.clone(), j.path.clone()))
    .or_else(|| pair("input size", i.bytes.to_string(), j.bytes.to_string()))
    .or_else(|| {
        pair(
            "input modification time (ns)",
            i.mtime_ns.to_string(),
            j.mtime_ns.to_string(),
        )
    })
    .or_else(|| {
        pair(
            "input contents (CRC-32 of its first and last MiB)",
            format!("{:08x} {:08x}", i.head_crc32, i.tail_crc32),
            format!("{:08x} {:08x}", j.head_crc32, j.tail_crc32),
        )
    })
    .or_else(|| {
        let crc = |c: Option<u32>| c.map_or_else(|| "(none)".into(), |c| format!("{c:08x}"));
        pair(
            "input contents (CRC-32 of every byte)",
            crc(i.stream_crc32),
            crc(j.stream_crc32),
        )
    })
    .or_else(|| {
        let names = made.flags.keys().chain(now.flags.keys());
        names.into_iter().find_map(|name| {
            let get = |m: &BTreeMap<String, String>| {
                m.get(name).cloned().unwrap_or_else(|| "(unset)".into())
            };
            pair(&format!("flag {name}"), get(&made.flags), get(&now.flags))
        })
    })
}

/// CRC-32 of a file's first `bytes` bytes (fails if it is shorter).
pub fn crc_of_prefix(path: &Path, bytes: u64) -> io::Result<u32> {
    let mut file = File::open(path)?;
    let mut hasher = crc32fast::Hasher::new();
    let mut left = bytes;
    let mut buf = vec![0u8; 1 << 20];
    while left > 0 {
        let n = left.min(buf.len() as u64) as usize;
        file.read_exact(&mut buf[..n])?;
        hasher.update(&buf[..n]);
        left -= n as u64;
    }
    Ok(hasher.finalize())
}
