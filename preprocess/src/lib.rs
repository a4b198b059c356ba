//! tessera-preprocess: importers, hierarchy construction, diamond simplification, repository
//! writer. The build reads like seed 001's pipeline: `build::build_repository` calls
//! `hierarchy` → `simplify` (each patch encoded by `strips` into `finished_patches` as it is
//! made) → `saturate` → the tet table → the core's streaming repository writer.
//!
//! Architecture invariant: nothing here knows the GPU; the runtime never imports this crate.

pub mod build;
mod build_checks;
mod build_config;
mod build_tables;
pub mod checkpoint;
pub mod cluster;
pub mod dem;
pub mod diamond_square;
pub mod external;
pub mod finished_patches;
pub mod frame;
pub mod fuzzing;
pub mod gen_mesh;
pub mod hierarchy;
pub mod import;
mod local_mesh;
pub mod mesh;
pub mod normals;
mod packed_key;
pub mod procedural;
pub mod saturate;
pub mod simplify;
mod staged_build;
pub mod strips;
pub mod texture;
pub mod texture_input;
pub mod vertex_table;

pub use build::{
    build_contents, build_repository, build_repository_checkpointed, build_repository_staged,
    BuildConfig, BuildError, BuildSummary, Domain, MemoryBudget, TexturePagesSummary,
};
pub use hierarchy::Construction;
pub use mesh::InputMesh;
pub use simplify::SimplifySettings;
