//! `bench stream --plot DIR`: `stream.png`, four panels over the frames of the path — resident
//! MiB, KiB loaded per frame, max ρ/τ of the drawn cut, frame ms — one line per run (warm,
//! cold).

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context};
use plotters::prelude::*;

use crate::cmd_bench_stream::{series, RowView};

const SIZE: (u32, u32) = (1280, 960);

/// A run's name and its four series.
type RunSeries = (String, [Vec<(f64, f64)>; 4]);

/// Draws the plot into `dir` (created if missing) and returns its path.
pub fn write_plot(dir: &Path, runs: &[(String, Vec<RowView>)]) -> anyhow::Result<PathBuf> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create --plot {}", dir.display()))?;
    crate::bench::plots::register_font()?;
    let path = dir.join("stream.png");
    let mut pixels = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, SIZE).into_drawing_area();
        let err = |e: &dyn std::fmt::Display| anyhow!("drawing {}: {e}", path.display());
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let panels = root.split_evenly((2, 2));
        let titles = [
            "resident MiB",
            "KiB loaded per frame",
            "max ρ/τ of the drawn cut",
            "frame ms (CPU traversal, plan, reads)",
        ];
        let all: Vec<RunSeries> = runs
            .iter()
            .map(|(m, rows)| (m.clone(), series(rows)))
            .collect();
        for (k, panel) in panels.iter().enumerate() {
            let x_max = all
                .iter()
                .map(|(_, s)| s[k].len())
                .max()
                .unwrap_or(1)
                .max(1) as f64;
            let y_max = all
                .iter()
                .flat_map(|(_, s)| s[k].iter().map(|p| p.1))
                .filter(|v| v.is_finite())
                .fold(0.0f64, f64::max)
                .max(1e-9)
                * 1.1;
            let mut chart = ChartBuilder::on(panel)
                .caption(titles[k], ("sans-serif", 20))
                .margin(10)
                .x_label_area_size(30)
                .y_label_area_size(60)
                .build_cartesian_2d(0.0..x_max, 0.0..y_max)
                .map_err(|e| err(&e))?;
            chart
                .configure_mesh()
                .x_desc("frame")
                .draw()
                .map_err(|e| err(&e))?;
            for (i, (mode, s)) in all.iter().enumerate() {
                let colour = if i == 0 {
                    RGBColor(214, 39, 40)
                } else {
                    RGBColor(31, 119, 180)
                };
                chart
                    .draw_series(LineSeries::new(
                        s[k].iter().copied(),
                        colour.stroke_width(2),
                    ))
                    .map_err(|e| err(&e))?
                    .label(mode.as_str())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                    });
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    let rgb = image::RgbImage::from_raw(SIZE.0, SIZE.1, pixels)
        .ok_or_else(|| anyhow!("plot buffer size"))?;
    let rgba = image::DynamicImage::ImageRgb8(rgb).to_rgba8();
    crate::output::save_png(&rgba, &path)?;
    Ok(path)
}
