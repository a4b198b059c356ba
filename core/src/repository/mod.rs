//! The repository: one memory-mapped file holding the hierarchy and its patches.

pub mod format;
pub mod patch;
pub mod reader;
pub mod writer;
