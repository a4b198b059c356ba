//! The repository: one memory-mapped file holding the whole multiresolution model.
//!
//! - `format`: the on-disk records (`Header`, `DiamondRecord`, `TetRecord`), constants and the
//!   position / normal encodings;
//! - `patch`: one simplex's patch (packed positions, attributes, a triangle strip with primitive
//!   restart over local vertices): `encode_patch` and the zero-copy `PatchView`;
//! - `patch_codec`: `PatchCodec`, raw or packed (and which strip coding), by section kind;
//! - `packed`: the packed (compressed) form of a patch, the default on disk, decoded on load
//!   into exactly what `encode_patch` writes; `strip_codec`: its strips in 4-bit symbols;
//! - `coded`: the entropy-coded form of a patch (`SECTION_CODED_STRIPS`, the default on disk):
//!   strip symbols and positions predicted along the strip, coded by `rans` (a static-model
//!   rANS coder with per-patch 4-bit-weight tables), decoded on load like `packed`;
//! - `attribute_errors`: the optional table of each diamond's colour, normal and UV errors;
//! - `textures`: the optional texture section: shapes, bands and pages (`crate::texture`);
//! - `normal_encoding`: the normals' octahedral i16 pairs and the build's 10-bit grid;
//! - `global_ids`: each patch's global vertex ids, delta + varint coded in their own blob (the
//!   CPU's checks need them, the GPU does not);
//! - `writer`: `write_repository[_file]` (temporary file, fsync, rename; stale temporaries of
//!   killed writers removed);
//! - `grid`: the global position grid chosen from the first level's error, applied after the
//!   build by `repack::repack_on_grid`;
//! - `repack`: a repository rewritten with its patches packed or raw, without a rebuild;
//! - `streamed_writer`: `write_repository_streamed`, the same file with the blobs fed a tet
//!   at a time (the out-of-core build);
//! - `directory_check`: the header's and the tables' checks, shared by reader and writer;
//! - `file_layout`: the header, its checksum and the section table, checked before any record;
//! - `reader`: `Repository::open`, which validates every count, offset and index before use.
//!   A bad file is an error (`RepositoryError`), never a panic or an out-of-bounds read.

pub mod attribute_errors;
pub mod coded;
pub mod cut_mesh;
mod directory_check;
mod file_layout;
pub mod format;
pub mod global_ids;
pub mod grid;
pub mod normal_encoding;
pub mod packed;
pub mod patch;
mod patch_codec;
pub mod rans;
pub mod reader;
pub mod repack;
pub mod streamed_writer;
pub mod strip;
pub mod strip_codec;
pub mod surface;
pub mod textures;
pub mod writer;

pub use format::PatchCodec;
pub use format::{DiamondRecord, Header, TetRecord, FORMAT_VERSION, NO_INDEX};
pub use global_ids::GlobalIds;
pub use patch::{
    encode_patch, patch_bytes, PatchData, PatchPlacement, PatchSource, PatchView, StripIndices,
};
pub use reader::{Patch, Repository, RepositoryError};
pub use streamed_writer::{write_repository_streamed, BlobFeed, RepositoryDirectory};
pub use textures::{TextureContents, TextureDirectory, TextureTable};
pub use writer::{
    remove_stale_temporaries, write_repository, write_repository_file, RepositoryContents,
};
