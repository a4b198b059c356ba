//! The viewer's cut exported as a PLY file (or a `.glb`: `export_glb.rs`) (issue 14): the whole model at the view's
//! resolution (the stateless rule for the camera's eye and τ, no culling), welded by global
//! vertex id (`repository::cut_mesh`), with its attributes, as binary little-endian PLY with
//! double-precision positions. Written through a temporary file and a rename
//! (`output::write_atomically`), so a failed export leaves nothing behind. A textured
//! repository's textures go beside a PLY as PNG files named by `comment TextureFile` lines
//! (MeshLab's convention), its coordinates out of their bands with `v` growing up the image.

use std::io::Write;
use std::path::Path;

use tessera_core::repository::cut_mesh::{cut_mesh, unculled_cut, CutMesh};
use tessera_core::repository::reader::Repository;
use tessera_runtime::camera::Camera;

use super::export_textures::{export_textures, unbanded_v, ExportTextures};
use crate::output::write_atomically;

/// The PLY header of `mesh`: `element vertex` with double x, y, z, then float nx, ny, nz,
/// uchar red, green, blue, alpha and float s, t as the mesh has them; `element face` with a
/// `list uchar uint vertex_indices`.
fn ply_header(mesh: &CutMesh, texture_files: &[String]) -> String {
    let mut h = String::from("ply\nformat binary_little_endian 1.0\ncomment tessera cut\n");
    for name in texture_files {
        h += &format!("comment TextureFile {name}\n");
    }
    h += &format!("element vertex {}\n", mesh.vertex_count());
    h += "property double x\nproperty double y\nproperty double z\n";
    if mesh.normals.is_some() {
        h += "property float nx\nproperty float ny\nproperty float nz\n";
    }
    if mesh.colors.is_some() {
        h += "property uchar red\nproperty uchar green\nproperty uchar blue\n\
              property uchar alpha\n";
    }
    if mesh.uvs.is_some() {
        h += "property float s\nproperty float t\n";
    }
    h += &format!("element face {}\n", mesh.triangle_count());
    h += "property list uchar uint vertex_indices\nend_header\n";
    h
}

/// Writes `mesh` to `w` as a binary little-endian PLY.
fn write_ply_to(
    mesh: &CutMesh,
    texture_files: &[String],
    w: &mut impl Write,
) -> std::io::Result<()> {
    let n = mesh.vertex_count();
    for (name, len) in [
        ("normals", mesh.normals.as_ref().map(Vec::len)),
        ("colours", mesh.colors.as_ref().map(Vec::len)),
        ("uvs", mesh.uvs.as_ref().map(Vec::len)),
    ] {
        if len.is_some_and(|len| len != n) {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("{name}: {len:?} for {n} vertices"),
            ));
        }
    }
    w.write_all(ply_header(mesh, texture_files).as_bytes())?;
    let mut record = Vec::with_capacity(24 + 12 + 4 + 8);
    for v in 0..n {
        record.clear();
        for x in mesh.positions[v] {
            record.extend_from_slice(&x.to_le_bytes());
        }
        if let Some(normals) = &mesh.normals {
            for x in normals[v] {
                record.extend_from_slice(&x.to_le_bytes());
            }
        }
        if let Some(colors) = &mesh.colors {
            record.extend_from_slice(&colors[v]);
        }
        if let Some(uvs) = &mesh.uvs {
            for x in uvs[v] {
                record.extend_from_slice(&x.to_le_bytes());
            }
        }
        w.write_all(&record)?;
    }
    let mut face = [0u8; 13];
    face[0] = 3;
    for t in mesh.indices.chunks_exact(3) {
        for (k, i) in t.iter().enumerate() {
            face[1 + 4 * k..5 + 4 * k].copy_from_slice(&i.to_le_bytes());
        }
        w.write_all(&face)?;
    }
    w.flush()
}

/// Writes `mesh` as a binary little-endian PLY at `path`, through a temporary file in the same
/// directory renamed into place once complete.
pub fn write_ply(mesh: &CutMesh, path: &Path) -> anyhow::Result<()> {
    write_ply_naming(mesh, &[], path)
}

/// `write_ply`, naming `texture_files` in `comment TextureFile` lines.
fn write_ply_naming(mesh: &CutMesh, texture_files: &[String], path: &Path) -> anyhow::Result<()> {
    write_atomically(path, |_, file| {
        let mut w = std::io::BufWriter::new(file);
        write_ply_to(mesh, texture_files, &mut w)?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        Ok(())
    })
}

/// Exports the cut the rule draws at `tau` pixels for `camera`, without culling, to `path`
/// (binary glTF when it ends in `.glb`, else PLY); returns its triangle and vertex counts.
pub fn export_cut(
    repo: &Repository,
    camera: &Camera,
    tau: f32,
    path: &Path,
) -> anyhow::Result<(usize, usize)> {
    let eye = camera.eye_local(repo.header().origin);
    let tets = unculled_cut(repo, eye, &camera.metric(), tau);
    let mesh = cut_mesh(repo, &tets)?;
    let glb = (path.extension()).is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    let textures = export_textures(repo)?;
    if glb {
        super::export_glb::write_glb(&mesh, textures.as_ref(), path)?;
    } else if let Some(textures) = &textures {
        write_textured_ply(mesh.clone(), textures, path)?;
    } else {
        write_ply(&mesh, path)?;
    }
    Ok((mesh.triangle_count(), mesh.vertex_count()))
}

/// A textured cut as PLY: each texture written beside it as `STEM.texI.png`, the mesh's `v`
/// out of its band and flipped to grow up the image (`1 − v`, the same texel row).
/// A PLY names textures but no texture a face samples: with several, only GLB keeps which.
fn write_textured_ply(
    mut mesh: CutMesh,
    textures: &ExportTextures,
    path: &Path,
) -> anyhow::Result<()> {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "cut".into());
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut names = Vec::new();
    for (i, texture) in textures.textures.iter().enumerate() {
        let name = format!("{stem}.tex{i}.png");
        write_atomically(&dir.join(&name), |_, file| {
            file.write_all(&texture.png)?;
            file.sync_all()?;
            Ok(())
        })?;
        names.push(name);
    }
    if let Some(uvs) = mesh.uvs.as_mut() {
        for uv in uvs {
            uv[1] = 1.0 - unbanded_v(&textures.bands, uv[1]);
        }
    }
    write_ply_naming(&mesh, &names, path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tessera_preprocess::import::load_mesh;

    /// A tetrahedron with every attribute; positions far from the origin, where f32 would round.
    fn tetrahedron() -> CutMesh {
        let base = [1.0e9 + 0.125, -2.0e8 + 0.375, 3.0];
        CutMesh {
            positions: vec![
                base,
                [base[0] + 1.0, base[1], base[2]],
                [base[0], base[1] + 1.0, base[2]],
                [base[0], base[1], base[2] + 1.0],
            ],
            normals: Some(vec![
                [0.0, 0.0, -1.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ]),
            colors: Some(vec![
                [1, 2, 3, 4],
                [5, 6, 7, 8],
                [9, 10, 11, 12],
                [13, 14, 15, 255],
            ]),
            uvs: Some(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.25]]),
            indices: vec![0, 2, 1, 0, 1, 3, 1, 2, 3, 2, 0, 3],
        }
    }

    #[test]
    fn writes_header_and_records() {
        let mesh = tetrahedron();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cut.ply");
        write_ply(&mesh, &path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let end = b"end_header\n";
        let at = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
        let header = std::str::from_utf8(&bytes[..at]).unwrap();
        assert_eq!(header, ply_header(&mesh, &[]));
        assert!(header.contains("comment tessera cut\n"));
        assert!(header.contains("element vertex 4\nproperty double x\n"));
        assert!(header.contains("property uchar alpha\nproperty float s\nproperty float t\n"));
        assert!(header.contains("element face 4\nproperty list uchar uint vertex_indices\n"));
        let vertex = 24 + 12 + 4 + 8;
        assert_eq!(bytes.len(), at + 4 * vertex + 4 * 13);
        let body = &bytes[at..];
        let f64_at = |o: usize| f64::from_le_bytes(body[o..o + 8].try_into().unwrap());
        let f32_at = |o: usize| f32::from_le_bytes(body[o..o + 4].try_into().unwrap());
        let v1 = vertex;
        assert_eq!(f64_at(v1), mesh.positions[1][0]);
        assert_eq!(f64_at(v1 + 8), mesh.positions[1][1]);
        assert_eq!(f32_at(v1 + 24), 1.0);
        assert_eq!(&body[v1 + 36..v1 + 40], &[5, 6, 7, 8]);
        assert_eq!(f32_at(v1 + 40), 1.0);
        let faces = &body[4 * vertex..];
        assert_eq!(faces[13], 3);
        let index = |o: usize| u32::from_le_bytes(faces[o..o + 4].try_into().unwrap());
        assert_eq!([index(14), index(18), index(22)], [0, 1, 3]);
        // Only the output is left in the directory: the temporary file was renamed.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn tesseras_importer_reads_it_back() {
        let mesh = tetrahedron();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cut.ply");
        write_ply(&mesh, &path).unwrap();
        let back = load_mesh(&path).unwrap().mesh;
        assert_eq!(back.positions, mesh.positions, "double positions, exactly");
        let triangles: Vec<u32> = back.triangles.iter().flatten().copied().collect();
        assert_eq!(triangles, mesh.indices);
        assert_eq!(back.normals, mesh.normals);
        assert_eq!(back.colors, mesh.colors);
        assert_eq!(back.uvs, mesh.uvs);
        // Without attributes.
        let bare = CutMesh {
            normals: None,
            colors: None,
            uvs: None,
            ..mesh
        };
        write_ply(&bare, &path).unwrap();
        let back = load_mesh(&path).unwrap().mesh;
        assert_eq!(back.positions, bare.positions);
        assert!(back.normals.is_none() && back.colors.is_none() && back.uvs.is_none());
    }

    #[test]
    fn an_exported_cut_reimports_with_its_triangles_and_closed() {
        use tessera_preprocess::procedural::demo_mesh;
        use tessera_preprocess::{build_repository, BuildConfig, Construction};
        let dir = tempfile::tempdir().unwrap();
        let repo_path = dir.path().join("model.tsr");
        let config = BuildConfig {
            construction: Construction::LeafTriangles(64),
            ..Default::default()
        };
        build_repository(&demo_mesh(4), &config, &repo_path, &|_| {}).unwrap();
        let repo = Repository::open(&repo_path).unwrap();
        let camera = Camera::looking_at([0.3, 0.2, 3.0], [0.0; 3], 1.0);
        let path = dir.path().join("cut.ply");
        for tau in [0.0, 8.0, 1e9] {
            let (triangles, vertices) = export_cut(&repo, &camera, tau, &path).unwrap();
            let report = load_mesh(&path).unwrap();
            assert_eq!(report.mesh.triangles.len(), triangles, "τ = {tau}");
            assert_eq!(report.mesh.positions.len(), vertices, "τ = {tau}");
            assert_eq!(report.welded_vertices + report.duplicate_triangles, 0);
            assert!(report.mesh.normals.is_some());
            let mut uses = std::collections::HashMap::new();
            for t in &report.mesh.triangles {
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
                }
            }
            assert!(uses.values().all(|&u| u == 2), "τ = {tau}: watertight");
        }
    }
}
