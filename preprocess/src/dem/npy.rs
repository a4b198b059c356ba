//! NumPy arrays: `.npy` (one array) and `.npz` (a zip of `.npy` files, like the Jacksboro fault
//! DEM of matplotlib's sample data).
//!
//! `.npy`: magic `\x93NUMPY`, version, header length (u16 for 1.x, u32 for 2.x/3.x), then a
//! Python dict literal `{'descr': '<i2', 'fortran_order': False, 'shape': (344, 403), }` and the
//! data. Integer, float and unsigned types of either byte order are read; Fortran order is
//! transposed. In an `.npz`, the grid is the asked-for array or the largest 2-D one, and scalar
//! arrays named `xmin`, `ymin`, `ymax`, `dx`, `dy` (the Jacksboro file's) place it.

use std::io::Read;

use super::error::{bad, check_fits, DemErrorKind};
use super::{DemOptions, HeightGrid};

/// An array read from `.npy` data.
#[derive(Clone, Debug, PartialEq)]
struct Array {
    shape: Vec<usize>,
    values: Values,
}

/// A 2-D array of more than one value (a grid) is read straight into the f32 heights a grid
/// keeps (the same values as through f64: every source type rounds to f32 alike either way),
/// so a large grid is never held twice; the rest (an `.npz`'s placing scalars) widened to f64.
#[derive(Clone, Debug, PartialEq)]
enum Values {
    Narrow(Vec<f32>),
    Wide(Vec<f64>),
}

impl Values {
    fn len(&self) -> usize {
        match self {
            Values::Narrow(v) => v.len(),
            Values::Wide(v) => v.len(),
        }
    }
}

/// Values decoded a chunk at a time (bounds the bytes held besides the values).
const CHUNK_VALUES: usize = 1 << 16;

/// The value of `key` in the header dict (the text up to the next top-level comma or brace).
fn dict_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let start = header.find(&format!("'{key}'"))? + key.len() + 2;
    let rest = header[start..].trim_start().strip_prefix(':')?.trim_start();
    let mut depth = 0;
    for (i, c) in rest.char_indices() {
        match c {
            '(' | '[' => depth += 1,
            ')' | ']' => {
                if depth == 0 {
                    return Some(rest[..i].trim());
                }
                depth -= 1;
                if depth == 0 {
                    return Some(rest[..=i].trim());
                }
            }
            ',' | '}' if depth == 0 => return Some(rest[..i].trim()),
            _ => {}
        }
    }
    None
}

fn parse_npy(bytes: &[u8]) -> Result<Array, DemErrorKind> {
    parse_npy_from(&mut &bytes[..], bytes.len() as u64)
}

fn read_exact(input: &mut impl Read, out: &mut [u8]) -> Result<(), DemErrorKind> {
    input.read_exact(out).map_err(DemErrorKind::Io)
}

fn decode_f32(b: &[u8], little: bool) -> f64 {
    let a = [b[0], b[1], b[2], b[3]];
    (if little {
        f32::from_le_bytes(a)
    } else {
        f32::from_be_bytes(a)
    }) as f64
}

/// A `.npy` header: the array's shape and order, and how its values decode.
struct Header {
    shape: Vec<usize>,
    fortran: bool,
    little: bool,
    size: usize,
    decode: fn(&[u8], bool) -> f64,
    count: usize,
}

/// `.npy` data from `input`, which holds `len` bytes: the header, then the values a chunk at
/// a time, so that a file is read without holding its bytes.
fn parse_npy_from(input: &mut impl Read, len: u64) -> Result<Array, DemErrorKind> {
    let header = read_header(input, len)?;
    read_values(input, header)
}

/// The header, checked against the `len` bytes the file holds; `input` is left at the data.
fn read_header(input: &mut impl Read, len: u64) -> Result<Header, DemErrorKind> {
    let mut head = [0u8; 12];
    if len < 10 {
        return Err(bad("not a .npy array (no \\x93NUMPY magic)"));
    }
    read_exact(input, &mut head[..10])?;
    if &head[..6] != b"\x93NUMPY" {
        return Err(bad("not a .npy array (no \\x93NUMPY magic)"));
    }
    let (header_len, header_start): (usize, usize) = match head[6] {
        1 => (u16::from_le_bytes([head[8], head[9]]) as usize, 10),
        2 | 3 if len >= 12 => {
            read_exact(input, &mut head[10..12])?;
            (
                u32::from_le_bytes([head[8], head[9], head[10], head[11]]) as usize,
                12,
            )
        }
        v => return Err(bad(format!("unsupported .npy version {v}"))),
    };
    let data_start = header_start
        .checked_add(header_len)
        .filter(|&e| e as u64 <= len)
        .ok_or_else(|| bad("the .npy header runs past the end of the file"))?;
    let mut header = vec![0u8; header_len];
    read_exact(input, &mut header)?;
    let header = std::str::from_utf8(&header).map_err(|_| bad("the .npy header is not text"))?;
    let descr = dict_value(header, "descr")
        .map(|d| d.trim_matches(|c| c == '\'' || c == '"'))
        .ok_or_else(|| bad(format!("no 'descr' in the .npy header {header:?}")))?;
    let fortran = dict_value(header, "fortran_order") == Some("True");
    let shape_text = dict_value(header, "shape")
        .ok_or_else(|| bad(format!("no 'shape' in the .npy header {header:?}")))?;
    let shape: Vec<usize> = shape_text
        .trim_matches(|c| c == '(' || c == ')')
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<usize>()
                .map_err(|_| bad(format!("shape {shape_text} is not a tuple of sizes")))
        })
        .collect::<Result<_, _>>()?;
    let (little, kind, size) = {
        let mut chars = descr.chars();
        let order = chars.next().ok_or_else(|| bad("empty descr"))?;
        let kind = chars.next().ok_or_else(|| bad("empty descr"))?;
        let size: usize = chars
            .as_str()
            .parse()
            .map_err(|_| bad(format!("descr {descr:?}")))?;
        (order != '>', kind, size)
    };
    let decode: fn(&[u8], bool) -> f64 = match (kind, size) {
        ('i', 1) => |b, _| b[0] as i8 as f64,
        ('u', 1) | ('b', 1) => |b, _| b[0] as f64,
        ('i', 2) => |b, le| {
            let a = [b[0], b[1]];
            (if le {
                i16::from_le_bytes(a)
            } else {
                i16::from_be_bytes(a)
            }) as f64
        },
        ('u', 2) => |b, le| {
            let a = [b[0], b[1]];
            (if le {
                u16::from_le_bytes(a)
            } else {
                u16::from_be_bytes(a)
            }) as f64
        },
        ('i', 4) => |b, le| {
            let a = [b[0], b[1], b[2], b[3]];
            (if le {
                i32::from_le_bytes(a)
            } else {
                i32::from_be_bytes(a)
            }) as f64
        },
        ('u', 4) => |b, le| {
            let a = [b[0], b[1], b[2], b[3]];
            (if le {
                u32::from_le_bytes(a)
            } else {
                u32::from_be_bytes(a)
            }) as f64
        },
        ('f', 4) => decode_f32,
        ('f', 8) => |b, le| {
            let a: [u8; 8] = b.try_into().expect("8 bytes");
            if le {
                f64::from_le_bytes(a)
            } else {
                f64::from_be_bytes(a)
            }
        },
        _ => return Err(bad(format!("unsupported array type {descr:?}"))),
    };
    let count = shape
        .iter()
        .try_fold(1u64, |n, &d| n.checked_mul(d as u64))
        .ok_or_else(|| DemErrorKind::TooLarge(format!("shape {shape:?}")))?;
    let count = check_fits("array", count, size as u64, len - data_start as u64)?;
    Ok(Header {
        shape,
        fortran,
        little,
        size,
        decode,
        count,
    })
}

/// The values that follow `header`.
fn read_values(input: &mut impl Read, header: Header) -> Result<Array, DemErrorKind> {
    let Header {
        shape,
        fortran,
        little,
        size,
        decode,
        count,
    } = header;
    let narrow = shape.len() == 2 && count > 1;
    let mut values = match narrow {
        true => Values::Narrow(Vec::with_capacity(count)),
        false => Values::Wide(Vec::with_capacity(count)),
    };
    let mut chunk = vec![0u8; CHUNK_VALUES.min(count) * size];
    let mut left = count;
    while left > 0 {
        let n = left.min(CHUNK_VALUES);
        let bytes = &mut chunk[..n * size];
        read_exact(input, bytes)?;
        let decoded = bytes.chunks_exact(size).map(|c| decode(c, little));
        match &mut values {
            Values::Narrow(v) => v.extend(decoded.map(|x| x as f32)),
            Values::Wide(v) => v.extend(decoded),
        }
        left -= n;
    }
    if fortran && shape.len() == 2 {
        // Column-major on disk: transpose into rows.
        let (rows, columns) = (shape[0], shape[1]);
        let at = |i: usize| (i % columns) * rows + i / columns;
        values = match values {
            Values::Narrow(v) => Values::Narrow((0..count).map(|i| v[at(i)]).collect()),
            Values::Wide(v) => Values::Wide((0..count).map(|i| v[at(i)]).collect()),
        };
    }
    Ok(Array { shape, values })
}

/// A 2-D `.npy` grid in row order (C order), read a row at a time: heights as f32, the values
/// [`read_npy_from`] gives.
pub struct NpyRows<R> {
    input: R,
    header: Header,
    rows_read: usize,
    bytes: Vec<u8>,
}

/// The rows of the `.npy` grid `input` holds (`len` bytes), or `None` where the array is not
/// a grid stored row by row (Fortran order, or not 2-D: read those whole).
pub fn npy_rows<R: Read>(mut input: R, len: u64) -> Result<Option<NpyRows<R>>, DemErrorKind> {
    let header = read_header(&mut input, len)?;
    if header.fortran || header.shape.len() != 2 || header.count <= 1 {
        return Ok(None);
    }
    Ok(Some(NpyRows {
        input,
        header,
        rows_read: 0,
        bytes: Vec::new(),
    }))
}

/// The rows of a headerless grid of `columns` × `rows` little-endian f32 samples (a raw f32
/// file, its size checked by the caller: `raw::f32_grid_size`), read as a `.npy` of that
/// shape is.
pub(super) fn raw_f32_rows<R: Read>(input: R, columns: usize, rows: usize) -> NpyRows<R> {
    NpyRows {
        input,
        header: Header {
            shape: vec![rows, columns],
            fortran: false,
            little: true,
            size: 4,
            decode: decode_f32,
            count: columns * rows,
        },
        rows_read: 0,
        bytes: Vec::new(),
    }
}

impl<R: Read> NpyRows<R> {
    pub fn columns(&self) -> usize {
        self.header.shape[1]
    }

    pub fn rows(&self) -> usize {
        self.header.shape[0]
    }

    /// The next row into `out`; false after the last.
    pub fn next_row(&mut self, out: &mut Vec<f32>) -> Result<bool, DemErrorKind> {
        if self.rows_read == self.rows() {
            return Ok(false);
        }
        let Header {
            size,
            little,
            decode,
            ..
        } = self.header;
        self.bytes.resize(self.columns() * size, 0);
        read_exact(&mut self.input, &mut self.bytes)?;
        out.clear();
        out.extend(
            self.bytes
                .chunks_exact(size)
                .map(|c| decode(c, little) as f32),
        );
        self.rows_read += 1;
        Ok(true)
    }
}

fn to_grid(array: Array) -> Result<HeightGrid, DemErrorKind> {
    if array.shape.len() != 2 {
        return Err(DemErrorKind::NoGrid(format!(
            "the array has shape {:?}, not 2-D",
            array.shape
        )));
    }
    let heights = match array.values {
        Values::Narrow(v) => v,
        Values::Wide(v) => v.iter().map(|&x| x as f32).collect(),
    };
    Ok(HeightGrid::unit(array.shape[1], array.shape[0], heights))
}

/// A `.npy` holding one 2-D array (unit spacing).
pub fn read_npy(bytes: &[u8]) -> Result<HeightGrid, DemErrorKind> {
    to_grid(parse_npy(bytes)?)
}

/// [`read_npy`] from a reader holding `len` bytes (a file, read a chunk at a time).
pub fn read_npy_from(input: &mut impl Read, len: u64) -> Result<HeightGrid, DemErrorKind> {
    to_grid(parse_npy_from(input, len)?)
}

/// An `.npz`: the asked-for array, or the largest 2-D one, placed by `xmin`, `ymin`, `ymax`,
/// `dx`, `dy` scalars where present (geographic when they look like degrees).
pub fn read_npz(bytes: &[u8], options: &DemOptions) -> Result<HeightGrid, DemErrorKind> {
    let mut zip = zip::ZipArchive::new(std::io::Cursor::new(bytes))
        .map_err(|e| bad(format!("not a valid .npz (zip) archive: {e}")))?;
    let mut arrays: Vec<(String, Array)> = Vec::new();
    for i in 0..zip.len() {
        let mut file = zip
            .by_index(i)
            .map_err(|e| bad(format!("zip entry {i}: {e}")))?;
        let name = file
            .name()
            .map_err(|e| bad(format!("zip entry {i}: {e}")))?
            .trim_end_matches(".npy")
            .to_string();
        // The entry's declared size is not trusted: read at most what a compressed stream of
        // this archive could hold (deflate expands at most ~1032:1).
        let limit = (bytes.len() as u64).saturating_mul(1032).min(1 << 34);
        let mut data = Vec::new();
        (&mut file)
            .take(limit)
            .read_to_end(&mut data)
            .map_err(|e| bad(format!("zip entry {name:?}: {e}")))?;
        arrays.push((name, parse_npy(&data)?));
    }
    let scalar = |key: &str| {
        arrays
            .iter()
            .find(|(n, _)| n == key)
            .and_then(|(_, a)| match &a.values {
                Values::Wide(v) if v.len() == 1 => Some(v[0]),
                _ => None,
            })
    };
    let chosen = match &options.variable {
        Some(name) => arrays.iter().position(|(n, _)| n == name).ok_or_else(|| {
            DemErrorKind::NoGrid(format!(
                "no array {name:?}; arrays: {}",
                arrays
                    .iter()
                    .map(|(n, _)| n.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })?,
        None => arrays
            .iter()
            .enumerate()
            .filter(|(_, (_, a))| a.shape.len() == 2)
            .max_by_key(|(_, (_, a))| a.values.len())
            .map(|(i, _)| i)
            .ok_or_else(|| DemErrorKind::NoGrid("no 2-D array in the archive".into()))?,
    };
    let (xmin, ymin, ymax, dx, dy) = (
        scalar("xmin"),
        scalar("ymin"),
        scalar("ymax"),
        scalar("dx"),
        scalar("dy"),
    );
    let mut grid = to_grid(arrays.swap_remove(chosen).1)?;
    if let (Some(x0), Some(a), Some(b), Some(dx), Some(dy)) = (xmin, ymin, ymax, dx, dy) {
        // Row 0 is the northern edge (matplotlib draws the array with its origin at the top),
        // whichever of the two keys holds it (the Jacksboro file's ymin is the larger).
        grid.origin = [x0, a.max(b)];
        grid.spacing = [dx.abs(), -dy.abs()];
        grid.geographic = x0.abs() <= 360.0 && a.abs() <= 90.0 && b.abs() <= 90.0;
    }
    Ok(grid)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    pub fn npy(descr: &str, shape: &str, data: &[u8]) -> Vec<u8> {
        let mut header =
            format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
        while (10 + header.len() + 1) % 64 != 0 {
            header.push(' ');
        }
        header.push('\n');
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend_from_slice(&(header.len() as u16).to_le_bytes());
        out.extend_from_slice(header.as_bytes());
        out.extend_from_slice(data);
        out
    }

    #[test]
    fn reads_types_and_orders() {
        let data: Vec<u8> = [1i16, -2, 3, 4, 5, 6]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let g = read_npy(&npy("<i2", "(2, 3)", &data)).unwrap();
        assert_eq!((g.rows, g.columns), (2, 3));
        assert_eq!(g.heights, [1.0, -2.0, 3.0, 4.0, 5.0, 6.0]);
        let data: Vec<u8> = [1.5f32, 2.5, 3.5, 4.5]
            .iter()
            .flat_map(|v| v.to_be_bytes())
            .collect();
        let g = read_npy(&npy(">f4", "(2, 2)", &data)).unwrap();
        assert_eq!(g.heights, [1.5, 2.5, 3.5, 4.5]);
        let fortran = npy("<f8", "(2, 2)", &[0u8; 32]);
        let text = String::from_utf8_lossy(&fortran[10..]).replace("False", "True ");
        let mut f = fortran[..10].to_vec();
        f.extend_from_slice(text.as_bytes());
        assert_eq!(read_npy(&f).unwrap().heights, [0.0; 4]);
    }

    #[test]
    fn bad_arrays_are_errors() {
        let good = npy("<i2", "(2, 3)", &[0; 12]);
        assert!(read_npy(b"NUMPY").is_err());
        assert!(read_npy(&good[..good.len() - 1])
            .unwrap_err()
            .to_string()
            .contains("too large"));
        assert!(read_npy(&npy("<c16", "(2, 2)", &[0; 64]))
            .unwrap_err()
            .to_string()
            .contains("unsupported array type"));
        assert!(read_npy(&npy("<i2", "(4,)", &[0; 8]))
            .unwrap_err()
            .to_string()
            .contains("not 2-D"));
        // An absurd shape is refused before anything is allocated.
        assert!(read_npy(&npy("<i2", "(4000000000, 4000000000)", &[0; 8])).is_err());
    }
}
