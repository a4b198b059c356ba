//! Importers and textures (`texture_input.rs`): the textures each format names, the bands of
//! `v` each material's corners are moved into, and inputs without textures left as they were.

use std::path::{Path, PathBuf};

use tessera_core::texture::{band_of, bands_valid, Band, Wrap, NO_TEXTURE};
use tessera_preprocess::import::{
    find_textures, load_mesh, load_mesh_with, stage_mesh, stage_mesh_with, ImportOptions,
    ImportReport,
};
use tessera_preprocess::mesh::InputMesh;
use tessera_preprocess::texture_input::{MeshTextures, TextureSource};

const WITHOUT: ImportOptions = ImportOptions { textures: false };

fn testdata(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata/mesh")
        .join(name)
}

fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn load(path: &Path, options: &ImportOptions) -> ImportReport {
    load_mesh_with(path, options).unwrap_or_else(|e| panic!("{e}"))
}

/// The corners of each triangle, as (position, uv): the weld numbers wedges apart in the two
/// imports, the corners stay in the same order.
fn corners(mesh: &InputMesh) -> Vec<([f64; 3], [f32; 2])> {
    let uvs = mesh.uvs.as_ref().expect("coordinates");
    (mesh.triangles.iter().flatten())
        .map(|&w| (mesh.positions[w as usize], uvs[w as usize]))
        .collect()
}

/// Checks the textured import against the plain one, corner by corner: every `v` inside a
/// band; a textured band's `v − shift` is the input's `v` negated (`up`: OBJ, PLY) or as it
/// is (glTF) within f32 rounding, `u` unchanged; an untextured band's corner is
/// `(0, start + 0.5)`. Returns each triangle's band.
fn check_bands(textured: &ImportReport, plain: &ImportReport, up: bool) -> Vec<Band> {
    let t = textured.textures.as_ref().expect("textures");
    assert!(
        bands_valid(&t.bands, t.textures.len() as u32),
        "{:?}",
        t.bands
    );
    assert!(plain.textures.is_none());
    let (a, b) = (corners(&textured.mesh), corners(&plain.mesh));
    assert_eq!(a.len(), b.len(), "the same triangles");
    let mut bands = Vec::new();
    for (k, ((p, uv), (q, input))) in a.iter().zip(&b).enumerate() {
        assert_eq!(p, q, "corner {k}: the same position");
        let band = *band_of(&t.bands, uv[1]).unwrap_or_else(|| panic!("corner {k}: {uv:?}"));
        if band.texture == NO_TEXTURE {
            assert_eq!(*uv, [0.0, band.start as f32 + 0.5], "corner {k}");
        } else {
            let want = if up { -input[1] } else { input[1] };
            let got = uv[1] - band.shift as f32;
            assert!(
                (got - want).abs() <= 4e-7 * (1.0 + band.shift.abs() as f32),
                "corner {k}: {got} vs {want}"
            );
            assert_eq!(uv[0], input[0], "corner {k}: u");
        }
        if k % 3 == 0 {
            bands.push(band);
        } else {
            assert_eq!(bands[k / 3], band, "corner {k}: its triangle's band");
        }
    }
    bands
}

/// The material of each triangle of an OBJ that the weld keeps (its faces fanned as the
/// importer does, triangles with two corners at one position dropped; the caller checks
/// that no triangle repeats another).
fn obj_materials(text: &str) -> Vec<String> {
    let mut current = String::new();
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut out = Vec::new();
    for line in text.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.first() {
            Some(&"usemtl") => current = words[1..].join(" "),
            Some(&"v") => positions.push([1, 2, 3].map(|k| words[k].parse().unwrap())),
            Some(&"f") => {
                let corner = |w: &str| {
                    let i: i64 = w.split('/').next().unwrap().parse().unwrap();
                    let i = if i > 0 {
                        i - 1
                    } else {
                        positions.len() as i64 + i
                    };
                    positions[i as usize]
                };
                let p: Vec<[f64; 3]> = words[1..].iter().map(|w| corner(w)).collect();
                for i in 1..p.len() - 1 {
                    let t = [p[0], p[i], p[i + 1]];
                    if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                        out.push(current.clone());
                    }
                }
            }
            _ => {}
        }
    }
    out
}

fn file_texture(t: &MeshTextures, index: u32) -> &Path {
    match &t.textures[index as usize].source {
        TextureSource::File(path) => path,
        other => panic!("{other:?}"),
    }
}

#[test]
fn spider_obj_has_a_band_a_textured_material() {
    let path = testdata("spider/spider.obj");
    let textured = load(&path, &ImportOptions::default());
    let plain = load(&path, &WITHOUT);
    assert_eq!(textured.missing_textures, Vec::<String>::new());
    assert_eq!(
        plain.duplicate_triangles, 0,
        "triangles match the file's but degenerate ones"
    );
    let bands = check_bands(&textured, &plain, true);
    let t = textured.textures.as_ref().unwrap();
    // Five materials, four used by faces (Brusttex is not): a texture each, no untextured band.
    assert_eq!(t.textures.len(), 4);
    assert_eq!(t.bands.len(), 4);
    for texture in &t.textures {
        assert_eq!(
            (texture.wrap_u, texture.wrap_v),
            (Wrap::Repeat, Wrap::Repeat)
        );
    }
    let maps = [
        ("Skin", "wal67ar_small.jpg"),
        ("Brusttex", "wal69ar_small.jpg"),
        ("HLeibTex", "SpiderTex.jpg"),
        ("BeinTex", "drkwood2.jpg"),
        ("Augentex", "engineflare1.jpg"),
    ];
    let materials = obj_materials(&std::fs::read_to_string(&path).unwrap());
    assert_eq!(materials.len(), bands.len());
    for (material, band) in materials.iter().zip(&bands) {
        let (_, map) = maps.iter().find(|(m, _)| m == material).unwrap();
        let file = file_texture(t, band.texture);
        assert_eq!(file.file_name().unwrap(), *map, "{material}");
        assert!(file.is_file());
        assert_eq!(t.textures[band.texture as usize].name, *map);
    }
    // The input's v runs from −0.49 to 1.48: a band spans up to three integers.
    assert!(t.bands.iter().all(|b| (1..=3).contains(&b.span)));
    // A vertex at a material border is a wedge a material now.
    assert!(textured.mesh.positions.len() >= plain.mesh.positions.len());
}

#[test]
fn a_textured_obj_out_of_core_is_refused_saying_how_to_build_it() {
    let dir = tempfile::tempdir().unwrap();
    let err = stage_mesh(&testdata("spider/spider.obj"), dir.path(), 1 << 20)
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("textured OBJ") && err.contains("--no-textures"),
        "{err}"
    );
}

#[test]
fn box_textured_glb_has_its_embedded_png_and_v_unchanged() {
    let path = testdata("BoxTextured.glb");
    let textured = load(&path, &ImportOptions::default());
    let plain = load(&path, &WITHOUT);
    let t = textured.textures.as_ref().expect("textures");
    assert_eq!(t.textures.len(), 1);
    let texture = &t.textures[0];
    assert_eq!(
        (texture.wrap_u, texture.wrap_v),
        (Wrap::Repeat, Wrap::Repeat)
    );
    match &texture.source {
        TextureSource::Encoded { bytes, mime } => {
            assert_eq!(mime.as_deref(), Some("image/png"));
            assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        }
        other => panic!("{other:?}"),
    }
    let bands = check_bands(&textured, &plain, false);
    assert!(bands.iter().all(|b| b.texture == 0));
    assert_eq!(t.bands.len(), 1);
    // Its v lies in [0, 1): shift 0, the coordinates as the file has them.
    assert_eq!(t.bands[0].shift, 0);
    assert_eq!(textured.mesh, plain.mesh);
    // Staged: the same textures and mesh.
    let dir = tempfile::tempdir().unwrap();
    let staged = stage_mesh(&path, dir.path(), 1 << 20).unwrap();
    assert_eq!(staged.textures, textured.textures);
    assert_eq!(staged.load().unwrap(), textured.mesh);
    // Found again without staging (a resumed build's).
    let again = find_textures(&path, &ImportOptions::default()).unwrap();
    assert_eq!(again, (textured.textures.clone(), Vec::new()));
    assert_eq!(find_textures(&path, &WITHOUT).unwrap(), (None, Vec::new()));
}

/// A glTF of two quads (data-URI buffer), the first textured by `tex.png` beside it with a
/// clamping sampler, the second with a material without texture.
fn two_material_gltf(dir: &Path, image_uri: &str) -> PathBuf {
    use base64::Engine as _;
    let mut bin = Vec::new();
    // Two quads side by side (a primitive each, so no triangle repeats another), their
    // coordinates, the indices of both.
    for x0 in [0.0f32, 2.0] {
        for [x, y] in [[0.0f32, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
            [x0 + x, y, 0.0]
                .iter()
                .for_each(|c| bin.extend(c.to_le_bytes()));
        }
    }
    let uvs: [[f32; 2]; 4] = [[0., 2.5], [1., 2.5], [1., 1.25], [0., 1.25]];
    for uv in uvs {
        uv.iter().for_each(|x| bin.extend(x.to_le_bytes()));
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    let data = base64::engine::general_purpose::STANDARD.encode(&bin);
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},
  "buffers":[{{"byteLength":{len},"uri":"data:application/octet-stream;base64,{data}"}}],
  "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},
                 {{"buffer":0,"byteOffset":96,"byteLength":32}},
                 {{"buffer":0,"byteOffset":128,"byteLength":12}},
                 {{"buffer":0,"byteOffset":48,"byteLength":48}}],
  "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
               {{"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"}},
               {{"bufferView":2,"componentType":5123,"count":6,"type":"SCALAR"}},
               {{"bufferView":3,"componentType":5126,"count":4,"type":"VEC3","min":[2,0,0],"max":[3,1,0]}}],
  "images":[{{"uri":"{image_uri}"}}],
  "samplers":[{{"wrapS":33071,"wrapT":33648}}],
  "textures":[{{"source":0,"sampler":0}}],
  "materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}}}}}},
               {{"pbrMetallicRoughness":{{"baseColorFactor":[1,1,1,1]}}}}],
  "meshes":[{{"primitives":[
      {{"attributes":{{"POSITION":0,"TEXCOORD_0":1}},"indices":2,"material":0}},
      {{"attributes":{{"POSITION":3,"TEXCOORD_0":1}},"indices":2,"material":1}}]}}],
  "nodes":[{{"mesh":0}},{{"mesh":0,"translation":[0,0,1]}}],
  "scenes":[{{"nodes":[0,1]}}],"scene":0}}"#,
        len = bin.len()
    );
    write(dir, "two.gltf", json)
}

#[test]
fn gltf_materials_take_bands_and_samplers_their_wrap() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "tex image.png", b"not decoded by the importer");
    let path = two_material_gltf(dir.path(), "tex%20image.png");
    let textured = load(&path, &ImportOptions::default());
    let plain = load(&path, &WITHOUT);
    let t = textured.textures.as_ref().unwrap();
    assert_eq!(t.textures.len(), 1);
    assert_eq!(file_texture(t, 0), dir.path().join("tex image.png"));
    // CLAMP_TO_EDGE across, MIRRORED_REPEAT down (drawn as repeat).
    assert_eq!(
        (t.textures[0].wrap_u, t.textures[0].wrap_v),
        (Wrap::Clamp, Wrap::Repeat)
    );
    let bands = check_bands(&textured, &plain, false);
    // v from 1.25 to 2.5: floors 1 and 2, moved to band [0, 2); the untextured one after it.
    assert_eq!(
        t.bands[0],
        Band {
            start: 0,
            span: 2,
            shift: -1,
            texture: 0
        }
    );
    assert_eq!((t.bands[1].start, t.bands[1].texture), (2, NO_TEXTURE));
    let per_triangle: Vec<u32> = bands.iter().map(|b| b.texture).collect();
    // Two instances of the mesh, each a textured quad then an untextured one.
    assert_eq!(
        per_triangle,
        [0, 0, NO_TEXTURE, NO_TEXTURE, 0, 0, NO_TEXTURE, NO_TEXTURE]
    );

    // The image file missing: no texture, reported, coordinates as read.
    let path = two_material_gltf(dir.path(), "gone.png");
    let report = load(&path, &ImportOptions::default());
    assert_eq!(report.textures, None);
    assert_eq!(
        report.missing_textures,
        [dir.path().join("gone.png").display().to_string()]
    );
    assert_eq!(report.mesh, load(&path, &WITHOUT).mesh);

    // The image in a data URI: its bytes, with the MIME type the URI declares.
    let path = two_material_gltf(dir.path(), "data:image/png;base64,iVBORw0KGgo=");
    let report = load(&path, &ImportOptions::default());
    let t = report.textures.as_ref().unwrap();
    let want = TextureSource::Encoded {
        bytes: b"\x89PNG\r\n\x1a\n".to_vec(),
        mime: Some("image/png".into()),
    };
    assert_eq!(t.textures[0].source, want);
    assert_eq!(t.bands, textured.textures.as_ref().unwrap().bands);

    // A texture read through another coordinate set: untextured, coordinates as read.
    let json = std::fs::read_to_string(&path).unwrap();
    let other_set = json.replace(r#"{"index":0}"#, r#"{"index":0,"texCoord":1}"#);
    assert_ne!(json, other_set);
    let path = write(dir.path(), "set1.gltf", other_set);
    let report = load(&path, &ImportOptions::default());
    assert_eq!((report.textures, report.missing_textures.len()), (None, 0));
    assert_eq!(report.mesh, load(&path, &WITHOUT).mesh);
}

const TEXTURED_PLY: &str = "ply\nformat ascii 1.0\ncomment made by hand\n\
    comment TextureFile checker board.png\nelement vertex 4\nproperty float x\n\
    property float y\nproperty float z\nproperty float s\nproperty float t\n\
    element face 2\nproperty list uchar int vertex_indices\nend_header\n\
    0 0 0 0 0\n1 0 0 3.5 0\n1 1 0 3.5 0.75\n0 1 0 0 0.75\n3 0 1 2\n3 0 2 3\n";

#[test]
fn ply_texture_file_in_memory_and_staged_give_the_same_wedges() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "checker board.png", b"png");
    let path = write(dir.path(), "quad.ply", TEXTURED_PLY);
    let textured = load(&path, &ImportOptions::default());
    let plain = load(&path, &WITHOUT);
    check_bands(&textured, &plain, true);
    let t = textured.textures.as_ref().unwrap();
    assert_eq!(file_texture(t, 0), dir.path().join("checker board.png"));
    // −v in [−0.75, 0]: floors −1 and 0, shifted by 1.
    assert_eq!(
        t.bands,
        [Band {
            start: 0,
            span: 2,
            shift: 1,
            texture: 0
        }]
    );
    let uvs = textured.mesh.uvs.as_ref().unwrap();
    assert_eq!(uvs[2], [3.5, 0.25]);
    // The plain import keeps the file's coordinates.
    assert_eq!(plain.mesh.uvs.as_ref().unwrap()[2], [3.5, 0.75]);

    for budget in [0, 1 << 20] {
        let temp = tempfile::tempdir().unwrap();
        let staged = stage_mesh(&path, temp.path(), budget).unwrap();
        assert_eq!(staged.textures, textured.textures);
        assert_eq!(staged.load().unwrap(), textured.mesh);
        let staged = stage_mesh_with(&path, temp.path(), budget, &WITHOUT).unwrap();
        assert_eq!(staged.textures, None);
        assert_eq!(staged.load().unwrap(), plain.mesh);
    }
    let again = find_textures(&path, &ImportOptions::default()).unwrap();
    assert_eq!(again, (textured.textures.clone(), Vec::new()));
    // Its texture missing: reported, the mesh untextured as read.
    std::fs::remove_file(dir.path().join("checker board.png")).unwrap();
    let report = load(&path, &ImportOptions::default());
    assert_eq!(report.textures, None);
    assert_eq!(report.missing_textures.len(), 1);
    assert!(report.missing_textures[0].ends_with("checker board.png"));
    assert_eq!(report.mesh, plain.mesh);
    let temp = tempfile::tempdir().unwrap();
    let staged = stage_mesh(&path, temp.path(), 0).unwrap();
    assert_eq!(staged.missing_textures, report.missing_textures);
    let again = find_textures(&path, &ImportOptions::default()).unwrap();
    assert_eq!(again, (None, report.missing_textures.clone()));
}

const TWO_MATERIAL_OBJ: &str = "mtllib lib.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\n\
    vt 0 0.25\nvt 1 0.25\nvt 1 1\nvt 0 1\nvt 0.5 0.5\n\
    usemtl painted\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\nusemtl plain\nf 2/2 5/5 3/3\n";

#[test]
fn an_obj_with_a_missing_texture_loads_that_material_untextured() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "paint.jpg", b"jpeg");
    // One Kd: the plain import has no colour border, so the material border's wedges are
    // the textures'.
    let mtl =
        "newmtl painted\nKd 1 1 1\nmap_Kd paint.jpg\nnewmtl plain\nKd 1 1 1\nmap_Kd gone.jpg\n";
    write(dir.path(), "lib.mtl", mtl);
    let path = write(dir.path(), "two.obj", TWO_MATERIAL_OBJ);
    let textured = load(&path, &ImportOptions::default());
    let plain = load(&path, &WITHOUT);
    assert_eq!(
        textured.missing_textures,
        [dir.path().join("gone.jpg").display().to_string()]
    );
    let bands = check_bands(&textured, &plain, true);
    let t = textured.textures.as_ref().unwrap();
    assert_eq!(t.textures.len(), 1);
    assert_eq!(file_texture(t, 0), dir.path().join("paint.jpg"));
    let per_triangle: Vec<u32> = bands.iter().map(|b| b.texture).collect();
    assert_eq!(per_triangle, [0, 0, NO_TEXTURE]);
    // Vertices 2 and 3 are shared by both materials: a wedge each side of the border.
    assert_eq!(
        textured.mesh.positions.len(),
        plain.mesh.positions.len() + 2
    );
    // Untextured faces need no vt once the OBJ has textures.
    let no_vt = TWO_MATERIAL_OBJ.replace("f 2/2 5/5 3/3", "f 2 5 3");
    let path = write(dir.path(), "partial.obj", no_vt);
    let report = load(&path, &ImportOptions::default());
    assert!(report.textures.is_some());
    let uvs = report.mesh.uvs.as_ref().unwrap();
    let no_texture = report.textures.as_ref().unwrap().bands[1];
    assert_eq!(no_texture.texture, NO_TEXTURE);
    let last = report.mesh.triangles.last().unwrap();
    assert!(last
        .iter()
        .all(|&w| uvs[w as usize] == [0.0, no_texture.start as f32 + 0.5]));

    // No texture found at all: no textures, coordinates as read, both files reported.
    std::fs::remove_file(dir.path().join("paint.jpg")).unwrap();
    let path = write(dir.path(), "none.obj", TWO_MATERIAL_OBJ);
    let report = load(&path, &ImportOptions::default());
    assert_eq!(report.textures, None);
    assert_eq!(report.missing_textures.len(), 2);
    assert_eq!(report.mesh, load(&path, &WITHOUT).mesh);
}

#[test]
fn inputs_without_textures_keep_their_coordinates_as_read() {
    let dir = tempfile::tempdir().unwrap();
    let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0.25 -0.5\nvt 1.5 0.75\nvt 0 3\nf 1/1 2/2 3/3\n";
    let ply = TEXTURED_PLY.replace("comment TextureFile checker board.png\n", "");
    for (name, text, want) in [
        (
            "plain.obj",
            obj.to_string(),
            [[0.25, -0.5], [1.5, 0.75], [0.0, 3.0]],
        ),
        ("plain.ply", ply, [[0.0, 0.0], [3.5, 0.0], [3.5, 0.75]]),
    ] {
        let path = write(dir.path(), name, text);
        let report = load_mesh(&path).unwrap();
        assert_eq!(report.textures, None, "{name}");
        assert!(report.missing_textures.is_empty());
        let uvs = report.mesh.uvs.as_ref().unwrap();
        assert_eq!(&uvs[..3], &want, "{name}: the file's coordinates");
        assert_eq!(report, load(&path, &WITHOUT), "{name}");
        let temp = tempfile::tempdir().unwrap();
        let staged = stage_mesh(&path, temp.path(), 0).unwrap();
        assert_eq!(staged.textures, None);
        assert_eq!(staged.load().unwrap(), report.mesh, "{name} staged");
    }
}
