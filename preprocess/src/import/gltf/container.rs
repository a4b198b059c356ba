//! Where a glTF's bytes are: the JSON document (a `.gltf` file, or a GLB's first chunk) and
//! its buffers (a GLB's binary chunk, `data:` URIs, files beside the `.gltf`). A GLB read
//! from a file keeps its binary chunk in the file, and an external buffer stays in its file:
//! both are read a span at a time, so a streamed import holds no buffer whole.

use std::borrow::Cow;
use std::fs::File;
use std::io;
use std::os::unix::fs::FileExt;
use std::path::Path;

use super::err;
use crate::import::error::{ImportErrorKind as K, Location};

/// Bytes to read spans of: in memory, or a region of a file.
pub(super) enum Bytes<'a> {
    Memory(Cow<'a, [u8]>),
    File {
        file: &'a File,
        start: u64,
        len: u64,
    },
}

impl<'a> Bytes<'a> {
    pub fn len(&self) -> u64 {
        match self {
            Bytes::Memory(bytes) => bytes.len() as u64,
            Bytes::File { len, .. } => *len,
        }
    }

    /// Fills `out` from `offset`: an error past the end.
    pub fn read_at(&self, offset: u64, out: &mut [u8]) -> io::Result<()> {
        let end = offset.checked_add(out.len() as u64);
        if end.is_none_or(|end| end > self.len()) {
            return Err(io::Error::new(
                io::ErrorKind::UnexpectedEof,
                format!(
                    "{} bytes from byte {offset} run past the end ({} bytes)",
                    out.len(),
                    self.len()
                ),
            ));
        }
        match self {
            Bytes::Memory(bytes) => {
                out.copy_from_slice(&bytes[offset as usize..offset as usize + out.len()]);
                Ok(())
            }
            Bytes::File { file, start, .. } => file.read_exact_at(out, start + offset),
        }
    }

    fn region(&self, start: u64, len: u64) -> Bytes<'_> {
        match self {
            Bytes::Memory(bytes) => Bytes::Memory(Cow::Borrowed(
                &bytes[start as usize..(start + len) as usize],
            )),
            Bytes::File { file, start: s, .. } => Bytes::File {
                file,
                start: s + start,
                len,
            },
        }
    }

    /// The first `len` bytes (at most the length).
    fn truncated(self, len: u64) -> Bytes<'a> {
        match self {
            Bytes::Memory(Cow::Borrowed(bytes)) => {
                Bytes::Memory(Cow::Borrowed(&bytes[..(len as usize).min(bytes.len())]))
            }
            Bytes::Memory(Cow::Owned(mut bytes)) => {
                bytes.truncate(len as usize);
                Bytes::Memory(Cow::Owned(bytes))
            }
            Bytes::File {
                file,
                start,
                len: l,
            } => Bytes::File {
                file,
                start,
                len: len.min(l),
            },
        }
    }

    fn to_vec(&self) -> io::Result<Vec<u8>> {
        let mut out = vec![0; self.len() as usize];
        self.read_at(0, &mut out)?;
        Ok(out)
    }
}

/// A glTF's document and, for a GLB, its binary chunk.
pub(super) struct Container<'a> {
    pub json: Vec<u8>,
    pub bin: Option<Bytes<'a>>,
}

const GLB_HEADER: u64 = 12;
const CHUNK_HEADER: u64 = 8;

/// Splits a GLB into its JSON and binary chunks (with the checks the gltf crate makes, and
/// the one it missed: a declared length shorter than the header); anything else is a JSON
/// document, read whole.
pub(super) fn open<'a>(all: &'a Bytes<'a>) -> Result<Container<'a>, K> {
    let io = |e: io::Error| err(Location::None, format!("cannot read: {e}"));
    let len = all.len();
    let mut magic = [0; 4];
    if len < 4 || all.read_at(0, &mut magic).is_err() || &magic != b"glTF" {
        return Ok(Container {
            json: all.to_vec().map_err(io)?,
            bin: None,
        });
    }
    let word = |at: u64| -> Result<u32, K> {
        let mut w = [0; 4];
        all.read_at(at, &mut w).map_err(|_| {
            err(
                Location::None,
                format!("the GLB ends at byte {len}, inside a header"),
            )
        })?;
        Ok(u32::from_le_bytes(w))
    };
    let (version, length) = (word(4)?, word(8)?);
    if u64::from(length) < GLB_HEADER {
        return Err(err(
            Location::None,
            format!("GLB header declares {length} bytes, less than the 12-byte header"),
        ));
    }
    if u64::from(length) > len {
        return Err(err(
            Location::None,
            format!("GLB header declares {length} bytes, the file has {len}"),
        ));
    }
    if version != 2 {
        return Err(err(
            Location::None,
            format!("GLB version {version}; only version 2 is read"),
        ));
    }
    let chunk = |at: u64, want: &[u8; 4], name: &str| -> Result<(u64, u64), K> {
        let (length, kind) = (word(at)?, word(at + 4)?);
        if &kind.to_le_bytes() != want {
            return Err(err(
                Location::None,
                format!("the GLB's chunk at byte {at} is not its {name} chunk"),
            ));
        }
        let start = at + CHUNK_HEADER;
        if u64::from(length) > len - start {
            return Err(err(
                Location::None,
                format!(
                    "the GLB's {name} chunk declares {length} bytes, {} remain",
                    len - start
                ),
            ));
        }
        Ok((start, u64::from(length)))
    };
    let (json_start, json_len) = chunk(GLB_HEADER, b"JSON", "JSON")?;
    let json = all.region(json_start, json_len).to_vec().map_err(io)?;
    let after = json_start + json_len;
    let bin = if after < len {
        let (start, bin_len) = chunk(after, b"BIN\0", "binary")?;
        Some(all.region(start, bin_len))
    } else {
        None
    };
    Ok(Container { json, bin })
}

/// Every buffer of `document`: the GLB's binary chunk, a `data:` URI (base64, decoded into
/// memory), or a file next to the glTF (with a `base` directory; `files` holds it open).
/// Each holds at least its declared length, and is cut to it (GLB chunks are padded to 4
/// bytes). (gltf's own `import_buffers` would pull in an image decoder we do not need.)
pub(super) fn buffers<'a>(
    document: &::gltf::Document,
    base: Option<&Path>,
    bin: Option<Bytes<'a>>,
    files: &'a [Option<File>],
) -> Result<Vec<Bytes<'a>>, String> {
    use base64::Engine as _;
    let mut bin = bin;
    let mut out = Vec::new();
    for (buffer, file) in document.buffers().zip(files) {
        let data = match (buffer.source(), file) {
            (_, Some(file)) => {
                let len = file.metadata().map_err(|e| e.to_string())?.len();
                Bytes::File {
                    file,
                    start: 0,
                    len,
                }
            }
            (::gltf::buffer::Source::Bin, None) => {
                bin.take().ok_or("the GLB has no binary chunk")?
            }
            (::gltf::buffer::Source::Uri(uri), None) => {
                let Some(rest) = uri.strip_prefix("data:") else {
                    return Err(match base {
                        Some(_) => {
                            format!("buffer {}: the file {uri:?} is not open", buffer.index())
                        }
                        None => format!(
                            "buffer {} is the external file {uri:?}, and these bytes come from \
                             no directory",
                            buffer.index()
                        ),
                    });
                };
                let (_, payload) = rest
                    .split_once(";base64,")
                    .ok_or_else(|| format!("unsupported data URI for buffer {}", buffer.index()))?;
                Bytes::Memory(Cow::Owned(
                    base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .map_err(|e| format!("buffer {}: bad base64: {e}", buffer.index()))?,
                ))
            }
        };
        let declared = buffer.length() as u64;
        if data.len() < declared {
            return Err(format!(
                "buffer {} holds {} bytes, the glTF says {declared}",
                buffer.index(),
                data.len(),
            ));
        }
        out.push(data.truncated(declared));
    }
    Ok(out)
}

/// Opens each buffer that is a file next to the glTF (`None` for the others, and for every
/// buffer without a `base` directory).
pub(super) fn open_buffer_files(
    document: &::gltf::Document,
    base: Option<&Path>,
) -> Result<Vec<Option<File>>, String> {
    document
        .buffers()
        .map(|buffer| match (buffer.source(), base) {
            (::gltf::buffer::Source::Uri(uri), Some(base)) if !uri.starts_with("data:") => {
                let path = base.join(percent_decode(uri));
                File::open(&path)
                    .map(Some)
                    .map_err(|e| format!("{}: {e}", path.display()))
            }
            _ => Ok(None),
        })
        .collect()
}

/// Decodes %XX escapes in a relative URI.
pub(super) fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            if let Ok(v) = u8::from_str_radix(&uri[i + 1..i + 3], 16) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}
