//! tessera-core: the exact LEB hierarchy (2D and 3D), diamonds and their DAG, bounds, the
//! screen-space error metric, the stateless cut rule and the repository format.
//!
//! Architecture invariant: this crate knows no GPU, no threads (no rayon) and no importer.

pub mod bounds;
pub mod cull;
pub mod cut;
pub mod eye_relative;
pub mod hausdorff;
pub mod leb;
pub mod metric;
pub mod repository;
pub mod texture;
pub mod texture_codec;
pub mod vec3;
