//! tessera-runtime: everything that reads a repository to show it — the camera, the GPU
//! renderer (device, resident model, stateless traversal, batched strip draws), and the crack
//! checks (geometric by global ids, and by pixels on the GPU).
//!
//! Architecture invariant: the runtime reads repositories only through tessera-core; it never
//! imports the preprocessor.

pub mod camera;
pub mod geometric_check;
pub mod gpu;
pub mod pixel_check;
pub mod views;
