//! `tessera bench breakdown REPO --source INPUT`: where our triangles go (issue 13, item 7),
//! measured on the repository itself, without a GPU.
//!
//! Two measurements:
//! - **The projection.** The run-time rule projects a diamond's error from the nearest point
//!   of its bounding sphere. The counterfactual projects it from the nearest point of the
//!   axis-aligned box of the diamond's own patches, less the error itself (still a bound on
//!   where the error can be seen), then takes the maximum over each diamond's descendants so
//!   that the rule stays monotone and every cut valid. Both cuts, at each τ over the bench's
//!   views (CPU selection with the frustum and normal-cone tests, as a lit frame draws), are
//!   measured like `bench` measures a frame: two-sided, visible samples only. What the box
//!   saves at equal measured error is what the sphere costs.
//! - **The reduction per level.** For each split diamond: the triangles of the patches its
//!   split creates (what it gathered) against those of its own patches (what it kept), and the
//!   share of the kept triangles with a corner on the boundary of the diamond's patches (the
//!   locked border, which the simplifier may not move). Summed per level: a level that keeps
//!   more than half of what it gathered is where the hierarchy stays fine, and the border
//!   share says whether the lock is why. Also per level: the diamonds whose stored error is
//!   one of their children's (saturation raised it above their own).
//! - **The counterfactuals per level** (`bench_breakdown_locks.rs`): each diamond simplified
//!   again with its border locked and free (the triangles the free one keeps at the locked
//!   one's error: what the lock costs), and its stored error against its own recomputed (how
//!   far saturation raised it).

use std::collections::HashMap;
use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde_json::json;
use tessera_core::cut::diamond_rhos;
use tessera_core::metric::center_minus_eye;
use tessera_core::repository::format::dequantize_position;
use tessera_core::repository::{Repository, NO_INDEX};
use tessera_runtime::camera::Camera;
use tessera_runtime::measure::SamplingConfig;

use crate::bench::cpu_cut::{cut_error_with, MeasuredCut};
use crate::bench::{outside_cameras, reference_mesh};
use crate::cmd_render::default_up;
use crate::Outcome;

#[derive(Args)]
pub struct BreakdownBenchArgs {
    /// The repository.
    pub repo: PathBuf,
    /// The mesh it was built from (the original the error is measured against).
    #[arg(long)]
    pub source: PathBuf,
    /// Pixel tolerances τ, one row each.
    #[arg(long, value_delimiter = ',', default_value = "0.25,0.5,1,2,4,8,16")]
    pub tolerances: Vec<f32>,
    /// Camera positions outside the bounding sphere (the bench's views).
    #[arg(long, default_value_t = 8)]
    pub views: usize,
    /// Target size, WIDTHxHEIGHT (τ is in pixels of this height).
    #[arg(long, default_value = "1920x1080", value_parser = crate::cmd_render::parse_size)]
    pub size: (u32, u32),
    /// Points sampled per view on each surface, as `bench --samples`.
    #[arg(long, default_value_t = 20_000)]
    pub samples: usize,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: BreakdownBenchArgs) -> anyhow::Result<Outcome> {
    let repo = crate::repository_arg::open(&args.repo, "bench breakdown")
        .with_context(|| format!("cannot open {}", args.repo.display()))?;
    let h = *repo.header();
    let mesh = crate::cmd_bench_render::load_source_mesh(&args.source, &repo)?;
    let reference = reference_mesh(&mesh, h.origin)?;
    let cameras = outside_cameras(&h, args.views, args.size, default_up(h.dimension));
    let boxes = diamond_boxes(&repo)?;
    let sampling = SamplingConfig {
        samples_per_view: args.samples,
        ..SamplingConfig::default()
    };

    let mut rows = Vec::new();
    for &tau in &args.tolerances {
        let sphere = cut_error_with(
            &repo,
            &reference,
            &cameras,
            tau,
            &sampling,
            |camera, eye| diamond_rhos(repo.diamonds(), eye, &camera.metric()),
        )?;
        let boxed = cut_error_with(
            &repo,
            &reference,
            &cameras,
            tau,
            &sampling,
            |camera, eye| box_rhos(&repo, &boxes, eye, camera),
        )?;
        rows.push((tau, sphere, boxed));
    }
    let levels = level_reduction(&repo)?;
    let locks = crate::bench_breakdown_locks::lock_counterfactuals(&repo)?;

    let row_json = |r: &MeasuredCut| {
        json!({
            "triangles": r.triangles,
            "error_max_px": r.error.map(|e| e.max_px),
            "error_p99_px": r.error.map(|e| e.p99_px),
            "error_samples": r.error.map_or(0, |e| e.samples),
        })
    };
    if args.json {
        let value = json!({
            "repository": args.repo.display().to_string(),
            "source": args.source.display().to_string(),
            "views": args.views,
            "size": [args.size.0, args.size.1],
            "metric": {"distance": "euclidean", "sides": "two-sided", "visible_only": true},
            "projection": rows.iter().map(|(tau, s, b)| json!({
                "tolerance": tau, "sphere": row_json(s), "box": row_json(b),
            })).collect::<Vec<_>>(),
            "levels": levels.iter().map(|l| json!({
                "level": l.level, "diamonds": l.diamonds, "gathered": l.gathered,
                "kept": l.kept, "kept_on_border": l.kept_on_border, "saturated": l.raised,
            })).collect::<Vec<_>>(),
            "locks": locks.iter().map(|l| json!({
                "level": l.level, "diamonds": l.diamonds, "gathered": l.gathered,
                "kept_locked": l.kept_locked,
                "kept_free_at_equal_error": l.kept_free_at_equal_error,
                "error_ratio_median": l.error_ratio_median,
                "raise_median": l.raise_median, "raise_p90": l.raise_p90,
            })).collect::<Vec<_>>(),
        });
        println!("{value}");
        return Ok(Outcome::Ok);
    }
    println!(
        "{}: {} views outside the bounding sphere, {}x{}, two-sided visible error (CPU cut)",
        args.repo.display(),
        args.views,
        args.size.0,
        args.size.1
    );
    println!("  τ px   sphere: triangles  max px  p99 px   box: triangles  max px  p99 px");
    let e = |r: &MeasuredCut| {
        r.error
            .map_or((f64::NAN, f64::NAN), |e| (e.max_px, e.p99_px))
    };
    for (tau, s, b) in &rows {
        let ((sm, sp), (bm, bp)) = (e(s), e(b));
        println!(
            "  {tau:>5}  {:>17.0}  {sm:>6.2}  {sp:>6.3}  {:>14.0}  {bm:>6.2}  {bp:>6.3}",
            s.triangles, b.triangles
        );
    }
    println!("  level  diamonds  gathered      kept  kept/gathered  kept on border  saturated");
    for l in &levels {
        println!(
            "  {:>5}  {:>8}  {:>8}  {:>8}  {:>13.3}  {:>14.3}  {:>9}",
            l.level,
            l.diamonds,
            l.gathered,
            l.kept,
            l.kept as f64 / l.gathered.max(1) as f64,
            l.kept_on_border as f64 / l.kept.max(1) as f64,
            l.raised
        );
    }
    println!(
        "  level  diamonds  gathered  kept locked  kept free at equal error  error locked/free  \
         stored/own median  p90"
    );
    let or_nan = |x: Option<f64>| x.unwrap_or(f64::NAN);
    for l in &locks {
        println!(
            "  {:>5}  {:>8}  {:>8}  {:>11}  {:>24}  {:>17.2}  {:>17.2}  {:>4.2}",
            l.level,
            l.diamonds,
            l.gathered,
            l.kept_locked,
            l.kept_free_at_equal_error,
            or_nan(l.error_ratio_median),
            or_nan(l.raise_median),
            or_nan(l.raise_p90)
        );
    }
    Ok(Outcome::Ok)
}

/// Per diamond, the box (origin-relative, f32) of its own patches' vertices: the geometry a
/// drawn diamond shows. Empty diamonds get an empty box.
fn diamond_boxes(repo: &Repository) -> anyhow::Result<Vec<([f32; 3], [f32; 3])>> {
    let h = repo.header();
    let empty = ([f32::MAX; 3], [f32::MIN; 3]);
    let mut boxes = vec![empty; repo.diamonds().len()];
    for (i, t) in repo.tets().iter().enumerate() {
        if t.diamond == NO_INDEX {
            continue;
        }
        let patch = repo.patch(i)?;
        let view = patch.view();
        let b = &mut boxes[t.diamond as usize];
        for v in 0..view.vertex_count() {
            let p = dequantize_position(view.position(v), h.bbox_min, h.position_step);
            for (k, (&coordinate, &origin)) in p.iter().zip(&h.origin).enumerate() {
                let x = (coordinate - origin) as f32;
                b.0[k] = b.0[k].min(x);
                b.1[k] = b.1[k].max(x);
            }
        }
    }
    Ok(boxes)
}

/// ρ from the nearest point of each diamond's box, less its error, then the maximum over its
/// descendants (children before parents: a child's level is its parent's plus one), so that
/// a parent's ρ is never below a child's and the rule's cuts stay valid.
fn box_rhos(
    repo: &Repository,
    boxes: &[([f32; 3], [f32; 3])],
    eye: [f32; 3],
    camera: &Camera,
) -> Vec<f32> {
    let metric = camera.metric();
    let diamonds = repo.diamonds();
    let mut rhos: Vec<f32> = diamonds
        .iter()
        .zip(boxes)
        .map(|(d, (lo, hi))| {
            if lo[0] > hi[0] {
                // No geometry: the sphere's value (a diamond with empty patches).
                return metric.rho(d.error, center_minus_eye(d.center, eye), d.radius);
            }
            let nearest: [f32; 3] = [0, 1, 2].map(|k| eye[k].clamp(lo[k], hi[k]));
            let to = center_minus_eye(nearest, eye);
            // A sphere of radius `error` at the nearest point: ρ = error·k / (distance − error).
            metric.rho(d.error, to, d.error)
        })
        .collect();
    let mut order: Vec<usize> = (0..diamonds.len()).collect();
    order.sort_by_key(|&d| std::cmp::Reverse(diamonds[d].level));
    for d in order {
        let rho = rhos[d];
        for &p in diamonds[d].parents() {
            let p = p as usize;
            rhos[p] = rhos[p].max(rho);
        }
    }
    rhos
}

struct LevelRow {
    level: u32,
    diamonds: usize,
    gathered: u64,
    kept: u64,
    kept_on_border: u64,
    /// Diamonds whose stored error is a descendant's (saturation raised it above its own).
    raised: usize,
}

/// Per LEB level: the triangles the level's diamonds gathered (their children's patches) and
/// kept (their own), and how many kept triangles touch the boundary of their diamond's kept
/// patches (edges, by global vertex id, used by one kept triangle).
fn level_reduction(repo: &Repository) -> anyhow::Result<Vec<LevelRow>> {
    let diamonds = repo.diamonds();
    let mut rows: Vec<LevelRow> = Vec::new();
    let mut own: Vec<Vec<usize>> = vec![Vec::new(); diamonds.len()];
    let mut created: Vec<Vec<usize>> = vec![Vec::new(); diamonds.len()];
    for (i, t) in repo.tets().iter().enumerate() {
        if t.diamond != NO_INDEX {
            own[t.diamond as usize].push(i);
        }
        if t.parent_diamond != NO_INDEX {
            created[t.parent_diamond as usize].push(i);
        }
    }
    // The largest stored error among each diamond's children: a diamond whose stored error
    // is that one's took it from below by saturation.
    let mut child_max = vec![f32::NEG_INFINITY; diamonds.len()];
    for record in diamonds {
        for &p in record.parents() {
            let m = &mut child_max[p as usize];
            *m = m.max(record.error);
        }
    }
    for (d, record) in diamonds.iter().enumerate() {
        let level = record.level as usize;
        while rows.len() <= level {
            rows.push(LevelRow {
                level: rows.len() as u32,
                diamonds: 0,
                gathered: 0,
                kept: 0,
                kept_on_border: 0,
                raised: 0,
            });
        }
        let count = |tets: &[usize]| -> u64 {
            tets.iter()
                .map(|&t| repo.tets()[t].triangle_count as u64)
                .sum()
        };
        let mut triangles: Vec<[u32; 3]> = Vec::new();
        for &t in &own[d] {
            triangles.extend(tessera_runtime::cut_patches::decode(repo, t)?);
        }
        let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *uses.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let on_border: std::collections::HashSet<u32> = uses
            .iter()
            .filter(|&(_, &n)| n == 1)
            .flat_map(|(&(a, b), _)| [a, b])
            .collect();
        let row = &mut rows[level];
        row.diamonds += 1;
        // Saturation stores a child's error times 1 + 1e-5 (`saturate.rs`, ERROR_MARGIN) plus
        // the quantisation: within 3e-5 of a child's error is a child's error.
        row.raised += usize::from(record.error > 0.0 && record.error <= child_max[d] * 1.000_03);
        row.gathered += count(&created[d]);
        row.kept += count(&own[d]);
        row.kept_on_border += triangles
            .iter()
            .filter(|t| t.iter().any(|v| on_border.contains(v)))
            .count() as u64;
    }
    Ok(rows)
}
