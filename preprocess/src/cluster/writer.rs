//! A cut of the simplified tree written as one mesh: binary PLY (positions as f32, the
//! input's attributes as `nx ny nz`, `red green blue alpha`, `u v`, triangles by index), or
//! binary glTF 2.0 for a `.glb` path (the same vertices interleaved in one buffer view,
//! `POSITION`, `NORMAL`, `COLOR_0` as normalised RGBA8, `TEXCOORD_0`; u32 indices).
//!
//! Vertices are numbered as first met; the map from vertex id to its number is the one
//! thing held that grows (with the output's vertices, 12 to 16 bytes each). Vertices and
//! faces go to two unnamed temporary files, then the header and both are copied into a
//! temporary file beside the output, renamed into place only when complete: a failed write
//! leaves nothing at the output's path.

use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::Path;

use rustc_hash::FxHashMap as HashMap;

use super::layout::{self, Attributes, Layout, COLOR_AT, NORMAL_AT, UV_AT};
use super::levels::Hierarchy;

/// What was written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Written {
    pub vertices: u64,
    pub triangles: u64,
    pub bytes: u64,
}

/// Writes the triangles of the nodes `cut` (post-order indices, ascending) to `path`: GLB
/// if its extension is `.glb`, else PLY.
pub fn write_mesh<L: Layout>(
    hierarchy: &Hierarchy<L>,
    cut: &[u32],
    attributes: Attributes,
    temp_dir: &Path,
    path: &Path,
) -> io::Result<Written> {
    let mut vertices = BufWriter::with_capacity(1 << 20, tempfile::tempfile_in(temp_dir)?);
    let mut faces = BufWriter::with_capacity(1 << 20, tempfile::tempfile_in(temp_dir)?);
    let mut number: HashMap<u32, u32> = HashMap::default();
    let mut reader = hierarchy.outputs.read()?;
    let mut at = 0u64;
    let mut triangles = 0u64;
    let glb = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for &i in cut {
        let (first, count) = (
            hierarchy.out_first[i as usize],
            hierarchy.out_count[i as usize] as u64,
        );
        debug_assert!(first >= at, "cut not in post-order");
        while at < first {
            reader
                .next()
                .ok_or_else(|| io::Error::other("the node outputs end early"))??;
            at += 1;
        }
        for _ in 0..count {
            let r = reader
                .next()
                .ok_or_else(|| io::Error::other("the node outputs end early"))??;
            at += 1;
            let ids = layout::ids::<L>(&r);
            // PLY: a count byte then three i32; GLB: three u32.
            let mut face = [0u8; 13];
            face[0] = 3;
            let skip = if glb { 1 } else { 0 };
            for k in 0..3 {
                let n = match number.get(&ids[k]) {
                    Some(&n) => n,
                    None => {
                        let n = number.len() as u32;
                        number.insert(ids[k], n);
                        let v = layout::corner::<L>(&r, k);
                        let p = layout::position(v);
                        for a in 0..3 {
                            lo[a] = lo[a].min(p[a]);
                            hi[a] = hi[a].max(p[a]);
                        }
                        write_vertex(&mut vertices, v, attributes)?;
                        n
                    }
                };
                face[1 + 4 * k..5 + 4 * k].copy_from_slice(&n.to_le_bytes());
            }
            faces.write_all(&face[skip..])?;
            triangles += 1;
        }
    }
    let vertex_count = number.len() as u64;
    if glb && triangles == 0 {
        return Err(io::Error::other(format!(
            "{}: no triangles to write, and a GLB mesh cannot be empty",
            path.display()
        )));
    }
    drop(number);
    let mut vertices = vertices.into_inner().map_err(|e| e.into_error())?;
    let mut faces = faces.into_inner().map_err(|e| e.into_error())?;
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut out = tempfile::Builder::new()
        .prefix(".tessera-")
        .suffix(".tmp")
        .tempfile_in(dir)?;
    {
        let mut w = BufWriter::with_capacity(1 << 20, out.as_file_mut());
        if glb {
            write_glb_head(&mut w, vertex_count, triangles, attributes, lo, hi)?;
        } else {
            write_ply_head(&mut w, vertex_count, triangles, attributes)?;
        }
        copy_from_start(&mut vertices, &mut w)?;
        // (GLB: the BIN chunk needs no padding, vertices and indices being whole words.)
        copy_from_start(&mut faces, &mut w)?;
        w.flush()?;
    }
    out.as_file().sync_all()?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        out.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))?;
    }
    out.persist(path).map_err(|e| e.error)?;
    Ok(Written {
        vertices: vertex_count,
        triangles,
        bytes: std::fs::metadata(path)?.len(),
    })
}

fn write_ply_head(
    w: &mut impl Write,
    vertex_count: u64,
    triangles: u64,
    attributes: Attributes,
) -> io::Result<()> {
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\ncomment written by tessera simplify\n\
         element vertex {vertex_count}\nproperty float x\nproperty float y\nproperty float z\n"
    )?;
    if attributes.normals {
        write!(
            w,
            "property float nx\nproperty float ny\nproperty float nz\n"
        )?;
    }
    if attributes.colors {
        write!(
            w,
            "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n"
        )?;
    }
    if attributes.uvs {
        write!(w, "property float u\nproperty float v\n")?;
    }
    write!(
        w,
        "element face {triangles}\nproperty list uchar int vertex_indices\nend_header\n"
    )
}

/// The GLB header, the JSON chunk and the BIN chunk's header: the vertices (interleaved,
/// `stride` bytes each) and the indices follow as the BIN chunk's contents.
fn write_glb_head(
    w: &mut impl Write,
    vertex_count: u64,
    triangles: u64,
    attributes: Attributes,
    lo: [f32; 3],
    hi: [f32; 3],
) -> io::Result<()> {
    let stride = 12
        + 12 * attributes.normals as u64
        + 4 * attributes.colors as u64
        + 8 * attributes.uvs as u64;
    let vertex_bytes = vertex_count * stride;
    let index_bytes = triangles * 12;
    let mut accessors = vec![serde_json::json!({
        "bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": vertex_count,
        "type": "VEC3", "min": lo, "max": hi,
    })];
    let mut named = serde_json::Map::new();
    named.insert("POSITION".into(), 0.into());
    let mut offset = 12;
    for (present, name, component, kind, size, normalized) in [
        (attributes.normals, "NORMAL", 5126, "VEC3", 12, false),
        (attributes.colors, "COLOR_0", 5121, "VEC4", 4, true),
        (attributes.uvs, "TEXCOORD_0", 5126, "VEC2", 8, false),
    ] {
        if !present {
            continue;
        }
        named.insert(name.into(), accessors.len().into());
        let mut a = serde_json::json!({
            "bufferView": 0, "byteOffset": offset, "componentType": component,
            "count": vertex_count, "type": kind,
        });
        if normalized {
            a["normalized"] = true.into();
        }
        accessors.push(a);
        offset += size;
    }
    let indices = accessors.len();
    accessors.push(serde_json::json!({
        "bufferView": 1, "byteOffset": 0, "componentType": 5125, "count": 3 * triangles,
        "type": "SCALAR",
    }));
    let gltf = serde_json::json!({
        "asset": {"version": "2.0", "generator": "tessera simplify"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": named, "indices": indices, "mode": 4}]}],
        "buffers": [{"byteLength": vertex_bytes + index_bytes}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": vertex_bytes, "byteStride": stride,
             "target": 34962},
            {"buffer": 0, "byteOffset": vertex_bytes, "byteLength": index_bytes,
             "target": 34963},
        ],
        "accessors": accessors,
    });
    let mut json = serde_json::to_vec(&gltf).map_err(io::Error::other)?;
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let bin = vertex_bytes + index_bytes;
    let total = 12 + 8 + json.len() as u64 + 8 + bin;
    let total = u32::try_from(total)
        .map_err(|_| io::Error::other("the mesh is too large for one GLB file (4 GiB)"))?;
    w.write_all(b"glTF")?;
    w.write_all(&2u32.to_le_bytes())?;
    w.write_all(&total.to_le_bytes())?;
    w.write_all(&(json.len() as u32).to_le_bytes())?;
    w.write_all(b"JSON")?;
    w.write_all(&json)?;
    w.write_all(&(bin as u32).to_le_bytes())?;
    w.write_all(b"BIN\0")
}

fn copy_from_start(file: &mut File, to: &mut impl Write) -> io::Result<()> {
    file.seek(SeekFrom::Start(0))?;
    io::copy(file, to)?;
    Ok(())
}

fn write_vertex(w: &mut impl Write, v: &[u32], attributes: Attributes) -> io::Result<()> {
    for word in &v[..3] {
        w.write_all(&word.to_le_bytes())?;
    }
    if attributes.normals {
        for k in 0..3 {
            w.write_all(&v[NORMAL_AT + k].to_le_bytes())?;
        }
    }
    if attributes.colors {
        w.write_all(&v[COLOR_AT].to_le_bytes())?;
    }
    if attributes.uvs {
        for k in 0..2 {
            w.write_all(&v[UV_AT + k].to_le_bytes())?;
        }
    }
    Ok(())
}
