//! The viewer's cut as binary glTF 2.0 (`.glb`): one mesh, one node. glTF positions are f32,
//! so they are written relative to the cut's bounding-box centre, which the node's
//! translation carries (in JSON, at full f64 precision as text); normals (unit), colours
//! (RGBA8, normalised) and UVs as the cut has them; u32 indices. A textured repository's cut
//! (`export_textures.rs`) is one primitive a band, each with its material's texture embedded
//! as PNG, its coordinates out of their bands.

use std::io::Write;
use std::path::Path;

use serde_json::json;
use tessera_core::repository::cut_mesh::CutMesh;
use tessera_core::texture::Wrap;

use super::export_textures::{unbanded_v, ExportTextures};

use crate::output::write_atomically;

const FLOAT: u32 = 5126;
const UNSIGNED_BYTE: u32 = 5121;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const LINEAR: u32 = 9729;
const LINEAR_MIPMAP_LINEAR: u32 = 9987;

fn wrap_code(wrap: Wrap) -> u32 {
    match wrap {
        Wrap::Repeat => 10497,
        Wrap::Clamp => 33071,
    }
}

/// The GLB bytes of `mesh`, with `textures` where its repository has them.
pub fn glb_bytes(mesh: &CutMesh, textures: Option<&ExportTextures>) -> Vec<u8> {
    let n = mesh.vertex_count();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &mesh.positions {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    let centre = if n == 0 {
        [0.0; 3]
    } else {
        [0, 1, 2].map(|i| 0.5 * (lo[i] + hi[i]))
    };
    let mut bin = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut attributes = serde_json::Map::new();
    // One buffer view per array, 4-aligned; `target` 0 for none.
    let mut push = |bin: &mut Vec<u8>, bytes: &[u8], target: u32| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let mut view = json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()});
        // Images are read by the loader, not bound to a vertex or index target.
        if target != 0 {
            view["target"] = json!(target);
        }
        views.push(view);
        bin.extend_from_slice(bytes);
        views.len() - 1
    };
    let local: Vec<[f32; 3]> = (mesh.positions.iter())
        .map(|p| [0, 1, 2].map(|i| (p[i] - centre[i]) as f32))
        .collect();
    let (mut lmin, mut lmax) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in &local {
        for i in 0..3 {
            lmin[i] = lmin[i].min(p[i]);
            lmax[i] = lmax[i].max(p[i]);
        }
    }
    let view = push(&mut bin, bytemuck::cast_slice(&local), ARRAY_BUFFER);
    accessors.push(
        json!({"bufferView": view, "componentType": FLOAT, "count": n,
        "type": "VEC3", "min": lmin, "max": lmax}),
    );
    attributes.insert("POSITION".into(), json!(accessors.len() - 1));
    if let Some(normals) = &mesh.normals {
        let view = push(&mut bin, bytemuck::cast_slice(normals), ARRAY_BUFFER);
        accessors.push(
            json!({"bufferView": view, "componentType": FLOAT, "count": n,
            "type": "VEC3"}),
        );
        attributes.insert("NORMAL".into(), json!(accessors.len() - 1));
    }
    if let Some(colors) = &mesh.colors {
        let view = push(&mut bin, bytemuck::cast_slice(colors), ARRAY_BUFFER);
        accessors.push(json!({"bufferView": view, "componentType": UNSIGNED_BYTE,
            "normalized": true, "count": n, "type": "VEC4"}));
        attributes.insert("COLOR_0".into(), json!(accessors.len() - 1));
    }
    if let Some(uvs) = &mesh.uvs {
        let unbanded: Vec<[f32; 2]>;
        let uvs = match textures {
            Some(t) => {
                unbanded = (uvs.iter())
                    .map(|&[u, v]| [u, unbanded_v(&t.bands, v)])
                    .collect();
                &unbanded
            }
            None => uvs,
        };
        let view = push(&mut bin, bytemuck::cast_slice(uvs), ARRAY_BUFFER);
        accessors.push(
            json!({"bufferView": view, "componentType": FLOAT, "count": n,
            "type": "VEC2"}),
        );
        attributes.insert("TEXCOORD_0".into(), json!(accessors.len() - 1));
    }
    // One primitive a band (triangles by their first corner's band), or one for the whole cut.
    let groups: Vec<(Option<usize>, Vec<u32>)> = match (textures, &mesh.uvs) {
        (Some(t), Some(uvs)) => {
            let bands = t.vertex_bands(uvs);
            let mut groups: Vec<(Option<usize>, Vec<u32>)> = Vec::new();
            for tri in mesh.indices.chunks_exact(3) {
                let band = bands[tri[0] as usize];
                match groups.iter_mut().find(|(b, _)| *b == band) {
                    Some((_, indices)) => indices.extend_from_slice(tri),
                    None => groups.push((band, tri.to_vec())),
                }
            }
            groups.sort_by_key(|(b, _)| *b);
            groups
        }
        _ => vec![(None, mesh.indices.clone())],
    };
    let mut primitives = Vec::new();
    let mut materials = Vec::new();
    for (band, indices) in &groups {
        let view = push(
            &mut bin,
            bytemuck::cast_slice(indices),
            ELEMENT_ARRAY_BUFFER,
        );
        accessors.push(json!({"bufferView": view, "componentType": UNSIGNED_INT,
            "count": indices.len(), "type": "SCALAR"}));
        let mut primitive =
            json!({"attributes": attributes, "indices": accessors.len() - 1, "mode": 4});
        if let (Some(t), Some(band)) = (textures, band) {
            let mut pbr = json!({"metallicFactor": 0.0});
            if let Some(texture) = t.band_texture(*band) {
                pbr["baseColorTexture"] = json!({"index": texture});
            }
            materials.push(json!({"pbrMetallicRoughness": pbr}));
            primitive["material"] = json!(materials.len() - 1);
        }
        primitives.push(primitive);
    }
    let mut images = Vec::new();
    let mut gltf_textures = Vec::new();
    let mut samplers = Vec::new();
    for (i, texture) in textures.iter().flat_map(|t| &t.textures).enumerate() {
        let view = push(&mut bin, &texture.png, 0);
        images.push(json!({"bufferView": view, "mimeType": "image/png"}));
        samplers.push(
            json!({"magFilter": LINEAR, "minFilter": LINEAR_MIPMAP_LINEAR,
            "wrapS": wrap_code(texture.wrap_u), "wrapT": wrap_code(texture.wrap_v)}),
        );
        gltf_textures.push(json!({"source": i, "sampler": i}));
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let mut gltf = json!({
        "asset": {"version": "2.0", "generator": "tessera view (the cut)"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "translation": centre}],
        "meshes": [{"primitives": primitives}],
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": views,
        "accessors": accessors,
    });
    if !materials.is_empty() {
        gltf["materials"] = json!(materials);
    }
    if !images.is_empty() {
        gltf["images"] = json!(images);
        gltf["textures"] = json!(gltf_textures);
        gltf["samplers"] = json!(samplers);
    }
    let mut text = serde_json::to_vec(&gltf).expect("JSON of plain values");
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// Writes `mesh` (with `textures`, if any) as a `.glb` through a temporary file and a rename.
pub fn write_glb(
    mesh: &CutMesh,
    textures: Option<&ExportTextures>,
    path: &Path,
) -> anyhow::Result<()> {
    let bytes = glb_bytes(mesh, textures);
    if bytes.len() > u32::MAX as usize {
        anyhow::bail!(
            "the cut is {} bytes as glTF, over the format's 4 GiB: export it as .ply",
            bytes.len()
        );
    }
    write_atomically(path, |_, file| {
        file.write_all(&bytes)?;
        file.sync_all()?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tesseras_gltf_importer_reads_the_glb_back() {
        let base = [1.0e6 + 0.5, -2.0e5, 3.0];
        let mesh = CutMesh {
            positions: vec![
                base,
                [base[0] + 1.0, base[1], base[2]],
                [base[0], base[1] + 1.0, base[2]],
                [base[0], base[1], base[2] + 1.0],
            ],
            normals: Some(vec![[0.0, 0.0, 1.0]; 4]),
            colors: Some(vec![[10, 20, 30, 255]; 4]),
            uvs: Some(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.5]]),
            indices: vec![0, 2, 1, 0, 1, 3, 1, 2, 3, 2, 0, 3],
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cut.glb");
        write_glb(&mesh, None, &path).unwrap();
        let back = tessera_preprocess::import::load_mesh(&path).unwrap().mesh;
        assert_eq!(back.triangles.len(), 4);
        assert_eq!(back.positions.len(), 4);
        for p in &mesh.positions {
            assert!(
                back.positions
                    .iter()
                    .any(|q| (0..3).all(|i| (p[i] - q[i]).abs() < 1e-6)),
                "{p:?} not found in {:?}",
                back.positions
            );
        }
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[..4], b"glTF");
        assert_eq!(
            u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
            bytes.len()
        );
    }
}
