//! A cut of the simplified tree written as one binary PLY mesh: positions (f32), and the
//! input's attributes (`nx ny nz`, `red green blue alpha`, `u v`), triangles by index.
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

/// Writes the triangles of the nodes `cut` (post-order indices, ascending) to `path`.
pub fn write_ply<L: Layout>(
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
            let mut face = [0u8; 13];
            face[0] = 3;
            for k in 0..3 {
                let n = match number.get(&ids[k]) {
                    Some(&n) => n,
                    None => {
                        let n = number.len() as u32;
                        number.insert(ids[k], n);
                        write_vertex(&mut vertices, layout::corner::<L>(&r, k), attributes)?;
                        n
                    }
                };
                face[1 + 4 * k..5 + 4 * k].copy_from_slice(&n.to_le_bytes());
            }
            faces.write_all(&face)?;
            triangles += 1;
        }
    }
    let vertex_count = number.len() as u64;
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
        )?;
        copy_from_start(&mut vertices, &mut w)?;
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
