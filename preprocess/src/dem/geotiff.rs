//! GeoTIFF height fields (`tiff` crate): one greyscale band of any integer or float type, placed
//! by ModelPixelScale (33550) and ModelTiepoint (33922), geographic when the GeoKey directory
//! (34735) says so (GTModelTypeGeoKey = 2), with GDAL's nodata tag (42113) turned into holes.

use std::io::Cursor;

use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::Tag;

use super::error::{bad, DemErrorKind};
use super::HeightGrid;

/// GeoKey id of the model type: 1 projected, 2 geographic, 3 geocentric.
const GT_MODEL_TYPE: u16 = 1024;

fn tiff_error(e: tiff::TiffError) -> DemErrorKind {
    match e {
        tiff::TiffError::LimitsExceeded => DemErrorKind::TooLarge(
            "the image exceeds the decoder's limits (more pixels than the file can hold?)".into(),
        ),
        e => bad(format!("TIFF: {e}")),
    }
}

pub fn read(bytes: &[u8]) -> Result<HeightGrid, DemErrorKind> {
    // A decoded image is at most 8 bytes a pixel; a file cannot describe more pixels than it
    // holds compressed by far, so the limit follows the file's size.
    let mut limits = Limits::default();
    limits.decoding_buffer_size = bytes.len().saturating_mul(64).clamp(1 << 20, 1 << 33);
    let mut decoder = Decoder::new(Cursor::new(bytes))
        .map_err(tiff_error)?
        .with_limits(limits);
    let (columns, rows) = decoder.dimensions().map_err(tiff_error)?;
    match decoder.colortype().map_err(tiff_error)? {
        tiff::ColorType::Gray(_) => {}
        other => {
            return Err(DemErrorKind::NoGrid(format!(
                "the image is {other:?}, not one greyscale band of heights"
            )))
        }
    }
    let values: Vec<f64> = match decoder.read_image().map_err(tiff_error)? {
        DecodingResult::U8(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::U16(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::U32(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::U64(v) => v.into_iter().map(|x| x as f64).collect(),
        DecodingResult::I8(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::I16(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::I32(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::I64(v) => v.into_iter().map(|x| x as f64).collect(),
        DecodingResult::F16(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::F32(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::F64(v) => v,
    };
    let nodata: Option<f64> = decoder
        .find_tag(Tag::GdalNodata)
        .map_err(tiff_error)?
        .and_then(|v| v.into_string().ok())
        .and_then(|s| s.trim_matches(char::from(0)).trim().parse().ok());
    let scale = decoder
        .find_tag(Tag::ModelPixelScaleTag)
        .map_err(tiff_error)?
        .and_then(|v| v.into_f64_vec().ok());
    let tiepoint = decoder
        .find_tag(Tag::ModelTiepointTag)
        .map_err(tiff_error)?
        .and_then(|v| v.into_f64_vec().ok());
    let geokeys = decoder
        .find_tag(Tag::GeoKeyDirectoryTag)
        .map_err(tiff_error)?
        .and_then(|v| v.into_u16_vec().ok());
    // GeoKey directory: header of 4 shorts, then (key, location, count, value) entries.
    let geographic = geokeys.is_some_and(|k| {
        k.get(4..)
            .unwrap_or(&[])
            .chunks_exact(4)
            .any(|e| e[0] == GT_MODEL_TYPE && e[1] == 0 && e[3] == 2)
    });
    let (origin, spacing) = match (scale, tiepoint) {
        (Some(s), Some(t)) if s.len() >= 2 && t.len() >= 6 => {
            // Tie point (i, j, k) ↔ (x, y, z); rows run against y (north-up images).
            let (dx, dy) = (s[0], -s[1]);
            ([t[3] - t[0] * dx, t[4] - t[1] * dy], [dx, dy])
        }
        _ => ([0.0, 0.0], [1.0, 1.0]),
    };
    let heights = values
        .into_iter()
        .map(|v| {
            if v.is_nan() || Some(v) == nodata {
                f32::NAN
            } else {
                v as f32
            }
        })
        .collect::<Vec<f32>>();
    if heights.len() != columns as usize * rows as usize {
        return Err(bad(format!(
            "{} samples for a {columns} × {rows} image",
            heights.len()
        )));
    }
    Ok(HeightGrid {
        columns: columns as usize,
        rows: rows as usize,
        heights,
        origin,
        spacing,
        geographic,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiff::encoder::{colortype, TiffEncoder};

    fn geotiff(nodata: Option<&str>, geographic: bool) -> Vec<u8> {
        let mut out = Cursor::new(Vec::new());
        let mut encoder = TiffEncoder::new(&mut out).unwrap();
        let mut image = encoder.new_image::<colortype::GrayI16>(3, 2).unwrap();
        let d = image.encoder();
        d.write_tag(Tag::ModelPixelScaleTag, &[30.0f64, 30.0, 0.0][..])
            .unwrap();
        d.write_tag(
            Tag::ModelTiepointTag,
            &[0.0f64, 0.0, 0.0, 500_000.0, 4_000_000.0, 0.0][..],
        )
        .unwrap();
        let model = if geographic { 2 } else { 1 };
        d.write_tag(
            Tag::GeoKeyDirectoryTag,
            &[1u16, 1, 0, 1, GT_MODEL_TYPE, 0, 1, model][..],
        )
        .unwrap();
        if let Some(n) = nodata {
            d.write_tag(Tag::GdalNodata, n).unwrap();
        }
        image.write_data(&[10i16, 20, -9999, 40, 50, 60]).unwrap();
        out.into_inner()
    }

    #[test]
    fn reads_placement_and_nodata() {
        let g = read(&geotiff(Some("-9999"), false)).unwrap();
        assert_eq!((g.columns, g.rows), (3, 2));
        assert_eq!(g.origin, [500_000.0, 4_000_000.0]);
        assert_eq!(g.spacing, [30.0, -30.0]);
        assert!(!g.geographic);
        assert!(g.heights[2].is_nan(), "nodata → hole");
        assert_eq!(g.heights[5], 60.0);
        let g = read(&geotiff(None, true)).unwrap();
        assert!(g.geographic);
        assert_eq!(g.heights[2], -9999.0, "without the tag it is a height");
    }

    #[test]
    fn bad_files_are_errors() {
        let good = geotiff(None, false);
        assert!(read(b"II*\0garbage").is_err());
        for len in [0, 8, good.len() / 2] {
            assert!(read(&good[..len]).is_err(), "{len}");
        }
    }
}
