//! `tessera compare A.png B.png [--background R,G,B] [--min-psnr DB] [--json]`: two frames of
//! one view, compared over the model's pixels (`tessera_runtime::measure::image_diff`, the
//! rule `bench` measures with).
//!
//! - A *model pixel* is one that is not the background in A or not the background in B: a
//!   pixel is background when each of its R, G, B channels is within 2 levels of
//!   `--background` (default: `render`'s clear colour 28,31,38). Pixels that are background in
//!   both images are left out, so the empty frame around a model neither inflates the PSNR nor
//!   depends on the model's size on screen.
//! - PSNR = 10·log10(255² / MSE), MSE over the R, G, B channels of the model pixels (alpha is
//!   ignored), saturated at 99 dB (identical images read 99).
//! - Also: the pixels each image covers, those only one covers, the pixels with a channel
//!   differing by more than 8 levels, and the largest channel difference over model pixels.
//!
//! Exit codes: 0 compared (and the PSNR at least `--min-psnr` when given); 1 the PSNR is below
//! `--min-psnr`; 2 bad input (an unreadable or undecodable file, images of different sizes, a
//! bad `--background`).

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use serde_json::json;
use tessera_runtime::gpu::target::BACKGROUND_RGBA8;
use tessera_runtime::measure::{compare_images, DIFF_THRESHOLD};

use crate::Outcome;

#[derive(Args)]
pub struct CompareArgs {
    /// The reference image (PNG, or any format the `image` crate reads).
    pub a: PathBuf,
    /// The image compared with it, of the same size.
    pub b: PathBuf,
    /// Background colour R,G,B (0-255): pixels within 2 levels of it in both images are not
    /// model pixels (default 28,31,38, what `render` clears to).
    #[arg(long, value_parser = parse_rgb)]
    pub background: Option<[u8; 3]>,
    /// Exit 1 when the PSNR over model pixels is below DB.
    #[arg(long, value_name = "DB")]
    pub min_psnr: Option<f64>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// What the comparison of two images found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    pub width: u32,
    pub height: u32,
    /// Pixels not background in A or not background in B: the pixels compared.
    pub model_pixels: u64,
    /// Pixels not background in A; in B.
    pub covered_a: u64,
    pub covered_b: u64,
    /// Model pixels background in B; in A.
    pub only_a: u64,
    pub only_b: u64,
    /// Model pixels with a channel differing by more than `DIFF_THRESHOLD` (8) levels.
    pub differing: u64,
    /// The largest R, G or B difference over model pixels, in levels.
    pub max_difference: u8,
    /// Mean squared R, G, B difference over model pixels, levels².
    pub mse: f64,
    /// PSNR over model pixels, dB, saturated at 99.
    pub psnr: f64,
}

/// Compares `b` with `a` over the pixels that are not `background` in both (module docs).
/// Errors when the sizes differ.
pub fn compare(
    a: &image::RgbaImage,
    b: &image::RgbaImage,
    background: [u8; 3],
) -> anyhow::Result<Comparison> {
    if a.dimensions() != b.dimensions() {
        anyhow::bail!(
            "the images differ in size: {}x{} and {}x{}",
            a.width(),
            a.height(),
            b.width(),
            b.height()
        );
    }
    // compare_images' rule for the background: within 2 levels in every channel.
    let is_background = |p: &image::Rgba<u8>| (0..3).all(|i| p.0[i].abs_diff(background[i]) <= 2);
    let (mut covered_a, mut covered_b, mut only_a, mut only_b) = (0u64, 0u64, 0u64, 0u64);
    let mut max_difference = 0u8;
    for (p, q) in a.pixels().zip(b.pixels()) {
        let (in_a, in_b) = (!is_background(p), !is_background(q));
        covered_a += in_a as u64;
        covered_b += in_b as u64;
        only_a += (in_a && !in_b) as u64;
        only_b += (in_b && !in_a) as u64;
        if in_a || in_b {
            for c in 0..3 {
                max_difference = max_difference.max(p.0[c].abs_diff(q.0[c]));
            }
        }
    }
    let diff = compare_images(a, b, DIFF_THRESHOLD, Some(background));
    Ok(Comparison {
        width: a.width(),
        height: a.height(),
        model_pixels: diff.pixels,
        covered_a,
        covered_b,
        only_a,
        only_b,
        differing: diff.differing,
        max_difference,
        mse: diff.mse,
        psnr: diff.psnr(),
    })
}

fn parse_rgb(s: &str) -> Result<[u8; 3], String> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        return Err(format!("{s:?} is not R,G,B"));
    }
    let mut rgb = [0u8; 3];
    for (c, p) in rgb.iter_mut().zip(&parts) {
        *c = p
            .trim()
            .parse::<u8>()
            .map_err(|_| format!("{p:?} in {s:?} is not a level from 0 to 255"))?;
    }
    Ok(rgb)
}

fn load(path: &Path) -> anyhow::Result<image::RgbaImage> {
    let image = image::ImageReader::open(path)
        .with_context(|| format!("reading {}", path.display()))?
        .with_guessed_format()
        .with_context(|| format!("reading {}", path.display()))?
        .decode()
        .with_context(|| format!("decoding {}", path.display()))?;
    Ok(image.to_rgba8())
}

pub fn run(args: CompareArgs) -> anyhow::Result<Outcome> {
    if let Some(db) = args.min_psnr {
        if !db.is_finite() {
            anyhow::bail!("--min-psnr {db} must be a finite number of dB");
        }
    }
    let [r, g, b, _] = BACKGROUND_RGBA8;
    let background = args.background.unwrap_or([r, g, b]);
    let (a, b) = (load(&args.a)?, load(&args.b)?);
    let c = compare(&a, &b, background)
        .with_context(|| format!("comparing {} with {}", args.a.display(), args.b.display()))?;
    let passed = args.min_psnr.is_none_or(|db| c.psnr >= db);
    if args.json {
        println!(
            "{}",
            json!({
                "a": args.a.display().to_string(),
                "b": args.b.display().to_string(),
                "width": c.width,
                "height": c.height,
                "background": background,
                "model_pixels": c.model_pixels,
                "covered_a": c.covered_a,
                "covered_b": c.covered_b,
                "only_a": c.only_a,
                "only_b": c.only_b,
                "differing": c.differing,
                "max_difference": c.max_difference,
                "mse": c.mse,
                "psnr_db": c.psnr,
                "min_psnr_db": args.min_psnr,
                "passed": passed,
            })
        );
    } else {
        let total = u64::from(c.width) * u64::from(c.height);
        println!(
            "PSNR {:.2} dB over {} model pixels of {} ({:.1} %; A covers {}, B {}; only A {}, \
             only B {}); {} differ by more than {DIFF_THRESHOLD} levels; max channel \
             difference {}",
            c.psnr,
            c.model_pixels,
            total,
            100.0 * c.model_pixels as f64 / total.max(1) as f64,
            c.covered_a,
            c.covered_b,
            c.only_a,
            c.only_b,
            c.differing,
            c.max_difference,
        );
        if !passed {
            println!("below --min-psnr {} dB", args.min_psnr.unwrap_or_default());
        }
    }
    Ok(if passed {
        Outcome::Ok
    } else {
        Outcome::CheckFailed
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const BG: [u8; 3] = [28, 31, 38];

    /// A `w`×`h` background image with `model` pixels (row-major from the top left) of `colour`.
    fn frame(w: u32, h: u32, model: u32, colour: [u8; 3]) -> image::RgbaImage {
        let mut image = image::RgbaImage::from_pixel(w, h, image::Rgba([BG[0], BG[1], BG[2], 255]));
        for k in 0..model {
            let [r, g, b] = colour;
            image.put_pixel(k % w, k / w, image::Rgba([r, g, b, 255]));
        }
        image
    }

    fn check(a: &image::RgbaImage, b: &image::RgbaImage, want_pixels: u64, want_psnr: f64) {
        let c = compare(a, b, BG).unwrap();
        assert_eq!(c.model_pixels, want_pixels, "{c:?}");
        assert!(
            (c.psnr - want_psnr).abs() < 1e-9,
            "{c:?}, want {want_psnr} dB"
        );
    }

    #[test]
    fn one_pixel_off_by_51_in_40_gives_30_db() {
        // MSE = 3 · 51² / (3 · 40) = 65.025 = 255² / 1000: exactly 30 dB.
        let a = frame(10, 10, 40, [100, 100, 100]);
        let mut b = a.clone();
        b.put_pixel(3, 2, image::Rgba([151, 49, 151, 255]));
        check(&a, &b, 40, 30.0);
        let c = compare(&a, &b, BG).unwrap();
        assert_eq!((c.max_difference, c.differing), (51, 1));
        // More background around the model changes nothing.
        let (mut wide_a, mut wide_b) = (frame(50, 10, 0, BG), frame(50, 10, 0, BG));
        for k in 0..40 {
            wide_a.put_pixel(k % 10, k / 10, *a.get_pixel(k % 10, k / 10));
            wide_b.put_pixel(k % 10, k / 10, *b.get_pixel(k % 10, k / 10));
        }
        check(&wide_a, &wide_b, 40, 30.0);
    }

    #[test]
    fn a_pixel_only_one_image_covers_is_a_model_pixel() {
        // A covers 9 pixels, B 10 (the tenth is A's background): 10 model pixels, one of
        // them off by (228, 225, 218) levels.
        let a = frame(4, 4, 9, [0, 0, 0]);
        let b = frame(4, 4, 10, [0, 0, 0]);
        let c = compare(&a, &b, BG).unwrap();
        assert_eq!(
            (c.model_pixels, c.covered_a, c.covered_b, c.only_a, c.only_b),
            (10, 9, 10, 0, 1)
        );
        let squared = 28.0f64 * 28.0 + 31.0 * 31.0 + 38.0 * 38.0;
        let want = 10.0 * (255.0f64 * 255.0 / (squared / 30.0)).log10();
        check(&a, &b, 10, want);
        assert_eq!(c.max_difference, 38);
    }

    #[test]
    fn identical_images_saturate_and_background_within_two_levels_is_left_out() {
        let a = frame(8, 8, 20, [200, 10, 10]);
        check(&a, &a, 20, 99.0);
        // A background pixel 2 levels off is still background; 3 levels off, a model pixel.
        let mut b = a.clone();
        b.put_pixel(7, 7, image::Rgba([BG[0] + 2, BG[1], BG[2] - 2, 255]));
        check(&a, &b, 20, 99.0);
        b.put_pixel(7, 7, image::Rgba([BG[0] + 3, BG[1], BG[2], 255]));
        check(&a, &b, 21, 10.0 * (255.0f64 * 255.0 / (9.0 / 63.0)).log10());
    }

    #[test]
    fn images_of_different_sizes_are_an_error() {
        let e = compare(&frame(4, 4, 1, [0; 3]), &frame(4, 5, 1, [0; 3]), BG).unwrap_err();
        assert!(e.to_string().contains("4x4 and 4x5"), "{e}");
    }

    #[test]
    fn background_parses_three_levels() {
        assert_eq!(parse_rgb("1, 2,255"), Ok([1, 2, 255]));
        assert!(parse_rgb("1,2").is_err());
        assert!(parse_rgb("1,2,256").is_err());
        assert!(parse_rgb("a,2,3").is_err());
    }
}
