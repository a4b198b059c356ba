//! Mesh importers: PLY (ASCII and binary), OBJ, OFF, STL (ASCII and binary), glTF/GLB, plain or
//! gzip-compressed (`.ply.gz`, ...). Every importer produces a [`RawMesh`] (polygons
//! fan-triangulated), which [`weld`] turns into the cleaned [`InputMesh`] the builder consumes.
//!
//! ```no_run
//! let report = tessera_preprocess::import::load_mesh("dragon.ply.gz".as_ref())?;
//! println!("{} vertices, {} triangles", report.mesh.positions.len(), report.mesh.triangles.len());
//! # Ok::<(), tessera_preprocess::import::ImportError>(())
//! ```

mod error;
mod gltf;
mod input;
mod obj;
mod off;
mod ply;
mod stl;
mod weld;

use std::io::Read;
use std::path::Path;

pub use error::{ImportError, ImportErrorKind, Location, SUPPORTED_EXTENSIONS};
pub use weld::{weld, RawMesh};

use crate::mesh::InputMesh;
use input::Input;

/// An imported mesh and what cleaning it took.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportReport {
    /// The welded, cleaned mesh.
    pub mesh: InputMesh,
    /// Vertices in the file.
    pub raw_vertices: usize,
    /// Triangles in the file, after fan-triangulating polygons.
    pub raw_triangles: usize,
    /// Vertices removed by welding bit-identical positions.
    pub welded_vertices: usize,
    /// Triangles dropped because two of their corners welded together.
    pub degenerate_triangles: usize,
    /// Triangles dropped because an earlier one has the same three vertices.
    pub duplicate_triangles: usize,
    /// Vertices (after welding) dropped because no kept triangle uses them.
    pub unreferenced_vertices: usize,
}

/// The file formats [`load_mesh`] reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    Ply,
    Obj,
    Off,
    Stl,
    Gltf,
}

impl MeshFormat {
    /// The format of `path` from its extension (case-insensitive), and whether a `.gz` suffix
    /// marks it gzip-compressed.
    pub fn from_path(path: &Path) -> Option<(MeshFormat, bool)> {
        let name = path.file_name()?.to_str()?.to_ascii_lowercase();
        let (name, gz) = match name.strip_suffix(".gz") {
            Some(stem) => (stem, true),
            None => (name.as_str(), false),
        };
        let ext = Path::new(name).extension()?.to_str()?;
        let format = match ext {
            "ply" => MeshFormat::Ply,
            "obj" => MeshFormat::Obj,
            "off" => MeshFormat::Off,
            "stl" => MeshFormat::Stl,
            "gltf" | "glb" => MeshFormat::Gltf,
            _ => return None,
        };
        Some((format, gz))
    }
}

/// Loads the mesh at `path` (format from the extension, see [`SUPPORTED_EXTENSIONS`]), welds and
/// cleans it (see [`weld`]). A mesh with no triangles left is an error.
pub fn load_mesh(path: &Path) -> Result<ImportReport, ImportError> {
    weld_nonempty(load_raw(path)?).map_err(|kind| kind.at_path(path))
}

/// Loads a mesh of `format` from `reader` (a pipe, standard input): the same reader and the
/// same welding as [`load_mesh`] of a file with these bytes, so the same [`ImportReport`].
/// Errors name the input `name`. glTF (not streamable) and `.gz` are not read this way.
pub fn load_mesh_from_reader(
    reader: impl Read + 'static,
    format: MeshFormat,
    name: &str,
) -> Result<ImportReport, ImportError> {
    let mut input = Input::new(Box::new(reader), false, None);
    let raw = match format {
        MeshFormat::Ply => ply::read(&mut input),
        MeshFormat::Obj => obj::read(&mut input),
        MeshFormat::Off => off::read(&mut input),
        MeshFormat::Stl => stl::read(&mut input),
        MeshFormat::Gltf => Err(ImportErrorKind::Unsupported {
            at: Location::None,
            what: "glTF from a stream (give a file)".into(),
        }),
    };
    raw.and_then(validate)
        .and_then(weld_nonempty)
        .map_err(|kind| kind.at_path(name))
}

/// Welds `raw`; a mesh with no triangles left is an error.
fn weld_nonempty(raw: RawMesh) -> Result<ImportReport, ImportErrorKind> {
    let report = weld(raw);
    if report.mesh.triangles.is_empty() {
        return Err(ImportErrorKind::Empty {
            raw_triangles: report.raw_triangles,
            degenerate: report.degenerate_triangles,
            duplicate: report.duplicate_triangles,
        });
    }
    Ok(report)
}

/// Reads the mesh at `path` without welding or cleaning it. Indices are validated and positions
/// are finite.
pub fn load_raw(path: &Path) -> Result<RawMesh, ImportError> {
    read_raw(path).map_err(|kind| kind.at_path(path))
}

fn read_raw(path: &Path) -> Result<RawMesh, ImportErrorKind> {
    let Some((format, gz)) = MeshFormat::from_path(path) else {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let ext = match name.rfind('.') {
            Some(i) => name[i..].to_string(),
            None => "(no extension)".to_string(),
        };
        return Err(ImportErrorKind::UnsupportedExtension(ext));
    };
    let raw = match format {
        MeshFormat::Gltf => {
            let bytes = if gz {
                Input::open(path, true)?.read_to_end()?
            } else {
                std::fs::read(path).map_err(ImportErrorKind::Io)?
            };
            gltf::read(&bytes, path.parent())?
        }
        _ => {
            let mut input = Input::open(path, gz)?;
            match format {
                MeshFormat::Ply => ply::read(&mut input)?,
                MeshFormat::Obj => obj::read(&mut input)?,
                MeshFormat::Off => off::read(&mut input)?,
                MeshFormat::Stl => stl::read(&mut input)?,
                MeshFormat::Gltf => unreachable!(),
            }
        }
    };
    validate(raw)
}

/// The readers check as they go (with line numbers); this catches anything they missed.
fn validate(raw: RawMesh) -> Result<RawMesh, ImportErrorKind> {
    for (i, p) in raw.positions.iter().enumerate() {
        input::check_finite(*p, i as u64, || Location::None)?;
    }
    let n = raw.positions.len() as u64;
    if let Some((i, &v)) = raw
        .triangles
        .iter()
        .flatten()
        .enumerate()
        .find(|(_, &v)| v as u64 >= n)
    {
        return Err(ImportErrorKind::IndexOutOfRange {
            at: Location::Record("triangle".into(), i as u64 / 3),
            index: v as i64,
            count: n,
        });
    }
    Ok(raw)
}
