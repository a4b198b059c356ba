//! A frame against the full-resolution frame of the same view: the share of pixels that
//! differ visibly, and the PSNR of the RGB channels.
//!
//! - A pixel *differs* when one of its R, G, B channels differs by more than `DIFF_THRESHOLD`
//!   levels (of 255): a threshold of 0 would count the one-level shading noise of two
//!   triangulations of the same flat region, which no one sees.
//! - Only *model pixels* count when a background colour is given: a pixel where both frames
//!   show the background (within 2 levels) is left out (the empty frame around a model would otherwise
//!   inflate the PSNR and shrink the differing share with the model's size on screen).
//! - PSNR = 10·log10(255² / MSE), MSE over the R, G, B channels of the pixels compared (alpha
//!   is ignored). Identical frames have MSE 0 and an infinite PSNR; JSON has no infinity, so PSNR
//!   **saturates at `PSNR_SATURATED_DB` = 99 dB**: every frame whose PSNR is 99 dB or more
//!   (identical, or differing by a few levels in a handful of pixels of a 1080p frame) reads 99.

/// Channel difference (levels of 255) above which a pixel counts as differing.
pub const DIFF_THRESHOLD: u8 = 8;

/// The PSNR of identical frames, and the ceiling of every PSNR reported (dB).
pub const PSNR_SATURATED_DB: f64 = 99.0;

/// What one comparison found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageDiff {
    /// Pixels compared (the frame's width × height, less the pixels where both frames show
    /// only the background when one was given).
    pub pixels: u64,
    /// Pixels with a channel differing by more than the threshold.
    pub differing: u64,
    /// Mean squared difference over the R, G, B channels, in levels².
    pub mse: f64,
}

impl ImageDiff {
    /// Differing pixels over all pixels, in [0, 1].
    pub fn differing_share(&self) -> f64 {
        if self.pixels == 0 {
            0.0
        } else {
            self.differing as f64 / self.pixels as f64
        }
    }

    /// PSNR in dB, saturated at `PSNR_SATURATED_DB` (identical frames read exactly that).
    pub fn psnr(&self) -> f64 {
        psnr_of_mse(self.mse)
    }
}

/// 10·log10(255² / `mse`) in dB, saturated at `PSNR_SATURATED_DB` (reached at MSE 0): e.g. the
/// PSNR of several frames taken as one, from their mean MSE.
pub fn psnr_of_mse(mse: f64) -> f64 {
    if mse <= 0.0 {
        return PSNR_SATURATED_DB;
    }
    (10.0 * (255.0f64 * 255.0 / mse).log10()).min(PSNR_SATURATED_DB)
}

/// Compares two frames of the same size, pixel by pixel, with `threshold` (usually
/// `DIFF_THRESHOLD`), over the model's pixels when `background` is given (RGB: pixels where
/// both frames are that colour, within 2 levels, are left out). Panics when the sizes differ (the frames
/// of one view share a size).
pub fn compare_images(
    a: &image::RgbaImage,
    b: &image::RgbaImage,
    threshold: u8,
    background: Option<[u8; 3]>,
) -> ImageDiff {
    assert_eq!(
        a.dimensions(),
        b.dimensions(),
        "compare_images needs frames of one size"
    );
    let (mut differing, mut squared, mut pixels) = (0u64, 0u64, 0u64);
    // Within 2 levels: a backend may round the clear colour one level off.
    let is_background = |p: &image::Rgba<u8>| {
        background.is_some_and(|c| (0..3).all(|i| p.0[i].abs_diff(c[i]) <= 2))
    };
    for (p, q) in a.pixels().zip(b.pixels()) {
        if is_background(p) && is_background(q) {
            continue;
        }
        pixels += 1;
        let mut differs = false;
        for c in 0..3 {
            let d = p.0[c].abs_diff(q.0[c]);
            differs |= d > threshold;
            squared += d as u64 * d as u64;
        }
        differing += differs as u64;
    }
    ImageDiff {
        pixels,
        differing,
        mse: if pixels == 0 {
            0.0
        } else {
            squared as f64 / (3 * pixels) as f64
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(width: u32, height: u32, colour: [u8; 4]) -> image::RgbaImage {
        image::RgbaImage::from_pixel(width, height, image::Rgba(colour))
    }

    #[test]
    fn identical_frames_saturate() {
        let a = image(64, 48, [10, 20, 30, 255]);
        let d = compare_images(&a, &a.clone(), DIFF_THRESHOLD, None);
        assert_eq!((d.pixels, d.differing, d.mse), (3072, 0, 0.0));
        assert_eq!(d.psnr(), PSNR_SATURATED_DB);
        assert_eq!(d.differing_share(), 0.0);
    }

    #[test]
    fn one_white_pixel_on_black() {
        let a = image(100, 10, [0, 0, 0, 255]);
        let mut b = a.clone();
        b.put_pixel(3, 4, image::Rgba([255, 255, 255, 255]));
        let d = compare_images(&a, &b, DIFF_THRESHOLD, None);
        assert_eq!(d.differing, 1);
        assert!((d.differing_share() - 0.001).abs() < 1e-15);
        // MSE = 255² / 1000: PSNR = 10·log10(1000) = 30 dB.
        assert!((d.psnr() - 30.0).abs() < 1e-9, "{}", d.psnr());
    }

    #[test]
    fn small_differences_are_under_the_threshold_and_alpha_is_ignored() {
        let a = image(8, 8, [100, 100, 100, 255]);
        let b = image(8, 8, [100 + DIFF_THRESHOLD, 100, 100 - DIFF_THRESHOLD, 0]);
        let d = compare_images(&a, &b, DIFF_THRESHOLD, None);
        assert_eq!(d.differing, 0);
        assert!(d.mse > 0.0 && d.psnr() < PSNR_SATURATED_DB);
        let c = image(8, 8, [100, 100 + DIFF_THRESHOLD + 1, 100, 255]);
        assert_eq!(compare_images(&a, &c, DIFF_THRESHOLD, None).differing, 64);
    }

    #[test]
    fn with_a_background_only_model_pixels_count() {
        let bg = [28, 31, 38];
        let a = image(100, 10, [28, 31, 38, 255]);
        let mut b = a.clone();
        b.put_pixel(3, 4, image::Rgba([255, 255, 255, 255]));
        let mut c = a.clone();
        c.put_pixel(3, 4, image::Rgba([255, 255, 255, 255]));
        c.put_pixel(5, 5, image::Rgba([100, 100, 100, 255]));
        // One model pixel in b; two in c, one of them the same as b's.
        let d = compare_images(&b, &c, DIFF_THRESHOLD, Some(bg));
        assert_eq!((d.pixels, d.differing), (2, 1));
        let all = compare_images(&b, &c, DIFF_THRESHOLD, None);
        assert_eq!((all.pixels, all.differing), (1000, 1));
        assert!(d.psnr() < all.psnr());
        assert_eq!(compare_images(&a, &a, DIFF_THRESHOLD, Some(bg)).pixels, 0);
    }
}
