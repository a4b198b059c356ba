//! glTF 2.0 / GLB reader: every triangle primitive (triangles, strips, fans) of every mesh
//! instance in the default scene (or the first scene; or, with no scenes, every mesh once),
//! with node transforms applied in f64. Point and line primitives are skipped. Normals
//! (`NORMAL`), colours (`COLOR_0`) and texture coordinates (`TEXCOORD_0`) are kept only if
//! every primitive has them. A material's `baseColorFactor` multiplies its primitives'
//! `COLOR_0` (white where they have none): colours are kept too when any primitive's factor is
//! not white (several materials, several colours, as wedges where they meet).
//!
//! The gltf crate parses the JSON document; the buffers are read here, a chunk of elements at
//! a time (`accessor.rs`), from memory or from the file (`container.rs`), into a
//! [`MeshSink`]: a GLB or a glTF with external buffers streams into the out-of-core staging
//! without being held whole. Only the document, `data:` URI buffers and sparse substitutions
//! are held in memory.

mod accessor;
mod container;
mod textures;

use std::borrow::Cow;
use std::fs::File;
use std::path::Path;

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::{Mode, Semantic};
use ::gltf::{Document, Gltf, Mesh, Node, Primitive};

use self::accessor::{check_accessor, readable, Elements, Want};
use self::container::Bytes;
use super::error::{ImportErrorKind as K, Location};
use super::sink::{self, in_memory, Declared, MeshSink};
use super::textures::{FoundTextures, Placement};
use super::RawMesh;

type Mat4 = [[f64; 4]; 4]; // column-major, m[column][row]

const IDENTITY: Mat4 = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// Deepest node hierarchy followed (guards against cycles in invalid files).
const MAX_DEPTH: usize = 256;

/// Elements read at a time.
const CHUNK: usize = 1 << 14;

fn err(at: Location, msg: impl Into<String>) -> K {
    K::Gltf {
        at,
        msg: msg.into(),
    }
}

/// Reads a .gltf or .glb file's bytes held in memory; external buffers are looked up
/// relative to `base`, and refused without one (bytes that come from no directory). With
/// `textures`, its base-colour textures and bands (`textures.rs`).
pub(crate) fn read(
    bytes: &[u8],
    base: Option<&Path>,
    textures: bool,
) -> Result<(RawMesh, FoundTextures), K> {
    read_into(
        &Bytes::Memory(Cow::Borrowed(bytes)),
        base,
        |d| Ok(in_memory(d)),
        textures,
    )
}

/// Reads the .gltf or .glb file at `path` into the sink `make_sink` makes: a GLB's binary
/// chunk and external buffers (beside the file) are read a chunk at a time, never whole.
pub(crate) fn read_file<S: MeshSink>(
    path: &Path,
    make_sink: impl FnOnce(&Declared) -> Result<S, K>,
    textures: bool,
) -> Result<(S, FoundTextures), K> {
    let file = File::open(path).map_err(K::Io)?;
    let len = file.metadata().map_err(K::Io)?.len();
    let base = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    };
    let all = Bytes::File {
        file: &file,
        start: 0,
        len,
    };
    read_into(&all, Some(base), make_sink, textures)
}

fn read_into<S: MeshSink>(
    all: &Bytes,
    base: Option<&Path>,
    make_sink: impl FnOnce(&Declared) -> Result<S, K>,
    textures: bool,
) -> Result<(S, FoundTextures), K> {
    let container = container::open(all)?;
    let document = parse_document(&container.json)?;
    let cannot_load = |e: String| err(Location::None, format!("cannot load buffers: {e}"));
    let files = container::open_buffer_files(&document, base).map_err(cannot_load)?;
    let buffers =
        container::buffers(&document, base, container.bin, &files).map_err(cannot_load)?;
    let lengths: Vec<u64> = buffers.iter().map(Bytes::len).collect();

    let instances = instances(&document)?;
    let mut declared = check_primitives(&instances, &lengths)?;
    let (found, placements) = match textures {
        true => textures::find(&document, &instances, &buffers, base)?,
        false => (FoundTextures::default(), None),
    };
    // Every vertex of a textured file has a coordinate in its band.
    declared.uvs |= placements.is_some();
    let mut sink = make_sink(&declared)?;
    let mut vertices = 0u32;
    for (mesh, m) in &instances {
        for prim in triangle_primitives(mesh) {
            let at =
                || Location::Other(format!("mesh {} primitive {}", mesh.index(), prim.index()));
            let placement = placements.as_ref().and_then(|p| p.of(&prim));
            vertices = stream_primitive(
                &mut sink, &prim, m, &declared, &buffers, vertices, placement,
            )
            .map_err(|e| match e {
                Streamed::Io(e) => err(at(), format!("cannot read: {e}")),
                Streamed::Index { index, count } => K::IndexOutOfRange {
                    at: at(),
                    index: index as i64,
                    count: count as u64,
                },
                Streamed::Sink(kind) => kind,
            })?;
        }
    }
    Ok((sink, found))
}

/// The document, validated: every check the gltf crate makes, and the ones it makes too
/// late; a required compression extension is refused.
fn parse_document(json: &[u8]) -> Result<Document, K> {
    let Gltf { document, .. } = Gltf::from_slice_without_validation(json)
        .map_err(|e| err(Location::None, e.to_string()))?;
    // gltf-json's validation indexes the accessors with a primitive's POSITION index before it
    // checks that index (an index-out-of-bounds panic, found by the gltf fuzzer): check every
    // attribute's accessor index first, then validate.
    let json = document.into_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(index) = primitive
                .attributes
                .values()
                .find(|index| index.value() >= json.accessors.len())
            {
                return Err(err(
                    Location::Other(format!("mesh {m} primitive {p}")),
                    format!(
                        "attribute accessor {} does not exist ({} accessors)",
                        index.value(),
                        json.accessors.len()
                    ),
                ));
            }
        }
    }
    let document = Document::from_json(json).map_err(|e| err(Location::None, e.to_string()))?;
    for ext in document.extensions_required() {
        if ext.contains("compression") || ext.starts_with("EXT_meshopt") {
            return Err(K::Unsupported {
                at: Location::None,
                what: format!("glTF extension {ext}"),
            });
        }
    }
    Ok(document)
}

/// The meshes to read with their world transforms: the default scene's (or the first
/// scene's) node instances, or every mesh once when there is no scene.
fn instances(document: &Document) -> Result<Vec<(Mesh<'_>, Mat4)>, K> {
    let mut out = Vec::new();
    match document
        .default_scene()
        .or_else(|| document.scenes().next())
    {
        Some(scene) => {
            let mut visited = vec![false; document.nodes().len()];
            for node in scene.nodes() {
                walk(&node, &IDENTITY, 0, &mut visited, &mut out)?;
            }
        }
        None => out.extend(document.meshes().map(|mesh| (mesh, IDENTITY))),
    }
    Ok(out)
}

/// `node` and its descendants. A node reached twice (two parents, a cycle) is an error, so a
/// small file cannot make the walk exponential.
fn walk<'d>(
    node: &Node<'d>,
    parent: &Mat4,
    depth: usize,
    visited: &mut [bool],
    out: &mut Vec<(Mesh<'d>, Mat4)>,
) -> Result<(), K> {
    let at = || Location::Other(format!("node {}", node.index()));
    if depth > MAX_DEPTH {
        return Err(err(
            at(),
            format!("node hierarchy deeper than {MAX_DEPTH} (cycle?)"),
        ));
    }
    if std::mem::replace(&mut visited[node.index()], true) {
        return Err(err(
            at(),
            "node reached twice (it has two parents, or is in a cycle)",
        ));
    }
    let local = node.transform().matrix().map(|c| c.map(f64::from));
    let world = mul(parent, &local);
    if let Some(mesh) = node.mesh() {
        out.push((mesh, world));
    }
    for child in node.children() {
        walk(&child, &world, depth + 1, visited, out)?;
    }
    Ok(())
}

fn triangle_primitives<'d>(mesh: &Mesh<'d>) -> impl Iterator<Item = Primitive<'d>> {
    mesh.primitives().filter(|p| {
        matches!(
            p.mode(),
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        )
    })
}

/// The attribute a primitive's vertices keep, when every primitive has it readable.
fn attribute<'d>(prim: &Primitive<'d>, semantic: Semantic) -> Option<::gltf::Accessor<'d>> {
    prim.get(&semantic).filter(readable)
}

/// Checks every accessor that will be read, and counts what will be read: the attributes
/// kept (those every primitive has), vertices and triangles.
fn check_primitives(instances: &[(Mesh, Mat4)], lengths: &[u64]) -> Result<Declared, K> {
    let (mut normals, mut colors, mut uvs) = (true, true, true);
    // Whether a material colours its primitives.
    let mut factors = false;
    let (mut vertices, mut triangles) = (0u64, 0u64);
    for (mesh, _) in instances {
        for prim in triangle_primitives(mesh) {
            let at =
                || Location::Other(format!("mesh {} primitive {}", mesh.index(), prim.index()));
            for (semantic, accessor) in prim.attributes() {
                let want = match semantic {
                    Semantic::Positions | Semantic::Normals => Want::Vec3F32,
                    Semantic::Colors(0) => Want::Color,
                    Semantic::TexCoords(0) => Want::TexCoord,
                    _ => continue,
                };
                check_accessor(&accessor, want, lengths).map_err(|msg| err(at(), msg))?;
            }
            let indices = prim.indices();
            if let Some(accessor) = &indices {
                check_accessor(accessor, Want::Index, lengths).map_err(|msg| err(at(), msg))?;
            }
            let Some(positions) = attribute(&prim, Semantic::Positions) else {
                return Err(err(at(), "no readable POSITION data"));
            };
            vertices += positions.count() as u64;
            if vertices > u64::from(u32::MAX) {
                return Err(K::TooLarge {
                    at: at(),
                    msg: "more than 4294967295 vertices".into(),
                });
            }
            let corners = indices.map_or(positions.count(), |i| i.count()) as u64;
            triangles += match prim.mode() {
                Mode::Triangles => corners / 3,
                _ => corners.saturating_sub(2),
            };
            normals &= attribute(&prim, Semantic::Normals).is_some();
            colors &= attribute(&prim, Semantic::Colors(0)).is_some();
            factors |= base_color_factor(&prim) != [1.0; 4];
            uvs &= attribute(&prim, Semantic::TexCoords(0)).is_some();
        }
    }
    let any = vertices > 0;
    Ok(Declared {
        normals: any && normals,
        colors: any && (colors || factors),
        uvs: any && uvs,
        // Hints, bounded: instancing can repeat a small buffer without end.
        vertex_capacity: vertices.min(1 << 20) as usize,
        face_capacity: triangles.min(1 << 20) as usize,
    })
}

/// Why streaming a primitive stopped.
enum Streamed {
    Io(std::io::Error),
    Index { index: u32, count: usize },
    Sink(K),
}

impl From<std::io::Error> for Streamed {
    fn from(e: std::io::Error) -> Self {
        Streamed::Io(e)
    }
}

/// An attribute's elements a chunk at a time.
struct Attribute<'a> {
    elements: Elements<'a>,
    ty: DataType,
    dims: Dimensions,
    size: usize,
    chunk: Vec<u8>,
}

impl<'a> Attribute<'a> {
    fn open(
        prim: &Primitive,
        semantic: Semantic,
        keep: bool,
        buffers: &'a [Bytes<'a>],
    ) -> std::io::Result<Option<Attribute<'a>>> {
        match attribute(prim, semantic).filter(|_| keep) {
            Some(accessor) => Attribute::open_accessor(&accessor, buffers).map(Some),
            None => Ok(None),
        }
    }

    fn open_accessor(
        accessor: &::gltf::Accessor,
        buffers: &'a [Bytes<'a>],
    ) -> std::io::Result<Attribute<'a>> {
        Ok(Attribute {
            elements: Elements::new(accessor, buffers)?,
            ty: accessor.data_type(),
            dims: accessor.dimensions(),
            size: accessor.size(),
            chunk: Vec::new(),
        })
    }

    /// The next chunk of at most `n` elements.
    fn fill(&mut self, n: usize) -> std::io::Result<usize> {
        self.elements.next_chunk(n, &mut self.chunk)
    }

    /// Element `k` of the chunk; none past its end (an attribute with fewer elements than
    /// the positions leaves the rest at their defaults, as the gltf crate's readers did).
    fn get(&self, k: usize) -> Option<&[u8]> {
        self.chunk.get(k * self.size..(k + 1) * self.size)
    }
}

/// Streams one primitive's vertices (transformed by `m`; normals by its cofactor matrix and
/// renormalised) then its triangles (numbered from `first`, flipped back to
/// counter-clockwise where `m` mirrors) into `sink`, texture coordinates moved into the
/// primitive's band (`placement`, a textured file's); the vertex count after it.
fn stream_primitive<S: MeshSink>(
    sink: &mut S,
    prim: &Primitive,
    m: &Mat4,
    keep: &Declared,
    buffers: &[Bytes],
    first: u32,
    placement: Option<&Placement>,
) -> Result<u32, Streamed> {
    let a = [0, 1, 2].map(|c| [m[c][0], m[c][1], m[c][2]]);
    let cof = [cross(a[1], a[2]), cross(a[2], a[0]), cross(a[0], a[1])];
    let det = a[0][0] * cof[0][0] + a[0][1] * cof[0][1] + a[0][2] * cof[0][2];
    let sign = if det < 0.0 { -1.0 } else { 1.0 };

    let mut positions = Attribute::open(prim, Semantic::Positions, true, buffers)?
        .expect("checked: every primitive read has positions");
    let mut normals = Attribute::open(prim, Semantic::Normals, keep.normals, buffers)?;
    let mut colors = Attribute::open(prim, Semantic::Colors(0), keep.colors, buffers)?;
    let mut uvs = Attribute::open(prim, Semantic::TexCoords(0), keep.uvs, buffers)?;
    let count = positions.elements.count();
    let factor = base_color_factor(prim);
    loop {
        let got = positions.fill(CHUNK)?;
        if got == 0 {
            break;
        }
        for attribute in [&mut normals, &mut colors, &mut uvs].into_iter().flatten() {
            attribute.fill(got)?;
        }
        for k in 0..got {
            let q = accessor::vec3(positions.get(k).expect("a whole chunk")).map(f64::from);
            let mut v = sink::at(
                [0, 1, 2].map(|r| m[0][r] * q[0] + m[1][r] * q[1] + m[2][r] * q[2] + m[3][r]),
            );
            if let Some(e) = normals.as_ref().and_then(|a| a.get(k)) {
                v.normal = transform_normal(accessor::vec3(e), &cof, sign);
            }
            if keep.colors {
                let c = match colors.as_ref().and_then(|a| Some((a.get(k)?, a))) {
                    Some((e, a)) => accessor::color(e, a.ty, a.dims),
                    None => [255; 4],
                };
                v.color = multiply(c, factor);
            }
            if let Some((e, a)) = uvs.as_ref().and_then(|a| Some((a.get(k)?, a))) {
                v.uv = accessor::tex_coord(e, a.ty);
            }
            if let Some(placement) = placement {
                v.uv = placement.place(v.uv);
            }
            sink.vertex(&v).map_err(Streamed::Sink)?;
        }
    }

    let mut assembler = Assembler::new(prim.mode());
    let mut triangles = Vec::new();
    let mut emit = |triangles: &mut Vec<[u32; 3]>| {
        for t in triangles.iter_mut() {
            *t = t.map(|i| first + i);
            if det < 0.0 {
                t.swap(1, 2);
            }
        }
        let sent = sink.triangles(triangles).map_err(Streamed::Sink);
        triangles.clear();
        sent
    };
    let check = |index: u32| {
        if index as usize >= count {
            return Err(Streamed::Index { index, count });
        }
        Ok(index)
    };
    match prim.indices() {
        Some(accessor) => {
            let mut indices = Attribute::open_accessor(&accessor, buffers)?;
            loop {
                let got = indices.fill(CHUNK)?;
                if got == 0 {
                    break;
                }
                for k in 0..got {
                    let index = accessor::index(indices.get(k).expect("a whole chunk"), indices.ty);
                    assembler.push(check(index)?, &mut triangles);
                }
                emit(&mut triangles)?;
            }
        }
        None => {
            for index in 0..count as u32 {
                assembler.push(index, &mut triangles);
                if triangles.len() >= CHUNK {
                    emit(&mut triangles)?;
                }
            }
            emit(&mut triangles)?;
        }
    }
    Ok(first + count as u32)
}

/// The `baseColorFactor` of `prim`'s material (white for the default material), each
/// component clamped to 0..1 (NaN as 1).
fn base_color_factor(prim: &Primitive) -> [f32; 4] {
    let f = prim.material().pbr_metallic_roughness().base_color_factor();
    f.map(|x| if x.is_nan() { 1.0 } else { x.clamp(0.0, 1.0) })
}

/// An 8-bit colour times a factor, rounded; a white factor leaves it as it is.
fn multiply(c: [u8; 4], factor: [f32; 4]) -> [u8; 4] {
    if factor == [1.0; 4] {
        return c;
    }
    [0, 1, 2, 3].map(|i| (f32::from(c[i]) * factor[i]).round() as u8)
}

/// Triangles from a primitive's index sequence, one index at a time.
struct Assembler {
    mode: Mode,
    /// Indices seen.
    seen: usize,
    /// Triangles: the pending corners; strips: the last two indices; fans: the first and
    /// the last.
    held: [u32; 2],
}

impl Assembler {
    fn new(mode: Mode) -> Assembler {
        Assembler {
            mode,
            seen: 0,
            held: [0; 2],
        }
    }

    fn push(&mut self, i: u32, out: &mut Vec<[u32; 3]>) {
        let k = self.seen;
        self.seen += 1;
        match self.mode {
            Mode::Triangles => match k % 3 {
                2 => out.push([self.held[0], self.held[1], i]),
                slot => self.held[slot] = i,
            },
            Mode::TriangleStrip => {
                let [a, b] = self.held;
                if k >= 2 {
                    out.push(if k.is_multiple_of(2) {
                        [a, b, i]
                    } else {
                        [b, a, i]
                    });
                }
                self.held = [b, i];
            }
            _ => {
                if k == 0 {
                    self.held[0] = i;
                } else {
                    if k >= 2 {
                        out.push([self.held[0], self.held[1], i]);
                    }
                    self.held[1] = i;
                }
            }
        }
    }
}

/// A normal by the cofactor matrix (the inverse transpose up to scale), `sign` undoing a
/// mirror's, renormalised (zero stays zero).
fn transform_normal(n: [f32; 3], cof: &[[f64; 3]; 3], sign: f64) -> [f32; 3] {
    let n = n.map(f64::from);
    let t = [0, 1, 2].map(|r| sign * (cof[0][r] * n[0] + cof[1][r] * n[1] + cof[2][r] * n[2]));
    let len = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
    if len > 0.0 {
        t.map(|x| (x / len) as f32)
    } else {
        [0.0; 3]
    }
}

fn mul(a: &Mat4, b: &Mat4) -> Mat4 {
    let mut m = [[0.0; 4]; 4];
    for (c, col) in m.iter_mut().enumerate() {
        for (r, v) in col.iter_mut().enumerate() {
            *v = (0..4).map(|k| a[k][r] * b[c][k]).sum();
        }
    }
    m
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests;
