//! The procedural texture of `gen mesh --texture N`: an N × N RGB PNG written a row at a time
//! (zlib through `flate2`, the chunks' CRCs through `crc32fast`), so its memory is a row and
//! a chunk whatever N. Its content shows sampling errors: a 16 × 16 checkerboard over red
//! (across) and green (down) gradients, fine grid lines every N/128 texels, and in each
//! checker cell its number in binary as a small block glyph (a flipped, shifted or wrongly
//! filtered texture reads differently). A pure function of (x, y, N): the same N, the same
//! bytes.

use std::io::{self, Write};

use flate2::write::ZlibEncoder;

/// Largest side written (the repository's `MAX_TEXTURE_SIDE`).
pub const MAX_SIDE: u32 = tessera_core::texture::MAX_TEXTURE_SIDE;

/// IDAT bytes gathered before a chunk is written.
const CHUNK: usize = 1 << 16;

/// Texel `(x, y)` (row `y` from the top) of the N × N texture.
pub fn texel(x: u32, y: u32, n: u32) -> [u8; 3] {
    let n = n.max(1);
    let cell = (n / 16).max(1);
    let (cx, cy) = (x / cell, y / cell);
    let light = (cx + cy) % 2 == 0;
    let base: u32 = if light { 190 } else { 60 };
    let ramp = |t: u32| (u64::from(t) * 255 / u64::from((n - 1).max(1))) as u32;
    let mut rgb = [(base + ramp(x)) / 2, (base + ramp(y)) / 2, base];
    // The cell's number (row-major, 8 bits) as a 4 × 2 block glyph in its top-left corner.
    let glyph = (cell / 8).max(1);
    let (gx, gy) = ((x % cell) / glyph, (y % cell) / glyph);
    if (1..5).contains(&gx) && (1..3).contains(&gy) {
        let bit = (gy - 1) * 4 + (gx - 1);
        let id = (cy * 16 + cx) & 0xff;
        rgb = if id >> bit & 1 == 1 {
            [255, 255, 255]
        } else {
            [0, 0, 0]
        };
    }
    let fine = (n / 128).max(8);
    if x.is_multiple_of(fine) || y.is_multiple_of(fine) {
        rgb = rgb.map(|c| c / 2);
    }
    rgb.map(|c| c as u8)
}

/// Writes PNG chunk `kind` holding `data`.
fn chunk(out: &mut dyn Write, kind: &[u8; 4], data: &[u8]) -> io::Result<()> {
    let len = u32::try_from(data.len()).expect("chunks are at most CHUNK bytes");
    out.write_all(&len.to_be_bytes())?;
    out.write_all(kind)?;
    out.write_all(data)?;
    let mut crc = crc32fast::Hasher::new();
    crc.update(kind);
    crc.update(data);
    out.write_all(&crc.finalize().to_be_bytes())
}

/// The zlib stream cut into IDAT chunks of [`CHUNK`] bytes.
struct Idat<'a> {
    out: &'a mut dyn Write,
    pending: Vec<u8>,
    written: u64,
}

impl Idat<'_> {
    fn flush_chunk(&mut self) -> io::Result<()> {
        if !self.pending.is_empty() {
            chunk(self.out, b"IDAT", &self.pending)?;
            self.written += self.pending.len() as u64 + 12;
            self.pending.clear();
        }
        Ok(())
    }
}

impl Write for Idat<'_> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let take = buf.len().min(CHUNK - self.pending.len());
        self.pending.extend_from_slice(&buf[..take]);
        if self.pending.len() == CHUNK {
            self.flush_chunk()?;
        }
        Ok(take)
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// Writes the N × N texture as an 8-bit RGB PNG to `out` (rows filtered by `Sub`); returns
/// the bytes written. `n` in `1..=MAX_SIDE`.
pub fn write_texture_png(n: u32, out: &mut dyn Write) -> io::Result<u64> {
    if !(1..=MAX_SIDE).contains(&n) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("texture side {n}: must be 1 to {MAX_SIDE}"),
        ));
    }
    out.write_all(b"\x89PNG\r\n\x1a\n")?;
    let mut header = Vec::with_capacity(13);
    header.extend(n.to_be_bytes());
    header.extend(n.to_be_bytes());
    // 8 bits, RGB, deflate, adaptive filtering, not interlaced.
    header.extend([8, 2, 0, 0, 0]);
    chunk(out, b"IHDR", &header)?;
    let idat = Idat {
        out: &mut *out,
        pending: Vec::with_capacity(CHUNK),
        written: 0,
    };
    let mut z = ZlibEncoder::new(idat, flate2::Compression::fast());
    let mut row = vec![0u8; 1 + 3 * n as usize];
    for y in 0..n {
        // Filter 1 (Sub): each byte less the one a texel before.
        row[0] = 1;
        let mut previous = [0u8; 3];
        for x in 0..n {
            let t = texel(x, y, n);
            let at = 1 + 3 * x as usize;
            for c in 0..3 {
                row[at + c] = t[c].wrapping_sub(previous[c]);
            }
            previous = t;
        }
        z.write_all(&row)?;
    }
    let mut idat = z.finish()?;
    idat.flush_chunk()?;
    let written = idat.written;
    chunk(out, b"IEND", &[])?;
    Ok(8 + 25 + written + 12)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_png_decodes_to_the_texels_and_is_deterministic() {
        for n in [1, 37, 256] {
            let mut bytes = Vec::new();
            let written = write_texture_png(n, &mut bytes).unwrap();
            assert_eq!(written, bytes.len() as u64);
            let image = image::load_from_memory_with_format(&bytes, image::ImageFormat::Png)
                .unwrap()
                .to_rgb8();
            assert_eq!(image.dimensions(), (n, n));
            for (x, y, p) in image.enumerate_pixels() {
                assert_eq!(p.0, texel(x, y, n), "texel ({x}, {y}) of {n}");
            }
            let mut again = Vec::new();
            write_texture_png(n, &mut again).unwrap();
            assert_eq!(bytes, again);
        }
        assert!(write_texture_png(0, &mut Vec::new()).is_err());
        assert!(write_texture_png(MAX_SIDE + 1, &mut Vec::new()).is_err());
    }

    #[test]
    fn cells_differ_so_a_flip_shows() {
        let n = 256;
        // The top-left and bottom-left cells' glyphs (cell numbers 0 and 240): a texel in
        // each of the eight blocks, off the grid lines.
        let glyph = |y0: u32| -> Vec<[u8; 3]> {
            (0..8)
                .map(|b| texel(3 + 2 * (b % 4), y0 + 3 + 2 * (b / 4), n))
                .collect()
        };
        assert_eq!(glyph(0), [[0; 3]; 8]);
        assert_eq!(glyph(240)[4..], [[255; 3]; 4]);
        // Red grows across, green down.
        assert!(texel(250, 5, n)[0] > texel(5, 5, n)[0]);
        assert!(texel(5, 250, n)[1] > texel(5, 5, n)[1]);
    }
}
