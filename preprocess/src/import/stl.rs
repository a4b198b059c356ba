//! STL reader, ASCII and binary. Facet normals are ignored (the mesh gets no normals); every
//! facet brings three vertices of its own, which welding merges. A binary facet's attribute
//! bytes carry its colour in two conventions, read as face colours (the facet's corners become
//! wedges of that colour, `sink::FaceColored`; refused when staged out of core):
//!
//! - Materialise Magics, when the header holds `COLOR=` and four bytes R, G, B, A (the
//!   object's colour): bit 15 clear, the facet's own colour, red in bits 0-4, green 5-9, blue
//!   10-14; bit 15 set, the object's colour;
//! - VisCAM / SolidView otherwise: bit 15 set, the facet's colour, blue in bits 0-4, green
//!   5-9, red 10-14; bit 15 clear, no colour (the usual zero attribute).

use super::error::{show, ImportErrorKind as K, Location};
use super::input::{check_finite, parse_float, Input};
use super::sink::{at, in_memory, Declared, FaceColored, MeshSink};
use super::RawMesh;

/// Reads an STL file into memory, telling ASCII from binary by content.
pub(crate) fn read(input: &mut Input) -> Result<RawMesh, K> {
    read_into(input, |d| Ok(FaceColored::new(in_memory(d)))).map(FaceColored::finish)
}

/// The colour a binary facet's attribute bytes give it, if any (module comment): `object` is
/// the Materialise header's colour, when the header has one.
fn facet_color(attribute: u16, object: Option<[u8; 4]>) -> Option<[u8; 4]> {
    let five = |shift: u16| {
        let v = ((attribute >> shift) & 31) as u8;
        (v << 3) | (v >> 2)
    };
    let flag = attribute & 0x8000 != 0;
    match object {
        Some(object) if flag => Some(object),
        Some(_) => Some([five(0), five(5), five(10), 255]),
        None if flag => Some([five(10), five(5), five(0), 255]),
        None => None,
    }
}

/// The Materialise object colour in a binary header: `COLOR=` and the four bytes after it.
fn header_color(header: &[u8]) -> Option<[u8; 4]> {
    let at = header[..80].windows(6).position(|w| w == b"COLOR=")? + 6;
    header.get(at..at + 4).map(|c| [c[0], c[1], c[2], c[3]])
}

/// Reads an STL file into the sink `make_sink` makes (told the expected size where the file
/// declares it), telling ASCII from binary by content.
pub(crate) fn read_into<S: MeshSink>(
    input: &mut Input,
    make_sink: impl FnOnce(&Declared) -> Result<S, K>,
) -> Result<S, K> {
    if is_ascii(input)? {
        read_ascii(input, make_sink(&no_attributes(0))?)
    } else {
        read_binary(input, make_sink)
    }
}

fn no_attributes(triangles: usize) -> Declared {
    Declared {
        normals: false,
        colors: false,
        uvs: false,
        vertex_capacity: 3 * triangles,
        face_capacity: triangles,
    }
}

/// ASCII files start with `solid`; so do some binary ones, whose 80-byte header is free text.
/// A binary file whose size matches its triangle count is binary; otherwise the file is ASCII
/// if `solid ...` is followed by `facet` or `endsolid`.
fn is_ascii(input: &mut Input) -> Result<bool, K> {
    let size = input.remaining();
    let head = input.peek(1024)?;
    let text = head.trim_ascii_start();
    if text.len() < 5 || !text[..5].eq_ignore_ascii_case(b"solid") {
        return Ok(false);
    }
    if let (Some(size), true) = (size, head.len() >= 84) {
        let count = u32::from_le_bytes(head[80..84].try_into().unwrap()) as u64;
        if 84 + 50 * count == size {
            return Ok(false);
        }
    }
    let Some(newline) = text.iter().position(|&c| c == b'\n') else {
        return Ok(head.is_ascii()); // "solid name" and nothing else: an empty ASCII file
    };
    let rest = text[newline..].trim_ascii_start();
    let word = rest
        .split(|c| c.is_ascii_whitespace())
        .next()
        .unwrap_or_default();
    Ok(word.eq_ignore_ascii_case(b"facet")
        || word.eq_ignore_ascii_case(b"endsolid")
        || rest.is_empty())
}

fn read_binary<S: MeshSink>(
    input: &mut Input,
    make_sink: impl FnOnce(&Declared) -> Result<S, K>,
) -> Result<S, K> {
    let size = input.remaining();
    let Some(header) = input.bytes(84)? else {
        return Err(K::Truncated {
            at: Location::None,
            msg: format!(
                "binary STL truncated: file is shorter than the 84-byte header{}",
                match size {
                    Some(s) => format!(" ({s} bytes)"),
                    None => String::new(),
                }
            ),
        });
    };
    let count = u32::from_le_bytes(header[80..84].try_into().unwrap()) as u64;
    let bounded = if let Some(size) = size {
        let need = 84 + 50 * count;
        if size < need {
            return Err(K::Truncated {
                at: Location::None,
                msg: format!(
                    "binary data truncated: header declares {count} triangles ({need} bytes), but the file has \
                     only {size} bytes"
                ),
            });
        }
        true
    } else {
        false
    };
    if 3 * count > u32::MAX as u64 {
        return Err(K::TooLarge {
            at: Location::None,
            msg: format!(
                "header declares {count} triangles (at most {} supported)",
                u32::MAX / 3
            ),
        });
    }
    let object = header_color(header);
    let mut mesh = make_sink(&no_attributes(input.prealloc(count, bounded)))?;
    for t in 0..count {
        let Some(rec) = input.bytes(50)? else {
            return Err(K::Truncated {
                at: Location::None,
                msg: format!(
                    "binary data truncated: expected {count} triangles, file ends after {t}"
                ),
            });
        };
        let f =
            |k: usize| f32::from_le_bytes(rec[12 + 4 * k..16 + 4 * k].try_into().unwrap()) as f64;
        // Facet t's corners are vertices 3t, 3t + 1, 3t + 2 (3t fits: the count was checked).
        let base = 3 * t as u32;
        for c in 0..3 {
            let p = [f(3 * c), f(3 * c + 1), f(3 * c + 2)];
            check_finite(p, (base + c as u32) as u64, || {
                Location::Record("triangle".into(), t)
            })?;
            mesh.vertex(&at(p))?;
        }
        mesh.triangles(&[[base, base + 1, base + 2]])?;
        if let Some(color) = facet_color(u16::from_le_bytes([rec[48], rec[49]]), object) {
            mesh.face_color(1, color)?;
        }
    }
    Ok(mesh)
}

/// The next word (across lines), or None at the end of the input.
fn word(input: &mut Input) -> Result<Option<(Vec<u8>, u64)>, K> {
    if !input.skip_blank(false)? {
        return Ok(None);
    }
    let line = input.line;
    Ok(input.token(false)?.map(|t| (t.to_vec(), line)))
}

fn expect(input: &mut Input, keyword: &str) -> Result<u64, K> {
    match word(input)? {
        Some((w, line)) if w.eq_ignore_ascii_case(keyword.as_bytes()) => Ok(line),
        Some((w, line)) => Err(K::Syntax {
            at: Location::Line(line),
            msg: format!("expected '{keyword}', found '{}'", show(&w)),
        }),
        None => Err(eof(keyword)),
    }
}

fn eof(keyword: &str) -> K {
    K::Truncated {
        at: Location::None,
        msg: format!("ASCII STL truncated: file ends where '{keyword}' was expected"),
    }
}

fn number(input: &mut Input) -> Result<f64, K> {
    match word(input)? {
        Some((w, line)) => parse_float(&w).ok_or_else(|| K::Syntax {
            at: Location::Line(line),
            msg: format!("invalid number '{}'", show(&w)),
        }),
        None => Err(eof("a number")),
    }
}

fn read_ascii<S: MeshSink>(input: &mut Input, mut mesh: S) -> Result<S, K> {
    expect(input, "solid")?;
    input.skip_line()?; // solid name
    let mut corners: Vec<u32> = Vec::new();
    let mut fanned: Vec<[u32; 3]> = Vec::new();
    let mut vertices: u64 = 0;
    loop {
        let Some((w, line)) = word(input)? else {
            return Ok(mesh); // tolerate a missing endsolid
        };
        if w.eq_ignore_ascii_case(b"endsolid") {
            input.skip_line()?;
            match word(input)? {
                None => return Ok(mesh),
                Some((w, _)) if w.eq_ignore_ascii_case(b"solid") => {
                    input.skip_line()?;
                    continue;
                }
                Some((w, line)) => {
                    return Err(K::Syntax {
                        at: Location::Line(line),
                        msg: format!(
                            "expected 'solid' or end of file after 'endsolid', found '{}'",
                            show(&w)
                        ),
                    })
                }
            }
        }
        if !w.eq_ignore_ascii_case(b"facet") {
            return Err(K::Syntax {
                at: Location::Line(line),
                msg: format!("expected 'facet' or 'endsolid', found '{}'", show(&w)),
            });
        }
        expect(input, "normal")?;
        for _ in 0..3 {
            number(input)?;
        }
        expect(input, "outer")?;
        expect(input, "loop")?;
        corners.clear();
        loop {
            match word(input)? {
                Some((w, line)) if w.eq_ignore_ascii_case(b"vertex") => {
                    let p = [number(input)?, number(input)?, number(input)?];
                    check_finite(p, vertices, || Location::Line(line))?;
                    if vertices > u32::MAX as u64 {
                        return Err(K::TooLarge {
                            at: Location::Line(line),
                            msg: format!("more than {} vertices", u32::MAX as u64 + 1),
                        });
                    }
                    corners.push(vertices as u32);
                    mesh.vertex(&at(p))?;
                    vertices += 1;
                }
                Some((w, _)) if w.eq_ignore_ascii_case(b"endloop") => break,
                Some((w, line)) => {
                    return Err(K::Syntax {
                        at: Location::Line(line),
                        msg: format!("expected 'vertex' or 'endloop', found '{}'", show(&w)),
                    })
                }
                None => return Err(eof("endloop")),
            }
        }
        if corners.len() < 3 {
            return Err(K::Syntax {
                at: Location::Line(line),
                msg: format!("facet has {} vertices, expected at least 3", corners.len()),
            });
        }
        fanned.clear();
        super::input::fan(&corners, &mut fanned);
        mesh.triangles(&fanned)?;
        expect(input, "endfacet")?;
    }
}
