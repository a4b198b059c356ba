//! Wavefront OBJ reader: `v` (with optional `r g b` vertex colours), `vt`, `vn` and `f`
//! (`v`, `v/vt`, `v//vn`, `v/vt/vn`, negative relative indices), all groups and objects merged
//! into one mesh; polygons fan-triangulated. Other statements (`o`, `g`, `s`, `usemtl`, `mtllib`,
//! `l`, `p`, ...) are ignored.
//!
//! A vertex takes its texture coordinate and normal from the first face corner that uses it
//! (OBJ indexes them separately); they are kept only if every face corner has them, colours
//! only if every `v` has them.

use super::error::{show, ImportErrorKind as K, Location};
use super::input::{check_finite, fan, parse_float, parse_int, Input};
use super::sink::{at, MeshSink};
use super::RawMesh;

enum Keyword {
    V,
    Vt,
    Vn,
    F,
    Other,
}

const UNSET: u32 = u32::MAX;

/// Resolves a 1-based (or negative, relative) OBJ index against `count` items.
fn resolve(raw: i64, count: usize, line: u64, what: &str) -> Result<u32, K> {
    let index = if raw > 0 { raw - 1 } else { count as i64 + raw };
    if raw == 0 {
        return Err(K::Syntax {
            at: Location::Line(line),
            msg: format!("{what} index 0 is invalid (OBJ indices start at 1)"),
        });
    }
    if index < 0 || index as usize >= count {
        if what == "vertex" {
            return Err(K::IndexOutOfRange {
                at: Location::Line(line),
                index: raw,
                count: count as u64,
            });
        }
        return Err(K::Syntax {
            at: Location::Line(line),
            msg: format!("{what} index {raw} out of range ({count} defined)"),
        });
    }
    Ok(index as u32)
}

/// Reads an OBJ file into memory.
pub(crate) fn read(input: &mut Input) -> Result<RawMesh, K> {
    let in_memory = |colors: bool| {
        Ok(RawMesh {
            colors: colors.then(Vec::new),
            ..Default::default()
        })
    };
    let (mut mesh, corners) =
        read_into(input, in_memory, true)?.expect("face attributes are tracked");
    let corners = corners.expect("face attributes are tracked");
    let attr = |keep: bool, of: &[u32]| {
        keep && !mesh.triangles.is_empty() && of.iter().any(|&i| i != UNSET)
    };
    mesh.uvs = attr(corners.all_vt, &corners.vt_of).then(|| {
        corners
            .vt_of
            .iter()
            .map(|&i| {
                if i == UNSET {
                    [0.0; 2]
                } else {
                    corners.texcoords[i as usize]
                }
            })
            .collect()
    });
    mesh.normals = attr(corners.all_vn, &corners.vn_of).then(|| {
        corners
            .vn_of
            .iter()
            .map(|&i| {
                if i == UNSET {
                    [0.0; 3]
                } else {
                    corners.normals[i as usize]
                }
            })
            .collect()
    });
    Ok(mesh)
}

/// The texture coordinates and normals an OBJ's face corners give its vertices, tracked by
/// the in-memory read (a `u32` a vertex each, and the `vt` and `vn` values).
#[derive(Default)]
pub(crate) struct CornerAttributes {
    texcoords: Vec<[f32; 2]>,
    normals: Vec<[f32; 3]>,
    /// Per vertex: index into texcoords / normals from its first face corner.
    vt_of: Vec<u32>,
    vn_of: Vec<u32>,
    all_vt: bool,
    all_vn: bool,
}

/// Reads an OBJ file into the sink `make_sink(colors)` makes at the first vertex (`colors`:
/// whether it has a colour; the sink is told to forget them if a later vertex has none).
/// With `track_corners` the face corners' texture coordinates and normals are tracked (in
/// memory) and returned; without, a face corner that has one stops the read: `Ok(None)`
/// (the out-of-core import then reads the file whole, as attributes are resolved by index).
pub(crate) fn read_into<S: MeshSink>(
    input: &mut Input,
    make_sink: impl FnOnce(bool) -> Result<S, K>,
    track_corners: bool,
) -> Result<Option<(S, Option<CornerAttributes>)>, K> {
    let mut make_sink = Some(make_sink);
    let mut sink: Option<S> = None;
    let mut vertices: u64 = 0;
    let mut all_colored = true;
    let mut corners = track_corners.then(|| CornerAttributes {
        all_vt: true,
        all_vn: true,
        ..Default::default()
    });
    // `vt` and `vn` statements seen (their values are kept only when tracked).
    let (mut texcoord_count, mut normal_count) = (0usize, 0usize);
    let mut fanned: Vec<[u32; 3]> = Vec::new();
    let mut poly: Vec<u32> = Vec::new();
    let mut vals = [0.0f64; 8];

    while input.skip_blank(true)? {
        let line = input.line;
        let keyword = match input.token(true)? {
            Some(b"v") => Keyword::V,
            Some(b"vt") => Keyword::Vt,
            Some(b"vn") => Keyword::Vn,
            Some(b"f") => Keyword::F,
            _ => Keyword::Other,
        };
        if let Keyword::Other = keyword {
            input.skip_line()?;
            continue;
        }
        if let Keyword::F = keyword {
            poly.clear();
            while let Some(tok) = input.token(true)? {
                let mut parts = tok.split(|&c| c == b'/');
                let index = |part: Option<&[u8]>| -> Result<Option<i64>, K> {
                    match part {
                        None | Some(b"") => Ok(None),
                        Some(p) => parse_int(p).map(Some).ok_or_else(|| K::Syntax {
                            at: Location::Line(line),
                            msg: format!("invalid face vertex '{}'", show(tok)),
                        }),
                    }
                };
                let v = index(parts.next())?;
                let vt = index(parts.next())?;
                let vn = index(parts.next())?;
                let Some(v) = v else {
                    return Err(K::Syntax {
                        at: Location::Line(line),
                        msg: format!("invalid face vertex '{}'", show(tok)),
                    });
                };
                let v = resolve(v, vertices as usize, line, "vertex")?;
                let Some(corners) = corners.as_mut() else {
                    if vt.is_some() || vn.is_some() {
                        return Ok(None);
                    }
                    poly.push(v);
                    continue;
                };
                match vt {
                    Some(vt) => {
                        let vt = resolve(vt, texcoord_count, line, "texture coordinate")?;
                        if corners.vt_of[v as usize] == UNSET {
                            corners.vt_of[v as usize] = vt;
                        }
                    }
                    None => corners.all_vt = false,
                }
                match vn {
                    Some(vn) => {
                        let vn = resolve(vn, normal_count, line, "normal")?;
                        if corners.vn_of[v as usize] == UNSET {
                            corners.vn_of[v as usize] = vn;
                        }
                    }
                    None => corners.all_vn = false,
                }
                poly.push(v);
            }
            input.end_line(true)?;
            fanned.clear();
            fan(&poly, &mut fanned);
            if !fanned.is_empty() {
                // A face comes after a vertex it uses, so the sink exists.
                sink.as_mut()
                    .expect("a face after its vertices")
                    .triangles(&fanned)?;
            }
            continue;
        }

        let mut n = 0;
        while let Some(tok) = input.token(true)? {
            if n == vals.len() {
                return Err(K::Syntax {
                    at: Location::Line(line),
                    msg: "too many values".into(),
                });
            }
            vals[n] = parse_float(tok).ok_or_else(|| K::Syntax {
                at: Location::Line(line),
                msg: format!("invalid number '{}'", show(tok)),
            })?;
            n += 1;
        }
        input.end_line(true)?;
        let count_err = |what: &str, expected: &str| K::Syntax {
            at: Location::Line(line),
            msg: format!("{what} with {n} values, expected {expected}"),
        };
        match keyword {
            Keyword::V => {
                if !(3..=7).contains(&n) {
                    return Err(count_err(
                        "vertex",
                        "3, 4 (x y z w) or 6, 7 (x y z r g b [a])",
                    ));
                }
                let p = [vals[0], vals[1], vals[2]];
                check_finite(p, vertices, || Location::Line(line))?;
                if vertices > u32::MAX as u64 {
                    return Err(K::TooLarge {
                        at: Location::Line(line),
                        msg: format!("more than {} vertices", u32::MAX as u64 + 1),
                    });
                }
                let mut vertex = at(p);
                if n >= 6 {
                    let c = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
                    let a = if n == 7 { c(vals[6]) } else { 255 };
                    vertex.color = [c(vals[3]), c(vals[4]), c(vals[5]), a];
                } else if all_colored {
                    all_colored = false;
                    if let Some(sink) = sink.as_mut() {
                        sink.forget_colors();
                    }
                }
                if let Some(make) = make_sink.take() {
                    sink = Some(make(all_colored)?);
                }
                sink.as_mut().expect("made above").vertex(&vertex)?;
                vertices += 1;
                if let Some(corners) = corners.as_mut() {
                    corners.vt_of.push(UNSET);
                    corners.vn_of.push(UNSET);
                }
            }
            Keyword::Vt => {
                if !(1..=3).contains(&n) {
                    return Err(count_err("texture coordinate", "1 to 3"));
                }
                texcoord_count += 1;
                if let Some(corners) = corners.as_mut() {
                    let uv = [vals[0] as f32, if n > 1 { vals[1] as f32 } else { 0.0 }];
                    corners.texcoords.push(uv);
                }
            }
            Keyword::Vn => {
                if n != 3 {
                    return Err(count_err("normal", "3"));
                }
                normal_count += 1;
                if let Some(corners) = corners.as_mut() {
                    corners
                        .normals
                        .push([vals[0] as f32, vals[1] as f32, vals[2] as f32]);
                }
            }
            Keyword::F | Keyword::Other => unreachable!(),
        }
    }
    let sink = match (sink, make_sink) {
        (Some(sink), _) => sink,
        // No vertex at all: an empty mesh.
        (None, Some(make)) => make(false)?,
        (None, None) => unreachable!("the sink is made when taken"),
    };
    Ok(Some((sink, corners)))
}
