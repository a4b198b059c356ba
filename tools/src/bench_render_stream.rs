//! `bench render --stream`: the streaming renderer `render` uses, timed τ after τ.

use serde_json::json;
use tessera_core::repository::reader::Repository;
use tessera_runtime::camera::Camera;
use tessera_runtime::gpu::{FrameRequest, Readback};

use std::time::Instant;

use crate::cmd_bench_render::{
    percentile, print_table, report, save_frame, RenderBenchArgs, Timings, WARM_UP_FRAMES,
};
use crate::Outcome;

/// Most frames drawn per τ while the stream settles.
const SETTLE_FRAMES: usize = 1000;

/// `--stream`: the streaming renderer (`gpu_args::streaming`), τ after τ. Per τ: frames until
/// settled (at most `SETTLE_FRAMES`), then the warm-up and timed frames of the settled view,
/// each waited for; `cpu_ms` is the streamer's whole frame call (landing units, recording,
/// submit, feedback, plan). The memory is read at the end (the process's resident set, the
/// GPU's allocations by the budget's accounting, RssAnon sampled after every frame).
pub(crate) fn run_streaming(
    args: &RenderBenchArgs,
    ctx: &tessera_runtime::gpu::GpuContext,
    repo: std::sync::Arc<Repository>,
    camera: Camera,
    orbit: [f64; 3],
) -> anyhow::Result<Outcome> {
    use crate::gpu_args::device_failure;
    let h = *repo.header();
    let simplices = repo.tets().len();
    let (mut renderer, mut streamer) =
        args.gpu
            .streaming(ctx, repo, (camera.width, camera.height))?;
    let mut anon_peak = crate::peak_rss::AnonPeak::default();
    anon_peak.sample();
    let mut rows = Vec::new();
    for &tau in &args.tolerances {
        let request = FrameRequest::new(camera, tau);
        let mut settled_after = None;
        for k in 1..=SETTLE_FRAMES {
            let f = streamer
                .frame(ctx, &mut renderer, &request, Readback::default())
                .map_err(device_failure)?;
            ctx.wait_idle()?;
            anon_peak.sample();
            if f.settled {
                settled_after = Some(k);
                break;
            }
        }
        let mut t = Timings::default();
        for round in 0..WARM_UP_FRAMES + args.frames {
            let start = Instant::now();
            streamer
                .frame(ctx, &mut renderer, &request, Readback::default())
                .map_err(device_failure)?;
            let cpu_ms = start.elapsed().as_secs_f64() * 1e3;
            ctx.wait_idle()?;
            let wall_ms = start.elapsed().as_secs_f64() * 1e3;
            anon_peak.sample();
            if round >= WARM_UP_FRAMES {
                t.gpu_ms.extend(renderer.read_gpu_ms(ctx)?);
                t.wall_ms.push(wall_ms);
                t.cpu_ms.push(cpu_ms);
            }
        }
        // One more frame, read back: what this τ drew.
        let last = streamer
            .frame(
                ctx,
                &mut renderer,
                &request,
                Readback {
                    image: args.save_frames.is_some(),
                    selection: true,
                },
            )
            .map_err(device_failure)?;
        let selection = renderer.read_selection(ctx)?;
        if args.save_frames.is_some() {
            let image = renderer.read_image(ctx)?;
            save_frame(&image, args.save_frames.as_deref(), &format!("tau-{tau}"))?;
        }
        rows.push(json!({
            "tolerance": tau,
            "patches": selection.len(),
            "triangles": renderer.triangles_of(&selection),
            "gpu_ms_median": t.gpu_median(),
            "gpu_ms_p90": percentile(&t.gpu_ms, 0.9),
            "wall_ms_median": percentile(&t.wall_ms, 0.5),
            "cpu_ms_median": percentile(&t.cpu_ms, 0.5),
            "cpu_ms_p90": percentile(&t.cpu_ms, 0.9),
            "speedup_vs_full": null,
            "wall_speedup_vs_full": null,
            "frames_to_converge": settled_after,
            "resident_patches": streamer.resident_patches(),
            "resident_patch_bytes": last.stats.resident_bytes,
            "pending_units": last.stats.pending_units,
        }));
    }
    let gpu = streamer.stats();
    let memory = anon_peak.sample();
    let mut value = report(
        args,
        ctx,
        (h.input_triangle_count, simplices),
        &camera,
        orbit,
        rows,
    );
    value["full_resolution"] = serde_json::Value::Null;
    value["stream"] = json!({
            "budget_bytes": args.gpu.budget_bytes(ctx),
            "resident_bytes": gpu.gpu_bytes,
            "fixed_bytes": gpu.fixed_bytes,
            "record_slots": gpu.record_slots,
            "record_bytes": gpu.record_bytes,
            "pool_bytes": gpu.pool_bytes,
            "pool_pages": gpu.pool_pages,
            "pool_growths": gpu.pool_growths,
            "max_resident_bytes": gpu.max_gpu_bytes,
            "loaded_bytes": streamer.residency().stats().loaded_bytes,
            "evictions": streamer.residency().stats().evictions,
    });
    value["memory"] = crate::peak_rss::MemoryNow::json(memory, anon_peak.bytes());
    if args.json {
        println!("{value}");
    } else {
        print_table(&value);
        let (s, m) = (&value["stream"], &value["memory"]);
        println!(
            "streamed: {} GPU bytes allocated of {} budget; peak RSS {} B, RssAnon {} B at the end \
             (sampled max {} B)",
            s["resident_bytes"],
            s["budget_bytes"],
            m["peak_rss_bytes"],
            m["rss_anon_bytes"],
            m["rss_anon_peak_sampled_bytes"]
        );
    }
    Ok(Outcome::Ok)
}
