//! The PLY header: its format line, its elements and their properties, parsed with line
//! numbers for errors; the scalar types and how their values decode.

use super::error::{show, ImportErrorKind as K, Location};
use super::input::{parse_int, Input};

/// Longest header line accepted.
pub(super) const MAX_HEADER_LINE: usize = 64 * 1024;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    pub(super) fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    pub(super) fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }

    pub(super) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    pub(super) fn is_int(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    pub(super) fn int_range(self) -> (i64, i64) {
        match self {
            Scalar::I8 => (i8::MIN as i64, i8::MAX as i64),
            Scalar::U8 => (0, u8::MAX as i64),
            Scalar::I16 => (i16::MIN as i64, i16::MAX as i64),
            Scalar::U16 => (0, u16::MAX as i64),
            Scalar::I32 => (i32::MIN as i64, i32::MAX as i64),
            Scalar::U32 => (0, u32::MAX as i64),
            Scalar::F32 | Scalar::F64 => (i64::MIN, i64::MAX),
        }
    }

    /// Decodes a binary value from the first `size()` bytes of `b`.
    #[inline]
    pub(super) fn decode(self, b: &[u8], big: bool) -> f64 {
        macro_rules! rd {
            ($t:ty, $n:literal) => {{
                let a: [u8; $n] = b[..$n].try_into().unwrap();
                if big {
                    <$t>::from_be_bytes(a) as f64
                } else {
                    <$t>::from_le_bytes(a) as f64
                }
            }};
        }
        match self {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => rd!(i16, 2),
            Scalar::U16 => rd!(u16, 2),
            Scalar::I32 => rd!(i32, 4),
            Scalar::U32 => rd!(u32, 4),
            Scalar::F32 => rd!(f32, 4),
            Scalar::F64 => rd!(f64, 8),
        }
    }

    /// Parses an ASCII value of this type (floats rounded to the declared precision, integers
    /// range-checked).
    #[inline]
    pub(super) fn parse_ascii(self, tok: &[u8]) -> Option<f64> {
        match self {
            Scalar::F32 => std::str::from_utf8(tok)
                .ok()?
                .parse::<f32>()
                .ok()
                .map(f64::from),
            Scalar::F64 => std::str::from_utf8(tok).ok()?.parse::<f64>().ok(),
            _ => {
                let v = parse_int(tok)?;
                let (lo, hi) = self.int_range();
                (lo..=hi).contains(&v).then_some(v as f64)
            }
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

#[derive(Clone, Copy, Debug)]
pub(super) enum PropType {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug)]
pub(super) struct Prop {
    pub(super) name: String,
    pub(super) ty: PropType,
    pub(super) line: u64,
}

#[derive(Debug)]
pub(super) struct Element {
    pub(super) name: String,
    pub(super) count: u64,
    pub(super) props: Vec<Prop>,
    pub(super) line: u64,
}

impl Element {
    /// "vertices", "faces", "'foo' elements".
    pub(super) fn plural(&self) -> String {
        match self.name.as_str() {
            "vertex" => "vertices".into(),
            "face" => "faces".into(),
            name => format!("'{name}' elements"),
        }
    }

    /// Fewest bytes one binary record can take.
    pub(super) fn min_record_size(&self) -> u128 {
        self.props
            .iter()
            .map(|p| match p.ty {
                PropType::Scalar(t) => t.size() as u128,
                PropType::List { count, .. } => count.size() as u128,
            })
            .sum()
    }
}

pub(super) fn header_err(line: u64, msg: impl Into<String>) -> K {
    K::Header {
        at: Location::Line(line),
        msg: msg.into(),
    }
}

/// The header's format, elements and the texture file of its first `comment TextureFile
/// NAME` (MeshLab's convention: NAME relative to the PLY's directory, spaces kept).
pub(super) fn parse_header(input: &mut Input) -> Result<(Format, Vec<Element>, Option<String>), K> {
    match input.read_line(MAX_HEADER_LINE)? {
        Some(l) if l.trim_ascii() == b"ply" => {}
        Some(l) => {
            return Err(header_err(
                1,
                format!("expected 'ply' magic, found '{}'", show(l)),
            ))
        }
        None => return Err(header_err(1, "empty file, expected 'ply' magic")),
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut texture_file = None;
    loop {
        let line_no = input.line;
        let Some(bytes) = input.read_line(MAX_HEADER_LINE)? else {
            return Err(header_err(line_no, "file ends before end_header"));
        };
        let text = String::from_utf8_lossy(bytes).into_owned();
        let words: Vec<&str> = text.split_ascii_whitespace().collect();
        let unsupported = |what: String| K::Unsupported {
            at: Location::Line(line_no),
            what,
        };
        match words.first().copied() {
            Some("comment") if words.get(1) == Some(&"TextureFile") && words.len() > 2 => {
                if texture_file.is_none() {
                    let rest = text.trim_start()["comment".len()..].trim_start();
                    texture_file = Some(rest["TextureFile".len()..].trim().to_string());
                }
            }
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                if words.len() != 3 {
                    return Err(header_err(line_no, format!("bad format line '{text}'")));
                }
                format = Some(match words[1] {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::BinaryLe,
                    "binary_big_endian" => Format::BinaryBe,
                    other => return Err(unsupported(format!("PLY format '{other}'"))),
                });
                if words[2] != "1.0" && words[2] != "1" {
                    return Err(unsupported(format!("PLY version '{}'", words[2])));
                }
            }
            Some("element") => {
                if words.len() != 3 {
                    return Err(header_err(line_no, format!("bad element line '{text}'")));
                }
                let count = words[2].parse::<u64>().map_err(|_| {
                    header_err(
                        line_no,
                        format!("invalid count '{}' for element '{}'", words[2], words[1]),
                    )
                })?;
                elements.push(Element {
                    name: words[1].to_string(),
                    count,
                    props: Vec::new(),
                    line: line_no,
                });
            }
            Some("property") => {
                let Some(element) = elements.last_mut() else {
                    return Err(header_err(line_no, "property before any element"));
                };
                let scalar = |name: &str| {
                    Scalar::from_name(name)
                        .ok_or_else(|| unsupported(format!("PLY property type '{name}'")))
                };
                let (ty, name) = match words.get(1).copied() {
                    Some("list") if words.len() == 5 => {
                        let count = scalar(words[2])?;
                        let item = scalar(words[3])?;
                        if !count.is_int() {
                            return Err(unsupported(format!("list count type '{}'", words[2])));
                        }
                        (PropType::List { count, item }, words[4])
                    }
                    Some(t) if t != "list" && words.len() == 3 => {
                        (PropType::Scalar(scalar(t)?), words[2])
                    }
                    _ => return Err(header_err(line_no, format!("bad property line '{text}'"))),
                };
                element.props.push(Prop {
                    name: name.to_string(),
                    ty,
                    line: line_no,
                });
            }
            Some("end_header") => break,
            Some(other) => {
                return Err(header_err(
                    line_no,
                    format!("unexpected keyword '{}'", show(other.as_bytes())),
                ))
            }
        }
    }
    let format = format.ok_or_else(|| header_err(1, "no format line"))?;
    Ok((format, elements, texture_file))
}
