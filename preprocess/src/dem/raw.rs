//! Height fields without a header of their own: raw little-endian f32 samples (dimensions
//! given by the caller), and the JSON grid `{"width": W, "height": H, "values": [...]}` (the
//! volcano of vega-datasets), `null` values marking holes, with an optional `"spacing"`.

use super::error::{bad, check_fits, DemErrorKind};
use super::{DemOptions, HeightGrid};

pub fn read_f32(bytes: &[u8], options: &DemOptions) -> Result<HeightGrid, DemErrorKind> {
    let (columns, rows) = f32_grid_size(options, bytes.len() as u64)?;
    let heights = bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    Ok(HeightGrid::unit(columns, rows, heights))
}

/// The (columns, rows) of a raw f32 file of `len` bytes: `--raw-size`'s, if the file holds
/// exactly that many samples.
pub(super) fn f32_grid_size(
    options: &DemOptions,
    len: u64,
) -> Result<(usize, usize), DemErrorKind> {
    let Some((columns, rows)) = options.raw_size else {
        return Err(DemErrorKind::NoGrid(
            "a raw f32 file needs its size (--raw-size WIDTHxHEIGHT)".into(),
        ));
    };
    let count = (columns as u64).saturating_mul(rows as u64);
    let n = check_fits("raw f32 samples", count, 4, len)?;
    if n as u64 * 4 != len {
        return Err(bad(format!(
            "{len} bytes is not {columns} × {rows} f32 samples ({} bytes)",
            n * 4
        )));
    }
    Ok((columns, rows))
}

pub fn read_json(bytes: &[u8]) -> Result<HeightGrid, DemErrorKind> {
    let value: serde_json::Value =
        serde_json::from_slice(bytes).map_err(|e| bad(format!("JSON: {e}")))?;
    let size = |key: &str| {
        value
            .get(key)
            .and_then(serde_json::Value::as_u64)
            .ok_or_else(|| bad(format!("no non-negative integer {key:?}")))
    };
    let (columns, rows) = (size("width")?, size("height")?);
    let values = value
        .get("values")
        .and_then(serde_json::Value::as_array)
        .ok_or_else(|| bad("no \"values\" array"))?;
    if Some(values.len() as u64) != columns.checked_mul(rows) {
        return Err(bad(format!(
            "{} values for a {columns} × {rows} grid",
            values.len()
        )));
    }
    let heights = values
        .iter()
        .enumerate()
        .map(|(i, v)| match v {
            serde_json::Value::Null => Ok(f32::NAN),
            v => v
                .as_f64()
                .map(|h| h as f32)
                .ok_or_else(|| bad(format!("value {i} is not a number or null"))),
        })
        .collect::<Result<_, _>>()?;
    let mut grid = HeightGrid::unit(columns as usize, rows as usize, heights);
    // Optional: the horizontal distance between samples (what `tessera gen terrain` writes).
    if let Some(spacing) = value.get("spacing") {
        match spacing.as_f64() {
            Some(s) if s.is_finite() && s > 0.0 => grid.spacing = [s, s],
            _ => {
                return Err(bad(format!(
                    "\"spacing\" {spacing} is not a positive number"
                )))
            }
        }
    }
    Ok(grid)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_raw_and_json() {
        let bytes: Vec<u8> = [1.0f32, 2.0, f32::NAN, 4.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let options = DemOptions {
            raw_size: Some((2, 2)),
            ..Default::default()
        };
        let g = read_f32(&bytes, &options).unwrap();
        assert_eq!(g.heights[3], 4.0);
        assert!(g.heights[2].is_nan());
        let g = read_json(br#"{"width": 2, "height": 2, "values": [1, 2.5, null, 4]}"#).unwrap();
        assert_eq!((g.columns, g.rows), (2, 2));
        assert!(g.heights[2].is_nan());
    }

    #[test]
    fn bad_grids_are_errors() {
        let options = DemOptions {
            raw_size: Some((3, 3)),
            ..Default::default()
        };
        assert!(read_f32(&[0; 16], &options).is_err());
        assert!(read_f32(&[0; 16], &DemOptions::default())
            .unwrap_err()
            .to_string()
            .contains("--raw-size"));
        assert!(read_json(br#"{"width": 2, "height": 3, "values": [1, 2]}"#).is_err());
        assert!(read_json(br#"{"width": 2, "height": 1, "values": [1, "x"]}"#).is_err());
        assert!(read_json(b"[1, 2").is_err());
    }
}
