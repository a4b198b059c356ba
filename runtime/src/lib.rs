//! tessera-runtime: cut extraction and checks on a repository. The wgpu device, resident patch
//! pool and GPU traversal land here next (issue 3).
//!
//! Architecture invariant: the runtime reads repositories only through tessera-core; it never
//! imports the preprocessor.

pub mod geometric_check;
pub mod views;
