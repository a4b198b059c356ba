//! A patch's columns bit-packed, lossless bit for bit (issue 12): the body of a live record
//! (`simplify/live_record.rs`: the live store was the largest temporary file while the
//! leaves were made) and, rows and ids alone, each leaf's triangles once the hierarchy is
//! built (`hierarchy/leaf_corners.rs`: they replace the staged triangle file).
//!
//! 1. rows: each triangle's three rows of the vertex table, `width_of(v - 1)` bits each;
//! 2. ids: ascending, so the first in 32 bits and each gap less one as a Rice code (its
//!    parameter in a byte first): a leaf's ids are a sample of the whole mesh's, about
//!    `log2(vertices / v) + 2` bits each whatever the input's vertex order;
//! 3. positions (f32): per axis the bits mapped to integers ordered as the floats are, less
//!    their least, in as many bits as the largest difference needs (a patch is small beside
//!    the model, so most high bits are shared).
//!
//! Each section ends on a byte. A live record's head holds the ids section's length, so the
//! triangles (rows and ids) are read without the positions.

use crate::external::bits::{width_of, BitReader, BitWriter};

/// An f32's bits as an integer in the floats' order (`-0.0` just below `+0.0`).
fn ordered(x: f32) -> u32 {
    let b = x.to_bits();
    if b >> 31 == 1 {
        !b
    } else {
        b | 0x8000_0000
    }
}

fn unordered(u: u32) -> f32 {
    if u >> 31 == 1 {
        f32::from_bits(u & 0x7FFF_FFFF)
    } else {
        f32::from_bits(!u)
    }
}

fn row_width(vertices: usize) -> u32 {
    width_of(vertices.saturating_sub(1) as u32)
}

/// Bytes of the rows section of a record of `triangles` triangles and `vertices` vertices.
pub(crate) fn rows_bytes(triangles: usize, vertices: usize) -> usize {
    (3 * triangles * row_width(vertices) as usize).div_ceil(8)
}

/// Appends the rows section.
pub(crate) fn put_rows(rows: &[[u32; 3]], vertices: usize, out: &mut Vec<u8>) {
    let width = row_width(vertices);
    let mut w = BitWriter::new(out);
    for &r in rows.iter().flatten() {
        w.put(r, width);
    }
    w.finish();
}

/// Appends the ids section (`ids` strictly ascending, at least one).
pub(crate) fn put_ids(ids: &[u32], out: &mut Vec<u8>) {
    let span = (ids[ids.len() - 1] - ids[0]) as u64;
    let gaps = (ids.len() - 1).max(1) as u64;
    // The Rice parameter near log2 of the mean gap.
    let k = width_of((span / gaps) as u32).saturating_sub(1);
    out.push(k as u8);
    out.extend_from_slice(&ids[0].to_le_bytes());
    let mut w = BitWriter::new(out);
    for pair in ids.windows(2) {
        w.rice(pair[1] - pair[0] - 1, k);
    }
    w.finish();
}

/// Appends the positions section.
pub(crate) fn put_positions(positions: &[[f32; 3]], out: &mut Vec<u8>) {
    let mut low = [u32::MAX; 3];
    let mut high = [0u32; 3];
    for p in positions {
        for axis in 0..3 {
            let u = ordered(p[axis]);
            low[axis] = low[axis].min(u);
            high[axis] = high[axis].max(u);
        }
    }
    let widths: [u32; 3] = std::array::from_fn(|a| width_of(high[a].saturating_sub(low[a])));
    for axis in 0..3 {
        out.extend_from_slice(&low[axis].to_le_bytes());
        out.push(widths[axis] as u8);
    }
    let mut w = BitWriter::new(out);
    for p in positions {
        for axis in 0..3 {
            w.put(ordered(p[axis]) - low[axis], widths[axis]);
        }
    }
    w.finish();
}

fn damaged(what: &str) -> std::io::Error {
    std::io::Error::new(
        std::io::ErrorKind::InvalidData,
        format!("a live record: {what}"),
    )
}

/// The rows section of `bytes` (which starts with it).
pub(crate) fn get_rows(
    bytes: &[u8],
    triangles: usize,
    vertices: usize,
) -> std::io::Result<Vec<[u32; 3]>> {
    let width = row_width(vertices);
    let mut r = BitReader::new(&bytes[..rows_bytes(triangles, vertices).min(bytes.len())]);
    let rows: Vec<[u32; 3]> = (0..triangles)
        .map(|_| [r.get(width), r.get(width), r.get(width)])
        .collect();
    if r.overran() || rows.iter().flatten().any(|&i| i as usize >= vertices) {
        return Err(damaged("rows"));
    }
    Ok(rows)
}

/// The `vertices` ids of an ids section (`bytes` is the section, exactly).
pub(crate) fn get_ids(bytes: &[u8], vertices: usize) -> std::io::Result<Vec<u32>> {
    if bytes.len() < 5 {
        return Err(damaged("ids"));
    }
    let k = bytes[0] as u32;
    let first = u32::from_le_bytes(bytes[1..5].try_into().expect("4 bytes"));
    let mut r = BitReader::new(&bytes[5..]);
    let mut ids = Vec::with_capacity(vertices);
    ids.push(first);
    let mut last = first;
    for _ in 1..vertices {
        last = r
            .rice(k)
            .and_then(|gap| last.checked_add(gap)?.checked_add(1))
            .ok_or_else(|| damaged("ids"))?;
        ids.push(last);
    }
    // The section is exactly its codes.
    if r.overran() || 5 + r.bytes_read() != bytes.len() {
        return Err(damaged("ids"));
    }
    Ok(ids)
}

/// The `vertices` positions of the positions section at the start of `bytes`, and the
/// section's length.
pub(crate) fn get_positions(
    bytes: &[u8],
    vertices: usize,
) -> std::io::Result<(Vec<[f32; 3]>, usize)> {
    if bytes.len() < 15 {
        return Err(damaged("positions"));
    }
    let low: [u32; 3] =
        std::array::from_fn(|a| u32::from_le_bytes(bytes[5 * a..5 * a + 4].try_into().unwrap()));
    let widths: [u32; 3] = std::array::from_fn(|a| bytes[5 * a + 4] as u32);
    if widths.iter().any(|&w| w > 32) {
        return Err(damaged("positions"));
    }
    let length = 15 + (vertices * widths.iter().sum::<u32>() as usize).div_ceil(8);
    let mut r = BitReader::new(&bytes[15..length.min(bytes.len())]);
    let positions = (0..vertices)
        .map(|_| std::array::from_fn(|a| unordered(low[a].wrapping_add(r.get(widths[a])))))
        .collect();
    if r.overran() {
        return Err(damaged("positions"));
    }
    Ok((positions, length))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_float_order_mapping_is_monotone_and_exact() {
        let xs = [
            f32::NEG_INFINITY,
            -3.4e38,
            -1.0,
            -f32::MIN_POSITIVE,
            -1e-45,
            -0.0,
            0.0,
            1e-45,
            f32::MIN_POSITIVE,
            0.1,
            1.0,
            3.4e38,
            f32::INFINITY,
        ];
        for pair in xs.windows(2) {
            assert!(ordered(pair[0]) < ordered(pair[1]), "{pair:?}");
        }
        for x in xs {
            assert_eq!(unordered(ordered(x)).to_bits(), x.to_bits());
        }
    }

    #[test]
    fn sections_read_back_bit_for_bit_and_damage_is_an_error() {
        let ids: Vec<u32> = vec![7, 8, 1000, 1001, 5_000_000, u32::MAX];
        let positions: Vec<[f32; 3]> = vec![
            [0.0, -0.0, 1.5],
            [-1e-30, 2.0, 1.5],
            [1e-30, 2.000_001, 1.5],
            [-0.0, 1.0, 1.5],
            [3.0, -2.0, 1.5],
            [f32::MIN_POSITIVE, 0.5, 1.5],
        ];
        let rows = vec![[0, 1, 2], [3, 4, 5], [5, 0, 3]];
        let mut out = Vec::new();
        put_rows(&rows, ids.len(), &mut out);
        assert_eq!(out.len(), rows_bytes(rows.len(), ids.len()));
        let ids_at = out.len();
        put_ids(&ids, &mut out);
        let positions_at = out.len();
        put_positions(&positions, &mut out);
        assert_eq!(get_rows(&out, rows.len(), ids.len()).unwrap(), rows);
        assert_eq!(get_ids(&out[ids_at..positions_at], ids.len()).unwrap(), ids);
        let (back, length) = get_positions(&out[positions_at..], ids.len()).unwrap();
        assert_eq!(length, out.len() - positions_at);
        for (a, b) in back.iter().zip(&positions) {
            assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits));
        }
        // Cut short: errors, not panics.
        assert!(get_rows(&out[..1], rows.len(), ids.len()).is_err());
        assert!(get_ids(&out[ids_at..ids_at + 6], ids.len()).is_err());
        assert!(get_positions(&out[positions_at..out.len() - 1], ids.len()).is_err());
        // A row past the table.
        let mut bad = Vec::new();
        put_rows(&[[0, 1, 7]], 8, &mut bad);
        assert!(get_rows(&bad, 1, 6).is_err());
    }
}
