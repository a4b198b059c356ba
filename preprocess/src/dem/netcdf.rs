//! netCDF-3 classic and 64-bit-offset files (the ETOPO5 and ETOPO20 relief grids): the header
//! is parsed (dimensions, attributes, variables with their types and offsets), the 2-D variable
//! found, its values read big-endian from where the header says, missing and fill values turned
//! into holes, `scale_factor` / `add_offset` applied, and the coordinate variables of its two
//! dimensions (longitude, latitude) giving the grid's placement. No offset is assumed.
//!
//! Format: NetCDF Classic and 64-bit Offset Format specification (Unidata), all big-endian:
//! `magic "CDF" version(1|2) numrecs dim_list gatt_list var_list data`.

use super::error::{bad, check_fits, DemErrorKind};
use super::{DemOptions, HeightGrid};

const NC_DIMENSION: u32 = 0x0A;
const NC_VARIABLE: u32 = 0x0B;
const NC_ATTRIBUTE: u32 = 0x0C;

/// External types.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum NcType {
    Byte,
    Char,
    Short,
    Int,
    Float,
    Double,
}

impl NcType {
    fn from_code(code: u32) -> Result<NcType, DemErrorKind> {
        Ok(match code {
            1 => NcType::Byte,
            2 => NcType::Char,
            3 => NcType::Short,
            4 => NcType::Int,
            5 => NcType::Float,
            6 => NcType::Double,
            _ => return Err(bad(format!("unknown netCDF type code {code}"))),
        })
    }

    fn size(self) -> u64 {
        match self {
            NcType::Byte | NcType::Char => 1,
            NcType::Short => 2,
            NcType::Int | NcType::Float => 4,
            NcType::Double => 8,
        }
    }
}

/// An attribute's values, numbers widened to f64.
#[derive(Clone, Debug)]
enum Values {
    Text(String),
    Numbers(Vec<f64>),
}

#[derive(Clone, Debug)]
struct Attribute {
    name: String,
    values: Values,
}

#[derive(Clone, Debug)]
struct Variable {
    name: String,
    dims: Vec<usize>,
    attributes: Vec<Attribute>,
    ty: NcType,
    begin: u64,
}

#[derive(Clone, Debug)]
struct Dimension {
    name: String,
    /// 0 for the record (unlimited) dimension.
    length: u64,
}

/// A cursor over the header.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
    offset_bytes: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize, what: &str) -> Result<&[u8], DemErrorKind> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(bad(format!(
                "header truncated reading {what} at byte {}",
                self.at
            )));
        };
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }

    fn u32(&mut self, what: &str) -> Result<u32, DemErrorKind> {
        let b = self.take(4, what)?;
        Ok(u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn offset(&mut self, what: &str) -> Result<u64, DemErrorKind> {
        if self.offset_bytes == 8 {
            let b = self.take(8, what)?;
            Ok(u64::from_be_bytes(b.try_into().expect("8 bytes")))
        } else {
            Ok(self.u32(what)? as u64)
        }
    }

    /// A count that is followed by at least `count × min_item` bytes of header.
    fn count(&mut self, what: &str, min_item: u64) -> Result<usize, DemErrorKind> {
        let n = self.u32(what)? as u64;
        let left = (self.bytes.len() - self.at) as u64;
        check_fits(what, n, min_item, left)
    }

    fn padded(&mut self, n: usize, what: &str) -> Result<&[u8], DemErrorKind> {
        let start = self.at;
        self.take(n.next_multiple_of(4), what)?;
        Ok(&self.bytes[start..start + n])
    }

    fn name(&mut self) -> Result<String, DemErrorKind> {
        let n = self.count("name length", 1)?;
        let raw = self.padded(n, "name")?;
        String::from_utf8(raw.to_vec()).map_err(|_| bad("a name is not UTF-8"))
    }

    /// `ABSENT` (two zero words) or `tag nelems ...`: the element count.
    fn list(&mut self, tag: u32, what: &str, min_item: u64) -> Result<usize, DemErrorKind> {
        let found = self.u32(what)?;
        let n = self.count(what, min_item)?;
        match found {
            0 if n == 0 => Ok(0),
            t if t == tag => Ok(n),
            t => Err(bad(format!(
                "{what}: tag {t:#x}, expected {tag:#x} or absent"
            ))),
        }
    }

    fn attributes(&mut self) -> Result<Vec<Attribute>, DemErrorKind> {
        let n = self.list(NC_ATTRIBUTE, "attribute list", 12)?;
        (0..n)
            .map(|_| {
                let name = self.name()?;
                let ty = NcType::from_code(self.u32("attribute type")?)?;
                let count = self.count("attribute values", ty.size())?;
                let raw = self.padded(count * ty.size() as usize, "attribute values")?;
                let values = match ty {
                    NcType::Char => {
                        Values::Text(String::from_utf8_lossy(raw).trim_end_matches('\0').into())
                    }
                    _ => Values::Numbers(
                        raw.chunks_exact(ty.size() as usize)
                            .map(|c| decode(ty, c))
                            .collect(),
                    ),
                };
                Ok(Attribute { name, values })
            })
            .collect()
    }
}

/// One big-endian value widened to f64.
fn decode(ty: NcType, b: &[u8]) -> f64 {
    match ty {
        NcType::Byte => b[0] as i8 as f64,
        NcType::Char => b[0] as f64,
        NcType::Short => i16::from_be_bytes([b[0], b[1]]) as f64,
        NcType::Int => i32::from_be_bytes([b[0], b[1], b[2], b[3]]) as f64,
        NcType::Float => f32::from_be_bytes([b[0], b[1], b[2], b[3]]) as f64,
        NcType::Double => f64::from_be_bytes(b.try_into().expect("8 bytes")),
    }
}

fn number(attributes: &[Attribute], name: &str) -> Option<f64> {
    attributes.iter().find_map(|a| match &a.values {
        Values::Numbers(v) if a.name == name => v.first().copied(),
        _ => None,
    })
}

fn text<'a>(attributes: &'a [Attribute], name: &str) -> Option<&'a str> {
    attributes.iter().find_map(|a| match &a.values {
        Values::Text(t) if a.name == name => Some(t.as_str()),
        _ => None,
    })
}

/// Reads the 2-D variable of a netCDF-3 file as a height grid.
pub fn read(bytes: &[u8], options: &DemOptions) -> Result<HeightGrid, DemErrorKind> {
    if bytes.len() < 4 || &bytes[..3] != b"CDF" {
        return Err(bad("not a netCDF-3 file (no \"CDF\" magic)"));
    }
    let offset_bytes = match bytes[3] {
        1 => 4,
        2 => 8,
        v => {
            return Err(bad(format!(
                "netCDF version byte {v}: only classic (1) and 64-bit offset (2) are read"
            )))
        }
    };
    let mut r = Reader {
        bytes,
        at: 4,
        offset_bytes,
    };
    let _numrecs = r.u32("record count")?;
    let n_dims = r.list(NC_DIMENSION, "dimension list", 8)?;
    let dims: Vec<Dimension> = (0..n_dims)
        .map(|_| {
            Ok(Dimension {
                name: r.name()?,
                length: r.u32("dimension length")? as u64,
            })
        })
        .collect::<Result<_, DemErrorKind>>()?;
    let _global = r.attributes()?;
    let n_vars = r.list(NC_VARIABLE, "variable list", 16)?;
    let mut vars = Vec::with_capacity(n_vars);
    for _ in 0..n_vars {
        let name = r.name()?;
        let rank = r.count("variable rank", 4)?;
        let ids: Vec<usize> = (0..rank)
            .map(|_| r.u32("dimension id").map(|d| d as usize))
            .collect::<Result<_, _>>()?;
        if let Some(&bad_id) = ids.iter().find(|&&d| d >= dims.len()) {
            return Err(bad(format!(
                "variable {name:?} uses dimension {bad_id} of {}",
                dims.len()
            )));
        }
        let attributes = r.attributes()?;
        let ty = NcType::from_code(r.u32("variable type")?)?;
        let _vsize = r.u32("variable size")?;
        let begin = r.offset("variable offset")?;
        vars.push(Variable {
            name,
            dims: ids,
            attributes,
            ty,
            begin,
        });
    }

    // The grid: the asked-for variable, else the largest numeric 2-D one.
    let numeric_2d = |v: &&Variable| v.dims.len() == 2 && v.ty != NcType::Char;
    let var = match &options.variable {
        Some(name) => vars.iter().find(|v| &v.name == name).ok_or_else(|| {
            DemErrorKind::NoGrid(format!(
                "no variable {name:?}; variables: {}",
                vars.iter()
                    .map(|v| v.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })?,
        None => vars
            .iter()
            .filter(numeric_2d)
            .max_by_key(|v| v.dims.iter().map(|&d| dims[d].length).product::<u64>())
            .ok_or_else(|| DemErrorKind::NoGrid("no 2-D numeric variable".into()))?,
    };
    if !numeric_2d(&var) {
        return Err(DemErrorKind::NoGrid(format!(
            "variable {:?} is not a 2-D numeric grid",
            var.name
        )));
    }
    let (row_dim, column_dim) = (&dims[var.dims[0]], &dims[var.dims[1]]);
    if row_dim.length == 0 || column_dim.length == 0 {
        return Err(DemErrorKind::NoGrid(format!(
            "variable {:?} uses the record dimension; only fixed-size grids are read",
            var.name
        )));
    }
    let (rows, columns) = (row_dim.length, column_dim.length);
    let begin = var.begin;
    let available = (bytes.len() as u64).saturating_sub(begin);
    let count = check_fits(
        &format!("variable {:?}", var.name),
        rows.saturating_mul(columns),
        var.ty.size(),
        available,
    )?;
    let size = var.ty.size() as usize;
    let data = &bytes[begin as usize..begin as usize + count * size];
    let missing: Vec<f64> = ["missing_value", "_FillValue"]
        .iter()
        .filter_map(|n| number(&var.attributes, n))
        .collect();
    let scale = number(&var.attributes, "scale_factor").unwrap_or(1.0);
    let offset = number(&var.attributes, "add_offset").unwrap_or(0.0);
    let heights: Vec<f32> = data
        .chunks_exact(size)
        .map(|c| {
            let v = decode(var.ty, c);
            if v.is_nan() || missing.contains(&v) {
                f32::NAN
            } else {
                (v * scale + offset) as f32
            }
        })
        .collect();

    // Placement from the coordinate variables (1-D, named like the dimensions).
    let axis = |dim: &Dimension| -> Result<Option<(f64, f64, bool)>, DemErrorKind> {
        let Some(v) = vars
            .iter()
            .find(|v| v.name == dim.name && v.dims.len() == 1 && v.ty != NcType::Char)
        else {
            return Ok(None);
        };
        let n = check_fits(
            &format!("coordinate {:?}", v.name),
            dim.length,
            v.ty.size(),
            (bytes.len() as u64).saturating_sub(v.begin),
        )?;
        if n < 2 {
            return Ok(None);
        }
        let at = |i: usize| {
            let s = v.begin as usize + i * v.ty.size() as usize;
            decode(v.ty, &bytes[s..s + v.ty.size() as usize])
        };
        let (first, last) = (at(0), at(n - 1));
        let degrees =
            text(&v.attributes, "units").is_some_and(|u| u.to_ascii_lowercase().contains("degree"));
        Ok(Some((first, (last - first) / (n - 1) as f64, degrees)))
    };
    let (x, y) = (axis(column_dim)?, axis(row_dim)?);
    let (origin, spacing, geographic) = match (x, y) {
        (Some((x0, dx, gx)), Some((y0, dy, gy))) => ([x0, y0], [dx, dy], gx && gy),
        _ => ([0.0, 0.0], [1.0, 1.0], false),
    };
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
pub(crate) mod tests {
    use super::*;

    /// A classic netCDF file: dims (lat 3, lon 4), coordinate variables, and a 2-D `z` of
    /// `ty` (3 = short, 5 = float) with a missing value.
    pub fn sample(ty: u32, version: u8) -> Vec<u8> {
        let mut h: Vec<u8> = Vec::new();
        let w = |h: &mut Vec<u8>, v: u32| h.extend_from_slice(&v.to_be_bytes());
        let name = |h: &mut Vec<u8>, s: &str| {
            h.extend_from_slice(&(s.len() as u32).to_be_bytes());
            h.extend_from_slice(s.as_bytes());
            h.resize(h.len().next_multiple_of(4), 0);
        };
        h.extend_from_slice(b"CDF");
        h.push(version);
        w(&mut h, 0);
        w(&mut h, NC_DIMENSION);
        w(&mut h, 2);
        name(&mut h, "lat");
        w(&mut h, 3);
        name(&mut h, "lon");
        w(&mut h, 4);
        w(&mut h, 0); // no global attributes
        w(&mut h, 0);
        w(&mut h, NC_VARIABLE);
        w(&mut h, 3);
        // Offsets are patched once the header's size is known.
        let mut patches = Vec::new();
        let mut var = |h: &mut Vec<u8>, n: &str, dims: &[u32], units: Option<&str>, ty: u32| {
            name(h, n);
            w(h, dims.len() as u32);
            for &d in dims {
                w(h, d);
            }
            match units {
                Some(u) => {
                    w(h, NC_ATTRIBUTE);
                    w(h, 1);
                    name(h, "units");
                    w(h, 2);
                    name(h, u);
                }
                None if ty != 5 && ty != 6 => {
                    w(h, NC_ATTRIBUTE);
                    w(h, 1);
                    name(h, "missing_value");
                    w(h, ty);
                    w(h, 1);
                    h.extend_from_slice(&(-32768i16).to_be_bytes());
                    h.extend_from_slice(&[0, 0]);
                }
                None => {
                    w(h, NC_ATTRIBUTE);
                    w(h, 1);
                    name(h, "_FillValue");
                    w(h, 5);
                    w(h, 1);
                    h.extend_from_slice(&(-1e30f32).to_be_bytes());
                }
            }
            w(h, ty);
            w(h, 0);
            patches.push(h.len());
            if version == 2 {
                h.extend_from_slice(&[0; 8]);
            } else {
                w(h, 0);
            }
        };
        var(&mut h, "lat", &[0], Some("degrees_north"), 6);
        var(&mut h, "lon", &[1], Some("degrees_east"), 6);
        var(&mut h, "z", &[0, 1], None, ty);
        let mut data = Vec::new();
        let mut begins = Vec::new();
        begins.push(h.len() + data.len());
        for v in [-10.0f64, -9.5, -9.0] {
            data.extend_from_slice(&v.to_be_bytes());
        }
        begins.push(h.len() + data.len());
        for v in [100.0f64, 100.25, 100.5, 100.75] {
            data.extend_from_slice(&v.to_be_bytes());
        }
        begins.push(h.len() + data.len());
        for i in 0..12i32 {
            if ty == 3 {
                let v: i16 = if i == 6 { -32768 } else { i as i16 * 10 };
                data.extend_from_slice(&v.to_be_bytes());
            } else {
                let v: f32 = if i == 6 { -1e30 } else { i as f32 * 10.0 };
                data.extend_from_slice(&v.to_be_bytes());
            }
        }
        for (&at, &begin) in patches.iter().zip(&begins) {
            if version == 2 {
                h[at..at + 8].copy_from_slice(&(begin as u64).to_be_bytes());
            } else {
                h[at..at + 4].copy_from_slice(&(begin as u32).to_be_bytes());
            }
        }
        h.extend_from_slice(&data);
        h
    }

    #[test]
    fn reads_the_grid_its_placement_and_holes() {
        for (ty, version) in [(3, 1), (5, 1), (3, 2)] {
            let g = read(&sample(ty, version), &DemOptions::default()).unwrap();
            assert_eq!((g.columns, g.rows), (4, 3));
            assert_eq!(g.origin, [100.0, -10.0]);
            assert_eq!(g.spacing, [0.25, 0.5]);
            assert!(g.geographic);
            assert_eq!(g.heights[5], 50.0);
            assert!(g.heights[6].is_nan(), "missing value → hole");
            assert_eq!(g.valid_samples(), 11);
        }
    }

    #[test]
    fn bad_files_are_errors() {
        let good = sample(3, 1);
        let message = |bytes: &[u8]| read(bytes, &DemOptions::default()).unwrap_err().to_string();
        assert!(message(b"HDF\x01").contains("magic"));
        assert!(message(b"CDF\x05abcd").contains("version byte 5"));
        for len in [4, 20, 60, good.len() / 2, good.len() - 1] {
            read(&good[..len], &DemOptions::default()).unwrap_err();
        }
        // An absurd dimension: the variable cannot fit in the file.
        let mut huge = good.clone();
        // magic, record count, dimension tag and count, lat's name (length + 4 bytes): then
        // lat's length.
        let at = 24;
        huge[at..at + 4].copy_from_slice(&0x4000_0000u32.to_be_bytes());
        assert!(message(&huge).contains("too large"));
        assert!(read(
            &good,
            &DemOptions {
                variable: Some("nope".into()),
                ..Default::default()
            }
        )
        .unwrap_err()
        .to_string()
        .contains("no variable \"nope\""));
    }
}
