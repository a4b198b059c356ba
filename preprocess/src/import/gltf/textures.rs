//! A glTF's textures: the `baseColorTexture` of each triangle primitive's material, its image
//! from a buffer view (a GLB's binary chunk), a `data:` URI or a file beside the `.gltf`
//! (percent-decoded; missing: the material is untextured and the file reported), its
//! sampler's wrap (`REPEAT` and `MIRRORED_REPEAT` as `Wrap::Repeat`: mirroring is not drawn,
//! a mirrored tile samples as the plain one; `CLAMP_TO_EDGE` as `Wrap::Clamp`).
//!
//! A material's primitives take one band of `v` (`import/textures.rs`; glTF's `v` already
//! grows down the image, so it is only shifted, never negated). A material whose texture reads
//! another coordinate set (`texCoord` ≠ 0), whose image cannot be found, or a primitive
//! without `TEXCOORD_0`, is drawn untextured, in the band shared by every material without a
//! texture. A file with no textured primitive keeps its coordinates as read.

use std::path::Path;

use ::gltf::mesh::Semantic;
use ::gltf::texture::WrappingMode;
use ::gltf::{Document, Mesh, Primitive};
use rustc_hash::FxHashMap;
use tessera_core::texture::Wrap;

use super::container::{percent_decode, Bytes};
use super::{accessor, err, triangle_primitives, Attribute, Mat4, CHUNK};
use crate::import::error::{ImportErrorKind as K, Location};
use crate::import::textures::{
    file_name, grow, place_materials, texture_index, FoundTextures, Orientation, Placement,
};
use crate::texture_input::{MeshTextures, TextureInput, TextureSource};

/// Which band a primitive's vertices take: by its material (`None`: the default one) and
/// whether it has readable texture coordinates.
type GroupKey = (Option<usize>, bool);

/// Each primitive group's placement, for `stream_primitive`.
pub(super) struct Placements {
    by_group: FxHashMap<GroupKey, Placement>,
}

impl Placements {
    pub fn of(&self, prim: &Primitive) -> Option<&Placement> {
        self.by_group.get(&group_key(prim))
    }
}

fn group_key(prim: &Primitive) -> GroupKey {
    let uvs = super::attribute(prim, Semantic::TexCoords(0)).is_some();
    (prim.material().index(), uvs)
}

fn wrap(mode: WrappingMode) -> Wrap {
    match mode {
        WrappingMode::ClampToEdge => Wrap::Clamp,
        WrappingMode::Repeat | WrappingMode::MirroredRepeat => Wrap::Repeat,
    }
}

/// Where image `index`'s bytes are: `Ok(None)` with its name pushed to `missing` when its
/// file does not exist (or the bytes come from no directory).
fn image_source(
    document: &Document,
    index: usize,
    buffers: &[Bytes],
    base: Option<&Path>,
    missing: &mut Vec<String>,
) -> Result<Option<(String, TextureSource)>, K> {
    let at = || Location::Other(format!("image {index}"));
    let json = &document.as_json().images[index];
    let mime = json.mime_type.as_ref().map(|m| m.0.clone());
    if let Some(view) = &json.buffer_view {
        let view = (document.views().nth(view.value()))
            .ok_or_else(|| err(at(), "its buffer view does not exist"))?;
        let buffer = (buffers.get(view.buffer().index()))
            .ok_or_else(|| err(at(), "its buffer does not exist"))?;
        let (offset, len) = (view.offset() as u64, view.length() as u64);
        if offset.checked_add(len).is_none_or(|end| end > buffer.len()) {
            return Err(err(at(), "its buffer view runs past its buffer"));
        }
        let mut bytes = vec![0; len as usize];
        (buffer.read_at(offset, &mut bytes)).map_err(|e| err(at(), format!("cannot read: {e}")))?;
        let source = TextureSource::Encoded { bytes, mime };
        return Ok(Some((format!("image {index}"), source)));
    }
    let Some(uri) = &json.uri else {
        return Err(err(at(), "neither a buffer view nor a URI"));
    };
    if let Some(rest) = uri.strip_prefix("data:") {
        use base64::Engine as _;
        let (header, payload) = (rest.split_once(";base64,"))
            .ok_or_else(|| err(at(), "unsupported data URI (not base64)"))?;
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map_err(|e| err(at(), format!("bad base64: {e}")))?;
        let mime = Some(header.to_string()).filter(|h| !h.is_empty()).or(mime);
        let source = TextureSource::Encoded { bytes, mime };
        return Ok(Some((format!("image {index}"), source)));
    }
    let Some(base) = base else {
        missing.push(uri.clone());
        return Ok(None);
    };
    let path = base.join(percent_decode(uri));
    if !path.is_file() {
        let name = path.display().to_string();
        if !missing.contains(&name) {
            missing.push(name);
        }
        return Ok(None);
    }
    Ok(Some((file_name(&path), TextureSource::File(path))))
}

/// The texture of a material's base colour, when it reads `TEXCOORD_0` and its image exists.
fn material_texture(
    document: &Document,
    material: &::gltf::Material,
    buffers: &[Bytes],
    base: Option<&Path>,
    missing: &mut Vec<String>,
) -> Result<Option<TextureInput>, K> {
    let Some(info) = material.pbr_metallic_roughness().base_color_texture() else {
        return Ok(None);
    };
    if info.tex_coord() != 0 {
        return Ok(None);
    }
    let texture = info.texture();
    let index = texture.source().index();
    let Some((name, source)) = image_source(document, index, buffers, base, missing)? else {
        return Ok(None);
    };
    let sampler = texture.sampler();
    Ok(Some(TextureInput {
        name,
        source,
        wrap_u: wrap(sampler.wrap_s()),
        wrap_v: wrap(sampler.wrap_t()),
    }))
}

/// The textures of `instances`' primitives and each primitive group's band; `None` where
/// no primitive is textured.
pub(super) fn find(
    document: &Document,
    instances: &[(Mesh, Mat4)],
    buffers: &[Bytes],
    base: Option<&Path>,
) -> Result<(FoundTextures, Option<Placements>), K> {
    let mut missing = Vec::new();
    let mut textures = Vec::new();
    // Groups in the order of their first primitive, with their texture.
    let mut groups: Vec<(GroupKey, Option<u32>)> = Vec::new();
    let mut by_material: FxHashMap<Option<usize>, Option<TextureInput>> = FxHashMap::default();
    for (mesh, _) in instances {
        for prim in triangle_primitives(mesh) {
            let key = group_key(&prim);
            if groups.iter().any(|(k, _)| *k == key) {
                continue;
            }
            if let std::collections::hash_map::Entry::Vacant(e) = by_material.entry(key.0) {
                let material = prim.material();
                e.insert(material_texture(
                    document,
                    &material,
                    buffers,
                    base,
                    &mut missing,
                )?);
            }
            let texture = (by_material[&key.0].clone())
                .filter(|_| key.1)
                .map(|t| texture_index(&mut textures, t));
            groups.push((key, texture));
        }
    }
    if textures.is_empty() {
        return Ok((
            FoundTextures {
                textures: None,
                missing,
            },
            None,
        ));
    }
    let mut ranges = vec![None; groups.len()];
    for (mesh, _) in instances {
        for prim in triangle_primitives(mesh) {
            let key = group_key(&prim);
            let g = groups.iter().position(|(k, _)| *k == key).expect("listed");
            if groups[g].1.is_none() {
                continue;
            }
            let at =
                || Location::Other(format!("mesh {} primitive {}", mesh.index(), prim.index()));
            let read = |e: std::io::Error| err(at(), format!("cannot read: {e}"));
            let mut uvs = Attribute::open(&prim, Semantic::TexCoords(0), true, buffers)
                .map_err(read)?
                .expect("a textured group has coordinates");
            loop {
                let got = uvs.fill(CHUNK).map_err(read)?;
                if got == 0 {
                    break;
                }
                for k in 0..got {
                    let uv = accessor::tex_coord(uvs.get(k).expect("a whole chunk"), uvs.ty);
                    grow(&mut ranges[g], uv[1]);
                }
            }
        }
    }
    let materials: Vec<_> = (groups.iter().zip(ranges))
        .map(|((_, texture), range)| (*texture, range))
        .collect();
    let (bands, placements) = place_materials(&materials, Orientation::Down)?;
    let by_group = (groups.iter().zip(placements))
        .map(|((key, _), p)| (*key, p))
        .collect();
    let found = FoundTextures {
        textures: Some(MeshTextures { textures, bands }),
        missing,
    };
    Ok((found, Some(Placements { by_group })))
}
