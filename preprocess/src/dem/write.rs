//! Writers for the two grid formats `tessera gen terrain` produces: NumPy `.npy` (little-endian
//! f32, C order, NaN for holes) and the JSON grid (`null` for holes, with a `"spacing"` in
//! metres that the JSON reader honours). Both read back into the same grid.

use super::HeightGrid;

/// The grid as a version-1.0 `.npy` file of shape (rows, columns).
pub fn npy_bytes(grid: &HeightGrid) -> Vec<u8> {
    let mut header = format!(
        "{{'descr': '<f4', 'fortran_order': False, 'shape': ({}, {}), }}",
        grid.rows, grid.columns
    );
    // Magic (6) + version (2) + header length (2) + header, padded with spaces to a multiple
    // of 64 and ended by a newline (the format's rule).
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + 4 * grid.heights.len());
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for h in &grid.heights {
        out.extend_from_slice(&h.to_le_bytes());
    }
    out
}

/// The grid as the JSON grid, with its horizontal spacing (the x step's magnitude).
pub fn json_bytes(grid: &HeightGrid) -> Vec<u8> {
    let values: Vec<serde_json::Value> = grid
        .heights
        .iter()
        .map(|&h| {
            if h.is_nan() {
                serde_json::Value::Null
            } else {
                serde_json::json!(h)
            }
        })
        .collect();
    serde_json::to_vec(&serde_json::json!({
        "width": grid.columns,
        "height": grid.rows,
        "spacing": grid.spacing[0].abs(),
        "values": values,
    }))
    .expect("a JSON value serialises")
}

#[cfg(test)]
mod tests {
    use super::super::{npy, raw};
    use super::*;

    #[test]
    fn both_formats_read_back() {
        let grid = HeightGrid {
            spacing: [30.0, 30.0],
            ..HeightGrid::unit(3, 2, vec![1.0, -2.5, f32::NAN, 4.0, 1e6, 0.125])
        };
        let same = |g: &HeightGrid| {
            assert_eq!((g.columns, g.rows), (3, 2));
            for (a, b) in g.heights.iter().zip(&grid.heights) {
                assert!(a == b || (a.is_nan() && b.is_nan()), "{a} vs {b}");
            }
        };
        let bytes = npy_bytes(&grid);
        assert_eq!((bytes.len() - 4 * 6) % 64, 0, "header padded to 64 bytes");
        same(&npy::read_npy(&bytes).unwrap());
        let g = raw::read_json(&json_bytes(&grid)).unwrap();
        same(&g);
        assert_eq!(g.spacing, [30.0, 30.0]);
    }
}
