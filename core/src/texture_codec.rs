//! A page's texels in and out of its stored encoding (`texture::PageEncoding`), and the two
//! smaller mips every page carries (`page_mips`): one definition for the build, which encodes
//! pages, and for the renderer and exporters, which decode them.
//!
//! Mips are made by a 2 × 2 box in linear light (alpha linear), an odd edge repeating its last
//! texel: 136 → 68 → 34 texels, so a 4-texel gutter becomes 2 and 1 and filtering inside the
//! page never crosses it. BC1 encodes each mip with libsquish's range fit (`texpresso`, weights
//! perceptual), alpha made opaque first (BC1's one-bit alpha would otherwise turn texels below
//! half alpha into black): about a microsecond a block, so a 4096² texture's 1,365 pages take
//! about 1.7 s on one core. Its loss is measured by `page_psnr`.

use crate::texture::{PageEncoding, BC1_PAGE_BYTES, PAGE_BYTES, PAGE_MIPS, PAGE_SIDE};

/// sRGB-encoded byte to linear light.
pub fn srgb_to_linear(byte: u8) -> f32 {
    let c = byte as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear light to an sRGB-encoded byte (rounded).
pub fn linear_to_srgb(linear: f32) -> u8 {
    let c = linear.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// An RGBA8 image (`w × h`) halved by a 2 × 2 box in linear light (alpha linear, its mean
/// rounded), an odd edge repeating its last texel: `(ceil(w / 2), ceil(h / 2))`. The build's
/// pyramid (`preprocess::texture::pyramid`) and every page's own mips are made by it.
pub fn halve(texels: &[u8], w: u32, h: u32) -> (Vec<u8>, u32, u32) {
    assert_eq!(
        texels.len(),
        (w * h * 4) as usize,
        "an RGBA8 image of {w} × {h}"
    );
    let (hw, hh) = (w.div_ceil(2).max(1), h.div_ceil(2).max(1));
    let lut: Vec<f32> = (0..=255u8).map(srgb_to_linear).collect();
    let mut out = Vec::with_capacity((hw * hh * 4) as usize);
    for y in 0..hh {
        for x in 0..hw {
            let mut sum = [0f32; 4];
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (sx, sy) = ((2 * x + dx).min(w - 1), (2 * y + dy).min(h - 1));
                let at = ((sy * w + sx) * 4) as usize;
                for c in 0..3 {
                    sum[c] += lut[texels[at + c] as usize];
                }
                sum[3] += f32::from(texels[at + 3]);
            }
            out.extend(sum[..3].iter().map(|&c| linear_to_srgb(c / 4.0)));
            out.push((sum[3] / 4.0 + 0.5).floor() as u8);
        }
    }
    (out, hw, hh)
}

/// Texels a side of mip `mip` of a page (136, 68, 34).
pub fn mip_side(mip: u32) -> u32 {
    PAGE_SIDE >> mip
}

/// A page's three mips (136, 68 and 34 texels a side, RGBA8) from its texels (`PAGE_BYTES`).
pub fn page_mips(page: &[u8]) -> [Vec<u8>; PAGE_MIPS as usize] {
    assert_eq!(page.len(), PAGE_BYTES, "a page is PAGE_BYTES bytes");
    let (one, w1, h1) = halve(page, PAGE_SIDE, PAGE_SIDE);
    let (two, _, _) = halve(&one, w1, h1);
    [page.to_vec(), one, two]
}

/// BC1 blocks across (and down) mip `mip` of a page: 34, 17, 9.
pub fn bc1_blocks_across(mip: u32) -> u32 {
    mip_side(mip).div_ceil(4)
}

/// Where mip `mip`'s blocks lie in a BC1 page.
pub fn bc1_mip_range(mip: u32) -> std::ops::Range<usize> {
    let bytes = |m: u32| 8 * (bc1_blocks_across(m) as usize).pow(2);
    let start: usize = (0..mip).map(bytes).sum();
    start..start + bytes(mip)
}

const _: () = assert!(PAGE_MIPS == 3);

/// A page's texels (`PAGE_BYTES`, as cut) in `encoding`: `encoding.page_bytes()` bytes.
pub fn encode_page(encoding: PageEncoding, page: &[u8]) -> Vec<u8> {
    assert_eq!(page.len(), PAGE_BYTES, "a page is PAGE_BYTES bytes");
    match encoding {
        PageEncoding::Rgba8 => page.to_vec(),
        PageEncoding::Bc1 => {
            let params = texpresso::Params {
                algorithm: texpresso::Algorithm::RangeFit,
                ..Default::default()
            };
            let mut out = vec![0u8; BC1_PAGE_BYTES];
            for (mip, texels) in page_mips(page).iter_mut().enumerate() {
                for texel in texels.chunks_exact_mut(4) {
                    texel[3] = 255;
                }
                let side = mip_side(mip as u32) as usize;
                let range = bc1_mip_range(mip as u32);
                texpresso::Format::Bc1.compress(texels, side, side, params, &mut out[range]);
            }
            out
        }
    }
}

/// Why stored page bytes do not decode.
#[derive(Debug, thiserror::Error)]
#[error("a {} page is {expected} bytes, not {got}", encoding.name())]
pub struct PageSizeError {
    pub encoding: PageEncoding,
    pub expected: usize,
    pub got: usize,
}

fn check_size(encoding: PageEncoding, bytes: &[u8]) -> Result<(), PageSizeError> {
    let expected = encoding.page_bytes();
    if bytes.len() != expected {
        return Err(PageSizeError {
            encoding,
            expected,
            got: bytes.len(),
        });
    }
    Ok(())
}

/// A stored page's three mips as RGBA8 (136², 68² and 34² texels): what the renderer samples.
/// For RGBA8 pages the mips are made here (`page_mips`); BC1 pages carry theirs.
pub fn decode_page_mips(
    encoding: PageEncoding,
    bytes: &[u8],
) -> Result<[Vec<u8>; PAGE_MIPS as usize], PageSizeError> {
    check_size(encoding, bytes)?;
    Ok(match encoding {
        PageEncoding::Rgba8 => page_mips(bytes),
        PageEncoding::Bc1 => std::array::from_fn(|mip| {
            let side = mip_side(mip as u32) as usize;
            let mut out = vec![0u8; side * side * 4];
            let blocks = &bytes[bc1_mip_range(mip as u32)];
            texpresso::Format::Bc1.decompress(blocks, side, side, &mut out);
            out
        }),
    })
}

/// A stored page's texels (`PAGE_BYTES`, the finest mip) as RGBA8.
pub fn decode_page(encoding: PageEncoding, bytes: &[u8]) -> Result<Vec<u8>, PageSizeError> {
    check_size(encoding, bytes)?;
    Ok(match encoding {
        PageEncoding::Rgba8 => bytes.to_vec(),
        PageEncoding::Bc1 => {
            let side = PAGE_SIDE as usize;
            let mut out = vec![0u8; PAGE_BYTES];
            texpresso::Format::Bc1.decompress(&bytes[bc1_mip_range(0)], side, side, &mut out);
            out
        }
    })
}

/// Squared error summed over the colour channels of two RGBA8 images, and the channel count:
/// what a PSNR over many pages accumulates (`psnr_db`).
pub fn colour_squared_error(a: &[u8], b: &[u8]) -> (f64, u64) {
    assert_eq!(a.len(), b.len(), "images of one size");
    let mut sum = 0f64;
    for (x, y) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        for c in 0..3 {
            let d = x[c] as f64 - y[c] as f64;
            sum += d * d;
        }
    }
    (sum, a.len() as u64 / 4 * 3)
}

/// PSNR in dB of a summed squared error over `count` 8-bit channels (∞ when equal).
pub fn psnr_db(squared_error: f64, count: u64) -> f64 {
    if squared_error == 0.0 || count == 0 {
        return f64::INFINITY;
    }
    10.0 * (255.0f64 * 255.0 / (squared_error / count as f64)).log10()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth page with a sharp edge: a gradient, a disc, alpha varying.
    fn page() -> Vec<u8> {
        let mut out = Vec::with_capacity(PAGE_BYTES);
        for y in 0..PAGE_SIDE {
            for x in 0..PAGE_SIDE {
                let (dx, dy) = (x as i32 - 60, y as i32 - 70);
                let inside = dx * dx + dy * dy < 40 * 40;
                out.extend_from_slice(&[
                    (x * 255 / 135) as u8,
                    if inside { 220 } else { 30 },
                    (y * 255 / 135) as u8,
                    (x + y) as u8,
                ]);
            }
        }
        out
    }

    #[test]
    fn bc1_pages_have_their_size_and_decode_close_to_their_texels() {
        let texels = page();
        let stored = encode_page(PageEncoding::Bc1, &texels);
        assert_eq!(stored.len(), BC1_PAGE_BYTES);
        assert_eq!(BC1_PAGE_BYTES, 12_208);
        let mips = decode_page_mips(PageEncoding::Bc1, &stored).unwrap();
        let reference = page_mips(&texels);
        for (mip, (got, want)) in mips.iter().zip(&reference).enumerate() {
            assert_eq!(got.len(), want.len());
            let (se, n) = colour_squared_error(got, want);
            let db = psnr_db(se, n);
            assert!(db > 30.0, "mip {mip}: {db:.2} dB");
            assert!(got.chunks_exact(4).all(|t| t[3] == 255), "opaque");
        }
        assert_eq!(decode_page(PageEncoding::Bc1, &stored).unwrap(), mips[0]);
    }

    #[test]
    fn rgba8_pages_are_stored_as_cut() {
        let texels = page();
        let stored = encode_page(PageEncoding::Rgba8, &texels);
        assert_eq!(stored, texels);
        assert_eq!(decode_page(PageEncoding::Rgba8, &stored).unwrap(), texels);
        assert_eq!(
            decode_page_mips(PageEncoding::Rgba8, &stored).unwrap(),
            page_mips(&texels)
        );
    }

    #[test]
    fn a_page_of_the_wrong_size_is_refused() {
        let e = decode_page(PageEncoding::Bc1, &[0u8; 100]).unwrap_err();
        assert_eq!((e.expected, e.got), (BC1_PAGE_BYTES, 100));
        assert!(decode_page_mips(PageEncoding::Rgba8, &[0u8; 12]).is_err());
    }

    #[test]
    fn the_srgb_round_trip_is_exact_on_8_bit_codes() {
        for code in 0..=255u8 {
            assert_eq!(linear_to_srgb(srgb_to_linear(code)), code);
        }
    }

    #[test]
    fn mip_ranges_tile_the_page() {
        assert_eq!(bc1_mip_range(0), 0..9248);
        assert_eq!(bc1_mip_range(1), 9248..11_560);
        assert_eq!(bc1_mip_range(2), 11_560..BC1_PAGE_BYTES);
        assert_eq!(
            (0..3).map(bc1_blocks_across).collect::<Vec<_>>(),
            [34, 17, 9]
        );
    }

    #[test]
    fn a_uniform_page_is_exact_in_bc1() {
        // (16, 16, 2) in RGB565, expanded to 8 bits by bit replication: an endpoint exactly.
        let colour = [0x84u8, 0x41, 0x10, 255];
        let texels: Vec<u8> = colour.repeat((PAGE_SIDE * PAGE_SIDE) as usize);
        let stored = encode_page(PageEncoding::Bc1, &texels);
        assert_eq!(decode_page(PageEncoding::Bc1, &stored).unwrap(), texels);
    }
}
