//! The welded mesh on disk (`StagedMesh`): the staged record files (`staged.rs`) once the
//! external weld (`weld.rs`) has numbered its wedges as the in-memory weld does.

use std::io;
use std::path::Path;

use bytemuck::Pod;

use super::position_file::PositionFile;
use super::staged::{RecordFile, VertexAttributes};
use crate::mesh::InputMesh;

/// A welded, cleaned mesh on disk: the out-of-core counterpart of `InputMesh`, with the same
/// vertex ids and triangle order the in-memory `import::weld` gives.
pub struct StagedMesh {
    pub positions: PositionFile,
    pub triangles: RecordFile<[u32; 3]>,
    pub attributes: VertexAttributes,
    /// What welding did, as `import::ImportReport` counts it.
    pub raw_vertices: u64,
    pub raw_triangles: u64,
    pub welded_vertices: u64,
    pub degenerate_triangles: u64,
    pub duplicate_triangles: u64,
    pub unreferenced_vertices: u64,
    /// The input's textures and bands, as `import::ImportReport::textures` (the import
    /// fills them in; `None` for an input without textures).
    pub textures: Option<crate::texture_input::MeshTextures>,
    /// Texture files the input names that do not exist, as
    /// `import::ImportReport::missing_textures`.
    pub missing_textures: Vec<String>,
}

impl StagedMesh {
    /// Writes a mesh welded in memory (`import::weld`'s report) as record files in `dir`.
    pub fn from_report(report: crate::import::ImportReport, dir: &Path) -> io::Result<StagedMesh> {
        fn write<T: Pod>(records: &[T], dir: &Path) -> io::Result<RecordFile<T>> {
            let mut file = RecordFile::create(dir)?;
            file.push_all(records)?;
            file.finish()
        }
        let mesh = &report.mesh;
        let mut positions = PositionFile::create(dir)?;
        positions.push_all(&mesh.positions)?;
        Ok(StagedMesh {
            positions: positions.finish()?,
            triangles: write(&mesh.triangles, dir)?,
            attributes: VertexAttributes {
                normals: mesh.normals.as_deref().map(|a| write(a, dir)).transpose()?,
                colors: mesh.colors.as_deref().map(|a| write(a, dir)).transpose()?,
                uvs: mesh.uvs.as_deref().map(|a| write(a, dir)).transpose()?,
            },
            raw_vertices: report.raw_vertices as u64,
            raw_triangles: report.raw_triangles as u64,
            welded_vertices: report.welded_vertices as u64,
            degenerate_triangles: report.degenerate_triangles as u64,
            duplicate_triangles: report.duplicate_triangles as u64,
            unreferenced_vertices: report.unreferenced_vertices as u64,
            textures: report.textures,
            missing_textures: report.missing_textures,
        })
    }

    /// Reads the whole mesh into memory (for tests, and for meshes that fit).
    pub fn load(&self) -> io::Result<InputMesh> {
        let (normals, colors, uvs) = self.attributes.read_all()?;
        Ok(InputMesh {
            positions: self.positions.read_all()?,
            triangles: self.triangles.read_all()?,
            normals,
            colors,
            uvs,
        })
    }

    /// Which wedges start a vertex (`mesh.rs`: runs of bit-identical positions), in one pass
    /// over the positions: a bit a wedge in memory, nothing for a mesh without seams.
    pub fn vertex_starts(&self) -> io::Result<crate::mesh::VertexStarts> {
        let mut error = None;
        let mut previous = None;
        let flags = super::fallible::ok_values(self.positions.read()?, &mut error).map(|p| {
            let key = p.map(crate::import::weld::canonical_bits);
            let start = previous != Some(key);
            previous = Some(key);
            start
        });
        let starts = crate::mesh::VertexStarts::from_flags(self.positions.len() as usize, flags);
        super::fallible::check(error)?;
        Ok(starts)
    }

    /// Empties every file (once the build has taken all it needs: their disk space is freed).
    pub fn discard(&self) -> io::Result<()> {
        self.positions.discard()?;
        self.triangles.discard()?;
        let a = &self.attributes;
        if let Some(f) = &a.normals {
            f.discard()?;
        }
        if let Some(f) = &a.colors {
            f.discard()?;
        }
        if let Some(f) = &a.uvs {
            f.discard()?;
        }
        Ok(())
    }

    /// Bytes of its files.
    pub fn bytes(&self) -> u64 {
        let a = &self.attributes;
        self.positions.bytes()
            + self.triangles.bytes()
            + a.normals.as_ref().map_or(0, RecordFile::bytes)
            + a.colors.as_ref().map_or(0, RecordFile::bytes)
            + a.uvs.as_ref().map_or(0, RecordFile::bytes)
    }
}
