//! The measurement loop of the trade-off benchmark: every subject at every τ over every view,
//! measured (counts, geometric error, image against the full resolution) and timed.
//!
//! Per view:
//! 1. the full-resolution frame (when that peer is there): the reference picture;
//! 2. one measured frame per (subject, τ): counts, the error both ways between the surface
//!    drawn and the original mesh over the samples the eye sees (`measure::two_sided_errors`;
//!    the original's visible samples are drawn once per view and shared by every cut), the
//!    image against the reference;
//! 3. timed rounds: one warm-up round, then `frames` rounds, each drawing one frame of every
//!    (subject, τ) in turn — interleaved, so that the shared machine's drifting load hits every
//!    subject alike — each frame waited for.
//!
//! Times: run r is the r-th timed round of every view; its time is the mean over views of that
//! round's frame. A row's time is the median over the runs, with the fastest and slowest run
//! as its spread (`frames` runs: 5 by default).
//!
//! Per (subject, τ) the rows average the per-view numbers (counts, share of differing pixels,
//! MSE — the PSNR is the mean MSE's) and pool the error samples of all views
//! before summarising them: each direction apart, and both together (the row's `error`).

use tessera_runtime::camera::Camera;
use tessera_runtime::faces::Faces;
use tessera_runtime::gpu::target::BACKGROUND_RGBA8;
use tessera_runtime::gpu::GpuContext;
use tessera_runtime::measure::{
    compare_images, original_sampling, psnr_of_mse, two_sided_errors, visible_samples,
    ErrorSummary, ReferenceMesh, SamplingConfig, TwoSidedErrors, DIFF_THRESHOLD, PSNR_SATURATED_DB,
};

use tessera_bench::subject::{timed_frame, FrameTimes, Subject};

/// What to measure.
#[derive(Clone, Debug)]
pub struct Settings {
    /// Pixel tolerances τ, one row each.
    pub tolerances: Vec<f32>,
    /// Timed frames per (view, subject, τ), after one warm-up frame.
    pub frames: usize,
    /// Samples per view (the seed is offset by the view's index).
    pub sampling: SamplingConfig,
    /// The repository origin: the frame of every surface and of the reference mesh.
    pub origin: [f64; 3],
    /// The face rule every subject draws with, and the measurement sees with.
    pub faces: Faces,
    /// After each timed frame, the same frame again with its selection and raster waited
    /// for apart (`Subject::phased_frame`): the rows' `select_ms` and `raster_ms`.
    pub phases: bool,
}

/// One subject at one τ, averaged over the views.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub tolerance: f32,
    pub views: usize,
    /// Mean over views.
    pub patches: f64,
    pub triangles: f64,
    /// Mean level drawn, for a subject with discrete levels.
    pub level: Option<f64>,
    /// Median over runs of the run's mean over views (see the module comment); without the
    /// uploads, which `upload_ms` counts.
    pub cpu_ms: f64,
    pub upload_ms: f64,
    pub wall_ms: f64,
    /// The fastest and the slowest run's wall time.
    pub wall_ms_spread: (f64, f64),
    /// Timed runs behind the times.
    pub runs: usize,
    /// `None` where the adapter has no timestamps.
    pub gpu_ms: Option<f64>,
    /// Medians over runs, as the times above, of the phased frames (`Settings::phases`):
    /// choosing what to draw, and drawing it; `None` where not asked for.
    pub select_ms: Option<f64>,
    pub raster_ms: Option<f64>,
    /// Two-sided: over the samples of all views, both directions pooled; `None` when no
    /// sample was seen.
    pub error: Option<ErrorSummary>,
    /// The drawn cut's visible samples against the original.
    pub error_to_original: Option<ErrorSummary>,
    /// The original's visible samples against the drawn cut.
    pub error_to_cut: Option<ErrorSummary>,
    /// Samples skipped as hidden (both directions, all views; summed, not averaged).
    pub hidden_samples: usize,
    /// Mean over views of the share of differing pixels; `None` without a reference picture.
    pub pixels_differing: Option<f64>,
    /// PSNR (dB) of the views' mean MSE — of all the views' frames as one — saturated at
    /// `PSNR_SATURATED_DB`; `None` without a reference picture. (Not the mean of per-view
    /// PSNRs: one identical view would weigh 99 dB into it.)
    pub psnr: Option<f64>,
}

/// A subject's rows, one per τ.
#[derive(Clone, Debug)]
pub struct SubjectRows {
    pub name: &'static str,
    pub rows: Vec<Row>,
}

/// Sums over views for one (subject, τ).
#[derive(Clone, Debug, Default)]
struct Tally {
    views: usize,
    patches: f64,
    triangles: f64,
    levels: Option<f64>,
    /// Per run (timed round), sums over views.
    cpu_ms: Vec<f64>,
    upload_ms: Vec<f64>,
    wall_ms: Vec<f64>,
    gpu_ms: Vec<f64>,
    gpu_missing: bool,
    select_ms: Vec<f64>,
    raster_ms: Vec<f64>,
    to_original: Vec<f64>,
    to_cut: Vec<f64>,
    hidden: usize,
    differing: Option<f64>,
    mse: Option<f64>,
}

impl Tally {
    /// One view's timed frames, one per run.
    fn add_times(&mut self, times: &[FrameTimes]) {
        let add = |sums: &mut Vec<f64>, values: &mut dyn Iterator<Item = f64>| {
            for (r, x) in values.enumerate() {
                if sums.len() <= r {
                    sums.push(0.0);
                }
                sums[r] += x;
            }
        };
        add(&mut self.cpu_ms, &mut times.iter().map(|t| t.cpu_ms));
        add(&mut self.upload_ms, &mut times.iter().map(|t| t.upload_ms));
        add(&mut self.wall_ms, &mut times.iter().map(|t| t.wall_ms));
        if times.iter().all(|t| t.gpu_ms.is_some()) && !times.is_empty() {
            add(&mut self.gpu_ms, &mut times.iter().filter_map(|t| t.gpu_ms));
        } else {
            self.gpu_missing = true;
        }
        if times.iter().all(|t| t.phases.is_some()) {
            let phases = || times.iter().filter_map(|t| t.phases);
            add(&mut self.select_ms, &mut phases().map(|p| p.select_ms));
            add(&mut self.raster_ms, &mut phases().map(|p| p.raster_ms));
        }
    }

    fn add_errors(&mut self, e: TwoSidedErrors) {
        self.hidden += e.to_original.hidden + e.to_cut.hidden;
        self.to_original.extend(e.to_original.errors_px);
        self.to_cut.extend(e.to_cut.errors_px);
    }

    fn row(&self, tolerance: f32) -> Row {
        let n = self.views.max(1) as f64;
        // Median over runs of the per-run mean over views.
        let median = |sums: &[f64]| -> f64 {
            if sums.is_empty() {
                return 0.0;
            }
            let mut v: Vec<f64> = sums.iter().map(|x| x / n).collect();
            v.sort_by(f64::total_cmp);
            let k = v.len() / 2;
            if v.len() % 2 == 1 {
                v[k]
            } else {
                0.5 * (v[k - 1] + v[k])
            }
        };
        let runs = self.wall_ms.iter().map(|x| x / n);
        let spread = runs.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        });
        Row {
            tolerance,
            views: self.views,
            patches: self.patches / n,
            triangles: self.triangles / n,
            level: self.levels.map(|l| l / n),
            cpu_ms: median(&self.cpu_ms),
            upload_ms: median(&self.upload_ms),
            wall_ms: median(&self.wall_ms),
            wall_ms_spread: if self.wall_ms.is_empty() {
                (0.0, 0.0)
            } else {
                spread
            },
            runs: self.wall_ms.len(),
            gpu_ms: (!self.gpu_missing && !self.gpu_ms.is_empty()).then(|| median(&self.gpu_ms)),
            select_ms: (!self.select_ms.is_empty()).then(|| median(&self.select_ms)),
            raster_ms: (!self.raster_ms.is_empty()).then(|| median(&self.raster_ms)),
            error: ErrorSummary::of(&[&self.to_original[..], &self.to_cut[..]].concat()),
            error_to_original: ErrorSummary::of(&self.to_original),
            error_to_cut: ErrorSummary::of(&self.to_cut),
            hidden_samples: self.hidden,
            pixels_differing: self.differing.map(|d| d / n),
            psnr: self.mse.map(|mse| psnr_of_mse(mse / n)),
        }
    }
}

/// Measures `subjects` (and `full`, the full-resolution peer, when given: the reference
/// picture and the baseline time) at every τ of `settings` from every camera. `on_view` is
/// called before each view (progress). The full-resolution rows repeat its per-view numbers
/// at every τ, with error 0 by definition, no differing pixel and a saturated PSNR.
pub fn measure(
    ctx: &GpuContext,
    cameras: &[Camera],
    subjects: &mut [&mut dyn Subject],
    mut full: Option<&mut dyn Subject>,
    reference: &ReferenceMesh,
    settings: &Settings,
    on_view: &dyn Fn(usize),
) -> anyhow::Result<(Vec<SubjectRows>, Option<SubjectRows>)> {
    let taus = &settings.tolerances;
    let mut tallies = vec![vec![Tally::default(); taus.len()]; subjects.len()];
    let mut full_tally = Tally::default();
    for (v, camera) in cameras.iter().enumerate() {
        on_view(v);
        // 1. The reference picture.
        let reference_image = match full.as_deref_mut() {
            Some(f) => {
                let (drawn, image) = f.measured_frame(ctx, camera, 0.0)?;
                full_tally.views += 1;
                full_tally.patches += drawn.patches as f64;
                full_tally.triangles += drawn.triangles as f64;
                Some(image)
            }
            None => None,
        };
        // 2. One measured frame per (subject, τ).
        let sampling = SamplingConfig {
            seed: settings.sampling.seed.wrapping_add(v as u64),
            ..settings.sampling
        };
        let original = visible_samples(
            reference,
            camera,
            settings.origin,
            &original_sampling(&sampling),
            settings.faces,
        );
        for (subject, tallies) in subjects.iter_mut().zip(&mut tallies) {
            for (&tau, tally) in taus.iter().zip(tallies.iter_mut()) {
                let (drawn, image) = subject.measured_frame(ctx, camera, tau)?;
                let errors = two_sided_errors(
                    reference,
                    &original,
                    subject.surface(),
                    camera,
                    settings.origin,
                    &sampling,
                    settings.faces,
                )
                .map_err(|e| {
                    anyhow::anyhow!(
                        "{} drew a surface that cannot be measured: {e}",
                        subject.name()
                    )
                })?;
                tally.views += 1;
                tally.patches += drawn.patches as f64;
                tally.triangles += drawn.triangles as f64;
                if let Some(level) = drawn.level {
                    *tally.levels.get_or_insert(0.0) += level as f64;
                }
                tally.add_errors(errors);
                if let Some(reference_image) = &reference_image {
                    // Over the model's pixels: the frame around it is left out.
                    let [r, g, b, _] = BACKGROUND_RGBA8;
                    let diff =
                        compare_images(&image, reference_image, DIFF_THRESHOLD, Some([r, g, b]));
                    *tally.differing.get_or_insert(0.0) += diff.differing_share();
                    *tally.mse.get_or_insert(0.0) += diff.mse;
                }
            }
        }
        // 3. Timed rounds, interleaved.
        let mut times = vec![vec![Vec::new(); taus.len()]; subjects.len()];
        let mut full_times = Vec::new();
        for round in 0..=settings.frames {
            for (subject, times) in subjects.iter_mut().zip(&mut times) {
                for (&tau, times) in taus.iter().zip(times.iter_mut()) {
                    let mut t = timed_frame(&mut **subject, ctx, camera, tau)?;
                    if settings.phases {
                        t.phases = Some(subject.phased_frame(ctx, camera, tau)?);
                    }
                    if round > 0 {
                        times.push(t);
                    }
                }
            }
            if let Some(f) = full.as_deref_mut() {
                let mut t = timed_frame(f, ctx, camera, 0.0)?;
                if settings.phases {
                    t.phases = Some(f.phased_frame(ctx, camera, 0.0)?);
                }
                if round > 0 {
                    full_times.push(t);
                }
            }
        }
        for (tallies, times) in tallies.iter_mut().zip(&times) {
            for (tally, times) in tallies.iter_mut().zip(times) {
                tally.add_times(times);
            }
        }
        if full.is_some() {
            full_tally.add_times(&full_times);
        }
    }
    let rows = subjects
        .iter()
        .zip(&tallies)
        .map(|(s, tallies)| SubjectRows {
            name: s.name(),
            rows: taus.iter().zip(tallies).map(|(&t, y)| y.row(t)).collect(),
        })
        .collect();
    let full_rows = full.map(|f| SubjectRows {
        name: f.name(),
        rows: taus
            .iter()
            .map(|&tau| Row {
                error: Some(ErrorSummary {
                    samples: 0,
                    max_px: 0.0,
                    p99_px: 0.0,
                    mean_px: 0.0,
                }),
                error_to_original: None,
                error_to_cut: None,
                pixels_differing: Some(0.0),
                psnr: Some(PSNR_SATURATED_DB),
                ..full_tally.row(tau)
            })
            .collect(),
    });
    Ok((rows, full_rows))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn times(wall: &[f64]) -> Vec<FrameTimes> {
        wall.iter()
            .map(|&w| FrameTimes {
                cpu_ms: w / 10.0,
                upload_ms: w / 100.0,
                wall_ms: w,
                gpu_ms: None,
                phases: None,
            })
            .collect()
    }

    /// A run is one timed round over every view: its time is the views' mean; a row keeps the
    /// median run and the fastest and slowest.
    #[test]
    fn times_are_the_median_run_with_its_spread() {
        let mut tally = Tally {
            views: 2,
            ..Default::default()
        };
        tally.add_times(&times(&[1.0, 2.0, 9.0]));
        tally.add_times(&times(&[3.0, 4.0, 1.0]));
        let row = tally.row(1.0);
        // Runs: (1 + 3) / 2 = 2, (2 + 4) / 2 = 3, (9 + 1) / 2 = 5.
        assert_eq!(row.runs, 3);
        assert_eq!(row.wall_ms, 3.0);
        assert_eq!(row.wall_ms_spread, (2.0, 5.0));
        assert!((row.cpu_ms - 0.3).abs() < 1e-12);
        assert!((row.upload_ms - 0.03).abs() < 1e-12);
        assert_eq!(row.gpu_ms, None, "no timestamps, no GPU time");
        // An even number of runs: the mean of the middle two.
        let mut even = Tally {
            views: 1,
            ..Default::default()
        };
        even.add_times(&times(&[4.0, 1.0, 3.0, 2.0]));
        assert_eq!(even.row(1.0).wall_ms, 2.5);
    }
}
