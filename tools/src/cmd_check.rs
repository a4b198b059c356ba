//! `tessera check REPO [--views N] [--tolerances a,b,...] [--gpu] [--json]`
//!
//! Always the geometric check (edges by global id); with `--gpu`, also the pixel check on the
//! GPU (flag colour on back faces, views from outside) and GPU-vs-CPU selection; with
//! `--gpu-budget`, that check under partial residency (the streaming renderer, every streamed
//! frame checked against the CPU streaming reference for its flags).

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use serde_json::json;
use tessera_core::repository::reader::Repository;
use tessera_runtime::cut_patches::RepositoryPatches;
use tessera_runtime::geometric_check::{check_cuts, check_metric, CheckConfig, CheckReport};
use tessera_runtime::pixel_check::{check_pixels, PixelCheckConfig, PixelCheckReport};
use tessera_runtime::stream_pixel_check::check_pixels_streaming;
use tessera_runtime::views::check_views;

use crate::Outcome;

#[derive(Args)]
pub struct CheckArgs {
    /// Repository file.
    pub repository: PathBuf,
    /// Number of camera positions (around and inside the model).
    #[arg(long, default_value_t = 64)]
    pub views: usize,
    /// Pixel tolerances, at 1920×1080 with a 60° vertical field of view.
    #[arg(long, value_delimiter = ',', default_value = "0.5,1,2,4,8")]
    pub tolerances: Vec<f32>,
    /// Also render every (view, tolerance) on the GPU and count back-face flag pixels (a
    /// closed model seen from outside shows none; views are outside its bounding sphere).
    #[arg(long)]
    pub gpu: bool,
    /// Image size of the GPU check, WIDTHxHEIGHT (tolerances are pixels at this height).
    #[arg(long, default_value = "1920x1080", value_parser = crate::cmd_render::parse_size)]
    pub size: (u32, u32),
    /// Up direction of the GPU check's cameras (default: y for meshes, z for terrains).
    #[arg(long, value_parser = crate::cmd_render::parse_vec3)]
    pub up: Option<[f64; 3]>,
    #[command(flatten)]
    pub device: crate::gpu_args::GpuArgs,
    /// Also measure every cut against the repository's leaves in pixels, both ways, sampled:
    /// the largest error against τ (`check_errors.rs`; reported, not failed)
    #[arg(long)]
    pub errors: bool,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: CheckArgs) -> anyhow::Result<Outcome> {
    if let Some(bad) = args.tolerances.iter().find(|t| !t.is_finite() || **t < 0.0) {
        anyhow::bail!("tolerance {bad} must be a finite number ≥ 0");
    }
    let start = Instant::now();
    let repo = crate::repository_arg::open(&args.repository, "check")?;
    let config = CheckConfig {
        views: args.views,
        tolerances: args.tolerances.clone(),
        ..Default::default()
    };
    // Decoded as each cut reaches them (every one decoded once first, so a damaged patch is an
    // error here): the check holds one cut's triangles, not every level's.
    let patches = RepositoryPatches::new(&repo)?;
    let report = check_cuts(&repo, &patches, &config);
    let eyes = check_views(repo.header().bbox_min, repo.header().bbox_max, config.views);
    let attribute_errors = crate::attribute_cut::cut_attribute_errors(
        &repo,
        &check_metric(repo.header(), &config),
        &eyes,
        &config.tolerances,
    );
    let largest_side = crate::attribute_cut::largest_texture_side(&repo);
    let seconds = start.elapsed().as_secs_f64();
    let errors = match args.errors {
        true => Some(crate::check_errors::measure(
            &repo,
            args.views,
            &args.tolerances,
        )?),
        false => None,
    };
    let mut streaming = None;
    let gpu = if args.gpu {
        let start = Instant::now();
        let ctx = args.device.context()?;
        let config = PixelCheckConfig {
            views: args.views,
            tolerances: args.tolerances.clone(),
            up: args
                .up
                .unwrap_or(crate::cmd_render::default_up(repo.header().dimension)),
            ..Default::default()
        };
        // With --gpu-budget: the check under partial residency (the streaming renderer, every
        // streamed frame checked; `stream_pixel_check`), closed meshes only.
        let pixels = if args.device.gpu_budget.is_some() {
            if repo.header().dimension != 3 {
                anyhow::bail!(
                    "check --gpu --gpu-budget checks closed meshes under partial residency; \
                     terrains are checked fully resident (omit --gpu-budget)"
                );
            }
            let shared = std::sync::Arc::new(Repository::open(&args.repository)?);
            let (mut renderer, mut streamer) =
                args.device
                    .streaming(&ctx, shared, (args.size.0, args.size.1))?;
            let pixels = check_pixels_streaming(&ctx, &mut renderer, &mut streamer, &repo, &config)
                .map_err(crate::gpu_args::device_failure)?;
            let (stats, gpu) = (streamer.residency().stats(), streamer.stats());
            streaming = Some(json!({
                "resident_bytes": gpu.gpu_bytes,
                "budget_bytes": args.device.budget_bytes(&ctx),
                "fixed_bytes": gpu.fixed_bytes,
                "record_slots": gpu.record_slots,
                "record_bytes": gpu.record_bytes,
                "pool_bytes": gpu.pool_bytes,
                "resident_patches": streamer.resident_patches(),
                "loaded_bytes": stats.loaded_bytes,
                "evictions": stats.evictions,
            }));
            pixels
        } else {
            let mut renderer = args
                .device
                .renderer(&ctx, &repo, (args.size.0, args.size.1))?;
            check_pixels(&ctx, &mut renderer, &repo, &config)?
        };
        Some((
            pixels,
            start.elapsed().as_secs_f64(),
            ctx.adapter_description(),
            ctx.backend.name(),
        ))
    } else {
        None
    };
    if args.json {
        let mut value = report_json(&report, seconds);
        value["attribute_errors"] =
            crate::attribute_cut::per_tolerance_json(attribute_errors.as_deref(), largest_side);
        if let Some((pixels, seconds, adapter, backend)) = &gpu {
            value["gpu"] = pixel_report_json(pixels, *seconds, adapter);
            value["gpu"]["backend"] = (*backend).into();
            value["backend"] = (*backend).into();
            value["flag_pixels"] = pixels.flag_pixels.into();
            if let Some(stream) = &streaming {
                for (k, v) in stream.as_object().into_iter().flatten() {
                    value[k] = v.clone();
                }
            }
        }
        if let Some(e) = &errors {
            value["errors"] = crate::check_errors::report_json(e);
        }
        println!("{value}");
    } else {
        print_report(&report, seconds);
        if let Some(per_tau) = &attribute_errors {
            crate::attribute_cut::print_per_tolerance(per_tau, largest_side);
        }
        if let Some(e) = &errors {
            crate::check_errors::print_report(e);
        }
        if let Some((pixels, seconds, adapter, _)) = &gpu {
            print_pixel_report(pixels, *seconds, adapter);
        }
    }
    let clean = report.is_clean() && gpu.as_ref().is_none_or(|(p, ..)| p.is_clean());
    Ok(if clean {
        Outcome::Ok
    } else {
        Outcome::CheckFailed
    })
}

pub fn pixel_report_json(r: &PixelCheckReport, seconds: f64, adapter: &str) -> serde_json::Value {
    json!({
        "frames": r.frames,
        "flag_pixels": r.flag_pixels,
        "frames_with_flags": r.frames_with_flags,
        "selection_mismatches": r.selection_mismatches,
        "covered_pixels": r.covered_pixels,
        "excused_pixels": r.excused_pixels,
        "worst": r.worst.as_ref().map(|w| json!({
            "view": w.view, "tolerance": w.tolerance, "flag_pixels": w.flag_pixels, "eye": w.eye,
        })),
        "adapter": adapter,
        "seconds": seconds,
    })
}

pub fn print_pixel_report(r: &PixelCheckReport, seconds: f64, adapter: &str) {
    println!(
        "GPU ({adapter}): {} frames in {seconds:.2} s: {} flag pixels in {} frames, {} selection mismatches (GPU vs CPU), {} pixels covered",
        r.frames, r.flag_pixels, r.frames_with_flags, r.selection_mismatches, r.covered_pixels
    );
    if r.excused_pixels > 0 {
        println!(
            "  {} flag pixels next to the input's own see-through pixels (holes) excused",
            r.excused_pixels
        );
    }
    if let Some(w) = &r.worst {
        println!(
            "worst frame: view {} at τ = {} px with {} flag pixels (eye {:?})",
            w.view, w.tolerance, w.flag_pixels, w.eye
        );
    }
    println!(
        "{}",
        if r.is_clean() {
            "GPU CLEAN"
        } else {
            "GPU FAILED"
        }
    );
}

pub fn report_json(r: &CheckReport, seconds: f64) -> serde_json::Value {
    json!({
        "cuts_checked": r.cuts_checked,
        "cracks": r.cracks,
        "nonmanifold_introduced": r.nonmanifold_introduced,
        "monotonicity_violations": r.monotonicity_violations,
        "traversal_mismatches": r.traversal_mismatches,
        "position_mismatches": r.position_mismatches,
        "min_triangles": r.min_triangles,
        "max_triangles": r.max_triangles,
        "worst": r.worst.as_ref().map(|(view, tau, cracks)| json!({"view": view, "tolerance": tau, "cracks": cracks})),
        "seconds": seconds,
    })
}

pub fn print_report(r: &CheckReport, seconds: f64) {
    println!(
        "{} cuts checked in {:.2} s: {} cracks, {} non-manifold edges introduced, {} monotonicity violations, {} traversal mismatches, {} shared vertices stored at two positions",
        r.cuts_checked, seconds, r.cracks, r.nonmanifold_introduced, r.monotonicity_violations, r.traversal_mismatches, r.position_mismatches
    );
    println!(
        "triangles per cut: {} .. {}",
        r.min_triangles, r.max_triangles
    );
    if let Some((view, tau, cracks)) = &r.worst {
        println!("worst cut: view {view} at τ = {tau} px with {cracks} cracks");
    }
    println!("{}", if r.is_clean() { "CLEAN" } else { "FAILED" });
}
