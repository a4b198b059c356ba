//! The GPU side (wgpu 30): device, resident model, per-frame uniforms, shaders, headless
//! target and the renderer that ties them together.
//!
//! - `device`: adapter choice and the features used;
//! - `resident`: slot records and patch pages in GPU memory, within a byte budget;
//! - `records`: the traversal's self-contained per-slot records and the streaming pool's
//!   record slots;
//! - `frame`: the per-frame uniforms and shading modes; `position_probe`: read-back of the
//!   clip positions the draw pass computes (position.wgsl), for precision tests;
//! - `full_mesh`: the full-resolution peer (the whole mesh in one indexed draw);
//! - `shaders`: the WGSL passes of `shaders/`;
//! - `target`: offscreen colour/depth and read-back; `timing`: GPU timestamps of a frame;
//! - `traversal`: the top-down stateless traversal, one indirect dispatch per depth;
//! - `draw_pipelines`: the fill, check and wireframe pipelines of draw.wgsl;
//! - `compact`: per page, the selected patches' strip-slot prefix sums and one indirect draw;
//! - `renderer`: traversal + draws, one submit per frame;
//! - streaming (GPU memory as a cache of the mapped repository): `stream_pool` (the page pool
//!   and its allocator), `stream_budget` (every allocation counted, the pool the budget buys),
//!   `feedback` (the traversal's refined and wanted lists, read back through a ring),
//!   `streamer` (the per-frame loop: land loads, flags, render, feedback, plan);
//! - textures as pages (virtual texturing): `texture_pages` (`PageSource`, the tables and the
//!   CPU mirror of texture.wgsl), `texture_residency` (which pages are in the pool),
//!   `texture_cache` (pool, page table, request bits and their read-back, the budget rule),
//!   `texture_memory` (a `PageSource` in memory).

pub mod compact;
pub mod device;
pub mod draw_pipelines;
pub mod feedback;
pub mod frame;
pub mod frame_request;
pub mod full_mesh;
pub mod pool_space;
pub mod position_probe;
pub mod records;
pub mod renderer;
pub mod repository_pages;
pub mod resident;
pub mod shaders;
pub mod skirts;
pub mod stream_budget;
pub mod stream_pool;
pub mod stream_report;
pub mod streamer;
pub mod target;
pub mod texture_cache;
pub mod texture_memory;
pub mod texture_pages;
pub mod texture_residency;
pub mod timing;
pub mod traversal;

pub use device::{Backend, DeviceError, DeviceOptions, GpuContext, GpuFailure};
pub use frame::{ShadingMode, ALBEDO_GREY, FLAG_COLOUR};
pub use renderer::{
    Frame, FramePhases, FrameRequest, Readback, RenderError, Renderer, RendererOptions, Settled,
};
pub use streamer::{GpuStreamStats, GpuStreamer, StreamError, StreamedGpuFrame};
pub use texture_pages::{PageSource, PoolFormat, TextureError};
