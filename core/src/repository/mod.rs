//! The repository: one memory-mapped file holding the hierarchy and its patches.
//!
//! - `format`: the on-disk records (`Header`, `DiamondRecord`, `TetRecord`), constants and the
//!   position / normal encodings;
//! - `patch`: one simplex's patch (triangle strip with primitive restart over local vertices,
//!   positions as u16 offsets from a per-patch base or packed absolute): `encode_patch` and the
//!   zero-copy `PatchView`;
//! - `writer`: `write_repository[_file]` (temporary file + rename);
//! - `reader`: `Repository::open`, which validates every count, offset and index before use.
//!   A bad file is an error (`RepositoryError`), never a panic or an out-of-bounds read.

pub mod format;
pub mod patch;
pub mod reader;
pub mod writer;

pub use format::{DiamondRecord, Header, TetRecord, FORMAT_VERSION, NO_INDEX};
pub use patch::{
    encode_patch, patch_bytes, patch_bytes_bound, PatchData, PatchView, PositionEncoding,
    PositionHeader, Positions,
};
pub use reader::{Repository, RepositoryError};
pub use writer::{write_repository, write_repository_file, RepositoryContents};
