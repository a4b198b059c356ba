//! Streaming PLY reader: ASCII, binary little- and big-endian. Reads `vertex` (x, y, z; optional
//! normals, colours, texture coordinates), `face` (list `vertex_indices`/`vertex_index`,
//! fan-triangulated, with an optional face colour: `red`, `green`, `blue` [`alpha`], whose
//! corners become wedges of that colour, `sink::FaceColored`; refused when staged out of core)
//! and `tristrips` (list `vertex_indices`, -1 restarts); skips every other property and
//! element.

use super::error::{show, ImportErrorKind as K, Location};
use super::input::{check_finite, fan, parse_int, Input};
use super::ply_header::{header_err, parse_header, Element, Format, Prop, PropType, Scalar};
use super::sink::{Declared, MeshSink};
use super::RawMesh;
use crate::external::RawVertex;

/// What a vertex property feeds.
#[derive(Clone, Copy, Debug)]
enum Slot {
    Skip,
    Pos(usize),
    Normal(usize),
    Color(usize, Scalar),
    Uv(usize),
}

const EMPTY_REC: RawVertex = RawVertex {
    position: [0.0; 3],
    normal: [0.0; 3],
    color: [0, 0, 0, 255],
    uv: [0.0; 2],
};

struct VertexLayout {
    slots: Vec<Slot>,
    normals: bool,
    colors: bool,
    uvs: bool,
}

impl VertexLayout {
    fn new(el: &Element) -> Result<Self, K> {
        let mut slots = vec![Slot::Skip; el.props.len()];
        let mut found = [false; 12]; // pos 0..3, normal 3..6, color 6..10, uv 10..12
        for (k, prop) in el.props.iter().enumerate() {
            let (index, slot) = match prop.name.as_str() {
                "x" => (0, Slot::Pos(0)),
                "y" => (1, Slot::Pos(1)),
                "z" => (2, Slot::Pos(2)),
                "nx" | "normal_x" => (3, Slot::Normal(0)),
                "ny" | "normal_y" => (4, Slot::Normal(1)),
                "nz" | "normal_z" => (5, Slot::Normal(2)),
                "red" | "diffuse_red" => (6, Slot::Color(0, Scalar::U8)),
                "green" | "diffuse_green" => (7, Slot::Color(1, Scalar::U8)),
                "blue" | "diffuse_blue" => (8, Slot::Color(2, Scalar::U8)),
                "alpha" | "diffuse_alpha" => (9, Slot::Color(3, Scalar::U8)),
                "u" | "s" | "texture_u" | "texture_s" => (10, Slot::Uv(0)),
                "v" | "t" | "texture_v" | "texture_t" => (11, Slot::Uv(1)),
                _ => continue,
            };
            if found[index] {
                continue; // first of several aliases wins
            }
            let PropType::Scalar(ty) = prop.ty else {
                return Err(K::Unsupported {
                    at: Location::Line(prop.line),
                    what: format!("list type for vertex property '{}'", prop.name),
                });
            };
            found[index] = true;
            slots[k] = match slot {
                Slot::Color(c, _) => Slot::Color(c, ty),
                s => s,
            };
        }
        if !(found[0] && found[1] && found[2]) {
            return Err(header_err(el.line, "vertex element lacks x, y or z"));
        }
        Ok(VertexLayout {
            slots,
            normals: found[3] && found[4] && found[5],
            colors: found[6] && found[7] && found[8],
            uvs: found[10] && found[11],
        })
    }

    #[inline]
    fn apply(&self, k: usize, v: f64, rec: &mut RawVertex) {
        match self.slots[k] {
            Slot::Skip => {}
            Slot::Pos(i) => rec.position[i] = v,
            Slot::Normal(i) => rec.normal[i] = v as f32,
            Slot::Color(i, ty) => {
                rec.color[i] = if ty.is_int() {
                    v.clamp(0.0, 255.0) as u8
                } else {
                    (v.clamp(0.0, 1.0) * 255.0).round() as u8
                }
            }
            Slot::Uv(i) => rec.uv[i] = v as f32,
        }
    }
}

/// How a face-like element is read.
#[derive(Clone, Copy, PartialEq, Eq)]
enum FaceKind {
    Polygons,
    Strips,
}

/// Reads a PLY file into memory; the texture file its header names (`comment TextureFile`)
/// when its vertices have texture coordinates.
pub(crate) fn read(input: &mut Input) -> Result<(RawMesh, Option<String>), K> {
    read_into(input, |d| {
        Ok(super::sink::FaceColored::new(super::sink::in_memory(d)))
    })
    .map(|(mesh, texture)| (mesh.finish(), texture))
}

/// Reads a PLY file into the sink `make_sink` makes once the header is read; the texture
/// file its header names (`comment TextureFile`) when its vertices have texture coordinates.
pub(crate) fn read_into<S: MeshSink>(
    input: &mut Input,
    make_sink: impl FnOnce(&Declared) -> Result<S, K>,
) -> Result<(S, Option<String>), K> {
    let (format, elements, texture_file) = parse_header(input)?;

    let mut vertex_el = None;
    for (i, el) in elements.iter().enumerate() {
        if el.name == "vertex" {
            if vertex_el.is_some() {
                return Err(header_err(el.line, "more than one vertex element"));
            }
            vertex_el = Some(i);
        }
    }
    let vertex_el = vertex_el.ok_or_else(|| header_err(1, "no vertex element"))?;
    let nv = elements[vertex_el].count;
    if nv > u32::MAX as u64 {
        return Err(K::TooLarge {
            at: Location::Line(elements[vertex_el].line),
            msg: format!(
                "header declares {nv} vertices (at most {} supported)",
                u32::MAX
            ),
        });
    }
    let layout = VertexLayout::new(&elements[vertex_el])?;

    // Face-like elements and their index list property.
    let mut face_prop = vec![None; elements.len()];
    for (i, el) in elements.iter().enumerate() {
        let kind = match el.name.as_str() {
            "face" => FaceKind::Polygons,
            "tristrips" => FaceKind::Strips,
            _ => continue,
        };
        let k = el
            .props
            .iter()
            .position(|p| {
                matches!(p.ty, PropType::List { .. })
                    && (p.name == "vertex_indices" || p.name == "vertex_index")
            })
            .ok_or_else(|| {
                header_err(
                    el.line,
                    format!("{} element has no vertex_indices list", el.name),
                )
            })?;
        if let PropType::List { item, .. } = el.props[k].ty {
            if !item.is_int() {
                return Err(K::Unsupported {
                    at: Location::Line(el.props[k].line),
                    what: format!("vertex index type '{}'", item.name()),
                });
            }
        }
        face_prop[i] = Some((k, kind));
    }

    // An uncompressed binary file bounds every count by its size: check before allocating.
    let binary = format != Format::Ascii;
    let bounded = match (binary, input.remaining()) {
        (true, Some(rem)) => {
            let need: u128 = elements
                .iter()
                .map(|e| e.count as u128 * e.min_record_size())
                .sum();
            if need > rem as u128 {
                let declared: Vec<String> = elements
                    .iter()
                    .map(|e| format!("{} {}", e.count, e.plural()))
                    .collect();
                return Err(K::Truncated {
                    at: Location::None,
                    msg: format!(
                        "binary data truncated: header declares {} (at least {need} bytes), but only {rem} bytes \
                         follow the header",
                        declared.join(", ")
                    ),
                });
            }
            true
        }
        _ => false,
    };

    // Saturating: an ASCII header may declare counts whose sum overflows (the records are
    // then missing, and reading them says so).
    let face_count: u64 = elements
        .iter()
        .zip(&face_prop)
        .filter(|(_, f)| f.is_some())
        .fold(0, |sum, (e, _)| sum.saturating_add(e.count));
    let mut mesh = make_sink(&Declared {
        normals: layout.normals,
        colors: layout.colors,
        uvs: layout.uvs,
        vertex_capacity: input.prealloc(nv, bounded),
        face_capacity: input.prealloc(face_count, bounded),
    })?;

    let big = format == Format::BinaryBe;
    for (i, el) in elements.iter().enumerate() {
        let mut reader = Reader {
            input: &mut *input,
            el,
            binary,
            big,
        };
        if i == vertex_el {
            reader.vertices(&layout, &mut mesh)?;
        } else if let Some((k, kind)) = face_prop[i] {
            reader.faces(k, kind, nv, &mut mesh)?;
        } else {
            reader.skip()?;
        }
    }
    Ok((mesh, texture_file.filter(|_| layout.uvs)))
}

/// Reads the records of one element.
struct Reader<'a> {
    input: &'a mut Input,
    el: &'a Element,
    binary: bool,
    big: bool,
}

impl Reader<'_> {
    fn truncated(&self, done: u64) -> K {
        K::Truncated {
            at: Location::None,
            msg: format!(
                "{}data truncated: expected {} {}, file ends after {done}",
                if self.binary { "binary " } else { "" },
                self.el.count,
                self.el.plural()
            ),
        }
    }

    /// ASCII: moves to the next record; error at the end of the input.
    fn start_record(&mut self, index: u64) -> Result<u64, K> {
        if self.binary {
            return Ok(0);
        }
        if !self.input.skip_blank(false)? {
            return Err(self.truncated(index));
        }
        Ok(self.input.line)
    }

    /// ASCII: the record must end here.
    fn end_record(&mut self, line: u64) -> Result<(), K> {
        if self.binary || self.input.end_line(false)? {
            return Ok(());
        }
        Err(K::Syntax {
            at: Location::Line(line),
            msg: format!(
                "too many values for one {} record ({} properties declared)",
                self.el.name,
                self.el.props.len()
            ),
        })
    }

    /// One scalar value of record `index` (started on `line` in ASCII).
    #[inline]
    fn value(&mut self, t: Scalar, index: u64, line: u64, prop: &Prop) -> Result<f64, K> {
        if self.binary {
            let big = self.big;
            match self.input.bytes(t.size())? {
                Some(b) => Ok(t.decode(b, big)),
                None => Err(self.truncated(index)),
            }
        } else {
            match self.input.token(false)? {
                Some(tok) => t.parse_ascii(tok).ok_or_else(|| K::Syntax {
                    at: Location::Line(line),
                    msg: format!(
                        "invalid {} value '{}' for property '{}'",
                        t.name(),
                        show(tok),
                        prop.name
                    ),
                }),
                None => Err(self.missing(index, line, prop)?),
            }
        }
    }

    /// ASCII: the error for a value missing from record `index`.
    #[cold]
    fn missing(&mut self, index: u64, line: u64, prop: &Prop) -> Result<K, K> {
        Ok(if self.input.at_end()? {
            self.truncated(index)
        } else {
            K::Syntax {
                at: Location::Line(line),
                msg: format!(
                    "missing value for property '{}' of {} {index}",
                    prop.name, self.el.name
                ),
            }
        })
    }

    /// A list length.
    #[inline]
    fn list_len(&mut self, t: Scalar, index: u64, line: u64, prop: &Prop) -> Result<u64, K> {
        let n = self.value(t, index, line, prop)?;
        if n < 0.0 {
            let at = if self.binary {
                Location::Record(self.el.name.clone(), index)
            } else {
                Location::Line(line)
            };
            return Err(K::Syntax {
                at,
                msg: format!("negative list length {n} for property '{}'", prop.name),
            });
        }
        Ok(n as u64)
    }

    /// Skips a property value (scalar or whole list).
    fn skip_prop(&mut self, prop: &Prop, index: u64, line: u64) -> Result<(), K> {
        match prop.ty {
            PropType::Scalar(t) => {
                self.value(t, index, line, prop)?;
            }
            PropType::List { count, item } => {
                let n = self.list_len(count, index, line, prop)?;
                if self.binary {
                    if !self
                        .input
                        .skip_bytes(n.saturating_mul(item.size() as u64))?
                    {
                        return Err(self.truncated(index));
                    }
                } else {
                    for _ in 0..n {
                        self.value(item, index, line, prop)?;
                    }
                }
            }
        }
        Ok(())
    }

    fn vertices(&mut self, layout: &VertexLayout, mesh: &mut impl MeshSink) -> Result<(), K> {
        let el = self.el;
        for i in 0..el.count {
            let line = self.start_record(i)?;
            let mut rec = EMPTY_REC;
            for (k, prop) in el.props.iter().enumerate() {
                match prop.ty {
                    PropType::Scalar(t) => {
                        let v = self.value(t, i, line, prop)?;
                        layout.apply(k, v, &mut rec);
                    }
                    PropType::List { .. } => self.skip_prop(prop, i, line)?,
                }
            }
            self.end_record(line)?;
            let binary = self.binary;
            check_finite(rec.position, i, || {
                if binary {
                    Location::None
                } else {
                    Location::Line(line)
                }
            })?;
            mesh.vertex(&rec)?;
        }
        Ok(())
    }

    fn faces(
        &mut self,
        list: usize,
        kind: FaceKind,
        nv: u64,
        sink: &mut impl MeshSink,
    ) -> Result<(), K> {
        let el = self.el;
        let mut poly: Vec<u32> = Vec::new();
        let mut out: Vec<[u32; 3]> = Vec::new();
        // A face's colour channel of each property (red, green, blue, alpha), and its type.
        let channel_of: Vec<Option<(usize, Scalar)>> = (el.props.iter())
            .map(|p| {
                let channel = match p.name.as_str() {
                    "red" | "diffuse_red" => 0,
                    "green" | "diffuse_green" => 1,
                    "blue" | "diffuse_blue" => 2,
                    "alpha" | "diffuse_alpha" => 3,
                    _ => return None,
                };
                match p.ty {
                    PropType::Scalar(ty) if kind == FaceKind::Polygons => Some((channel, ty)),
                    _ => None,
                }
            })
            .collect();
        let colored = (0..3).all(|c| channel_of.iter().flatten().any(|&(k, _)| k == c));
        for f in 0..el.count {
            let line = self.start_record(f)?;
            let mut color = [0u8, 0, 0, 255];
            let mut triangles = 0;
            for (k, prop) in el.props.iter().enumerate() {
                let PropType::List { count, item } = prop.ty else {
                    match channel_of[k] {
                        Some((c, ty)) if colored => {
                            let v = self.value(ty, f, line, prop)?;
                            color[c] = if ty.is_int() {
                                v.clamp(0.0, 255.0) as u8
                            } else {
                                (v.clamp(0.0, 1.0) * 255.0).round() as u8
                            };
                        }
                        _ => self.skip_prop(prop, f, line)?,
                    }
                    continue;
                };
                if k != list {
                    self.skip_prop(prop, f, line)?;
                    continue;
                }
                let n = self.list_len(count, f, line, prop)?;
                poly.clear();
                for _ in 0..n {
                    let v = if self.binary {
                        self.value(item, f, line, prop)? as i64
                    } else {
                        match self.input.token(false)? {
                            Some(tok) => parse_int(tok).ok_or_else(|| K::Syntax {
                                at: Location::Line(line),
                                msg: format!("invalid vertex index '{}'", show(tok)),
                            })?,
                            None => return Err(self.missing(f, line, prop)?),
                        }
                    };
                    if v >= 0 && (v as u64) < nv {
                        poly.push(v as u32);
                    } else if v == -1 && kind == FaceKind::Strips {
                        poly.push(u32::MAX);
                    } else {
                        let at = if self.binary {
                            Location::Record(el.name.clone(), f)
                        } else {
                            Location::Line(line)
                        };
                        return Err(K::IndexOutOfRange {
                            at,
                            index: v,
                            count: nv,
                        });
                    }
                }
                out.clear();
                match kind {
                    FaceKind::Polygons => fan(&poly, &mut out),
                    FaceKind::Strips => strips(&poly, &mut out),
                }
                sink.triangles(&out)?;
                triangles += out.len();
            }
            self.end_record(line)?;
            if colored && triangles > 0 {
                sink.face_color(triangles, color)?;
            }
        }
        Ok(())
    }

    fn skip(&mut self) -> Result<(), K> {
        let el = self.el;
        for i in 0..el.count {
            if self.binary {
                for prop in &el.props {
                    self.skip_prop(prop, i, 0)?;
                }
            } else {
                if !self.input.skip_blank(false)? {
                    return Err(self.truncated(i));
                }
                self.input.skip_line()?;
            }
        }
        Ok(())
    }
}

/// Triangulates triangle strips separated by `u32::MAX` (restart) markers.
fn strips(indices: &[u32], out: &mut Vec<[u32; 3]>) {
    for strip in indices.split(|&v| v == u32::MAX) {
        for k in 2..strip.len() {
            out.push(if k % 2 == 0 {
                [strip[k - 2], strip[k - 1], strip[k]]
            } else {
                [strip[k - 1], strip[k - 2], strip[k]]
            });
        }
    }
}
