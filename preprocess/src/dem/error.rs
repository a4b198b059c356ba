//! Why a height field could not be read. `Display` gives `<path>: <problem>`.

use std::io;
use std::path::{Path, PathBuf};

/// A height field could not be imported.
#[derive(Debug, thiserror::Error)]
#[error("{}: {kind}", path.display())]
pub struct DemError {
    pub path: PathBuf,
    #[source]
    pub kind: DemErrorKind,
}

impl DemError {
    pub fn new(path: &Path, kind: DemErrorKind) -> DemError {
        DemError {
            path: path.to_path_buf(),
            kind,
        }
    }
}

/// What went wrong.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DemErrorKind {
    #[error("cannot read file: {0}")]
    Io(#[source] io::Error),
    /// The bytes are not what the format says (bad magic, header, type, truncation...).
    #[error("{0}")]
    Format(String),
    /// The file is valid but holds no usable 2-D grid (or not the one asked for).
    #[error("{0}")]
    NoGrid(String),
    /// Counts that the file cannot hold, refused before allocating.
    #[error("too large: {0}")]
    TooLarge(String),
}

/// A `Format` error.
pub(crate) fn bad(message: impl Into<String>) -> DemErrorKind {
    DemErrorKind::Format(message.into())
}

/// Checks that `count` items of `item_bytes` bytes fit in the `available` bytes of the file
/// (and in memory arithmetic), before anything is allocated from `count`.
pub(crate) fn check_fits(
    what: &str,
    count: u64,
    item_bytes: u64,
    available: u64,
) -> Result<usize, DemErrorKind> {
    match count.checked_mul(item_bytes) {
        Some(bytes) if bytes <= available => usize::try_from(count)
            .map_err(|_| DemErrorKind::TooLarge(format!("{what}: {count} items"))),
        _ => Err(DemErrorKind::TooLarge(format!(
            "{what}: {count} items of {item_bytes} bytes, but the file has {available} bytes for them"
        ))),
    }
}
