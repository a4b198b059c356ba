//! The streaming binary PLY writer of `gen mesh`: fixed-size blocks of vertices, then of
//! triangles, each filled in parallel (rayon) from the pure functions of [`GenMesh`] and
//! written with one `write_all`. Memory: two block buffers, whatever the mesh's size.

use std::io::{self, Write};

use rayon::prelude::*;

use super::GenMesh;

/// Bytes of one vertex record: three little-endian f32, then two with texture coordinates,
/// then three u8 with colours.
pub fn vertex_bytes(mesh: &GenMesh) -> u64 {
    12 + 8 * mesh.has_uvs() as u64 + 3 * mesh.params.colour as u64
}
/// Bytes of one face record (a u8 count, 3, then three little-endian i32).
pub const PLY_FACE_BYTES: u64 = 13;

/// Records computed and written at a time.
const BLOCK: u64 = 1 << 16;

/// The PLY header of `mesh`.
pub fn header(mesh: &GenMesh) -> String {
    let p = &mesh.params;
    format!(
        "ply\nformat binary_little_endian 1.0\n\
         comment tessera gen mesh: requested {} triangles, seed {}, density range {}{}\n{}\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n{}{}\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        p.triangles,
        p.seed,
        p.density_range,
        if p.shuffle_vertices {
            ", shuffled vertices"
        } else {
            ""
        },
        match mesh.texture_file() {
            Some(name) => format!("comment TextureFile {name}\n"),
            None => String::new(),
        },
        mesh.vertex_count(),
        if mesh.has_uvs() {
            "property float s\nproperty float t\n"
        } else {
            ""
        },
        if p.colour {
            "property uchar red\nproperty uchar green\nproperty uchar blue\n"
        } else {
            ""
        },
        mesh.triangle_count()
    )
}

/// Writes `mesh` as binary little-endian PLY to `out`; returns the bytes written.
/// `progress` is told the records written so far (vertices, then vertices + triangles).
pub fn write_ply(
    mesh: &GenMesh,
    out: &mut dyn Write,
    progress: &mut dyn FnMut(u64),
) -> io::Result<u64> {
    let header = header(mesh);
    out.write_all(header.as_bytes())?;
    let mut buf = Vec::with_capacity((BLOCK * PLY_FACE_BYTES) as usize);
    let nv = mesh.vertex_count();
    let vertex_bytes = vertex_bytes(mesh);
    for start in (0..nv).step_by(BLOCK as usize) {
        let count = BLOCK.min(nv - start);
        buf.resize((count * vertex_bytes) as usize, 0);
        buf.par_chunks_mut(vertex_bytes as usize)
            .with_min_len(1024)
            .enumerate()
            .for_each(|(k, rec)| {
                let slot = start + k as u64;
                let p = mesh.position(slot);
                for (c, x) in rec[..12].chunks_exact_mut(4).zip(p) {
                    c.copy_from_slice(&x.to_le_bytes());
                }
                let mut at = 12;
                if mesh.has_uvs() {
                    for (c, x) in rec[12..20].chunks_exact_mut(4).zip(mesh.uv(slot)) {
                        c.copy_from_slice(&x.to_le_bytes());
                    }
                    at = 20;
                }
                if mesh.params.colour {
                    rec[at..at + 3].copy_from_slice(&mesh.colour(slot));
                }
            });
        out.write_all(&buf)?;
        progress(start + count);
    }
    let nt = mesh.triangle_count();
    for start in (0..nt).step_by(BLOCK as usize) {
        let count = BLOCK.min(nt - start);
        buf.resize((count * PLY_FACE_BYTES) as usize, 0);
        buf.par_chunks_mut(PLY_FACE_BYTES as usize)
            .with_min_len(4096)
            .enumerate()
            .for_each(|(k, rec)| {
                rec[0] = 3;
                let t = mesh.triangle(start + k as u64);
                for (c, v) in rec[1..].chunks_exact_mut(4).zip(t) {
                    c.copy_from_slice(&(v as i32).to_le_bytes());
                }
            });
        out.write_all(&buf)?;
        progress(nv + start + count);
    }
    out.flush()?;
    Ok(header.len() as u64 + nv * vertex_bytes + nt * PLY_FACE_BYTES)
}
