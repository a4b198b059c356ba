//! tessera-preprocess: importers, hierarchy construction, diamond simplification, repository writer.

pub mod import;
pub mod mesh;
pub mod procedural;
