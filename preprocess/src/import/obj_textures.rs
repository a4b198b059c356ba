//! An OBJ's textures (`obj.rs` reads them): each material with a `map_Kd` file that exists
//! is a texture (wrap repeat both ways), its faces' corners moved into its band of `v`
//! (`textures.rs`, `shift − v`: OBJ's `v` grows up the image), the faces of the other
//! materials into one band without texture. A corner shared by faces of two materials becomes
//! two wedges: a material border is a seam.

use super::mtl::Material;
use super::textures::{
    file_name, grow, place_corners, place_materials, texture_index, Orientation,
};
use super::RawMesh;
use crate::import::error::ImportErrorKind as K;
use crate::texture_input::{MeshTextures, TextureInput, TextureSource};
use tessera_core::texture::Wrap;

/// The textures of an OBJ's materials and its corners moved into their bands: one band a
/// used material with an existing `map_Kd` (wrap repeat both ways), in the order of the
/// materials, one shared by the faces of the others. `material_of`: each triangle's material
/// (an index into `materials`, `NO_MATERIAL` for none).
pub(super) fn place_obj_textures(
    mesh: &mut RawMesh,
    materials: &[(Material, bool)],
    material_of: &[u32],
) -> Result<MeshTextures, K> {
    let mut used: Vec<u32> = material_of.to_vec();
    used.sort_unstable();
    used.dedup();
    let group = |m: u32| used.binary_search(&m).expect("a used material") as u32;
    let uvs = mesh.uvs.as_ref().expect("textured OBJs keep coordinates");
    let mut ranges = vec![None; used.len()];
    for (t, &m) in mesh.triangles.iter().zip(material_of) {
        for &v in t {
            grow(&mut ranges[group(m) as usize], uvs[v as usize][1]);
        }
    }
    let mut textures = Vec::new();
    let groups: Vec<_> = (used.iter().zip(ranges))
        .map(|(&m, range)| {
            let texture = materials.get(m as usize).and_then(|(material, exists)| {
                let path = material.diffuse_map.as_ref().filter(|_| *exists)?;
                Some(texture_index(
                    &mut textures,
                    TextureInput {
                        name: file_name(path),
                        source: TextureSource::File(path.clone()),
                        wrap_u: Wrap::Repeat,
                        wrap_v: Wrap::Repeat,
                    },
                ))
            });
            (texture, range)
        })
        .collect();
    let (bands, placements) = place_materials(&groups, Orientation::Up)?;
    let group_of: Vec<u32> = material_of.iter().map(|&m| group(m)).collect();
    place_corners(mesh, &group_of, &placements)?;
    Ok(MeshTextures { textures, bands })
}

/// What an OBJ reader does with its materials' textures.
pub(crate) enum ObjTextures<'a> {
    /// Nothing: coordinates as read.
    Ignore,
    /// The triangles' materials (indices into `ObjFacts::materials`, `NO_MATERIAL` for
    /// none) as runs of one material, (first triangle, material): a few bytes a `usemtl`,
    /// not four a triangle.
    Track(&'a mut Vec<(usize, u32)>),
    /// A face of a textured material is an error (the out-of-core import keeps one
    /// coordinate a vertex, and a textured OBJ needs a band a material).
    Refuse,
}

/// A triangle's material when no `usemtl` named a known one.
pub(crate) const NO_MATERIAL: u32 = u32::MAX;
