//! The terrain benchmark's plots (PNG, `plotters`), log–log against triangles drawn, one line
//! per method (RUSTiC one per cluster size):
//!
//! - `error_vs_triangles.png`: vertical error against the full grid, max solid, mean dashed;
//! - `cpu_vs_triangles.png`: CPU milliseconds per frame;
//! - `frame_time_vs_triangles.png`: frame milliseconds (to the end of the GPU's work).

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context};
use plotters::prelude::*;

use super::bench::TerrainRow;
use crate::output::save_png;

const SIZE: (u32, u32) = (960, 640);

/// A named line: its rows and its colour.
struct Line<'a> {
    name: String,
    rows: Vec<&'a TerrainRow>,
    colour: RGBColor,
}

fn lines<'a>(
    roam: &'a [TerrainRow],
    rustic: &'a [TerrainRow],
    tessera: &'a [TerrainRow],
) -> Vec<Line<'a>> {
    let mut out = vec![
        Line {
            name: "tessera".into(),
            rows: tessera.iter().collect(),
            colour: RGBColor(214, 39, 40),
        },
        Line {
            name: "ROAM".into(),
            rows: roam.iter().collect(),
            colour: RGBColor(31, 119, 180),
        },
    ];
    let mut sizes: Vec<usize> = rustic.iter().filter_map(|r| r.cluster_size).collect();
    sizes.dedup();
    let greens = [
        (44, 160, 44),
        (23, 190, 207),
        (148, 103, 189),
        (140, 86, 75),
    ];
    for (k, size) in sizes.into_iter().enumerate() {
        let (r, g, b) = greens[k % greens.len()];
        out.push(Line {
            name: format!("RUSTiC {size}"),
            rows: rustic
                .iter()
                .filter(|r| r.cluster_size == Some(size))
                .collect(),
            colour: RGBColor(r, g, b),
        });
    }
    out
}

/// One plot of `values` (each row's one or two y values: solid, dashed) against triangles.
fn plot(
    dir: &Path,
    file: &str,
    caption: &str,
    y_label: &str,
    lines: &[Line<'_>],
    values: &dyn Fn(&TerrainRow) -> (f64, Option<f64>),
) -> anyhow::Result<PathBuf> {
    let all = || lines.iter().flat_map(|l| l.rows.iter());
    let x = crate::bench::plots::log_range(all().map(|r| r.triangles));
    let y = crate::bench::plots::log_range(all().flat_map(|r| {
        let (a, b) = values(r);
        [Some(a), b].into_iter().flatten()
    }));
    let mut buffer = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let err = |e: &dyn std::fmt::Display| anyhow!("drawing {file}: {e}");
        let root = BitMapBackend::with_buffer(&mut buffer, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(caption, ("sans-serif", 22))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(80)
            .build_cartesian_2d(x.log_scale(), y.log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("triangles drawn")
            .y_desc(y_label)
            .x_labels(6)
            .x_label_formatter(&|v| crate::bench::verdict::group_digits(*v))
            .y_label_formatter(&|v| {
                if *v >= 10.0 {
                    format!("{v:.0}")
                } else {
                    format!("{}", (*v * 1000.0).round() / 1000.0)
                }
            })
            .label_style(("sans-serif", 15))
            .draw()
            .map_err(|e| err(&e))?;
        for line in lines {
            let c = line.colour;
            let solid: Vec<(f64, f64)> = line
                .rows
                .iter()
                .map(|r| (r.triangles, values(r).0))
                .filter(|p| p.1 > 0.0 && p.1.is_finite())
                .collect();
            chart
                .draw_series(LineSeries::new(solid.clone(), c.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(line.name.clone())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
            chart
                .draw_series(solid.iter().map(|&p| Circle::new(p, 3, c.filled())))
                .map_err(|e| err(&e))?;
            let dashed: Vec<(f64, f64)> = line
                .rows
                .iter()
                .filter_map(|r| values(r).1.map(|v| (r.triangles, v)))
                .filter(|p| p.1 > 0.0 && p.1.is_finite())
                .collect();
            if dashed.len() > 1 {
                chart
                    .draw_series(DashedLineSeries::new(dashed, 6, 4, c.stroke_width(1)))
                    .map_err(|e| err(&e))?;
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(("sans-serif", 15))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    let image = image::RgbImage::from_raw(SIZE.0, SIZE.1, buffer).context("plot buffer size")?;
    let path = dir.join(file);
    save_png(&image::DynamicImage::ImageRgb8(image).to_rgba8(), &path)?;
    Ok(path)
}

/// Writes the three plots into `dir` (created if missing); returns their paths.
pub fn write_plots(
    dir: &Path,
    roam: &[TerrainRow],
    rustic: &[TerrainRow],
    tessera: &[TerrainRow],
) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create --plot {}", dir.display()))?;
    crate::bench::plots::register_font()?;
    let lines = lines(roam, rustic, tessera);
    Ok(vec![
        plot(
            dir,
            "error_vs_triangles.png",
            "Vertical error against the full grid (max solid, mean dashed)",
            "metres",
            &lines,
            &|r| (r.error_max_m, Some(r.error_mean_m)),
        )?,
        plot(
            dir,
            "cpu_vs_triangles.png",
            "CPU per frame",
            "ms",
            &lines,
            &|r| (r.cpu_ms, None),
        )?,
        plot(
            dir,
            "frame_time_vs_triangles.png",
            "Frame time (to the end of the GPU's work)",
            "ms",
            &lines,
            &|r| (r.frame_ms, None),
        )?,
    ])
}
