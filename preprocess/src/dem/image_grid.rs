//! Height fields stored as greyscale images: 8- or 16-bit PNG (decoded by `image`), and PGM
//! (`P5` binary, 8-bit or 16-bit big-endian; `P2` ASCII). Sample values are heights, unit
//! spacing; `TerrainOptions` scale them.

use super::error::{bad, check_fits, DemErrorKind};
use super::HeightGrid;

pub fn read_png(bytes: &[u8]) -> Result<HeightGrid, DemErrorKind> {
    let mut reader =
        image::ImageReader::with_format(std::io::Cursor::new(bytes), image::ImageFormat::Png);
    // The decoded image cannot be much larger than the file compresses (PNG's deflate expands
    // at most ~1032:1).
    let mut limits = image::Limits::default();
    limits.max_alloc = Some((bytes.len() as u64).saturating_mul(1032).max(1 << 20));
    reader.limits(limits);
    let image = reader.decode().map_err(|e| bad(format!("PNG: {e}")))?;
    let (columns, rows) = (image.width() as usize, image.height() as usize);
    let heights: Vec<f32> = match image {
        image::DynamicImage::ImageLuma8(i) => i.into_raw().into_iter().map(f32::from).collect(),
        image::DynamicImage::ImageLuma16(i) => i.into_raw().into_iter().map(f32::from).collect(),
        other => {
            return Err(DemErrorKind::NoGrid(format!(
                "the PNG is {:?}, not greyscale heights",
                other.color()
            )))
        }
    };
    Ok(HeightGrid::unit(columns, rows, heights))
}

/// The next whitespace-separated token of a PGM header (comments `#` to end of line skipped).
fn token(bytes: &[u8], at: &mut usize) -> Result<u64, DemErrorKind> {
    loop {
        match bytes.get(*at) {
            Some(b'#') => {
                while bytes.get(*at).is_some_and(|&b| b != b'\n') {
                    *at += 1;
                }
            }
            Some(b) if b.is_ascii_whitespace() => *at += 1,
            _ => break,
        }
    }
    let start = *at;
    while bytes.get(*at).is_some_and(|b| b.is_ascii_digit()) {
        *at += 1;
    }
    std::str::from_utf8(&bytes[start..*at])
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| bad(format!("PGM: expected a number at byte {start}")))
}

pub fn read_pgm(bytes: &[u8]) -> Result<HeightGrid, DemErrorKind> {
    let ascii = match bytes.get(..2) {
        Some(b"P5") => false,
        Some(b"P2") => true,
        _ => return Err(bad("not a PGM (no P5 or P2 magic)")),
    };
    let mut at = 2;
    let columns = token(bytes, &mut at)?;
    let rows = token(bytes, &mut at)?;
    let max = token(bytes, &mut at)?;
    if !(1..=65_535).contains(&max) {
        return Err(bad(format!("PGM: maxval {max} is not in 1..=65535")));
    }
    let count = columns
        .checked_mul(rows)
        .ok_or_else(|| DemErrorKind::TooLarge(format!("{columns} × {rows}")))?;
    let heights: Vec<f32> = if ascii {
        // At least 2 bytes per sample ("0 ").
        let n = check_fits("PGM samples", count, 2, (bytes.len() - at) as u64 + 1)?;
        (0..n)
            .map(|_| token(bytes, &mut at).map(|v| v as f32))
            .collect::<Result<_, _>>()?
    } else {
        // A single whitespace byte separates maxval from the samples.
        if !bytes.get(at).is_some_and(u8::is_ascii_whitespace) {
            return Err(bad(format!(
                "PGM: expected one whitespace byte after maxval at byte {at}"
            )));
        }
        at += 1;
        let size = if max > 255 { 2 } else { 1 };
        let n = check_fits(
            "PGM samples",
            count,
            size,
            (bytes.len().saturating_sub(at)) as u64,
        )?;
        let data = &bytes[at..at + n * size as usize];
        if size == 2 {
            data.chunks_exact(2)
                .map(|c| u16::from_be_bytes([c[0], c[1]]) as f32)
                .collect()
        } else {
            data.iter().map(|&b| b as f32).collect()
        }
    };
    Ok(HeightGrid::unit(columns as usize, rows as usize, heights))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_16_bit_png_and_pgm() {
        let image = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(
            3,
            2,
            vec![0u16, 1000, 65535, 7, 8, 9],
        )
        .unwrap();
        let mut png = Vec::new();
        image
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        let g = read_png(&png).unwrap();
        assert_eq!((g.columns, g.rows), (3, 2));
        assert_eq!(g.heights, [0.0, 1000.0, 65535.0, 7.0, 8.0, 9.0]);
        let mut pgm = b"P5\n# a comment\n3 2\n65535\n".to_vec();
        for v in [0u16, 1000, 65535, 7, 8, 9] {
            pgm.extend_from_slice(&v.to_be_bytes());
        }
        assert_eq!(read_pgm(&pgm).unwrap(), g);
        let ascii = b"P2 3 2 255\n0 10 255\n7 8 9\n";
        assert_eq!(
            read_pgm(ascii).unwrap().heights,
            [0.0, 10.0, 255.0, 7.0, 8.0, 9.0]
        );
    }

    #[test]
    fn bad_images_are_errors() {
        assert!(read_png(b"\x89PNG garbage").is_err());
        assert!(read_pgm(b"P6 1 1 255 x").is_err());
        assert!(read_pgm(b"P5 3 2 65535\n\x00\x01")
            .unwrap_err()
            .to_string()
            .contains("too large"));
        assert!(read_pgm(b"P5 4000000000 4000000000 255\n\x00").is_err());
        assert!(read_pgm(b"P5 2 2 0\n\x00\x00\x00\x00").is_err());
        // The file ends right after maxval (found by the pgm fuzzer: it sliced past the end).
        assert!(read_pgm(b"P5 0\n1 3")
            .unwrap_err()
            .to_string()
            .contains("whitespace"));
        let rgb = image::RgbImage::new(2, 2);
        let mut png = Vec::new();
        rgb.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        assert!(read_png(&png)
            .unwrap_err()
            .to_string()
            .contains("greyscale"));
    }
}
