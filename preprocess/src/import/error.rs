//! Import errors. Every error names the file it came from and the specific problem, with a line
//! number (text formats) or a record index (binary formats) where one is known.

use std::fmt;
use std::io;
use std::path::PathBuf;

/// The extensions [`load_mesh`](super::load_mesh) understands, for error messages.
pub const SUPPORTED_EXTENSIONS: &str =
    ".ply, .obj, .off, .stl, .gltf, .glb (each optionally gzip-compressed with a further .gz)";

/// A mesh file could not be imported. `Display` gives `<path>: <problem>`, e.g.
/// `dragon.ply: line 12: vertex index 90210 out of range (437645 vertices)`.
#[derive(Debug, thiserror::Error)]
#[error("{}: {kind}", path.display())]
pub struct ImportError {
    /// The file, as passed to [`load_mesh`](super::load_mesh).
    pub path: PathBuf,
    /// What went wrong.
    #[source]
    pub kind: ImportErrorKind,
}

/// Where in a file a problem was found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    /// Nowhere in particular (or the whole file).
    None,
    /// A 1-based line number (text formats).
    Line(u64),
    /// A 0-based record of a named element (binary formats): `face 17`, `triangle 3`.
    Record(String, u64),
    /// Any other description (glTF: `mesh 0 primitive 1`).
    Other(String),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::None => Ok(()),
            Location::Line(line) => write!(f, "line {line}: "),
            Location::Record(element, index) => write!(f, "{element} {index}: "),
            Location::Other(what) => write!(f, "{what}: "),
        }
    }
}

/// The problem behind an [`ImportError`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImportErrorKind {
    /// The file could not be opened or read.
    #[error("cannot read file: {0}")]
    Io(#[source] io::Error),
    /// A `.gz` file is not a valid gzip stream (or is truncated).
    #[error("bad gzip stream: {0}")]
    Gzip(#[source] io::Error),
    /// The file extension is not one of [`SUPPORTED_EXTENSIONS`].
    #[error("unsupported file type {0:?}; supported: {SUPPORTED_EXTENSIONS}")]
    UnsupportedExtension(String),
    /// The header is malformed (missing magic, bad counts, bad property lines, ...).
    #[error("{at}malformed header: {msg}")]
    Header { at: Location, msg: String },
    /// A valid but unsupported feature (PLY property type, binary OFF, ...).
    #[error("{at}unsupported {what}")]
    Unsupported { at: Location, what: String },
    /// Malformed body data: a bad number, a missing or extra value, an unexpected keyword.
    #[error("{at}{msg}")]
    Syntax { at: Location, msg: String },
    /// A face refers to a vertex that does not exist.
    #[error("{at}vertex index {index} out of range ({count} vertices)")]
    IndexOutOfRange {
        at: Location,
        index: i64,
        count: u64,
    },
    /// A vertex position is NaN or infinite.
    #[error("{at}vertex {vertex} has a non-finite coordinate ({x}, {y}, {z})")]
    NonFinite {
        at: Location,
        vertex: u64,
        x: f64,
        y: f64,
        z: f64,
    },
    /// The file ends before the data its header (or structure) announces.
    #[error("{at}{msg}")]
    Truncated { at: Location, msg: String },
    /// A count is beyond what the pipeline supports (more than `u32::MAX` vertices).
    #[error("{at}too large: {msg}")]
    TooLarge { at: Location, msg: String },
    /// No triangles are left after cleaning.
    #[error(
        "empty mesh: no triangles left after cleaning ({raw_triangles} raw triangles, \
         {degenerate} degenerate, {duplicate} duplicate)"
    )]
    Empty {
        raw_triangles: usize,
        degenerate: usize,
        duplicate: usize,
    },
    /// The glTF crate rejected the file, or it has no usable triangle primitives.
    #[error("{at}glTF: {msg}")]
    Gltf { at: Location, msg: String },
}

impl ImportErrorKind {
    /// Attaches the file name.
    pub fn at_path(self, path: impl Into<PathBuf>) -> ImportError {
        ImportError {
            path: path.into(),
            kind: self,
        }
    }
}

/// A token for an error message: lossy UTF-8, shortened to 40 characters.
pub(crate) fn show(token: &[u8]) -> String {
    let s = String::from_utf8_lossy(token);
    if s.chars().count() > 40 {
        let mut t: String = s.chars().take(40).collect();
        t.push('…');
        t
    } else {
        s.into_owned()
    }
}
