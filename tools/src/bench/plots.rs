//! The trade-off plots (PNG, `plotters`), every subject on each:
//!
//! - `triangles_vs_tau.png`: triangles drawn against τ (log–log);
//! - `error_vs_tau.png`: measured error against τ (log–log): p99 solid, max dashed, and the
//!   line y = τ (the bound the cut rule aims at); a subject whose error is 0 (the full
//!   resolution, by definition) has no point on a log axis and says so in its legend;
//! - `frame_time_vs_tau.png`: wall milliseconds per frame against τ (log–log);
//! - `triangles_vs_max_error.png`: each subject's rows as (dense max error, triangles), joined
//!   in τ order, its Pareto front drawn bold (log–log): the trade itself, read at equal error
//!   front to front (the full resolution, error 0 by definition, is left out). The dense max
//!   (`dense`, as `check --errors`) where the bench measured it, else the sparse visible max;
//! - `error_vs_tau.png` also draws the dense max (dotted) where measured.
//!
//! Rows with τ ≤ 0 are left out (no place on a log axis). Each plot is drawn into memory and
//! written through a temporary file (`output::save_png`). Text is drawn with DejaVu Sans
//! embedded in the binary (`dejavu`, through plotters' pure-Rust `ab_glyph`): no system font
//! library or font file is needed.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context};
use plotters::prelude::*;

use super::dense::DenseRows;
use super::trade_off::{Row, SubjectRows};
use crate::output::save_png;

/// The file names, in the order `write_plots` returns them.
pub const PLOT_FILES: [&str; 4] = [
    "triangles_vs_tau.png",
    "error_vs_tau.png",
    "frame_time_vs_tau.png",
    "triangles_vs_max_error.png",
];

const SIZE: (u32, u32) = (960, 640);

/// A subject's colour: ours red, the peers in fixed colours.
fn colour(name: &str) -> RGBColor {
    match name {
        "ours" => RGBColor(214, 39, 40),
        "full_resolution" => RGBColor(60, 60, 60),
        "discrete_lod" => RGBColor(31, 119, 180),
        "cluster_dag" => RGBColor(44, 160, 44),
        _ => RGBColor(148, 103, 189),
    }
}

/// A value range for a log axis: the positive values, widened to whole decades (so that the
/// axis has labels), or [1, 10].
pub fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| *v > 0.0 && v.is_finite())
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo.is_finite() && hi > 0.0 {
        10f64.powf((lo / 1.2).log10().floor())..10f64.powf((hi * 1.2).log10().ceil())
    } else {
        1.0..10.0
    }
}

/// The τ axis: the positive tolerances, widened a little (no empty decades).
fn tau_range(taus: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = taus
        .filter(|v| *v > 0.0 && v.is_finite())
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo.is_finite() && hi > 0.0 {
        lo / 1.4..hi * 1.4
    } else {
        1.0..10.0
    }
}

/// An axis label: integers with thousands separators, small numbers with their digits.
fn label(v: &f64) -> String {
    if *v >= 1.0 {
        super::verdict::group_digits(*v)
    } else {
        format!("{}", (*v * 1e6).round() / 1e6)
    }
}

/// One plot: `value` of each row against τ, for every subject; `extra` draws more series.
struct Plot<'a> {
    file: &'a str,
    caption: &'a str,
    x_label: &'a str,
    y_label: &'a str,
    /// Where the legend goes (away from the curves).
    legend: SeriesLabelPosition,
}

type Chart<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    Cartesian2d<
        plotters::coord::combinators::LogCoord<f64>,
        plotters::coord::combinators::LogCoord<f64>,
    >,
>;

fn draw_plot(
    dir: &Path,
    plot: &Plot<'_>,
    xs: std::ops::Range<f64>,
    values: std::ops::Range<f64>,
    series: impl FnOnce(&mut Chart<'_, '_>) -> anyhow::Result<()>,
) -> anyhow::Result<PathBuf> {
    let mut buffer = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, SIZE).into_drawing_area();
        let err = |e: &dyn std::fmt::Display| anyhow!("drawing {}: {e}", plot.file);
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(plot.caption, ("sans-serif", 22))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(80)
            .build_cartesian_2d(xs.log_scale(), values.log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc(plot.x_label)
            .y_desc(plot.y_label)
            .x_label_formatter(&label)
            .y_label_formatter(&label)
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(|e| err(&e))?;
        series(&mut chart)?;
        chart
            .configure_series_labels()
            .position(plot.legend.clone())
            .label_font(("sans-serif", 15))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    let image = image::RgbImage::from_raw(SIZE.0, SIZE.1, buffer).context("plot buffer size")?;
    let path = dir.join(plot.file);
    save_png(&image::DynamicImage::ImageRgb8(image).to_rgba8(), &path)?;
    Ok(path)
}

/// Points (τ, value) of the rows with τ > 0 and a positive value.
fn points(rows: &[Row], value: impl Fn(&Row) -> Option<f64>) -> Vec<(f64, f64)> {
    rows.iter()
        .filter(|r| r.tolerance > 0.0)
        .filter_map(|r| Some((r.tolerance as f64, value(r).filter(|v| *v > 0.0)?)))
        .collect()
}

/// A solid line with dots, labelled in the legend.
fn line(
    chart: &mut Chart<'_, '_>,
    name: &str,
    points: Vec<(f64, f64)>,
    label: String,
) -> anyhow::Result<()> {
    let c = colour(name);
    let err = |e: &dyn std::fmt::Display| anyhow!("drawing {name}: {e}");
    chart
        .draw_series(LineSeries::new(points.clone(), c.stroke_width(2)))
        .map_err(|e| err(&e))?
        .label(label)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(2)));
    chart
        .draw_series(points.into_iter().map(|p| Circle::new(p, 3, c.filled())))
        .map_err(|e| err(&e))?;
    Ok(())
}

/// Registers the embedded font as plotters' "sans-serif" (idempotent).
pub fn register_font() -> anyhow::Result<()> {
    plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| anyhow!("the embedded DejaVu Sans font does not parse"))
}

/// Writes the four plots into `dir` (created if missing); returns their paths. `dense`: the
/// dense pass's rows by subject name, when measured.
pub fn write_plots(
    dir: &Path,
    subjects: &[&SubjectRows],
    dense: Option<&[DenseRows]>,
) -> anyhow::Result<Vec<PathBuf>> {
    let dense_of = |name: &str| dense.and_then(|d| d.iter().find(|s| s.name == name));
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create --plot {}", dir.display()))?;
    register_font()?;
    let all_rows = || subjects.iter().flat_map(|s| s.rows.iter());
    let taus = tau_range(all_rows().map(|r| r.tolerance as f64));
    let mut written = Vec::new();

    // Triangles.
    written.push(draw_plot(
        dir,
        &Plot {
            file: PLOT_FILES[0],
            caption: "Triangles drawn",
            x_label: TAU_LABEL,
            y_label: "triangles (mean over views)",
            legend: SeriesLabelPosition::UpperRight,
        },
        taus.clone(),
        log_range(all_rows().map(|r| r.triangles)),
        |chart| {
            for s in subjects {
                line(
                    chart,
                    s.name,
                    points(&s.rows, |r| Some(r.triangles)),
                    s.name.to_string(),
                )?;
            }
            Ok(())
        },
    )?);

    // Measured error, with y = τ.
    let dense_errors = dense
        .into_iter()
        .flatten()
        .flat_map(|s| s.rows.iter().map(|r| r.max_px));
    let errors = all_rows()
        .filter_map(|r| r.error)
        .flat_map(|e| [e.p99_px, e.max_px])
        .chain(all_rows().map(|r| r.tolerance as f64))
        .chain(dense_errors);
    written.push(draw_plot(
        dir,
        &Plot {
            file: PLOT_FILES[1],
            caption: "Screen-space error (sparse visible: p99 solid, max dashed; dense max dotted)",
            x_label: TAU_LABEL,
            y_label: "error (px)",
            legend: SeriesLabelPosition::UpperLeft,
        },
        taus.clone(),
        log_range(errors),
        |chart| {
            let err = |e: &dyn std::fmt::Display| anyhow!("drawing y = τ: {e}");
            chart
                .draw_series(LineSeries::new(
                    [taus.start, taus.end].map(|t| (t, t)),
                    BLACK.stroke_width(1),
                ))
                .map_err(|e| err(&e))?
                .label("y = τ")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], BLACK));
            for s in subjects {
                let p99 = points(&s.rows, |r| r.error.map(|e| e.p99_px));
                if p99.is_empty() {
                    // Nothing positive: say why it is not on the plot.
                    let c = colour(s.name);
                    chart
                        .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
                        .map_err(|e| err(&e))?
                        .label(format!("{}: error 0 (not on a log axis)", s.name))
                        .legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(2))
                        });
                    continue;
                }
                line(chart, s.name, p99, format!("{} p99", s.name))?;
                let max = points(&s.rows, |r| r.error.map(|e| e.max_px));
                let c = colour(s.name);
                chart
                    .draw_series(DashedLineSeries::new(max, 8, 5, c.stroke_width(1)))
                    .map_err(|e| err(&e))?
                    .label(format!("{} max", s.name))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], c));
                if let Some(d) = dense_of(s.name) {
                    let points: Vec<(f64, f64)> = d
                        .rows
                        .iter()
                        .map(|r| (r.tolerance as f64, r.max_px))
                        .filter(|p| p.0 > 0.0 && p.1 > 0.0 && p.1.is_finite())
                        .collect();
                    chart
                        .draw_series(DashedLineSeries::new(points, 2, 4, c.stroke_width(2)))
                        .map_err(|e| err(&e))?
                        .label(format!("{} dense max", s.name))
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], c));
                }
            }
            Ok(())
        },
    )?);

    // Frame time.
    written.push(draw_plot(
        dir,
        &Plot {
            file: PLOT_FILES[2],
            caption: "Frame time (wall: record, submit, GPU, wait)",
            x_label: TAU_LABEL,
            y_label: "wall ms per frame (mean over views)",
            legend: SeriesLabelPosition::UpperRight,
        },
        taus.clone(),
        log_range(all_rows().map(|r| r.wall_ms)),
        |chart| {
            for s in subjects {
                line(
                    chart,
                    s.name,
                    points(&s.rows, |r| Some(r.wall_ms)),
                    s.name.to_string(),
                )?;
            }
            Ok(())
        },
    )?);

    // The trade: triangles at each max error, dense where measured.
    let trade_of = |s: &SubjectRows| -> Vec<(f64, f64)> {
        let points: Vec<(f64, f64)> = match dense_of(s.name) {
            Some(d) => d.rows.iter().map(|r| (r.max_px, r.triangles)).collect(),
            None => s
                .rows
                .iter()
                .filter_map(|r| Some((r.error?.max_px, r.triangles)))
                .collect(),
        };
        points
            .into_iter()
            .filter(|p| p.0 > 0.0 && p.0.is_finite() && p.1 > 0.0)
            .collect()
    };
    let measured: Vec<&SubjectRows> = subjects
        .iter()
        .filter(|s| s.name != "full_resolution")
        .copied()
        .collect();
    let trades: Vec<Vec<(f64, f64)>> = measured.iter().map(|s| trade_of(s)).collect();
    let (caption, x_label, y_label) = match dense {
        Some(_) => (
            "Triangles against dense max error (as check --errors; fronts bold)",
            "dense max error (px)",
            "triangles (no culling, mean over the check's eyes)",
        ),
        None => (
            "Triangles against measured max error (two-sided, visible)",
            "measured max error (px)",
            "triangles (mean over views)",
        ),
    };
    written.push(draw_plot(
        dir,
        &Plot {
            file: PLOT_FILES[3],
            caption,
            x_label,
            y_label,
            legend: SeriesLabelPosition::UpperRight,
        },
        log_range(trades.iter().flatten().map(|p| p.0)),
        log_range(trades.iter().flatten().map(|p| p.1)),
        |chart| {
            for (s, trade) in measured.iter().zip(&trades) {
                let c = colour(s.name);
                let err = |e: &dyn std::fmt::Display| anyhow!("drawing {}: {e}", s.name);
                chart
                    .draw_series(DashedLineSeries::new(
                        trade.clone(),
                        4,
                        4,
                        c.stroke_width(1),
                    ))
                    .map_err(|e| err(&e))?;
                let front = super::verdict::pareto_front(trade.iter().copied());
                line(chart, s.name, front, format!("{} (front)", s.name))?;
                chart
                    .draw_series(trade.iter().map(|&p| Circle::new(p, 3, c)))
                    .map_err(|e| err(&e))?;
            }
            Ok(())
        },
    )?);
    Ok(written)
}

/// The x axis of the plots against τ.
const TAU_LABEL: &str = "tolerance τ (px)";
