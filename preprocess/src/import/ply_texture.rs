//! A PLY's texture, MeshLab's convention: `comment TextureFile NAME` in the header (NAME
//! relative to the PLY's directory) and per-vertex texture coordinates (`texture_u`/`s`/`u`
//! …). One texture, one band over every vertex's `v` (wrap repeat both ways), each `v` stored
//! as `shift − v` (`textures.rs`). Read into memory, the coordinates are moved once the file
//! is read; staged on disk, a first pass finds the range of `v` and the second stages the
//! moved coordinates, so both give the same wedges. A named file that does not exist leaves
//! the mesh untextured and is reported; a PLY read from no directory (standard input, bytes)
//! has no texture.

use std::path::Path;

use tessera_core::texture::Wrap;

use super::error::ImportErrorKind as K;
use super::input::Input;
use super::sink::MeshSink;
use super::textures::{grow, place_materials, FoundTextures, Orientation, Placement, VRange};
use super::{ply, RawMesh};
use crate::external::{RawStaged, RawStager, RawVertex};
use crate::texture_input::{MeshTextures, TextureInput, TextureSource};

/// The texture a header names, resolved against `base`: `Ok` with the texture when the file
/// exists, `Err` with its name for the missing list.
fn resolve(name: &str, base: &Path) -> Result<TextureInput, String> {
    let path = base.join(name.replace('\\', "/"));
    if !path.is_file() {
        return Err(path.display().to_string());
    }
    Ok(TextureInput {
        name: super::textures::file_name(&path),
        source: TextureSource::File(path),
        wrap_u: Wrap::Repeat,
        wrap_v: Wrap::Repeat,
    })
}

/// The band of a PLY whose vertices' `v` span `range`, and its placement.
fn placed(
    texture: TextureInput,
    range: Option<(f32, f32)>,
) -> Result<(FoundTextures, Placement), K> {
    let (bands, placements) = place_materials(&[(Some(0), range)], Orientation::Up)?;
    let found = FoundTextures {
        textures: Some(MeshTextures {
            textures: vec![texture],
            bands,
        }),
        missing: Vec::new(),
    };
    Ok((found, placements[0]))
}

/// A PLY read into memory, its texture's coordinates moved into their band when `base` holds
/// the texture its header names (`textures` off: coordinates as read).
pub(crate) fn read(
    input: &mut Input,
    base: Option<&Path>,
    textures: bool,
) -> Result<(RawMesh, FoundTextures), K> {
    let (mut mesh, name) = ply::read(input)?;
    let (Some(name), Some(base), true) = (name, base, textures) else {
        return Ok((mesh, FoundTextures::default()));
    };
    let texture = match resolve(&name, base) {
        Ok(texture) => texture,
        Err(missing) => {
            let found = FoundTextures {
                textures: None,
                missing: vec![missing],
            };
            return Ok((mesh, found));
        }
    };
    let uvs = mesh
        .uvs
        .as_mut()
        .expect("a texture file is kept only with coordinates");
    let mut range = None;
    uvs.iter().for_each(|uv| grow(&mut range, uv[1]));
    let (found, placement) = placed(texture, range)?;
    uvs.iter_mut().for_each(|uv| *uv = placement.place(*uv));
    Ok((mesh, found))
}

/// Stages vertices with their coordinates moved into a band.
struct PlacedSink {
    inner: RawStager,
    placement: Placement,
}

impl MeshSink for PlacedSink {
    fn vertex(&mut self, v: &RawVertex) -> Result<(), K> {
        let mut v = *v;
        v.uv = self.placement.place(v.uv);
        self.inner.vertex(&v)
    }
    fn triangles(&mut self, t: &[[u32; 3]]) -> Result<(), K> {
        self.inner.triangles(t)
    }
    fn forget_colors(&mut self) {
        MeshSink::forget_colors(&mut self.inner);
    }
    fn face_color(&mut self, triangles: usize, color: [u8; 4]) -> Result<(), K> {
        MeshSink::face_color(&mut self.inner, triangles, color)
    }
}

/// Stages a PLY on disk (`open` opens it again for each pass): as [`read`] does in memory,
/// with a first pass for the range of `v` when the texture it names exists.
pub(crate) fn stage(
    open: impl Fn() -> Result<Input, K>,
    base: &Path,
    dir: &Path,
    textures: bool,
) -> Result<(RawStaged, FoundTextures), K> {
    let stager =
        |d: &super::sink::Declared| RawStager::new(dir, d.normals, d.colors, d.uvs).map_err(K::Io);
    let finish = |s: RawStager| s.finish().map_err(K::Io);
    // The header alone first: a PLY naming no texture is read once.
    let named = textures && super::ply_header::parse_header(&mut open()?)?.2.is_some();
    let name = if named {
        ply::read_into(&mut open()?, |_| Ok(VRange::default()))
            .map(|(sink, name)| name.map(|name| (name, sink.range)))?
    } else {
        None
    };
    let Some((name, range)) = name else {
        let (stager, _) = ply::read_into(&mut open()?, stager)?;
        return Ok((finish(stager)?, FoundTextures::default()));
    };
    let (found, placement) = match resolve(&name, base) {
        Ok(texture) => placed(texture, range)?,
        Err(missing) => {
            let (stager, _) = ply::read_into(&mut open()?, stager)?;
            let found = FoundTextures {
                textures: None,
                missing: vec![missing],
            };
            return Ok((finish(stager)?, found));
        }
    };
    let (sink, _) = ply::read_into(&mut open()?, |d| {
        Ok(PlacedSink {
            inner: stager(d)?,
            placement,
        })
    })?;
    Ok((finish(sink.inner)?, found))
}

/// The textures [`stage`] finds, without staging: the header, then a pass for the range of
/// `v` when the texture it names exists (a resumed build's, whose checkpoint keeps none).
pub(crate) fn find(open: impl Fn() -> Result<Input, K>, base: &Path) -> Result<FoundTextures, K> {
    if super::ply_header::parse_header(&mut open()?)?.2.is_none() {
        return Ok(FoundTextures::default());
    }
    let (sink, name) = ply::read_into(&mut open()?, |_| Ok(VRange::default()))?;
    let Some(name) = name else {
        return Ok(FoundTextures::default());
    };
    match resolve(&name, base) {
        Ok(texture) => Ok(placed(texture, sink.range)?.0),
        Err(missing) => Ok(FoundTextures {
            textures: None,
            missing: vec![missing],
        }),
    }
}
