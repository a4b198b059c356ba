//! Measured error: what a renderer actually drew, compared with the original mesh.
//!
//! The cut rule promises ρ ≤ τ, where ρ is an *estimate* (the simplifier's object-space error,
//! saturated, projected from a bounding sphere). These modules measure instead:
//!
//! - `drawn`: the surface a frame drew, as a triangle soup — dequantised from the patches of
//!   the simplices the GPU selected, or any triangle list a peer renderer drew;
//! - `nearest`: the original mesh in a BVH (`obvhs`), and the exact closest distance from a
//!   point to it;
//! - `sampling`: area-weighted, deterministic samples on a triangle surface;
//! - `geometric_error`: samples both ways (the drawn surface
//!   against the original, the original against the drawn surface), only those the eye sees,
//!   each one's distance converted to pixels at its distance from the eye (d · K / |p − eye|),
//!   and the summary (max, p99, mean, count) over every sample of every view;
//! - `visibility`: whether a surface hides a point from the eye (a segment cast through its
//!   BVH), the exact form of a frame's depth test;
//! - `image_diff`: a frame against the full-resolution frame of the same view (share of pixels
//!   that differ, PSNR).
//!
//! All positions are f64 relative to one frame origin (the repository's `Header::origin`), so
//! the drawn surface, the original mesh and the eye are subtracted without cancellation.
//!
//! Architecture invariant: like the rest of the runtime, measurement reads repositories and
//! slices, never the preprocessor (the caller loads the original mesh).

pub mod drawn;
pub mod geometric_error;
pub mod image_diff;
pub mod nearest;
pub mod sampling;
pub mod visibility;

pub use drawn::{drawn_cut, DrawnSurface};
pub use geometric_error::{
    original_sampling, two_sided_errors, visible_samples, ErrorSummary, SamplingConfig, Surface,
    TwoSidedErrors, ViewErrors, VisibleSamples,
};
pub use image_diff::{compare_images, psnr_of_mse, ImageDiff, DIFF_THRESHOLD, PSNR_SATURATED_DB};
pub use nearest::{MeshError, ReferenceMesh};
