//! One function per importer entry point, shared by the cargo-fuzz targets (`fuzz/`) and the
//! corpus regression test (`tests/fuzz_corpus.rs`): each feeds its bytes through the same code
//! path a file of that format takes ([`load_mesh_bytes`], [`load_dem_bytes`]) and panics if
//! what must hold does not:
//!
//! - an error names the file and says something;
//! - an imported mesh has triangles, finite positions, indices in range, no triangle repeating
//!   a vertex, and one attribute per vertex;
//! - a height grid holds one height per sample, at least 2 × 2, no infinite height, a finite
//!   placement; and (grids up to [`MESH_CELLS`] samples) its mesh has finite positions and
//!   indices in range.
//!
//! `repository` does the same for the repository reader, and `packed_patch` for the packed
//! patch decoder alone (behind a repository's checksums a mutation rarely reaches it). Each
//! returns whether the input was accepted. Unbounded allocations are caught by running the fuzzers with `-malloc_limit_mb`.

use std::path::Path;

use tessera_core::cut::{diamond_rhos, select_stateless, select_top_down};
use tessera_core::metric::{eye_local, ScreenSpaceMetric};
use tessera_core::repository::Repository;

use crate::dem::{load_dem_bytes, DemOptions, HeightGrid, TerrainOptions};
use crate::import::load_mesh_bytes;
use crate::mesh::InputMesh;

/// A target's body: true if the input was accepted.
pub type Target = fn(&[u8]) -> bool;

/// Every target: its name (the fuzz target's and the corpus directory's) and its function.
pub const TARGETS: &[(&str, Target)] = &[
    ("ply", ply),
    ("obj", obj),
    ("off", off),
    ("stl", stl),
    ("gltf", gltf),
    ("netcdf", netcdf),
    ("npy", npy),
    ("npz", npz),
    ("geotiff", geotiff),
    ("png", png),
    ("pgm", pgm),
    ("raw_f32", raw_f32),
    ("json_grid", json_grid),
    ("repository", repository),
    ("packed_patch", packed_patch),
    ("coded_patch", coded_patch),
];

/// Largest grid (samples) also turned into a mesh and checked.
pub const MESH_CELLS: usize = 1 << 16;

pub fn ply(data: &[u8]) -> bool {
    mesh("fuzz.ply", data)
}

/// The bytes as an OBJ, and as an OBJ whose every `mtllib` is those bytes too (materials:
/// `newmtl`, `Kd`, `usemtl`; each reader skips the other's statements).
pub fn obj(data: &[u8]) -> bool {
    let name = "fuzz.obj";
    let with_library = crate::import::load_obj_bytes_with_library(Path::new(name), data, data);
    match with_library {
        Ok(report) => check_mesh(&report.mesh),
        Err(e) => check_message(name, &e.to_string()),
    }
    mesh(name, data)
}

pub fn off(data: &[u8]) -> bool {
    mesh("fuzz.off", data)
}

pub fn stl(data: &[u8]) -> bool {
    mesh("fuzz.stl", data)
}

/// glTF and GLB (told apart by content, as for a file).
pub fn gltf(data: &[u8]) -> bool {
    mesh("fuzz.glb", data)
}

pub fn netcdf(data: &[u8]) -> bool {
    dem("fuzz.nc", data, &DemOptions::default())
}

pub fn npy(data: &[u8]) -> bool {
    dem("fuzz.npy", data, &DemOptions::default())
}

pub fn npz(data: &[u8]) -> bool {
    dem("fuzz.npz", data, &DemOptions::default())
}

pub fn geotiff(data: &[u8]) -> bool {
    dem("fuzz.tif", data, &DemOptions::default())
}

pub fn png(data: &[u8]) -> bool {
    dem("fuzz.png", data, &DemOptions::default())
}

pub fn pgm(data: &[u8]) -> bool {
    dem("fuzz.pgm", data, &DemOptions::default())
}

/// A raw f32 file needs its size from the command line (`--raw-size`): the first four bytes
/// are the columns and rows (u16, little-endian), the rest is the file.
pub fn raw_f32(data: &[u8]) -> bool {
    let Some((size, file)) = data.split_first_chunk::<4>() else {
        return false;
    };
    let columns = u16::from_le_bytes([size[0], size[1]]) as usize;
    let rows = u16::from_le_bytes([size[2], size[3]]) as usize;
    let options = DemOptions {
        raw_size: Some((columns, rows)),
        ..Default::default()
    };
    dem("fuzz.f32", file, &options)
}

pub fn json_grid(data: &[u8]) -> bool {
    dem("fuzz.json", data, &DemOptions::default())
}

/// The repository reader (`Repository::from_bytes`, the checks `open` runs on a mapped file),
/// then every patch, the id blob, every texture page, and the cut at a few tolerances from a few eyes, by the flat
/// rule and by descent from the roots. A refused file must be refused with a message; an
/// accepted one must not panic anywhere, and every selected simplex exists.
pub fn repository(data: &[u8]) -> bool {
    let repo = match Repository::from_bytes(data.to_vec()) {
        Ok(repo) => repo,
        Err(e) => {
            assert!(!e.to_string().trim().is_empty(), "an empty error message");
            return false;
        }
    };
    for i in 0..repo.tets().len() {
        if let Ok(size) = repo.decoded_patch_bytes(i) {
            let mut out = vec![0; size];
            if let Err(e) = repo.read_patch(i, &mut out) {
                assert!(!e.to_string().trim().is_empty());
            }
        }
        match repo.patch(i) {
            Ok(patch) => {
                let patch = patch.view();
                let n = patch.vertex_count();
                for t in patch.triangles() {
                    assert!(t.iter().all(|&v| (v as usize) < n), "tet {i}: {t:?} of {n}");
                }
                assert_eq!(patch.global_ids().count(), n, "tet {i}: one id per vertex");
            }
            Err(e) => assert!(!e.to_string().trim().is_empty()),
        }
    }
    let _ = repo.verify_ids();
    // The texture section: tables checked on open, every page read (its CRC checked) as the
    // renderer would, by global index, and one index past the end refused.
    if let Some(textures) = repo.textures() {
        let shapes = textures.shapes();
        let bands = textures.bands();
        assert!(tessera_core::texture::bands_valid(
            &bands,
            shapes.len() as u32
        ));
        let mut first = 0u32;
        for (t, shape) in shapes.iter().enumerate() {
            assert_eq!(
                textures.first_page(t as u32),
                first,
                "texture {t}'s first page"
            );
            first += shape.page_count();
        }
        assert_eq!(first, textures.page_count());
        for page in 0..textures.page_count() {
            match textures.page(page) {
                Ok(stored) => {
                    let encoding = textures.encoding();
                    assert_eq!(stored.len(), encoding.page_bytes());
                    let texels = tessera_core::texture_codec::decode_page(encoding, stored)
                        .expect("a page of its encoding's size decodes");
                    assert_eq!(texels.len(), tessera_core::texture::PAGE_BYTES);
                }
                Err(e) => assert!(!e.to_string().trim().is_empty()),
            }
        }
        assert!(textures.page(textures.page_count()).is_err());
    }
    let header = repo.header();
    let (lo, hi) = (header.bbox_min, header.bbox_max);
    let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let size = (0..3).map(|k| hi[k] - lo[k]).fold(1e-3, f64::max);
    let metric = ScreenSpaceMetric::new(1080, 60.0, 1e-3 * size);
    let tets = repo.tets();
    let roots = header.root_tet_count as usize;
    for offset in [[0.0, 0.0, 3.0], [2.0, -1.0, 0.5], [0.0, 0.0, 0.0]] {
        let eye = [0, 1, 2].map(|k| centre[k] + offset[k] * size);
        let rhos = diamond_rhos(repo.diamonds(), eye_local(eye, header.origin), &metric);
        for tau in [0.0, 1.0, 8.0, 1e9] {
            for cut in [
                select_stateless(tets, &rhos, tau),
                select_top_down(tets, roots, &rhos, tau),
            ] {
                assert!(cut.iter().all(|&t| (t as usize) < tets.len()));
            }
        }
    }
    true
}

/// Imports `data` as the file `name`; true if it was accepted.
fn mesh(name: &str, data: &[u8]) -> bool {
    match load_mesh_bytes(Path::new(name), data) {
        Ok(report) => {
            check_mesh(&report.mesh);
            assert!(
                !report.mesh.triangles.is_empty(),
                "an empty mesh was accepted"
            );
            assert!(report.raw_vertices >= report.mesh.positions.len());
            assert!(report.raw_triangles >= report.mesh.triangles.len());
            true
        }
        Err(e) => {
            check_message(name, &e.to_string());
            false
        }
    }
}

/// Reads `data` as the height field `name`; true if it was accepted.
fn dem(name: &str, data: &[u8], options: &DemOptions) -> bool {
    match load_dem_bytes(Path::new(name), data, options) {
        Ok(grid) => {
            check_grid(&grid);
            true
        }
        Err(e) => {
            check_message(name, &e.to_string());
            false
        }
    }
}

fn check_message(name: &str, message: &str) {
    let problem = message
        .strip_prefix(name)
        .and_then(|m| m.strip_prefix(": "));
    assert!(
        problem.is_some_and(|p| !p.trim().is_empty()),
        "the error does not name the file and a problem: {message:?}"
    );
}

/// What every mesh handed to the build must satisfy.
fn check_mesh(mesh: &InputMesh) {
    let n = mesh.positions.len();
    if let Some((i, p)) = mesh
        .positions
        .iter()
        .enumerate()
        .find(|(_, p)| !p.iter().all(|x| x.is_finite()))
    {
        panic!("vertex {i} of {n} is not finite: {p:?}");
    }
    for (j, t) in mesh.triangles.iter().enumerate() {
        assert!(
            t.iter().all(|&v| (v as usize) < n),
            "triangle {j} {t:?} out of range ({n} vertices)"
        );
        assert!(
            t[0] != t[1] && t[1] != t[2] && t[0] != t[2],
            "triangle {j} {t:?} repeats a vertex"
        );
    }
    for len in [
        mesh.normals.as_ref().map(Vec::len),
        mesh.colors.as_ref().map(Vec::len),
        mesh.uvs.as_ref().map(Vec::len),
    ]
    .into_iter()
    .flatten()
    {
        assert_eq!(len, n, "an attribute has {len} entries for {n} vertices");
    }
}

fn check_grid(grid: &HeightGrid) {
    assert!(
        grid.columns >= 2 && grid.rows >= 2,
        "a {} × {} grid",
        grid.columns,
        grid.rows
    );
    assert_eq!(
        Some(grid.heights.len()),
        grid.columns.checked_mul(grid.rows)
    );
    assert!(
        grid.heights.iter().all(|h| !h.is_infinite()),
        "an infinite height"
    );
    assert!(grid.valid_samples() > 0, "no valid sample");
    assert!(
        grid.origin
            .iter()
            .chain(&grid.spacing)
            .all(|x| x.is_finite()),
        "origin {:?}, spacing {:?}",
        grid.origin,
        grid.spacing
    );
    assert!(
        !grid.spacing.contains(&0.0),
        "zero spacing {:?}",
        grid.spacing
    );
    if grid.heights.len() <= MESH_CELLS {
        for options in [
            TerrainOptions::default(),
            TerrainOptions {
                spacing: Some(30.0),
                vertical_exaggeration: 2.0,
            },
        ] {
            let mesh = grid.to_mesh(&options);
            assert_eq!(mesh.positions.len(), grid.valid_samples());
            check_mesh(&mesh);
        }
    }
}

/// The packed patch decoder on any bytes: `data` is a vertex count (u16 LE), a strip index
/// count (u16 LE), an attribute mask (the low 3 bits of a byte) and the packed patch. A decoded
/// patch must have every coordinate on the grid and every strip index below the vertex count
/// (or a restart), and pack and decode again to the same bytes.
pub fn packed_patch(data: &[u8]) -> bool {
    use tessera_core::repository::packed::{pack_patch, unpack_patch, StripCoding};
    use tessera_core::repository::patch::patch_bytes;
    if data.len() < 5 {
        return false;
    }
    let n = u16::from_le_bytes([data[0], data[1]]) as usize;
    let m = u16::from_le_bytes([data[2], data[3]]) as usize;
    let attributes = (data[4] & 7) as u32;
    // Bit 3 picks the older strip coding (repositories packed before commit 4fa9fc2, 2026-12-03).
    let strips = if data[4] & 8 != 0 {
        StripCoding::IndexSequence
    } else {
        StripCoding::Nibbles
    };
    let packed = &data[5..];
    let mut out = vec![0u8; patch_bytes(n, m, attributes)];
    if let Err(e) = unpack_patch(packed, n, m, attributes, strips, &mut out) {
        assert!(!e.to_string().trim().is_empty(), "an empty error message");
        return false;
    }
    assert_decoded_patch(&out, n, m, attributes);
    let mut again = Vec::new();
    pack_patch(&out, n, m, attributes, strips, &mut again);
    let mut twice = vec![0u8; out.len()];
    unpack_patch(&again, n, m, attributes, strips, &mut twice).expect("a repacked patch decodes");
    assert!(twice == out, "packing what was decoded changes it");
    true
}

/// The coded patch decoder (`SECTION_CODED_STRIPS`) on any bytes: `data` is a vertex count
/// (u16 LE), a strip index count (u16 LE), an attribute mask (the low 3 bits of a byte) and
/// the coded patch. A decoded patch must have every coordinate on the grid and every strip
/// index below the vertex count (or a restart), and code and decode again to the same bytes.
pub fn coded_patch(data: &[u8]) -> bool {
    use tessera_core::repository::coded::{code_patch, decode_patch};
    use tessera_core::repository::patch::patch_bytes;
    if data.len() < 5 {
        return false;
    }
    let n = u16::from_le_bytes([data[0], data[1]]) as usize;
    let m = u16::from_le_bytes([data[2], data[3]]) as usize;
    let attributes = (data[4] & 7) as u32;
    let coded = &data[5..];
    let mut out = vec![0u8; patch_bytes(n, m, attributes)];
    if let Err(e) = decode_patch(coded, n, m, attributes, &mut out) {
        assert!(!e.to_string().trim().is_empty(), "an empty error message");
        return false;
    }
    assert_decoded_patch(&out, n, m, attributes);
    let mut again = Vec::new();
    code_patch(&out, n, m, attributes, &mut again);
    let mut twice = vec![0u8; out.len()];
    decode_patch(&again, n, m, attributes, &mut twice).expect("a recoded patch decodes");
    assert!(twice == out, "coding what was decoded changes it");
    true
}

/// What every decoded patch of `n` vertices and `m` strip indices must be, whatever bytes it
/// came from: every coordinate on the grid, every strip index below `n` or a restart.
fn assert_decoded_patch(out: &[u8], n: usize, m: usize, attributes: u32) {
    use tessera_core::repository::format::{unpack_position, POSITION_MAX};
    use tessera_core::repository::patch::strip_byte_offset;
    let word = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    for (k, w) in out[..8 * n].chunks_exact(8).enumerate() {
        let q = unpack_position([word(&w[..4]), word(&w[4..])]);
        assert!(q.iter().all(|&c| c <= POSITION_MAX), "vertex {k} at {q:?}");
    }
    // n ≤ 65,535 here: u16 indices, restart 0xFFFF.
    let strip = &out[strip_byte_offset(n, attributes)..];
    for (k, c) in strip.chunks_exact(2).take(m).enumerate() {
        let i = u16::from_le_bytes([c[0], c[1]]);
        assert!(
            i == u16::MAX || (i as usize) < n,
            "strip index {k} is {i} of {n}"
        );
    }
}
