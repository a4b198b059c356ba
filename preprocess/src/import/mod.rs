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
pub mod mtl;
mod obj;
mod obj_textures;
mod off;
mod ply;
mod ply_header;
mod ply_texture;
mod sink;
mod stl;
mod textures;
pub(crate) mod weld;

use std::io::Read;
use std::path::Path;

pub use error::{ImportError, ImportErrorKind, Location, SUPPORTED_EXTENSIONS};
pub use weld::{weld, RawMesh};

use crate::mesh::InputMesh;
use crate::texture_input::MeshTextures;
use input::Input;
use textures::FoundTextures;

/// How the importers read a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImportOptions {
    /// Read the textures the input names (OBJ `map_Kd`, glTF `baseColorTexture`, PLY
    /// `comment TextureFile`) and move each material's `v` into its band
    /// (`texture_input.rs`); off: texture coordinates as the file has them, no textures.
    pub textures: bool,
}

impl Default for ImportOptions {
    fn default() -> Self {
        ImportOptions { textures: true }
    }
}

/// An imported mesh and what cleaning it took.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportReport {
    /// The welded, cleaned mesh.
    pub mesh: InputMesh,
    /// Vertices in the file (an OBJ read into memory: and one for each further `vt`/`vn`
    /// combination of a vertex's face corners whose kept attributes differ, `obj.rs`).
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
    /// The input's textures and the bands its wedges' `v` were moved into; `None` for an
    /// input without textures (or read without them), whose coordinates are as in the file.
    pub textures: Option<MeshTextures>,
    /// Texture files the input names that do not exist (paths as resolved): their materials
    /// are drawn untextured.
    pub missing_textures: Vec<String>,
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
    load_mesh_with(path, &ImportOptions::default())
}

/// [`load_mesh`] with `options` (without textures: the mesh as before textures were read).
pub fn load_mesh_with(path: &Path, options: &ImportOptions) -> Result<ImportReport, ImportError> {
    read_raw(path, options)
        .and_then(|(raw, found)| Ok((check_raw(raw)?, found)))
        .and_then(finish)
        .map_err(|kind| kind.at_path(path))
}

/// Loads a mesh from `bytes` held in memory as if they were the file `name` (format from its
/// extension, `.gz` decompressed): the same readers, checks, welding and cleaning as
/// [`load_mesh`], and errors name `name`. A glTF's external buffers (`uri` naming a file) are
/// refused, since there is no directory to look them up in; `data:` URIs and GLB chunks work.
pub fn load_mesh_bytes(name: &Path, bytes: &[u8]) -> Result<ImportReport, ImportError> {
    read_raw_bytes(name, bytes)
        .and_then(finish)
        .map_err(|kind| kind.at_path(name))
}

/// An OBJ's bytes as [`load_mesh_bytes`] reads them, except that every `mtllib` it names
/// reads `library` (the fuzz target passes the OBJ itself: `newmtl`/`Kd` lines are skipped by
/// the OBJ reader, `v`/`f` lines by the MTL one).
pub(crate) fn load_obj_bytes_with_library(
    name: &Path,
    bytes: &[u8],
    library: &[u8],
) -> Result<ImportReport, ImportError> {
    let libraries = obj::Libraries::Bytes(library);
    obj::read(
        &mut Input::from_bytes(bytes.to_vec(), false),
        libraries,
        false,
    )
    .and_then(|(raw, found)| Ok((check_raw(raw)?, found)))
    .and_then(finish)
    .map_err(|kind| kind.at_path(name))
}

/// Loads a mesh of `format` from `reader` (a pipe, standard input): the same reader and the
/// same welding as [`load_mesh`] of a file with these bytes, so the same [`ImportReport`].
/// Errors name the input `name`. glTF (its buffers are read at offsets) and `.gz` are not
/// read this way.
pub fn load_mesh_from_reader(
    reader: impl Read + 'static,
    format: MeshFormat,
    name: &str,
) -> Result<ImportReport, ImportError> {
    let raw = match format {
        MeshFormat::Gltf => Err(ImportErrorKind::Unsupported {
            at: Location::None,
            what: "glTF from a stream (give a file)".into(),
        }),
        _ => read_stream(format, &mut Input::new(Box::new(reader), false, None)),
    };
    raw.and_then(check_raw)
        .and_then(|raw| finish((raw, FoundTextures::default())))
        .map_err(|kind| kind.at_path(name))
}

/// Stages the mesh at `path` on disk (the out-of-core build's import): streamed once into
/// record files in `dir`, then welded and cleaned by `external::weld_within_budget` with about
/// `budget` bytes of memory — the same mesh, ids and counts as [`load_mesh`]. PLY, OFF, STL
/// and OBJ (plain or `.gz`) stream through the same readers as [`load_mesh`]'s (an OBJ's
/// texture coordinates and normals, indexed apart from its positions, are joined into
/// vertex order by external sorts); a glTF's buffers are read by chunks from its file (a
/// gzipped glTF is read whole first). A mesh with no triangles left
/// is an error. Its textures are `StagedMesh::textures`, as [`load_mesh`] finds them (a
/// textured OBJ is refused: it needs a band a material, and this import keeps one texture
/// coordinate a vertex).
pub fn stage_mesh(
    path: &Path,
    dir: &Path,
    budget: usize,
) -> Result<crate::external::StagedMesh, ImportError> {
    stage_mesh_with(path, dir, budget, &ImportOptions::default())
}

/// [`stage_mesh`] with `options` (without textures: the mesh as before textures were read).
pub fn stage_mesh_with(
    path: &Path,
    dir: &Path,
    budget: usize,
    options: &ImportOptions,
) -> Result<crate::external::StagedMesh, ImportError> {
    let at = |kind: ImportErrorKind| kind.at_path(path);
    let (format, gz) = format_of(path).map_err(at)?;
    let stager = |d: &sink::Declared| {
        crate::external::RawStager::new(dir, d.normals, d.colors, d.uvs)
            .map_err(ImportErrorKind::Io)
    };
    let finish = |stager: crate::external::RawStager| stager.finish().map_err(ImportErrorKind::Io);
    let open = || Input::open(path, gz);
    let whole = || {
        let (raw, found) = read_raw(path, options)?;
        let staged = crate::external::RawStaged::from_raw(&check_raw(raw)?, dir);
        Ok((staged.map_err(ImportErrorKind::Io)?, found))
    };
    let none = |raw| Ok((raw, FoundTextures::default()));
    let textures = options.textures;
    let (raw, found) = match format {
        MeshFormat::Ply => ply_texture::stage(open, base_of(path), dir, textures),
        MeshFormat::Off => off::read_into(&mut open().map_err(at)?, stager)
            .and_then(finish)
            .and_then(none),
        MeshFormat::Stl => stl::read_into(&mut open().map_err(at)?, stager)
            .and_then(finish)
            .and_then(none),
        MeshFormat::Obj => {
            let base = base_of(path);
            stage_obj(&mut open().map_err(at)?, base, dir, budget, textures)
        }
        MeshFormat::Gltf if gz => whole(),
        MeshFormat::Gltf => gltf::read_file(path, stager, textures)
            .and_then(|(stager, found)| Ok((finish(stager)?, found))),
    }
    .map_err(at)?;
    let mut staged = weld_staged(raw, dir, budget).map_err(at)?;
    staged.textures = found.textures;
    staged.missing_textures = found.missing;
    Ok(staged)
}

/// [`stage_mesh`] of a PLY (ASCII or binary) read from `reader` (standard input), named
/// `name` in messages.
pub fn stage_ply_from_reader(
    reader: impl Read + 'static,
    name: &str,
    dir: &Path,
    budget: usize,
) -> Result<crate::external::StagedMesh, ImportError> {
    let at = |kind: ImportErrorKind| kind.at_path(name);
    let input = &mut Input::new(Box::new(reader), false, None);
    let raw = ply::read_into(input, |d| {
        crate::external::RawStager::new(dir, d.normals, d.colors, d.uvs)
            .map_err(ImportErrorKind::Io)
    })
    .and_then(|(stager, _)| stager.finish().map_err(ImportErrorKind::Io))
    .map_err(at)?;
    weld_staged(raw, dir, budget).map_err(at)
}

/// An OBJ streamed to disk: positions and colours through the stager, texture coordinates
/// and normals through `CornerStager`, joined into vertex order when the file keeps them;
/// the `map_Kd` files its faces' materials name that do not exist (a textured face refused).
fn stage_obj(
    input: &mut Input,
    base: &Path,
    dir: &Path,
    budget: usize,
    textures: bool,
) -> Result<(crate::external::RawStaged, FoundTextures), ImportErrorKind> {
    let io = ImportErrorKind::Io;
    let colored =
        |colors: bool| crate::external::RawStager::new(dir, false, colors, false).map_err(io);
    let mut corners = crate::external::corner_attributes::CornerStager::new(dir).map_err(io)?;
    let libraries = obj::Libraries::Dir(base);
    let mode = match textures {
        true => obj::ObjTextures::Refuse,
        false => obj::ObjTextures::Ignore,
    };
    let (stager, facts) = obj::read_into(input, libraries, colored, &mut corners, mode)?;
    let mut raw = stager.finish().map_err(io)?;
    let (uvs, normals) = corners
        .finish(
            facts.vertices,
            facts.all_vt && facts.triangles,
            facts.all_vn && facts.triangles,
            budget,
        )
        .map_err(io)?;
    raw.attributes.uvs = uvs;
    raw.attributes.normals = normals;
    let found = FoundTextures {
        textures: None,
        missing: facts.missing,
    };
    Ok((raw, found))
}

fn weld_staged(
    raw: crate::external::RawStaged,
    dir: &Path,
    budget: usize,
) -> Result<crate::external::StagedMesh, ImportErrorKind> {
    let staged =
        crate::external::weld_within_budget(raw, budget, dir).map_err(ImportErrorKind::Io)?;
    if staged.triangles.is_empty() {
        return Err(ImportErrorKind::Empty {
            raw_triangles: staged.raw_triangles as usize,
            degenerate: staged.degenerate_triangles as usize,
            duplicate: staged.duplicate_triangles as usize,
        });
    }
    Ok(staged)
}

/// The textures [`stage_mesh_with`] reports for the file at `path`, without staging it (a
/// resumed out-of-core build's: its checkpoint keeps the staged mesh, not its textures). An
/// OBJ's: `None` and its missing `map_Kd` files (a textured one: the error staging gives).
pub fn find_textures(
    path: &Path,
    options: &ImportOptions,
) -> Result<(Option<MeshTextures>, Vec<String>), ImportError> {
    let at = |kind: ImportErrorKind| kind.at_path(path);
    let (format, gz) = format_of(path).map_err(at)?;
    if !options.textures {
        return Ok((None, Vec::new()));
    }
    let open = || Input::open(path, gz);
    let base = base_of(path);
    let found = match format {
        MeshFormat::Ply => ply_texture::find(open, base),
        MeshFormat::Gltf if gz => read_raw(path, options).map(|(_, found)| found),
        MeshFormat::Gltf => {
            let sink = |_: &sink::Declared| Ok(textures::VRange::default());
            gltf::read_file(path, sink, true).map(|(_, found)| found)
        }
        MeshFormat::Obj => {
            let libraries = obj::Libraries::Dir(base);
            let sink = |_| Ok(textures::VRange::default());
            let mut corners = obj::NoCorners;
            (open().and_then(|mut input| {
                obj::read_into(
                    &mut input,
                    libraries,
                    sink,
                    &mut corners,
                    obj::ObjTextures::Refuse,
                )
            }))
            .map(|(_, facts)| FoundTextures {
                textures: None,
                missing: facts.missing,
            })
        }
        MeshFormat::Off | MeshFormat::Stl => Ok(FoundTextures::default()),
    }
    .map_err(at)?;
    Ok((found.textures, found.missing))
}

/// Welds and cleans; a mesh with no triangles left is an error.
fn finish((raw, found): (RawMesh, FoundTextures)) -> Result<ImportReport, ImportErrorKind> {
    let mut report = weld(raw);
    report.textures = found.textures;
    report.missing_textures = found.missing;
    if report.mesh.triangles.is_empty() {
        return Err(ImportErrorKind::Empty {
            raw_triangles: report.raw_triangles,
            degenerate: report.degenerate_triangles,
            duplicate: report.duplicate_triangles,
        });
    }
    Ok(report)
}

/// Reads the mesh at `path` without welding or cleaning it, its texture coordinates as the
/// file has them (no textures). Indices are validated and positions are finite.
pub fn load_raw(path: &Path) -> Result<RawMesh, ImportError> {
    let options = ImportOptions { textures: false };
    read_raw(path, &options)
        .and_then(|(raw, _)| check_raw(raw))
        .map_err(|kind| kind.at_path(path))
}

/// The format of `path`, or the unsupported-extension error.
fn format_of(path: &Path) -> Result<(MeshFormat, bool), ImportErrorKind> {
    MeshFormat::from_path(path).ok_or_else(|| {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let ext = match name.rfind('.') {
            Some(i) => name[i..].to_string(),
            None => "(no extension)".to_string(),
        };
        ImportErrorKind::UnsupportedExtension(ext)
    })
}

/// Reads the mesh at `path` (unchecked: the caller runs [`check_raw`]) and its textures.
fn read_raw(
    path: &Path,
    options: &ImportOptions,
) -> Result<(RawMesh, FoundTextures), ImportErrorKind> {
    let (format, gz) = format_of(path)?;
    let textures = options.textures;
    let base = base_of(path);
    Ok(match format {
        MeshFormat::Gltf if gz => gltf::read(
            &Input::open(path, true)?.read_to_end()?,
            Some(base),
            textures,
        )?,
        MeshFormat::Gltf => gltf::read_file(path, |d| Ok(sink::in_memory(d)), textures)?,
        MeshFormat::Obj => {
            let libraries = obj::Libraries::Dir(base);
            obj::read(&mut Input::open(path, gz)?, libraries, textures)?
        }
        MeshFormat::Ply => ply_texture::read(&mut Input::open(path, gz)?, Some(base), textures)?,
        _ => (
            read_stream(format, &mut Input::open(path, gz)?)?,
            FoundTextures::default(),
        ),
    })
}

/// The directory of `path`, where the files it names are looked up (`.` for a bare name).
fn base_of(path: &Path) -> &Path {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    }
}

/// Bytes from no directory: only a glTF's embedded images are textures.
fn read_raw_bytes(name: &Path, bytes: &[u8]) -> Result<(RawMesh, FoundTextures), ImportErrorKind> {
    let (format, gz) = format_of(name)?;
    let (raw, found) = match format {
        MeshFormat::Gltf if gz => {
            let bytes = Input::from_bytes(bytes.to_vec(), true).read_to_end()?;
            gltf::read(&bytes, None, true)?
        }
        MeshFormat::Gltf => gltf::read(bytes, None, true)?,
        _ => {
            let raw = read_stream(format, &mut Input::from_bytes(bytes.to_vec(), gz))?;
            (raw, FoundTextures::default())
        }
    };
    Ok((check_raw(raw)?, found))
}

/// The streaming readers (every format but glTF).
fn read_stream(format: MeshFormat, input: &mut Input) -> Result<RawMesh, ImportErrorKind> {
    match format {
        MeshFormat::Ply => ply::read(input).map(|(raw, _)| raw),
        MeshFormat::Obj => obj::read(input, obj::Libraries::None, false).map(|(raw, _)| raw),
        MeshFormat::Off => off::read(input),
        MeshFormat::Stl => stl::read(input),
        MeshFormat::Gltf => unreachable!("glTF is read from a file or bytes, not a stream"),
    }
}

/// The readers check as they go (with line numbers); this catches anything they missed.
fn check_raw(raw: RawMesh) -> Result<RawMesh, ImportErrorKind> {
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
