//! Files the CLI writes besides repositories: PNG frames, binary PLY meshes (`gen mesh` streams
//! its own through [`write_atomically`]). Each goes
//! through a temporary file in the target directory and a rename, so a failed write leaves
//! nothing behind; the result gets ordinary permissions (0644), not the temporary file's 0600.

use std::io::Write;
use std::path::Path;

use anyhow::Context;
use tessera_preprocess::InputMesh;

/// Writes `path` through a temporary file: `write` fills it, then it is renamed into place.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&Path, &mut std::fs::File) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut builder = tempfile::Builder::new();
    builder.prefix(".tessera-").suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    let mut tmp = builder
        .tempfile_in(dir)
        .with_context(|| format!("cannot write into {}", dir.display()))?;
    let tmp_path = tmp.path().to_path_buf();
    write(&tmp_path, tmp.as_file_mut()).with_context(|| format!("writing {}", path.display()))?;
    tmp.persist(path)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// Saves an RGBA image as PNG.
pub fn save_png(image: &image::RgbaImage, path: &Path) -> anyhow::Result<()> {
    write_atomically(path, |tmp, _| {
        image.save_with_format(tmp, image::ImageFormat::Png)?;
        Ok(())
    })
}

/// Writes positions (as f32) and triangles as a binary little-endian PLY; returns its size.
pub fn write_binary_ply(mesh: &InputMesh, path: &Path) -> anyhow::Result<u64> {
    write_atomically(path, |_, file| {
        let mut w = std::io::BufWriter::new(file);
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment written by tessera\n\
             element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
             element face {}\nproperty list uchar int vertex_indices\nend_header\n",
            mesh.positions.len(),
            mesh.triangles.len()
        )?;
        for p in &mesh.positions {
            for x in p {
                w.write_all(&(*x as f32).to_le_bytes())?;
            }
        }
        let mut face = [0u8; 13];
        face[0] = 3;
        for t in &mesh.triangles {
            for (k, v) in t.iter().enumerate() {
                face[1 + 4 * k..5 + 4 * k].copy_from_slice(&(*v as i32).to_le_bytes());
            }
            w.write_all(&face)?;
        }
        w.flush()?;
        Ok(())
    })?;
    Ok(std::fs::metadata(path)?.len())
}

/// Writes bytes through a temporary file and a rename.
pub fn write_bytes(bytes: &[u8], path: &Path) -> anyhow::Result<()> {
    write_atomically(path, |_, file| {
        file.write_all(bytes)?;
        Ok(())
    })
}

/// The directory an out-of-core command keeps its temporary files in: `--temp`, else the
/// output's directory; checked now, with its name, rather than deep in a stage.
pub fn temp_dir_for(temp: Option<&Path>, output: &Path) -> anyhow::Result<std::path::PathBuf> {
    let dir = match temp {
        Some(dir) => dir.to_path_buf(),
        None => output
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_path_buf(),
    };
    tempfile::tempfile_in(&dir)
        .with_context(|| format!("cannot make temporary files in {} (--temp)", dir.display()))?;
    Ok(dir)
}
