//! Textures into the repository, end to end: a small mesh with texture coordinates and two
//! synthetic images (a PNG and a JPEG) built in memory and out of core; every stored page is
//! what the pyramid and the page cutter make of the decoded image, the bytes do not depend on
//! `--memory` or `--threads`, an input without textures gets no texture section, and a bad
//! texture stops the build naming it.

use std::path::{Path, PathBuf};

use tessera_core::repository::format::SECTION_TEXTURES;
use tessera_core::repository::Repository;
use tessera_core::texture::{Band, PageEncoding, TextureShape, Wrap, NO_TEXTURE};
use tessera_core::texture_codec::encode_page;
use tessera_preprocess::checkpoint::{manifest::Fingerprint, manifest_for};
use tessera_preprocess::import::{load_mesh, stage_mesh};
use tessera_preprocess::texture::decode::{decode, encoded_bytes};
use tessera_preprocess::texture::pages::cut_page;
use tessera_preprocess::texture::pyramid::pyramid;
use tessera_preprocess::texture::texture_memory_bytes;
use tessera_preprocess::texture_input::{MeshTextures, TextureInput, TextureSource};
use tessera_preprocess::{
    build_repository, build_repository_staged, BuildConfig, BuildError, MemoryBudget,
};

/// A wavy 24 × 24 quad grid with texture coordinates in [0, 1), as OBJ.
fn grid_obj(dir: &Path) -> PathBuf {
    let n = 24;
    let mut text = String::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
            let z = 0.1 * (6.0 * x).sin() * (4.0 * y).cos();
            text += &format!("v {x} {y} {z}\nvt {} {}\n", x * 0.999, y * 0.999);
        }
    }
    let at = |i: usize, j: usize| j * (n + 1) + i + 1;
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            text += &format!("f {a}/{a} {b}/{b} {c}/{c}\nf {a}/{a} {c}/{c} {d}/{d}\n");
        }
    }
    let path = dir.join("grid.obj");
    std::fs::write(&path, text).unwrap();
    path
}

/// Texels that vary smoothly and in noise, alpha included.
fn texels(width: u32, height: u32) -> Vec<u8> {
    let mut out = Vec::new();
    for y in 0..height {
        for x in 0..width {
            let noise = (x.wrapping_mul(2_654_435_761) ^ y.wrapping_mul(40_503)) >> 7;
            out.extend_from_slice(&[
                (x * 255 / width) as u8,
                (y * 255 / height) as u8,
                noise as u8,
                (255 - (noise >> 9) % 64) as u8,
            ]);
        }
    }
    out
}

/// A 300 × 200 PNG (repeat along u, clamp along v) and a 130 × 70 JPEG (clamp both), and three
/// bands: one a texture and one untextured.
fn write_textures(dir: &Path) -> MeshTextures {
    let png = dir.join("wood.png");
    image::RgbaImage::from_raw(300, 200, texels(300, 200))
        .unwrap()
        .save(&png)
        .unwrap();
    let rgb: Vec<u8> = texels(130, 70)
        .chunks(4)
        .flat_map(|t| [t[0], t[1], t[2]])
        .collect();
    let jpeg = dir.join("stone.jpg");
    image::RgbImage::from_raw(130, 70, rgb)
        .unwrap()
        .save(&jpeg)
        .unwrap();
    MeshTextures {
        textures: vec![
            TextureInput {
                name: "wood.png".into(),
                source: TextureSource::File(png),
                wrap_u: Wrap::Repeat,
                wrap_v: Wrap::Clamp,
            },
            TextureInput {
                name: "stone.jpg".into(),
                source: TextureSource::File(jpeg),
                wrap_u: Wrap::Clamp,
                wrap_v: Wrap::Clamp,
            },
        ],
        bands: vec![
            Band::covering(0, 0.0, 0.999, 0).unwrap(),
            Band::covering(1, 0.0, 0.5, 1).unwrap(),
            Band::covering(2, 0.0, 0.5, NO_TEXTURE).unwrap(),
        ],
    }
}

fn config(textures: Option<MeshTextures>, threads: usize) -> BuildConfig {
    BuildConfig {
        textures,
        threads: Some(threads),
        construction: tessera_preprocess::Construction::LeafTriangles(128),
        ..BuildConfig::default()
    }
}

fn build(mesh_path: &Path, config: &BuildConfig, out: &Path) -> Result<Vec<u8>, BuildError> {
    let mesh = load_mesh(mesh_path).unwrap().mesh;
    build_repository(&mesh, config, out, &|_| {})?;
    Ok(std::fs::read(out).unwrap())
}

/// Every page of `repo` is the pyramid and page cutter's from the decoded texture, stored in
/// the repository's encoding (`texture_codec::encode_page`).
fn assert_pages_are_the_pyramids(repo: &Repository, textures: &MeshTextures) {
    let table = repo.textures().expect("a texture section");
    let encoding = table.encoding();
    let shapes = table.shapes();
    assert_eq!(
        shapes,
        [
            TextureShape::new(300, 200, Wrap::Repeat, Wrap::Clamp).unwrap(),
            TextureShape::new(130, 70, Wrap::Clamp, Wrap::Clamp).unwrap(),
        ]
    );
    assert_eq!(table.bands(), textures.bands);
    assert_eq!(table.page_count(), 9 + 3);
    let mut page = Vec::new();
    for (t, (shape, input)) in shapes.iter().zip(&textures.textures).enumerate() {
        let bytes = encoded_bytes(input).unwrap();
        let levels = pyramid(decode(&bytes, texture_memory_bytes(shape)).unwrap(), shape);
        for local in 0..shape.page_count() {
            let (l, x, y) = shape.page_coords(local).unwrap();
            page.clear();
            cut_page(&levels[l as usize], shape, l, x, y, &mut page);
            let global = table.first_page(t as u32) + local;
            assert!(
                table.page(global).unwrap() == encode_page(encoding, &page).as_slice(),
                "texture {t} page {local} (level {l}, {x}, {y}), {encoding:?}"
            );
        }
    }
}

#[test]
fn pages_are_the_pyramid_cut_and_do_not_depend_on_memory_or_threads() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = grid_obj(dir.path());
    let textures = write_textures(dir.path());
    let textured = config(Some(textures.clone()), 1);
    let bytes = build(&mesh, &textured, &dir.path().join("a.tsr")).unwrap();
    let repo = Repository::open(dir.path().join("a.tsr")).unwrap();
    assert!(repo.header().attributes & 4 != 0, "the mesh has uvs");
    assert_eq!(
        repo.textures().unwrap().encoding(),
        PageEncoding::Bc1,
        "the default"
    );
    assert_pages_are_the_pyramids(&repo, &textures);
    repo.validate_patches().unwrap();

    // RGBA8 pages: the cut texels themselves.
    let rgba8 = BuildConfig {
        texture_encoding: PageEncoding::Rgba8,
        ..config(Some(textures.clone()), 1)
    };
    build(&mesh, &rgba8, &dir.path().join("rgba8.tsr")).unwrap();
    let lossless = Repository::open(dir.path().join("rgba8.tsr")).unwrap();
    assert_eq!(lossless.textures().unwrap().encoding(), PageEncoding::Rgba8);
    assert_pages_are_the_pyramids(&lossless, &textures);

    let two_threads = build(
        &mesh,
        &config(Some(textures.clone()), 2),
        &dir.path().join("b.tsr"),
    );
    assert!(two_threads.unwrap() == bytes, "--threads changed the bytes");

    // Out of core: staged mesh, a memory budget; the same bytes.
    let temp = dir.path().join("temp");
    std::fs::create_dir(&temp).unwrap();
    let staged = stage_mesh(&mesh, &temp, 1 << 20).unwrap();
    let budget = MemoryBudget {
        bytes: 64 << 20,
        temp_dir: temp.clone(),
    };
    let out = dir.path().join("staged.tsr");
    let staged_config = BuildConfig {
        memory: Some(budget),
        ..textured
    };
    build_repository_staged(&staged, &staged_config, &out, &|_| {}).unwrap();
    assert!(
        std::fs::read(&out).unwrap() == bytes,
        "--memory changed the bytes"
    );
}

#[test]
fn without_textures_there_is_no_section() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = grid_obj(dir.path());
    let plain = build(&mesh, &config(None, 1), &dir.path().join("plain.tsr")).unwrap();
    let repo = Repository::from_bytes(plain.clone()).unwrap();
    assert!(repo.textures().is_none());
    assert!(repo.sections().iter().all(|s| s.kind != SECTION_TEXTURES));
    // The textured build's other sections hold the same bytes.
    let textures = write_textures(dir.path());
    let textured = build(&mesh, &config(Some(textures), 1), &dir.path().join("t.tsr")).unwrap();
    let textured = Repository::from_bytes(textured).unwrap();
    assert_eq!(textured.tets(), repo.tets());
    assert!(textured.patch_blob() == repo.patch_blob());
    assert_eq!(textured.sections().len(), repo.sections().len() + 1);
}

#[test]
fn a_bad_texture_stops_the_build_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = grid_obj(dir.path());
    let mut textures = write_textures(dir.path());
    let out = dir.path().join("bad.tsr");
    // A PNG cut short: found before the geometry is built, and nothing is written.
    let png = dir.path().join("wood.png");
    let whole = std::fs::read(&png).unwrap();
    std::fs::write(&png, &whole[..whole.len() / 3]).unwrap();
    let err = build(&mesh, &config(Some(textures.clone()), 1), &out).unwrap_err();
    let message = err.to_string();
    assert!(
        matches!(err, BuildError::Texture { ref name, .. } if name == "wood.png"),
        "{message}"
    );
    assert!(message.contains("corrupt image"), "{message}");
    assert!(!out.exists());
    std::fs::write(&png, &whole).unwrap();
    // A missing file; a texture past the memory budget.
    textures.textures[1].source = TextureSource::File(dir.path().join("gone.jpg"));
    let message = build(&mesh, &config(Some(textures.clone()), 1), &out)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("stone.jpg") && message.contains("gone.jpg"),
        "{message}"
    );
    let textures = write_textures(dir.path());
    let small = BuildConfig {
        memory: Some(MemoryBudget {
            bytes: 300_000,
            temp_dir: dir.path().to_path_buf(),
        }),
        ..config(Some(textures), 1)
    };
    let message = build(&mesh, &small, &out).unwrap_err().to_string();
    assert!(
        message.contains("wood.png") && message.contains("memory budget"),
        "{message}"
    );
    assert!(!out.exists());
}

#[test]
fn a_changed_texture_changes_the_checkpoint_manifest() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = grid_obj(dir.path());
    let textures = write_textures(dir.path());
    let manifest = || {
        let config = config(Some(textures.clone()), 1);
        manifest_for(Fingerprint::of(&mesh).unwrap(), &config)
    };
    let before = manifest();
    assert!(before.flags["textures"].contains("wood.png"));
    assert_eq!(manifest(), before);
    image::RgbaImage::from_raw(300, 200, vec![7; 300 * 200 * 4])
        .unwrap()
        .save(dir.path().join("wood.png"))
        .unwrap();
    let after = manifest();
    assert_ne!(after.flags["textures"], before.flags["textures"]);
    // Without textures the manifest's flags are what they were.
    let plain = manifest_for(Fingerprint::of(&mesh).unwrap(), &config(None, 1));
    assert!(!plain.flags.contains_key("textures"));
}
