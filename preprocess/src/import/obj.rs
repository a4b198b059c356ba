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

/// Reads an OBJ file.
pub(crate) fn read(input: &mut Input) -> Result<RawMesh, K> {
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut colors: Vec<[u8; 4]> = Vec::new();
    let mut all_colored = true;
    let mut texcoords: Vec<[f32; 2]> = Vec::new();
    let mut normals: Vec<[f32; 3]> = Vec::new();
    // Per position: index into texcoords / normals from its first face corner.
    let mut vt_of: Vec<u32> = Vec::new();
    let mut vn_of: Vec<u32> = Vec::new();
    let mut all_vt = true;
    let mut all_vn = true;
    let mut triangles: Vec<[u32; 3]> = Vec::new();
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
                let v = resolve(v, positions.len(), line, "vertex")?;
                match vt {
                    Some(vt) => {
                        let vt = resolve(vt, texcoords.len(), line, "texture coordinate")?;
                        if vt_of[v as usize] == UNSET {
                            vt_of[v as usize] = vt;
                        }
                    }
                    None => all_vt = false,
                }
                match vn {
                    Some(vn) => {
                        let vn = resolve(vn, normals.len(), line, "normal")?;
                        if vn_of[v as usize] == UNSET {
                            vn_of[v as usize] = vn;
                        }
                    }
                    None => all_vn = false,
                }
                poly.push(v);
            }
            input.end_line(true)?;
            fan(&poly, &mut triangles);
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
                check_finite(p, positions.len() as u64, || Location::Line(line))?;
                positions.push(p);
                vt_of.push(UNSET);
                vn_of.push(UNSET);
                if n >= 6 {
                    let c = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
                    let a = if n == 7 { c(vals[6]) } else { 255 };
                    colors.push([c(vals[3]), c(vals[4]), c(vals[5]), a]);
                } else {
                    all_colored = false;
                }
            }
            Keyword::Vt => {
                if !(1..=3).contains(&n) {
                    return Err(count_err("texture coordinate", "1 to 3"));
                }
                texcoords.push([vals[0] as f32, if n > 1 { vals[1] as f32 } else { 0.0 }]);
            }
            Keyword::Vn => {
                if n != 3 {
                    return Err(count_err("normal", "3"));
                }
                normals.push([vals[0] as f32, vals[1] as f32, vals[2] as f32]);
            }
            Keyword::F | Keyword::Other => unreachable!(),
        }
    }

    let attr =
        |keep: bool, of: &[u32]| keep && !triangles.is_empty() && of.iter().any(|&i| i != UNSET);
    let uvs = attr(all_vt, &vt_of).then(|| {
        vt_of
            .iter()
            .map(|&i| {
                if i == UNSET {
                    [0.0; 2]
                } else {
                    texcoords[i as usize]
                }
            })
            .collect()
    });
    let normals = attr(all_vn, &vn_of).then(|| {
        vn_of
            .iter()
            .map(|&i| {
                if i == UNSET {
                    [0.0; 3]
                } else {
                    normals[i as usize]
                }
            })
            .collect()
    });
    Ok(RawMesh {
        colors: (all_colored && !positions.is_empty()).then_some(colors),
        positions,
        triangles,
        normals,
        uvs,
    })
}
