//! `tessera bench stream REPO --gpu-budget MB`: a camera path flown under a residency budget,
//! warm and cold, frame by frame.
//!
//! By default the streaming loop is `tessera_runtime::stream::CpuStreamer`: the residency's
//! flags gate the cut, the traversal's feedback (refined and wanted diamonds) drives loads by
//! screen error within a per-frame allowance, loads land `--latency-frames` later (read through
//! the map, checksums checked, at that moment), evictions make room. The traversal runs on the
//! CPU there (`"traversal": "cpu"` in the JSON): the figures are the residency's — resident
//! bytes, bytes loaded, wanted units not resident, how far the drawn cut is from what τ asks
//! (max ρ/τ over the drawn simplices), frames to settle — and `frame_ms` is the CPU time of a
//! frame's traversal, planning and the reads of the loads landing in it, not GPU time.
//!
//! `--gpu` drives the GPU renderer instead (`"traversal": "gpu"`: what `render` runs — the
//! page pool within `--gpu-budget`, every GPU allocation counted, the traversal's feedback
//! read back a frame or two late, a loader thread); `frame_ms` is then the whole frame,
//! waited for. `--loops N` flies the path N times (the soak run): at each loop's end the last
//! camera is held until the stream settles, and the report says per loop whether the settled
//! cut equals the first loop's, the most bytes resident, and the process's memory
//! (`bench_stream_loops.rs`).
//!
//! Warm: the file is read once first, so the page cache holds it. Cold: the file is dropped
//! from the page cache first (`posix_fadvise(DONTNEED)`), so loads read the disk; each run
//! reports the share of the file's pages resident before it (`mincore`).

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{anyhow, bail, Context};
use clap::Args;
use serde_json::json;
use tessera_core::repository::reader::Repository;
use tessera_runtime::camera::Camera;
use tessera_runtime::stream::StreamSettings;

use crate::bench_stream_loops::{run_loops, Driver, Row};
use crate::camera_path::CameraPath;

use crate::cmd_render::default_up;
use crate::Outcome;

#[derive(Args)]
pub struct StreamBenchArgs {
    /// Repository file.
    pub repository: PathBuf,
    /// Residency budget in MiB: the resident units plus the pinned roots.
    #[arg(long, default_value_t = 32.0)]
    pub gpu_budget: f64,
    /// Camera path: a JSON file `{"keyframes": [{"eye": [x,y,z], "target": [x,y,z]}, ...],
    /// "frames_between": N, "pause_frames": M}` (model coordinates; eyes interpolated
    /// linearly, N frames per segment, then M frames paused at the last keyframe). Default: a
    /// fly-in from 3 bounding radii to 0.9 turning 120° (120 frames), half a turn at 0.9 radii
    /// (120 frames), 120 frames paused.
    #[arg(long)]
    pub path: Option<PathBuf>,
    /// Pixel tolerance τ (1920×1080 unless --size, 60° vertical field of view).
    #[arg(long, default_value_t = 1.0)]
    pub tolerance: f32,
    /// Viewport WxH.
    #[arg(long, default_value = "1920x1080")]
    pub size: String,
    /// Bytes of loads issued per frame, MiB.
    #[arg(long, default_value_t = 4.0)]
    pub upload_mb_per_frame: f64,
    /// Frames between issuing a load and its data being usable.
    #[arg(long, default_value_t = 2)]
    pub latency_frames: u64,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    /// Write `stream.png` (resident MB, bytes loaded, max error / τ, frame ms over the frames,
    /// warm and cold) into this directory.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Stream with the GPU renderer (`render`'s streaming renderer) instead of the CPU
    /// traversal; `--gpu-budget` then bounds every GPU allocation.
    #[arg(long)]
    pub gpu: bool,
    /// wgpu backend with `--gpu`: vulkan, gl, metal or dx12 (default: $WGPU_BACKEND, else any).
    #[arg(long, requires = "gpu")]
    pub backend: Option<tessera_runtime::gpu::Backend>,
    /// Adapter name substring with `--gpu` (default: $TESSERA_ADAPTER, else the best present).
    #[arg(long, requires = "gpu")]
    pub adapter: Option<String>,
    /// Fly the path this many times (a soak run); each loop's last camera is held until the
    /// stream settles, and its settled cut is compared with the first loop's.
    #[arg(long, default_value_t = 1)]
    pub loops: usize,
    /// Most frames a loop's last camera is held waiting for the stream to settle.
    #[arg(long, default_value_t = 1000)]
    pub settle_frames: usize,
}

fn parse_size(s: &str) -> anyhow::Result<(u32, u32)> {
    let (w, h) = s
        .split_once('x')
        .ok_or_else(|| anyhow!("--size {s:?} is not WxH"))?;
    let (w, h): (u32, u32) = (w.trim().parse()?, h.trim().parse()?);
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        bail!("--size {s:?}: each side must be 1..=16384");
    }
    Ok((w, h))
}

/// The cameras of the run, sized `width` × `height`.
fn cameras(
    args: &StreamBenchArgs,
    repo: &Repository,
    size: (u32, u32),
) -> anyhow::Result<Vec<Camera>> {
    let h = repo.header();
    let up = default_up(h.dimension);
    let radius = tessera_runtime::camera::bounding_radius(h.bbox_min, h.bbox_max);
    let mut cams: Vec<Camera> = match &args.path {
        Some(file) => {
            let path = CameraPath::load(file).context("--path")?;
            path.frames()
                .into_iter()
                .map(|k| Camera {
                    up,
                    ..Camera::looking_at(k.eye, k.target, radius)
                })
                .collect()
        }
        None => {
            let orbit = |az: f64, el: f64, dist: f64| {
                Camera::orbit(h.bbox_min, h.bbox_max, up, az, el, dist)
            };
            let mut out: Vec<Camera> = (0..120)
                .map(|i| {
                    let s = i as f64 / 119.0;
                    orbit(30.0 + 120.0 * s, 20.0 - 10.0 * s, 3.0 - 2.1 * s)
                })
                .collect();
            out.extend((0..120).map(|i| orbit(150.0 + 180.0 * (i as f64 / 119.0), 10.0, 0.9)));
            let last = *out.last().unwrap();
            out.extend(std::iter::repeat_n(last, 120));
            out
        }
    };
    for c in &mut cams {
        (c.width, c.height) = size;
    }
    Ok(cams)
}

/// Share of `path`'s pages in the page cache (`mincore` over a fresh map).
fn page_cache_share(path: &Path) -> anyhow::Result<f64> {
    let file = File::open(path)?;
    let len = file.metadata()?.len() as usize;
    if len == 0 {
        return Ok(0.0);
    }
    // SAFETY: read-only map of a file this process does not modify; only its address is used.
    let map = unsafe { memmap2::Mmap::map(&file)? };
    let page = 4096usize;
    let pages = len.div_ceil(page);
    let mut vec = vec![0u8; pages];
    // SAFETY: `vec` has one byte per page of the mapped range.
    let rc = unsafe { libc::mincore(map.as_ptr() as *mut libc::c_void, len, vec.as_mut_ptr()) };
    if rc != 0 {
        bail!("mincore failed: {}", std::io::Error::last_os_error());
    }
    Ok(vec.iter().filter(|&&b| b & 1 != 0).count() as f64 / pages as f64)
}

/// Reads the whole file (warm) or drops it from the page cache (cold).
fn prepare_cache(path: &Path, cold: bool) -> anyhow::Result<()> {
    let mut file = File::open(path)?;
    if cold {
        use std::os::fd::AsRawFd;
        // Dirty pages are not dropped: a repository just built would stay cached whole.
        file.sync_data()
            .with_context(|| format!("flushing {} before dropping it", path.display()))?;
        // SAFETY: a valid descriptor; advice only.
        let rc = unsafe { libc::posix_fadvise(file.as_raw_fd(), 0, 0, libc::POSIX_FADV_DONTNEED) };
        if rc != 0 {
            bail!("posix_fadvise(DONTNEED) failed with {rc}");
        }
    } else {
        let mut buf = vec![0u8; 1 << 20];
        while file.read(&mut buf)? > 0 {}
    }
    Ok(())
}

pub fn run(args: StreamBenchArgs) -> anyhow::Result<Outcome> {
    if !(args.gpu_budget.is_finite() && args.gpu_budget > 0.0) {
        bail!(
            "--gpu-budget {} must be a positive number of MiB",
            args.gpu_budget
        );
    }
    if !(args.upload_mb_per_frame.is_finite() && args.upload_mb_per_frame > 0.0) {
        bail!("--upload-mb-per-frame must be positive");
    }
    if !(args.tolerance.is_finite() && args.tolerance > 0.0) {
        bail!("--tolerance {} must be positive and finite", args.tolerance);
    }
    if args.loops == 0 {
        bail!("--loops must be at least 1");
    }
    let size = parse_size(&args.size)?;
    let probe = crate::repository_arg::open(&args.repository, "bench stream")?;
    let cams = cameras(&args, &probe, size)?;
    let file_bytes = probe.file_bytes();
    let codec = probe.codec().name();
    drop(probe);
    let settings = StreamSettings {
        budget_bytes: (args.gpu_budget * (1u64 << 20) as f64) as u64,
        upload_bytes_per_frame: (args.upload_mb_per_frame * (1u64 << 20) as f64) as u64,
        latency_frames: args.latency_frames.max(1),
    };
    let gpu_args = crate::gpu_args::GpuArgs {
        adapter: args.adapter.clone(),
        backend: args.backend,
        gpu_budget: Some(args.gpu_budget),
    };
    let ctx = if args.gpu {
        Some(gpu_args.context()?)
    } else {
        None
    };
    let mut runs = Vec::new();
    let mut plotted = Vec::new();
    for mode in ["warm", "cold"] {
        prepare_cache(&args.repository, mode == "cold")?;
        let cached = page_cache_share(&args.repository)?;
        let t = Instant::now();
        let repo = Arc::new(Repository::open(&args.repository)?);
        let mut driver = match &ctx {
            Some(ctx) => Driver::gpu(ctx, &gpu_args, repo.clone(), size)?,
            None => Driver::cpu(&repo, settings)?,
        };
        let (rows, loops) = run_loops(
            t,
            &mut driver,
            &cams,
            args.tolerance,
            args.loops,
            args.settle_frames,
        )?;
        let seconds = t.elapsed().as_secs_f64();
        for failure in driver.failures().iter().take(1) {
            eprintln!("warning: {failure} could not be loaded");
        }
        let stats = driver.stats();
        // Settled from: the first frame from which the stream stayed quiet to the end.
        let settled_from = settled_from_frame(&rows);
        // What a user waits for the settled cut: from the start (the repository opened, the
        // roots read) to the end of the first frame of the quiet run, reads included.
        let seconds_to_settle = settled_from
            .and_then(|f| rows.get(f))
            .map(|r| r.at_ms / 1e3);
        let mut ms: Vec<f64> = rows.iter().map(|r| r.frame_ms).collect();
        ms.sort_by(f64::total_cmp);
        let first_cut = loops[0].cut.clone();
        let loop_json: Vec<_> = loops
            .iter()
            .enumerate()
            .map(|(i, l)| l.json(i + 1, &first_cut))
            .collect();
        let anon_end: Vec<u64> = loops
            .iter()
            .filter_map(|l| l.memory.map(|m| l.anon_peak.unwrap_or(m.rss_anon)))
            .collect();
        let last = loops.last().expect("at least one loop");
        let summary = json!({
            "page_cache_share_before": cached,
            "seconds": seconds,
            "frames": rows.len(),
            "loops": args.loops,
            "settled_from_frame": settled_from,
            "seconds_to_settle": seconds_to_settle,
            "every_loop_settled": loops.iter().all(|l| l.settle_frames.is_some()),
            "cuts_equal_first_loop": loops.iter().all(|l| l.cut == first_cut),
            "resident_budget_bytes": driver.resident_budget(),
            "peak_resident_bytes": stats.peak_resident_bytes,
            "gpu_bytes": driver.gpu_bytes(),
            "loaded_bytes": stats.loaded_bytes,
            "loads": stats.loads,
            "evictions": stats.evictions,
            // Of which for contiguous pool room, and loads given back for want of it
            // (runtime/src/stream/residency/space.rs).
            "space_evictions": stats.space_evictions,
            "withdrawn_loads": stats.withdrawn_loads,
            "broken_units": stats.broken_units,
            "frame_ms_median": ms[ms.len() / 2],
            "read_ms_total": rows.iter().map(|r| r.read_ms).sum::<f64>(),
            "read_ms_max_frame": rows.iter().map(|r| r.read_ms).fold(0.0, f64::max),
            "patch_codec": codec,
            "frame_ms_max": ms[ms.len() - 1],
            "max_error_over_tau_last": last.max_error_over_tau,
            "wanted_not_resident_last": rows.last().map(|r| r.wanted_not_resident),
            // RssAnon's sampled maximum in loops 2.. minus loop 1's (flat after the first).
            "rss_anon_growth_after_first_loop": anon_end.first().map(|&first| {
                anon_end[1..].iter().map(|&a| a as i64 - first as i64).max().unwrap_or(0)
            }),
        });
        if !args.json {
            println!(
                "{mode}: {} frames in {seconds:.2} s (page cache {:.0} % before); settled from \
                 frame {settled_from:?} ({}); peak resident {:.2} MiB of {:.2}; loaded {:.2} MiB in {} \
                 loads, {} evictions; frame ms median {:.3}, max {:.3}; read ({codec}) {:.1} ms \
                 in all, {:.2} ms at most in a frame; last settled cut max ρ/τ {}",
                rows.len(),
                100.0 * cached,
                seconds_to_settle.map_or("never".to_string(), |s| format!("{s:.2} s")),
                stats.peak_resident_bytes as f64 / (1u64 << 20) as f64,
                args.gpu_budget,
                stats.loaded_bytes as f64 / (1u64 << 20) as f64,
                stats.loads,
                stats.evictions,
                ms[ms.len() / 2],
                ms[ms.len() - 1],
                rows.iter().map(|r| r.read_ms).sum::<f64>(),
                rows.iter().map(|r| r.read_ms).fold(0.0, f64::max),
                last.max_error_over_tau
                    .map_or("n/a".to_string(), |e| format!("{e:.3}")),
            );
            if args.loops > 1 {
                for l in &loop_json {
                    println!(
                        "  loop {}: settled after {} held frames, cut {} patches ({}), peak \
                         resident {} B, {} loads, {} evictions, RssAnon {} B (sampled max {})",
                        l["loop"],
                        l["settle_frames"],
                        l["cut_patches"],
                        if l["cut_equals_first_loop"] == true {
                            "= loop 1"
                        } else {
                            "DIFFERS from loop 1"
                        },
                        l["peak_resident_bytes"],
                        l["loads"],
                        l["evictions"],
                        l["memory"]["rss_anon_bytes"],
                        l["memory"]["rss_anon_peak_sampled_bytes"],
                    );
                }
            }
        }
        let frames: Vec<_> = rows
            .iter()
            .map(|r| {
                json!({
                    "patches": r.patches,
                    "triangles": r.triangles,
                    "resident_bytes": r.resident_bytes,
                    "loaded_bytes": r.loaded_bytes,
                    "wanted_not_resident": r.wanted_not_resident,
                    "max_error_over_tau": r.max_error_over_tau,
                    "frame_ms": r.frame_ms,
                    "read_ms": r.read_ms,
                    "at_ms": r.at_ms,
                })
            })
            .collect();
        runs.push(json!({
            "mode": mode,
            "summary": summary,
            "loops": loop_json,
            "per_frame": frames,
        }));
        plotted.push((mode, rows));
    }
    if let Some(dir) = &args.plot {
        let file = crate::bench_stream_plot::write_plot(dir, &views(&plotted))?;
        if !args.json {
            println!("plot: {}", file.display());
        }
    }
    if args.json {
        println!(
            "{}",
            json!({
                "repository": args.repository,
                "repository_bytes": file_bytes,
                "traversal": if args.gpu { "gpu" } else { "cpu" },
                "adapter": ctx.as_ref().map(|c| c.adapter_description()),
                "backend": ctx.as_ref().map(|c| c.backend.name()),
                "tolerance": args.tolerance,
                "size": [size.0, size.1],
                "budget_bytes": settings.budget_bytes,
                "upload_bytes_per_frame": if args.gpu {
                    crate::gpu_args::UPLOAD_BYTES_PER_FRAME
                } else {
                    settings.upload_bytes_per_frame
                },
                "latency_frames": (!args.gpu).then_some(settings.latency_frames),
                "runs": runs,
            })
        );
    }
    Ok(Outcome::Ok)
}

/// The first frame from which every frame to the end was settled, if the last one was.
fn settled_from_frame(rows: &[Row]) -> Option<usize> {
    match rows.iter().rposition(|r| !r.settled) {
        None => Some(0),
        Some(i) if i + 1 < rows.len() => Some(i + 1),
        Some(_) => None,
    }
}

/// What `bench_stream_plot` draws from a run's rows.
pub fn series(rows: &[RowView]) -> [Vec<(f64, f64)>; 4] {
    let mut out: [Vec<(f64, f64)>; 4] = Default::default();
    for (i, r) in rows.iter().enumerate() {
        let x = i as f64;
        out[0].push((x, r.0));
        out[1].push((x, r.1));
        // Known on the GPU only for the frames read back.
        if r.2.is_finite() {
            out[2].push((x, r.2));
        }
        out[3].push((x, r.3));
    }
    out
}

/// (resident MiB, loaded KiB, max ρ/τ, frame ms) of one frame.
pub type RowView = (f64, f64, f64, f64);

/// The plotted quantities of a row.
trait View {
    fn view(&self) -> RowView;
}

impl View for Row {
    fn view(&self) -> RowView {
        (
            self.resident_bytes as f64 / (1u64 << 20) as f64,
            self.loaded_bytes as f64 / 1024.0,
            self.max_error_over_tau.map_or(f64::NAN, f64::from),
            self.frame_ms,
        )
    }
}

/// Rows of every run as plotted quantities.
fn views(runs: &[(&str, Vec<Row>)]) -> Vec<(String, Vec<RowView>)> {
    runs.iter()
        .map(|(m, rows)| (m.to_string(), rows.iter().map(Row::view).collect()))
        .collect()
}
