//! The methods tessera is measured against, with the interface they are measured through:
//! the trade-off benchmark's peers (`peers`, each a `subject::Subject`) and the terrain
//! baselines (`terrain`: ROAM and RUSTiC on the bintree of a padded square grid).
//!
//! This crate implements the methods only: selecting, building and drawing. Parsing flags,
//! driving a measured run, printing and plotting stay in the `tessera` CLI
//! (`tools/src/bench/`, `tools/src/terrain/`). It may depend on tessera-core, -runtime and
//! -preprocess, never on tessera-tools.

pub mod peers;
pub mod subject;
pub mod terrain;
