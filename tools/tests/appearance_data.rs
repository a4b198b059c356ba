//! Real appearance data (issue 47, "Done when"): the assets `tools/fetch-testdata.sh` fetches
//! (or, for the coloured scan, makes by projecting a photograph: `tools/project-photo.py`)
//! import with their appearance, build, and check clean:
//!
//! - `mesh/bunny-astronaut.ply`: the bunny range scan coloured per vertex (a closed scan);
//! - `mesh/BoxTextured.glb`: Khronos' textured box (base-colour texture, UV seams on every
//!   edge), from Debian's assimp-testmodels;
//! - `mesh/spider/spider.obj`: an OBJ with five MTL materials, each with a `Kd` and a `map_Kd`
//!   texture beside it (an open model), from the same package.
//!
//! Each builds; `check` finds no crack; `check --gpu` shows no flag pixel on the closed ones,
//! and, on every view of `render --mode check` (front faces grey, back faces magenta), no
//! flag pixel that the τ = 1e-6 frame of the same view lacks (an open model shows its own back
//! faces through its holes at every τ). The open OBJ built with a hierarchy to simplify
//! (`--leaf-triangles 32`) is held to the rule `check --gpu` holds terrains to: a new flag
//! pixel within ⌈2τ⌉ + 1 pixels of one the reference frame sees through (background or flag:
//! the outline moved by the cut's error) is excused and counted; any other fails.

mod cli_support;

use std::path::{Path, PathBuf};

use cli_support::{json, tessera};
use tessera_preprocess::import::{load_mesh, mtl};

fn asset(name: &str) -> PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata/mesh")
        .join(name);
    assert!(
        path.exists(),
        "{} is missing: run tools/fetch-testdata.sh first (README.md, 'Tests')",
        path.display()
    );
    path
}

fn succeeds(args: &[&str]) -> std::process::Output {
    let out = tessera(args);
    assert!(
        out.status.success(),
        "tessera {}: {}{}",
        args.join(" "),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// What the importer keeps of an asset: triangles, vertices, wedges, and which attributes.
struct Imported {
    triangles: usize,
    vertices: usize,
    wedges: usize,
    colours: usize,
    uvs: bool,
}

fn import(path: &Path) -> Imported {
    let mesh = load_mesh(path).unwrap_or_else(|e| panic!("{e}")).mesh;
    let colours = (mesh.colors.iter().flatten())
        .collect::<std::collections::HashSet<_>>()
        .len();
    Imported {
        triangles: mesh.triangles.len(),
        vertices: mesh.vertex_starts().vertex_count(mesh.positions.len()),
        wedges: mesh.positions.len(),
        colours,
        uvs: mesh.uvs.is_some(),
    }
}

/// A frame's flag pixels (FLAG_COLOUR, magenta) and see-through pixels (flag or background,
/// the corner pixel's colour), as masks, and its width.
fn flags(png: &Path) -> (Vec<bool>, Vec<bool>, usize) {
    let image = image::open(png).unwrap().to_rgba8();
    let background = *image.get_pixel(0, 0);
    let flag: Vec<bool> = image.pixels().map(|p| p.0 == [255, 0, 255, 255]).collect();
    let through = (image.pixels().zip(&flag))
        .map(|(p, &f)| f || *p == background)
        .collect();
    (flag, through, image.width() as usize)
}

/// Whether a pixel within `reach` (Chebyshev) of (x, y) is set in `mask`.
fn near(mask: &[bool], width: usize, at: usize, reach: usize) -> bool {
    let (x, y, height) = (at % width, at / width, mask.len() / width);
    (y.saturating_sub(reach)..(y + reach + 1).min(height)).any(|yy| {
        (x.saturating_sub(reach)..(x + reach + 1).min(width)).any(|xx| mask[yy * width + xx])
    })
}

/// Builds `input` (with `extra` flags) and checks it: no crack on the CPU; with `closed`, no
/// flag pixel in `check --gpu`; on every orbit, no flag pixel at τ = 1 or 4 that the
/// τ = 1e-6 frame lacks (with `excuse`, except within reach of its see-through pixels).
/// Returns (cuts checked, flag pixels of the τ = 1e-6 frames, excused pixels).
fn build_and_check(
    input: &Path,
    extra: &[&str],
    closed: bool,
    excuse: bool,
    dir: &Path,
) -> (u64, usize, usize) {
    let repo = dir.join("asset.tsr");
    let repo = repo.to_str().unwrap();
    let mut args = vec!["build", input.to_str().unwrap(), "-o", repo];
    args.extend(extra);
    succeeds(&args);
    let c = json(&succeeds(&["check", repo, "--views", "16", "--json"]));
    assert_eq!(c["cracks"], 0, "{c}");
    let g = json(&tessera(&[
        "check",
        repo,
        "--gpu",
        "--views",
        "8",
        "--size",
        "320x180",
        "--tolerances",
        "0.000001,1,4",
        "--json",
    ]));
    assert_eq!(g["cracks"], 0, "{g}");
    assert_eq!(g["gpu"]["selection_mismatches"], 0, "{g}");
    if closed {
        assert_eq!(g["gpu"]["flag_pixels"], 0, "{g}");
    }
    let (mut reference_flags, mut excused) = (0, 0);
    for orbit in ["30,20,1.8", "120,-35,1.8", "210,50,1.8", "300,-10,1.8"] {
        let mut frames = Vec::new();
        for tau in ["0.000001", "1", "4"] {
            let png = dir.join(format!("check-{orbit}-{tau}.png"));
            succeeds(&[
                "render",
                repo,
                "-o",
                png.to_str().unwrap(),
                "--mode",
                "check",
                "--size",
                "320x180",
                "--tolerance",
                tau,
                &format!("--orbit={orbit}"),
            ]);
            frames.push(flags(&png));
        }
        let (reference, through, width) = &frames[0];
        reference_flags += reference.iter().filter(|&&f| f).count();
        for ((tau, reach), (frame, _, _)) in [("1", 3), ("4", 9)].iter().zip(&frames[1..]) {
            let mut new = 0;
            for at in (0..frame.len()).filter(|&at| frame[at] && !reference[at]) {
                match excuse && near(through, *width, at, *reach) {
                    true => excused += 1,
                    false => new += 1,
                }
            }
            assert_eq!(
                new,
                0,
                "{}: orbit {orbit}, τ = {tau}: {new} flag pixels the τ = 1e-6 frame lacks",
                input.display()
            );
        }
    }
    (
        c["cuts_checked"].as_u64().unwrap(),
        reference_flags,
        excused,
    )
}

#[test]
fn the_coloured_scan_builds_and_checks_clean() {
    let path = asset("bunny-astronaut.ply");
    let m = import(&path);
    // Colour on every vertex, no seam: one wedge a vertex.
    assert_eq!(
        (m.triangles, m.vertices, m.wedges),
        (75_408, 37_706, 37_706)
    );
    assert!(m.colours > 10_000, "{} distinct colours", m.colours);
    let dir = tempfile::tempdir().unwrap();
    let (cuts, flags, _) = build_and_check(&path, &[], true, false, dir.path());
    eprintln!("bunny-astronaut: {cuts} cuts, 0 cracks; τ = 1e-6 flag pixels {flags}");
    assert_eq!(flags, 0);
}

#[test]
fn the_textured_gltf_builds_and_checks_clean() {
    let path = asset("BoxTextured.glb");
    let m = import(&path);
    // A chart a face: every corner of the cube is three wedges.
    assert_eq!((m.triangles, m.vertices, m.wedges), (12, 8, 24));
    assert!(m.uvs);
    let dir = tempfile::tempdir().unwrap();
    let (cuts, flags, _) = build_and_check(&path, &[], true, false, dir.path());
    eprintln!("BoxTextured: {cuts} cuts, 0 cracks; τ = 1e-6 flag pixels {flags}");
    assert_eq!(flags, 0);
}

#[test]
fn the_obj_with_materials_builds_and_checks_clean() {
    let path = asset("spider/spider.obj");
    let m = import(&path);
    // Its materials' Kd colour its faces (five materials, three distinct Kd: three share
    // 0.8 grey); its texture seams are wedges.
    assert!(m.uvs);
    assert_eq!(m.colours, 3, "distinct colours");
    assert!(
        m.wedges > m.vertices,
        "{} wedges, {} vertices",
        m.wedges,
        m.vertices
    );
    // Every material's map_Kd resolves to a file beside the library (`.\x.jpg` as written).
    let materials = mtl::load_libraries(path.parent().unwrap(), &["spider.mtl".into()]).unwrap();
    assert_eq!(materials.len(), 5);
    for m in &materials {
        let texture = m.diffuse_map.as_ref().expect("map_Kd");
        assert!(texture.exists(), "{}: {}", m.name, texture.display());
    }
    let dir = tempfile::tempdir().unwrap();
    // The default build (one level: 1,312 triangles) and one with a hierarchy to simplify.
    for (extra, excuse) in [(&[][..], false), (&["--leaf-triangles", "32"][..], true)] {
        let (cuts, flags, excused) = build_and_check(&path, extra, false, excuse, dir.path());
        eprintln!(
            "spider {extra:?}: {cuts} cuts, 0 cracks; τ = 1e-6 flag pixels {flags}, new flag \
             pixels at τ = 1, 4 next to the outline {excused}"
        );
    }
    eprintln!(
        "spider: {} triangles, {} vertices, {} wedges",
        m.triangles, m.vertices, m.wedges
    );
}
