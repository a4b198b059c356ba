//! Out-of-core building blocks (issue 12): external sorting, meshes staged on disk as flat
//! record files, and welding them with bounded memory. Every result equals what the
//! in-memory path computes (tests compare them), so an out-of-core build can give the same
//! repository bytes.

pub mod allocator;
pub mod bits;
mod chunk_reader;
pub mod corner_attributes;
pub mod creased_normals;
mod cursor;
pub mod face_colors;
mod fallible;
pub(crate) mod file_io;
pub mod holes;
pub mod joins;
pub mod leaf_corners;
pub mod packed_columns;
pub mod position_file;
pub mod prefetch;
pub mod sort;
pub mod staged;
mod staged_mesh;
pub mod temp_usage;
pub mod varint;
pub mod vertex_normals;
pub mod wedge_check;
pub mod weld;
mod weld_keys;
mod weld_wedges;

pub use joins::{coincident_nudges, JoinedBarycentres, LeafGroups};
pub use leaf_corners::leaf_corners;
pub use position_file::PositionFile;
pub use sort::{sort_external, SortStats, Sorted};
pub use staged::{RawStaged, RawStager, RawVertex, RecordFile, StagedMesh};
pub use weld::{weld_external, weld_within_budget};
