//! `bench stream`'s run of a camera path: the streaming loop driven by the CPU traversal
//! (`CpuStreamer`) or by the GPU renderer (`--gpu`: `GpuStreamer`, the traversal's feedback
//! read back a frame or two late, a loader thread, the page pool), the path flown `--loops`
//! times, each loop's last camera held until the stream settles (the soak run of issue 11).
//!
//! Per loop: the settled cut (the drawn simplices, ascending; on the GPU read back from one
//! more frame of the held camera), whether it equals the first loop's, the most resident
//! bytes of any frame, and the process's memory at the loop's end (RSS, RssAnon; on a CPU
//! adapter the GPU's buffers are anonymous memory) with RssAnon's sampled maximum.

use std::sync::Arc;
use std::time::Instant;

use anyhow::anyhow;
use serde_json::json;
use tessera_core::cull::CullTests;
use tessera_core::repository::reader::Repository;
use tessera_runtime::camera::Camera;
use tessera_runtime::gpu::{FrameRequest, GpuContext, GpuStreamer, Readback, Renderer};
use tessera_runtime::stream::{CpuStreamer, ResidencyStats, StreamSettings};

use crate::gpu_args::device_failure;
use crate::peak_rss::{AnonPeak, MemoryNow};

/// One frame of a run. Patches, triangles and max ρ/τ are known every frame on the CPU; on
/// the GPU only for the frames read back (each loop's settled cut).
#[derive(Clone, Copy, Debug)]
pub struct Row {
    pub patches: Option<usize>,
    pub triangles: Option<u64>,
    pub resident_bytes: u64,
    pub loaded_bytes: u64,
    pub wanted_not_resident: usize,
    pub max_error_over_tau: Option<f32>,
    pub frame_ms: f64,
    /// Milliseconds spent reading the units that landed this frame out of the map (and
    /// decoding them, when packed): on the CPU inside `frame_ms`, on the GPU on the loader
    /// thread.
    pub read_ms: f64,
    /// The stream was quiet after this frame (CPU: nothing issued or in flight; GPU: the
    /// streamer's `settled`).
    pub settled: bool,
    /// Wall-clock milliseconds from the run's start (before the repository was opened) to
    /// this frame's end: what a user waits, reads from the disk included.
    pub at_ms: f64,
}

/// What one loop of the path ended with.
#[derive(Clone, Debug)]
pub struct LoopReport {
    /// Frames drawn in the loop: the path, the frames holding its last camera until the
    /// stream settled, and (GPU) the frame read back.
    pub frames: usize,
    /// Frames the last camera was held after the path until the stream settled (0: it was
    /// settled at the path's end); `None`: not settled within the cap.
    pub settle_frames: Option<usize>,
    /// The settled cut, ascending simplex ids.
    pub cut: Vec<u32>,
    pub triangles: u64,
    pub max_error_over_tau: Option<f32>,
    /// The largest resident bytes of any frame of the loop (units and roots).
    pub peak_resident_bytes: u64,
    /// Loads issued, evictions, bytes loaded in the loop.
    pub loads: u64,
    pub evictions: u64,
    pub loaded_bytes: u64,
    /// Memory at the loop's end, and RssAnon's largest sample over the loop's frames.
    pub memory: Option<MemoryNow>,
    pub anon_peak: Option<u64>,
}

impl LoopReport {
    pub fn json(&self, index: usize, first_cut: &[u32]) -> serde_json::Value {
        json!({
            "loop": index,
            "frames": self.frames,
            "settle_frames": self.settle_frames,
            "settled": self.settle_frames.is_some(),
            "cut_patches": self.cut.len(),
            "cut_triangles": self.triangles,
            "cut_equals_first_loop": self.cut == first_cut,
            "max_error_over_tau": self.max_error_over_tau,
            "peak_resident_bytes": self.peak_resident_bytes,
            "loads": self.loads,
            "evictions": self.evictions,
            "loaded_bytes": self.loaded_bytes,
            "memory": MemoryNow::json(self.memory, self.anon_peak),
        })
    }
}

/// The streaming loop a run drives.
pub enum Driver<'r> {
    Cpu {
        repo: &'r Repository,
        streamer: Box<CpuStreamer<'r>>,
    },
    Gpu {
        ctx: &'r GpuContext,
        renderer: Box<Renderer>,
        streamer: Box<GpuStreamer>,
    },
}

/// What one frame did.
struct Step {
    row: Row,
    settled: bool,
    stats: ResidencyStats,
    /// The drawn simplices, ascending, when known.
    cut: Option<Vec<u32>>,
}

impl<'r> Driver<'r> {
    pub fn cpu(repo: &'r Repository, settings: StreamSettings) -> anyhow::Result<Driver<'r>> {
        let streamer = CpuStreamer::new(repo, settings).map_err(|e| anyhow!("{e}"))?;
        Ok(Driver::Cpu {
            repo,
            streamer: Box::new(streamer),
        })
    }

    pub fn gpu(
        ctx: &'r GpuContext,
        gpu: &crate::gpu_args::GpuArgs,
        repo: Arc<Repository>,
        size: (u32, u32),
    ) -> anyhow::Result<Driver<'r>> {
        let (renderer, streamer) = gpu.streaming(ctx, repo, size)?;
        Ok(Driver::Gpu {
            ctx,
            renderer: Box::new(renderer),
            streamer: Box::new(streamer),
        })
    }

    /// The residency's totals now.
    pub fn stats(&self) -> ResidencyStats {
        match self {
            Driver::Cpu { streamer, .. } => streamer.residency().stats(),
            Driver::Gpu { streamer, .. } => streamer.residency().stats(),
        }
    }

    /// The residency's own byte budget (units and roots: on the GPU, 7/8 of the page pool).
    pub fn resident_budget(&self) -> u64 {
        match self {
            Driver::Cpu { streamer, .. } => streamer.residency().budget_bytes(),
            Driver::Gpu { streamer, .. } => streamer.residency().budget_bytes(),
        }
    }

    /// Every GPU allocation (`None` on the CPU).
    pub fn gpu_bytes(&self) -> Option<u64> {
        match self {
            Driver::Cpu { .. } => None,
            Driver::Gpu { streamer, .. } => Some(streamer.stats().gpu_bytes),
        }
    }

    /// Units that could not be loaded, with the reason (a damaged patch).
    pub fn failures(&self) -> Vec<String> {
        match self {
            Driver::Cpu { streamer, .. } => streamer
                .failures
                .iter()
                .map(|(u, e)| format!("unit {u}: {e}"))
                .collect(),
            Driver::Gpu { .. } => Vec::new(),
        }
    }

    /// One frame of `cam`; `read_cut`: also the drawn cut (and its max ρ/τ), which on the GPU
    /// costs a read-back and the CPU reference.
    fn frame(&mut self, cam: &Camera, tau: f32, read_cut: bool) -> anyhow::Result<Step> {
        let cull = CullTests {
            frustum: Some(cam.view_volume()),
            cones: true,
        };
        match self {
            Driver::Cpu { repo, streamer } => {
                let eye = cam.eye_local(repo.header().origin);
                let t = Instant::now();
                let f = streamer.frame(eye, &cam.metric(), tau, &cull);
                let frame_ms = t.elapsed().as_secs_f64() * 1e3;
                let triangles = f
                    .frame
                    .selection
                    .iter()
                    .map(|&s| repo.tets()[s as usize].triangle_count as u64)
                    .sum();
                Ok(Step {
                    row: Row {
                        patches: Some(f.frame.selection.len()),
                        triangles: Some(triangles),
                        resident_bytes: f.stats.resident_bytes,
                        loaded_bytes: f.loaded_bytes,
                        wanted_not_resident: f.stats.pending_units,
                        max_error_over_tau: Some(f.frame.max_error_over_tau),
                        frame_ms,
                        read_ms: f.read_seconds * 1e3,
                        settled: f.loads == 0 && f.stats.loading_units == 0,
                        at_ms: 0.0,
                    },
                    // Quiet: nothing issued, nothing in flight.
                    settled: f.loads == 0 && f.stats.loading_units == 0,
                    stats: f.stats,
                    cut: Some(f.frame.selection),
                })
            }
            Driver::Gpu {
                ctx,
                renderer,
                streamer,
            } => {
                let before = streamer.residency().stats().loaded_bytes;
                let read_before = streamer.stats().read_seconds;
                let request = FrameRequest::new(*cam, tau);
                streamer.set_cpu_reference(read_cut);
                let t = Instant::now();
                let f = streamer
                    .frame(
                        ctx,
                        renderer,
                        &request,
                        Readback {
                            image: false,
                            selection: read_cut,
                        },
                    )
                    .map_err(device_failure)?;
                ctx.wait_idle()?;
                let frame_ms = t.elapsed().as_secs_f64() * 1e3;
                streamer.set_cpu_reference(false);
                let cut = match read_cut {
                    true => {
                        let mut s = renderer.read_selection(ctx)?;
                        s.sort_unstable();
                        Some(s)
                    }
                    false => None,
                };
                let triangles = cut.as_ref().map(|c| renderer.triangles_of(c));
                Ok(Step {
                    row: Row {
                        patches: cut.as_ref().map(Vec::len),
                        triangles,
                        resident_bytes: f.stats.resident_bytes,
                        loaded_bytes: f.stats.loaded_bytes - before,
                        wanted_not_resident: f.stats.pending_units,
                        max_error_over_tau: read_cut.then_some(f.reference.max_error_over_tau),
                        frame_ms,
                        read_ms: (streamer.stats().read_seconds - read_before) * 1e3,
                        settled: f.settled,
                        at_ms: 0.0,
                    },
                    settled: f.settled,
                    stats: f.stats,
                    cut,
                })
            }
        }
    }
}

/// Flies `cams` `loops` times; after each loop the last camera is held until the stream
/// settles (at most `settle_cap` frames), and the settled cut is recorded. Each row's `at_ms`
/// counts from `started`.
pub fn run_loops(
    started: Instant,
    driver: &mut Driver,
    cams: &[Camera],
    tau: f32,
    loops: usize,
    settle_cap: usize,
) -> anyhow::Result<(Vec<Row>, Vec<LoopReport>)> {
    let mut rows = Vec::with_capacity(cams.len() * loops);
    let mut reports = Vec::with_capacity(loops);
    let last_cam = *cams.last().ok_or_else(|| anyhow!("an empty camera path"))?;
    let is_gpu = matches!(driver, Driver::Gpu { .. });
    for _ in 0..loops {
        let start = driver.stats();
        let mut anon = AnonPeak::default();
        anon.sample();
        let mut peak_resident = 0u64;
        let mut frames = 0usize;
        let mut last = None;
        // The path, then the held camera until settled.
        let mut settle_frames = None;
        for (i, cam) in cams.iter().chain(std::iter::repeat(&last_cam)).enumerate() {
            let held = i.saturating_sub(cams.len() - 1);
            if held > settle_cap {
                break;
            }
            let mut step = driver.frame(cam, tau, false)?;
            step.row.at_ms = started.elapsed().as_secs_f64() * 1e3;
            anon.sample();
            frames += 1;
            peak_resident = peak_resident.max(step.stats.resident_bytes);
            rows.push(step.row);
            let at_end = i + 1 >= cams.len();
            if at_end && step.settled {
                settle_frames = Some(held);
                last = Some(step);
                break;
            }
        }
        // The settled cut: on the CPU the settled frame's; on the GPU one more frame of the
        // held camera, read back (the flags do not change in a settled stream).
        let step = match last {
            Some(step) if !is_gpu => step,
            _ => {
                let mut step = driver.frame(&last_cam, tau, true)?;
                step.row.at_ms = started.elapsed().as_secs_f64() * 1e3;
                anon.sample();
                frames += 1;
                peak_resident = peak_resident.max(step.stats.resident_bytes);
                rows.push(step.row);
                step
            }
        };
        let end = driver.stats();
        reports.push(LoopReport {
            frames,
            settle_frames,
            triangles: step.row.triangles.unwrap_or(0),
            max_error_over_tau: step.row.max_error_over_tau,
            cut: step.cut.unwrap_or_default(),
            peak_resident_bytes: peak_resident,
            loads: end.loads - start.loads,
            evictions: end.evictions - start.evictions,
            loaded_bytes: end.loaded_bytes - start.loaded_bytes,
            memory: MemoryNow::read(),
            anon_peak: anon.bytes(),
        });
    }
    Ok((rows, reports))
}
