//! tessera-runtime: everything that reads a repository to show it — the camera, the GPU
//! renderer (device, resident model, stateless traversal, batched strip draws), and the crack
//! checks (geometric by global ids, and by pixels on the GPU), and the measured error of what a
//! frame drew (`measure`).
//!
//! Architecture invariant: the runtime reads repositories only through tessera-core; it never
//! imports the preprocessor.

pub mod border_loops;
pub mod camera;
pub mod cut_patches;
pub mod faces;
pub mod geometric_check;
pub mod gpu;
pub mod measure;
pub mod mesh_problem;
pub mod pixel_check;
pub mod stream;
pub mod stream_pixel_check;
/// The f64 vector helpers (they live in core, shared with the distance bounds).
pub use tessera_core::vec3;
pub mod views;
