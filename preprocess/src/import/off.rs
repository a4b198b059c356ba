//! OFF reader (Geomview object file format, ASCII): `OFF` and its `C`/`N`/`ST` variants (vertex
//! colours, normals, texture coordinates), `#` comments; polygons are fan-triangulated. A
//! face's colour (three or four components after its indices) colours its corners as wedges
//! (`sink::FaceColored`; refused when staged out of core).

use super::error::{show, ImportErrorKind as K, Location};
use super::input::{check_finite, fan, parse_float, parse_int, Input};
use super::sink::{at, in_memory, Declared, FaceColored, MeshSink};
use super::RawMesh;

#[derive(Default, Clone, Copy)]
struct Flags {
    colors: bool,
    normals: bool,
    uvs: bool,
}

/// Parses a header keyword such as `OFF`, `COFF`, `NOFF`, `STCNOFF`.
fn keyword(tok: &[u8], line: u64) -> Result<Flags, K> {
    let bad = || K::Header {
        at: Location::Line(line),
        msg: format!("expected OFF header keyword, found '{}'", show(tok)),
    };
    let mut prefix = tok.strip_suffix(b"OFF").ok_or_else(bad)?;
    let mut flags = Flags::default();
    while !prefix.is_empty() {
        if let Some(rest) = prefix.strip_prefix(b"ST") {
            flags.uvs = true;
            prefix = rest;
            continue;
        }
        match prefix[0] {
            b'C' => flags.colors = true,
            b'N' => flags.normals = true,
            b'4' | b'n' => {
                return Err(K::Unsupported {
                    at: Location::Line(line),
                    what: format!(
                        "OFF variant '{}' (only 3D vertices are supported)",
                        show(tok)
                    ),
                })
            }
            _ => return Err(bad()),
        }
        prefix = &prefix[1..];
    }
    Ok(flags)
}

/// Collects the rest of the line's tokens (at most 8) into `out`.
fn rest_of_line(input: &mut Input, out: &mut Vec<Vec<u8>>, line: u64) -> Result<(), K> {
    while let Some(tok) = input.token(true)? {
        if tok.eq_ignore_ascii_case(b"BINARY") {
            return Err(K::Unsupported {
                at: Location::Line(line),
                what: "binary OFF".into(),
            });
        }
        if out.len() < 8 {
            out.push(tok.to_vec());
        }
    }
    input.end_line(true)?;
    Ok(())
}

fn truncated(expected: u64, what: &str, done: u64) -> K {
    K::Truncated {
        at: Location::None,
        msg: format!("data truncated: expected {expected} {what}, file ends after {done}"),
    }
}

/// Reads an OFF file into memory.
pub(crate) fn read(input: &mut Input) -> Result<RawMesh, K> {
    read_into(input, |d| Ok(FaceColored::new(in_memory(d)))).map(FaceColored::finish)
}

/// Reads an OFF file into the sink `make_sink` makes once the header is read.
pub(crate) fn read_into<S: MeshSink>(
    input: &mut Input,
    make_sink: impl FnOnce(&Declared) -> Result<S, K>,
) -> Result<S, K> {
    if !input.skip_blank(true)? {
        return Err(K::Header {
            at: Location::Line(input.line),
            msg: "empty file, expected 'OFF'".into(),
        });
    }
    let line = input.line;
    let first = input.token(true)?.unwrap_or_default().to_vec();
    let mut counts: Vec<Vec<u8>> = Vec::new();
    let flags = if parse_int(&first).is_some() {
        counts.push(first); // the keyword is optional
        Flags::default()
    } else {
        keyword(&first, line)?
    };
    rest_of_line(input, &mut counts, line)?;
    let mut counts_line = line;
    if counts.is_empty() {
        if !input.skip_blank(true)? {
            return Err(K::Header {
                at: Location::Line(input.line),
                msg: "file ends before the vertex and face counts".into(),
            });
        }
        counts_line = input.line;
        rest_of_line(input, &mut counts, counts_line)?;
    }
    let count = |i: usize, what: &str| -> Result<u64, K> {
        let tok = counts.get(i).ok_or_else(|| K::Header {
            at: Location::Line(counts_line),
            msg: format!("missing {what} count"),
        })?;
        parse_int(tok)
            .and_then(|v| u64::try_from(v).ok())
            .ok_or_else(|| K::Header {
                at: Location::Line(counts_line),
                msg: format!("invalid {what} count '{}'", show(tok)),
            })
    };
    let nv = count(0, "vertex")?;
    let nf = count(1, "face")?;
    if nv > u32::MAX as u64 {
        return Err(K::TooLarge {
            at: Location::Line(counts_line),
            msg: format!(
                "header declares {nv} vertices (at most {} supported)",
                u32::MAX
            ),
        });
    }

    let mut mesh = make_sink(&Declared {
        normals: flags.normals,
        colors: flags.colors,
        uvs: flags.uvs,
        vertex_capacity: input.prealloc(nv, false),
        face_capacity: input.prealloc(nf, false),
    })?;

    let simple = !(flags.colors || flags.normals || flags.uvs);
    let mut vals: Vec<f64> = Vec::new();
    let mut float_syntax: Vec<bool> = Vec::new();
    for i in 0..nv {
        if !input.skip_blank(true)? {
            return Err(truncated(nv, "vertices", i));
        }
        let line = input.line;
        let bad_number = |tok: &[u8]| K::Syntax {
            at: Location::Line(line),
            msg: format!("invalid number '{}' in vertex {i}", show(tok)),
        };
        if simple {
            let mut p = [0.0; 3];
            for (c, slot) in p.iter_mut().enumerate() {
                let Some(tok) = input.token(true)? else {
                    if input.at_end()? {
                        return Err(truncated(nv, "vertices", i));
                    }
                    return Err(K::Syntax {
                        at: Location::Line(line),
                        msg: format!("vertex {i} has {c} coordinates, expected 3"),
                    });
                };
                *slot = parse_float(tok).ok_or_else(|| bad_number(tok))?;
            }
            if !input.end_line(true)? {
                input.skip_line()?; // extra values (4th coordinate, colours) are ignored
            }
            check_finite(p, i, || Location::Line(line))?;
            mesh.vertex(&at(p))?;
            continue;
        }
        vals.clear();
        float_syntax.clear();
        while let Some(tok) = input.token(true)? {
            vals.push(parse_float(tok).ok_or_else(|| bad_number(tok))?);
            float_syntax.push(tok.iter().any(|c| matches!(c, b'.' | b'e' | b'E')));
        }
        input.end_line(true)?;
        let base = 3 + if flags.normals { 3 } else { 0 } + if flags.uvs { 2 } else { 0 };
        let ncolor = vals.len().saturating_sub(base);
        let ok = if flags.colors {
            vals.len() >= base && (ncolor == 3 || ncolor == 4)
        } else {
            vals.len() >= base
        };
        if !ok {
            return Err(K::Syntax {
                at: Location::Line(line),
                msg: format!(
                    "vertex {i} has {} values, expected {}{}",
                    vals.len(),
                    base,
                    if flags.colors {
                        " plus 3 or 4 colour components"
                    } else {
                        ""
                    }
                ),
            });
        }
        let p = [vals[0], vals[1], vals[2]];
        check_finite(p, i, || Location::Line(line))?;
        let mut vertex = at(p);
        let mut at = 3;
        if flags.normals {
            vertex.normal = [vals[at] as f32, vals[at + 1] as f32, vals[at + 2] as f32];
            at += 3;
        }
        if flags.colors {
            let float = float_syntax[at..at + ncolor].iter().any(|&f| f);
            let mut rgba = [255u8; 4];
            for (k, v) in vals[at..at + ncolor].iter().enumerate() {
                rgba[k] = if float {
                    (v.clamp(0.0, 1.0) * 255.0).round() as u8
                } else {
                    v.clamp(0.0, 255.0) as u8
                };
            }
            vertex.color = rgba;
            at += ncolor;
        }
        if flags.uvs {
            vertex.uv = [vals[at] as f32, vals[at + 1] as f32];
        }
        mesh.vertex(&vertex)?;
    }

    let mut poly: Vec<u32> = Vec::new();
    let mut fanned: Vec<[u32; 3]> = Vec::new();
    for f in 0..nf {
        if !input.skip_blank(true)? {
            return Err(truncated(nf, "faces", f));
        }
        let line = input.line;
        let tok = input.token(true)?.unwrap_or_default();
        let n = parse_int(tok)
            .and_then(|n| u64::try_from(n).ok())
            .ok_or_else(|| K::Syntax {
                at: Location::Line(line),
                msg: format!("invalid vertex count '{}' for face {f}", show(tok)),
            })?;
        poly.clear();
        for j in 0..n {
            let Some(tok) = input.token(true)? else {
                if input.at_end()? {
                    return Err(truncated(nf, "faces", f));
                }
                return Err(K::Syntax {
                    at: Location::Line(line),
                    msg: format!("face {f} has {n} vertices but only {j} indices"),
                });
            };
            let v = parse_int(tok).ok_or_else(|| K::Syntax {
                at: Location::Line(line),
                msg: format!("invalid vertex index '{}' in face {f}", show(tok)),
            })?;
            if v < 0 || v as u64 >= nv {
                return Err(K::IndexOutOfRange {
                    at: Location::Line(line),
                    index: v,
                    count: nv,
                });
            }
            poly.push(v as u32);
        }
        fanned.clear();
        fan(&poly, &mut fanned);
        mesh.triangles(&fanned)?;
        if !input.end_line(true)? {
            // A face colour: three or four components (integers 0–255, or reals 0–1); one
            // value (a colour map index) or anything else is ignored.
            let mut c = [0.0f64; 5];
            let mut count = 0;
            let mut float = false;
            while let Some(tok) = input.token(true)? {
                if count < c.len() {
                    float |= tok.iter().any(|&b| b == b'.' || b == b'e' || b == b'E');
                    c[count] = parse_float(tok).unwrap_or(f64::NAN);
                }
                count += 1;
            }
            input.skip_line()?;
            if (count == 3 || count == 4) && c[..count].iter().all(|x| x.is_finite()) {
                let channel = |x: f64| match float {
                    true => (x.clamp(0.0, 1.0) * 255.0).round() as u8,
                    false => x.clamp(0.0, 255.0) as u8,
                };
                let alpha = if count == 4 { channel(c[3]) } else { 255 };
                let color = [channel(c[0]), channel(c[1]), channel(c[2]), alpha];
                if !fanned.is_empty() {
                    mesh.face_color(fanned.len(), color)?;
                }
            }
        }
    }
    Ok(mesh)
}
