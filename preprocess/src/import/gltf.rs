//! glTF 2.0 / GLB reader (via the `gltf` crate): every triangle primitive (triangles, strips,
//! fans) of every mesh instance in the default scene (or the first scene; or, with no scenes,
//! every mesh once), with node transforms applied in f64. Point and line primitives are skipped.
//! Normals (`NORMAL`), colours (`COLOR_0`) and texture coordinates (`TEXCOORD_0`) are kept only
//! if every primitive has them.

use std::io::Read;
use std::path::Path;

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::{Mode, Semantic};
use ::gltf::{Accessor, Gltf, Node};

use super::error::{ImportErrorKind as K, Location};
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

fn err(at: Location, msg: impl Into<String>) -> K {
    K::Gltf {
        at,
        msg: msg.into(),
    }
}

struct Builder<'a> {
    buffers: &'a [Vec<u8>],
    mesh: RawMesh,
    normals: Vec<[f32; 3]>,
    colors: Vec<[u8; 4]>,
    uvs: Vec<[f32; 2]>,
    all_normals: bool,
    all_colors: bool,
    all_uvs: bool,
    /// Nodes already visited: a node reached twice (two parents, a cycle) is an error, so a
    /// small file cannot make the walk exponential.
    visited: Vec<bool>,
}

/// Reads a .gltf or .glb file's bytes; external buffers are looked up relative to `base`, and
/// refused without one (bytes that come from no directory).
pub(crate) fn read(bytes: &[u8], base: Option<&Path>) -> Result<RawMesh, K> {
    // The gltf crate subtracts the 12-byte header from a GLB's declared length unchecked (an
    // overflow panic with overflow checks, found by the gltf fuzzer).
    if let Some(header) = bytes.strip_prefix(b"glTF").and_then(|b| b.get(4..8)) {
        let length = u32::from_le_bytes(header.try_into().expect("4 bytes"));
        if length < 12 {
            return Err(err(
                Location::None,
                format!("GLB header declares {length} bytes, less than the 12-byte header"),
            ));
        }
    }
    let Gltf { document, blob } = Gltf::from_slice_without_validation(bytes)
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
    let document =
        ::gltf::Document::from_json(json).map_err(|e| err(Location::None, e.to_string()))?;
    for ext in document.extensions_required() {
        if ext.contains("compression") || ext.starts_with("EXT_meshopt") {
            return Err(K::Unsupported {
                at: Location::None,
                what: format!("glTF extension {ext}"),
            });
        }
    }
    let buffers = load_buffers(&document, base, blob)
        .map_err(|e| err(Location::None, format!("cannot load buffers: {e}")))?;
    let mut b = Builder {
        buffers: &buffers,
        mesh: RawMesh::default(),
        normals: Vec::new(),
        colors: Vec::new(),
        uvs: Vec::new(),
        all_normals: true,
        all_colors: true,
        all_uvs: true,
        visited: vec![false; document.nodes().len()],
    };
    match document
        .default_scene()
        .or_else(|| document.scenes().next())
    {
        Some(scene) => {
            for node in scene.nodes() {
                b.node(&node, &IDENTITY, 0)?;
            }
        }
        None => {
            for mesh in document.meshes() {
                b.add_mesh(&mesh, &IDENTITY)?;
            }
        }
    }
    let mut mesh = b.mesh;
    let any = !mesh.positions.is_empty();
    mesh.normals = (any && b.all_normals).then_some(b.normals);
    mesh.colors = (any && b.all_colors).then_some(b.colors);
    mesh.uvs = (any && b.all_uvs).then_some(b.uvs);
    Ok(mesh)
}

impl Builder<'_> {
    fn node(&mut self, node: &Node, parent: &Mat4, depth: usize) -> Result<(), K> {
        if depth > MAX_DEPTH {
            return Err(err(
                Location::Other(format!("node {}", node.index())),
                format!("node hierarchy deeper than {MAX_DEPTH} (cycle?)"),
            ));
        }
        if std::mem::replace(&mut self.visited[node.index()], true) {
            return Err(err(
                Location::Other(format!("node {}", node.index())),
                "node reached twice (it has two parents, or is in a cycle)",
            ));
        }
        let local = node.transform().matrix().map(|c| c.map(f64::from));
        let world = mul(parent, &local);
        if let Some(mesh) = node.mesh() {
            self.add_mesh(&mesh, &world)?;
        }
        for child in node.children() {
            self.node(&child, &world, depth + 1)?;
        }
        Ok(())
    }

    fn add_mesh(&mut self, mesh: &::gltf::Mesh, m: &Mat4) -> Result<(), K> {
        let a = [0, 1, 2].map(|c| [m[c][0], m[c][1], m[c][2]]);
        let det = a[0][0] * cross(a[1], a[2])[0]
            + a[0][1] * cross(a[1], a[2])[1]
            + a[0][2] * cross(a[1], a[2])[2];
        let sign = if det < 0.0 { -1.0 } else { 1.0 };
        let cof = [cross(a[1], a[2]), cross(a[2], a[0]), cross(a[0], a[1])];

        for prim in mesh.primitives() {
            let at =
                || Location::Other(format!("mesh {} primitive {}", mesh.index(), prim.index()));
            let mode = prim.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                continue;
            }
            let buffers = self.buffers;
            for (semantic, accessor) in prim.attributes() {
                let want = match semantic {
                    Semantic::Positions => Want::Vec3F32,
                    Semantic::Normals => Want::Vec3F32,
                    Semantic::Colors(0) => Want::Color,
                    Semantic::TexCoords(0) => Want::TexCoord,
                    _ => continue,
                };
                check_accessor(&accessor, want, buffers).map_err(|msg| err(at(), msg))?;
            }
            if let Some(accessor) = prim.indices() {
                check_accessor(&accessor, Want::Index, buffers).map_err(|msg| err(at(), msg))?;
            }
            let reader = prim.reader(|buf| buffers.get(buf.index()).map(|d| &d[..]));
            let Some(positions) = reader.read_positions() else {
                return Err(err(at(), "no readable POSITION data"));
            };
            let base = self.mesh.positions.len();
            for p in positions {
                let p = p.map(f64::from);
                let mut q = [0.0; 3];
                for (r, v) in q.iter_mut().enumerate() {
                    *v = m[0][r] * p[0] + m[1][r] * p[1] + m[2][r] * p[2] + m[3][r];
                }
                self.mesh.positions.push(q);
            }
            let n = self.mesh.positions.len() - base;
            if base + n > u32::MAX as usize {
                return Err(K::TooLarge {
                    at: at(),
                    msg: "more than 4294967295 vertices".into(),
                });
            }

            match reader.read_normals() {
                Some(normals) => self.normals.extend(normals.map(|nv| {
                    let nv = nv.map(f64::from);
                    let mut t = [0.0; 3];
                    for (r, v) in t.iter_mut().enumerate() {
                        *v = sign * (cof[0][r] * nv[0] + cof[1][r] * nv[1] + cof[2][r] * nv[2]);
                    }
                    let len = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
                    if len > 0.0 {
                        t.map(|x| (x / len) as f32)
                    } else {
                        [0.0; 3]
                    }
                })),
                None => self.all_normals = false,
            }
            match reader.read_colors(0) {
                Some(colors) => self.colors.extend(colors.into_rgba_u8()),
                None => self.all_colors = false,
            }
            match reader.read_tex_coords(0) {
                Some(uvs) => self.uvs.extend(uvs.into_f32()),
                None => self.all_uvs = false,
            }
            // Keep attribute vectors aligned with positions even when they will be dropped.
            self.normals.resize(base + n, [0.0; 3]);
            self.colors.resize(base + n, [0, 0, 0, 255]);
            self.uvs.resize(base + n, [0.0; 2]);

            let indices: Vec<u32> = match reader.read_indices() {
                Some(ix) => ix.into_u32().collect(),
                None => (0..n as u32).collect(),
            };
            if let Some(&bad) = indices.iter().find(|&&i| i as usize >= n) {
                return Err(K::IndexOutOfRange {
                    at: at(),
                    index: bad as i64,
                    count: n as u64,
                });
            }
            let base = base as u32;
            let mut push = |t: [u32; 3]| {
                let t = t.map(|i| base + i);
                self.mesh
                    .triangles
                    .push(if det < 0.0 { [t[0], t[2], t[1]] } else { t });
            };
            match mode {
                Mode::Triangles => indices
                    .chunks_exact(3)
                    .for_each(|t| push([t[0], t[1], t[2]])),
                Mode::TriangleStrip => {
                    for k in 2..indices.len() {
                        let (a, b, c) = (indices[k - 2], indices[k - 1], indices[k]);
                        push(if k % 2 == 0 { [a, b, c] } else { [b, a, c] });
                    }
                }
                Mode::TriangleFan => {
                    for k in 2..indices.len() {
                        push([indices[0], indices[k - 1], indices[k]]);
                    }
                }
                _ => unreachable!(),
            }
        }
        Ok(())
    }
}

/// The element type a semantic needs (the gltf crate's readers panic on any other).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Want {
    Vec3F32,
    Color,
    TexCoord,
    Index,
}

/// Checks what the gltf crate's readers assume and do not check (they panic, or read without
/// bound, otherwise): the accessor has the type its semantic needs and at least one element,
/// its elements lie within its buffer view and the view within its buffer (sparse indices and
/// values too), strides are at least an element; and an accessor without a buffer view (zeros
/// plus sparse values) has no more elements than the buffers have bytes.
fn check_accessor(accessor: &Accessor, want: Want, buffers: &[Vec<u8>]) -> Result<(), String> {
    use DataType::{F32, U16, U32, U8};
    use Dimensions::{Scalar, Vec2, Vec3, Vec4};
    let (ty, dims) = (accessor.data_type(), accessor.dimensions());
    let ok = match want {
        Want::Vec3F32 => ty == F32 && dims == Vec3,
        Want::Color => matches!(ty, U8 | U16 | F32) && matches!(dims, Vec3 | Vec4),
        Want::TexCoord => matches!(ty, U8 | U16 | F32) && dims == Vec2,
        Want::Index => matches!(ty, U8 | U16 | U32) && dims == Scalar,
    };
    let name = format!("accessor {}", accessor.index());
    if !ok {
        return Err(format!("{name} has the wrong type ({ty:?} {dims:?})"));
    }
    let count = accessor.count();
    if count == 0 {
        return Err(format!("{name} has no elements"));
    }
    let size = accessor.size();
    match accessor.view() {
        Some(view) => check_view(&name, &view, accessor.offset(), size, count, buffers)?,
        None => {
            let bytes: usize = buffers.iter().map(Vec::len).sum();
            if count > bytes {
                return Err(format!(
                    "{name} has {count} elements and no buffer view, more than the {bytes} \
                     bytes of buffers"
                ));
            }
        }
    }
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        if n == 0 || n > count {
            return Err(format!("{name}: {n} sparse values for {count} elements"));
        }
        let indices = sparse.indices();
        let index_size = indices.index_type().size();
        check_view(
            &format!("{name} sparse indices"),
            &indices.view(),
            indices.offset(),
            index_size,
            n,
            buffers,
        )?;
        let values = sparse.values();
        check_view(
            &format!("{name} sparse values"),
            &values.view(),
            values.offset(),
            size,
            n,
            buffers,
        )?;
    }
    Ok(())
}

/// `count` elements of `size` bytes from `offset` in `view` lie within the view, and the view
/// within its buffer.
fn check_view(
    name: &str,
    view: &::gltf::buffer::View,
    offset: usize,
    size: usize,
    count: usize,
    buffers: &[Vec<u8>],
) -> Result<(), String> {
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "{name}: buffer view {} has stride {stride}, less than the element's {size} bytes",
            view.index()
        ));
    }
    let end = (count as u128 - 1) * stride as u128 + offset as u128 + size as u128;
    if end > view.length() as u128 {
        return Err(format!(
            "{name}: {count} elements from byte {offset} need {end} bytes, buffer view {} has {}",
            view.index(),
            view.length()
        ));
    }
    let view_end = view.offset() as u128 + view.length() as u128;
    let buffer = view.buffer().index();
    let held = buffers.get(buffer).map_or(0, Vec::len);
    if view_end > held as u128 {
        return Err(format!(
            "buffer view {} ends at byte {view_end}, buffer {buffer} has {held} bytes",
            view.index()
        ));
    }
    Ok(())
}

/// The bytes of every buffer: the GLB binary chunk, a `data:` URI (base64), or a file next to
/// the glTF (with a `base` directory). (gltf's own `import_buffers` would pull in an image
/// decoder we do not need.)
fn load_buffers(
    document: &::gltf::Document,
    base: Option<&Path>,
    blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, String> {
    use base64::Engine as _;
    let mut blob = blob;
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let mut data = match buffer.source() {
            ::gltf::buffer::Source::Bin => blob.take().ok_or("the GLB has no binary chunk")?,
            ::gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (_, payload) = rest.split_once(";base64,").ok_or_else(|| {
                        format!("unsupported data URI for buffer {}", buffer.index())
                    })?;
                    base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .map_err(|e| format!("buffer {}: bad base64: {e}", buffer.index()))?
                } else {
                    let Some(base) = base else {
                        return Err(format!(
                            "buffer {} is the external file {uri:?}, and these bytes come from \
                             no directory",
                            buffer.index()
                        ));
                    };
                    let path = base.join(percent_decode(uri));
                    // At most the declared length: a device or a growing file is not read
                    // without end.
                    let mut data = Vec::new();
                    std::fs::File::open(&path)
                        .and_then(|f| f.take(buffer.length() as u64).read_to_end(&mut data))
                        .map_err(|e| format!("{}: {e}", path.display()))?;
                    data
                }
            }
        };
        if data.len() < buffer.length() {
            return Err(format!(
                "buffer {} holds {} bytes, the glTF says {}",
                buffer.index(),
                data.len(),
                buffer.length()
            ));
        }
        // GLB chunks are padded to 4 bytes.
        data.truncate(buffer.length());
        out.push(data);
    }
    Ok(out)
}

/// Decodes %XX escapes in a relative URI.
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            if let Ok(v) = u8::from_str_radix(&uri[i + 1..i + 3], 16) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}
