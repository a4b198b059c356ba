//! Streaming: the GPU (and the process) hold only what the current view needs.
//!
//! - `units`: R(D), the patches that splitting diamond D creates — the unit of residency — and
//!   the diamond DAG both ways;
//! - `residency`: which units are resident, the `may_refine` flags that keep every cut valid
//!   while data is missing, what to load next (requests from the traversal, by screen error)
//!   and what to evict (least recently used, never for a request of lower priority);
//! - `loader`: a thread that reads units through the memory map (each patch's checksum checked
//!   on first read) and hands their bytes to the caller;
//! - `cpu_frame`: the streaming traversal on the CPU, the reference for the GPU's.

pub mod cpu_frame;
pub mod cpu_streamer;
pub mod loader;
pub mod residency;
pub mod units;

pub use cpu_frame::{gated_rhos, stream_frame, StreamFrame};
pub use cpu_streamer::{CpuStreamer, StreamSettings, StreamedFrame};
pub use loader::{LoadedUnit, Loader};
pub use residency::{Plan, Residency, ResidencyStats, UnitState};
pub use units::UnitTable;
