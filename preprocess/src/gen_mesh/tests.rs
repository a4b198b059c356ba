//! The generated mesh through tessera's own importer: closed, exact counts, deterministic,
//! seeded, shuffled = the same mesh renumbered, density range measured.

use std::collections::HashMap;
use std::io::Cursor;

use super::*;
use crate::import::{load_mesh_from_reader, ImportReport, MeshFormat};

fn params(triangles: u64) -> MeshParams {
    MeshParams {
        triangles,
        seed: 1,
        shuffle_vertices: false,
        density_range: 1.0,
        colour: false,
    }
}

fn ply_bytes(mesh: &GenMesh) -> Vec<u8> {
    let mut bytes = Vec::new();
    let n = write_ply(mesh, &mut bytes, &mut |_| {}).unwrap();
    assert_eq!(n, bytes.len() as u64);
    bytes
}

fn import(bytes: Vec<u8>) -> ImportReport {
    load_mesh_from_reader(Cursor::new(bytes), MeshFormat::Ply, "generated").unwrap()
}

/// Every undirected edge (by welded id) shared by exactly two triangles, in opposite
/// directions.
fn assert_closed(report: &ImportReport, what: &str) {
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for &[a, b, c] in &report.mesh.triangles {
        for e in [(a, b), (b, c), (c, a)] {
            *directed.entry(e).or_default() += 1;
        }
    }
    for (&(a, b), &k) in &directed {
        assert_eq!(k, 1, "{what}: directed edge ({a}, {b}) used {k} times");
        assert_eq!(
            directed.get(&(b, a)),
            Some(&1),
            "{what}: ({a}, {b}) is a border"
        );
    }
}

fn areas(mesh: &InputMesh) -> Vec<f64> {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let n = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
        })
        .collect()
}

#[test]
fn imports_closed_with_the_exact_count_and_nothing_welded() {
    for (n, r) in [(192, 1.0), (1001, 1.0), (20_000, 1.0), (20_002, 1000.0)] {
        let mesh = GenMesh::new(MeshParams {
            density_range: r,
            colour: false,
            ..params(n)
        })
        .unwrap();
        let report = import(ply_bytes(&mesh));
        let what = format!("{n} triangles, R = {r}");
        assert_eq!(
            report.mesh.triangles.len() as u64,
            achievable_triangles(n),
            "{what}"
        );
        assert_eq!(report.raw_triangles as u64, mesh.triangle_count());
        assert_eq!(
            report.mesh.positions.len() as u64,
            mesh.vertex_count(),
            "{what}"
        );
        assert_eq!(
            (report.welded_vertices, report.degenerate_triangles),
            (0, 0),
            "{what}"
        );
        assert_closed(&report, &what);
        // The file holds exactly the in-memory mesh.
        let direct = mesh.to_input_mesh();
        assert_eq!(report.mesh.positions, direct.positions, "{what}");
        assert_eq!(report.mesh.triangles, direct.triangles, "{what}");
        // Outward: every triangle turns counter-clockwise around the origin (radial relief of
        // a star-shaped sphere triangulation never folds).
        for &[a, b, c] in &direct.triangles {
            let [a, b, c] = [a, b, c].map(|i| direct.positions[i as usize]);
            let det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]);
            assert!(det > 0.0, "{what}: a triangle turns clockwise");
        }
    }
}

#[test]
fn deterministic_and_seeded() {
    let a = ply_bytes(&GenMesh::new(params(5000)).unwrap());
    assert_eq!(a, ply_bytes(&GenMesh::new(params(5000)).unwrap()));
    let other = GenMesh::new(MeshParams {
        seed: 2,
        ..params(5000)
    })
    .unwrap();
    let b = ply_bytes(&other);
    assert_eq!(a.len(), b.len());
    assert_ne!(a, b);
    // Another seed moves the relief, not the connectivity.
    let (ma, mb) = (import(a).mesh, import(b).mesh);
    assert_eq!(ma.triangles, mb.triangles);
    let moved = ma
        .positions
        .iter()
        .zip(&mb.positions)
        .filter(|(p, q)| p != q);
    assert!(moved.count() > ma.positions.len() * 9 / 10);
}

/// Shuffled: the same triangles, in the same order, over the same positions, renumbered.
#[test]
fn shuffled_is_the_same_mesh_renumbered() {
    let plain = GenMesh::new(params(30_000)).unwrap().to_input_mesh();
    let shuffled_gen = GenMesh::new(MeshParams {
        shuffle_vertices: true,
        ..params(30_000)
    })
    .unwrap();
    let shuffled = import(ply_bytes(&shuffled_gen));
    assert_closed(&shuffled, "shuffled");
    let s = &shuffled.mesh;
    assert_eq!(s.triangles.len(), plain.triangles.len());
    for (ts, tp) in s.triangles.iter().zip(&plain.triangles) {
        assert_eq!(
            ts.map(|i| s.positions[i as usize]),
            tp.map(|i| plain.positions[i as usize])
        );
    }
    let key = |p: &[f64; 3]| p.map(f64::to_bits);
    let mut ps: Vec<_> = s.positions.iter().map(key).collect();
    let mut pp: Vec<_> = plain.positions.iter().map(key).collect();
    ps.sort_unstable();
    pp.sort_unstable();
    assert_eq!(ps, pp);
    // Actually out of order: few vertices keep their slot.
    let kept = (0..plain.positions.len())
        .filter(|&i| s.positions[i] == plain.positions[i])
        .count();
    assert!(kept < 10, "{kept} vertices kept their slot");
}

/// `--density-range R` sets the ratio of the largest to the smallest triangle area before
/// the relief (flat triangles between the unit directions of the corners): within a factor 2
/// of R (1,043 for R = 1000 at 200,000 triangles). The relief's slopes and radii then move
/// single areas further; the output's own max/min stays within a factor 2 of R as well
/// (1,373; 5.0 for R = 1).
#[test]
fn density_range_sets_the_area_ratio() {
    let ratio = |a: Vec<f64>| {
        let (lo, hi) = a
            .iter()
            .fold((f64::MAX, 0f64), |(lo, hi), &x| (lo.min(x), hi.max(x)));
        hi / lo
    };
    for r in [1.0, 1000.0] {
        let mut mesh = GenMesh::new(MeshParams {
            density_range: r,
            colour: false,
            ..params(200_000)
        })
        .unwrap()
        .to_input_mesh();
        let output = ratio(areas(&mesh));
        for p in &mut mesh.positions {
            let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            *p = p.map(|x| x / l);
        }
        let directions = ratio(areas(&mesh));
        eprintln!("R = {r}: max/min area {directions:.1} before the relief, {output:.1} after");
        if r == 1.0 {
            // Equal-angle cube map (1.3) and the split cells' half-size triangles.
            assert!(directions < 3.0, "R = 1: ratio {directions}");
            assert!(output < 8.0, "R = 1: ratio {output}");
        } else {
            assert!(
                directions > r / 2.0 && directions < r * 2.0,
                "R = {r}: {directions}"
            );
            assert!(output > r / 2.0 && output < r * 2.0, "R = {r}: {output}");
        }
    }
}

#[test]
fn bad_parameters_are_refused_with_the_reason() {
    let e = GenMesh::new(params(100)).unwrap_err();
    assert!(e.contains("--triangles 100") && e.contains("192"), "{e}");
    for r in [0.5, f64::NAN, 1e7] {
        let e = GenMesh::new(MeshParams {
            density_range: r,
            colour: false,
            ..params(1000)
        })
        .unwrap_err();
        assert!(e.contains("--density-range"), "{e}");
    }
    assert_eq!(achievable_triangles(1001), 1002);
    assert_eq!(achievable_triangles(1000), 1000);
}

/// The stream reader gives what reading the same bytes from a file gives, field for field.
#[test]
fn reading_a_stream_equals_reading_the_file() {
    let mesh = GenMesh::new(MeshParams {
        shuffle_vertices: true,
        ..params(3000)
    })
    .unwrap();
    let bytes = ply_bytes(&mesh);
    let path = std::env::temp_dir().join(format!("tessera-gen-{}.ply", std::process::id()));
    std::fs::write(&path, &bytes).unwrap();
    let from_file = crate::import::load_mesh(&path);
    std::fs::remove_file(&path).unwrap();
    assert_eq!(from_file.unwrap(), import(bytes.clone()));
    // A truncated stream is an error naming the stream, not a panic.
    let cut = bytes[..bytes.len() - 7].to_vec();
    let e = load_mesh_from_reader(Cursor::new(cut), MeshFormat::Ply, "standard input");
    let message = e.unwrap_err().to_string();
    assert!(
        message.starts_with("standard input: ") && message.contains("truncated"),
        "{message}"
    );
}

/// `colour`: every vertex gets its colour (red, green, blue as PLY names them), read back as
/// the importers read colours; the geometry is the same mesh's.
#[test]
fn coloured_meshes_carry_a_colour_a_vertex() {
    let plain = GenMesh::new(params(20_000)).unwrap();
    let coloured = GenMesh::new(MeshParams {
        colour: true,
        shuffle_vertices: true,
        ..params(20_000)
    })
    .unwrap();
    let bytes = ply_bytes(&coloured);
    let mesh = import(bytes).mesh;
    let colours = mesh.colors.as_ref().expect("colours read back");
    assert_eq!(colours.len(), mesh.positions.len());
    assert_eq!(Some(colours.clone()), coloured.to_input_mesh().colors);
    let distinct: std::collections::HashSet<[u8; 4]> = colours.iter().copied().collect();
    assert!(
        distinct.len() > colours.len() / 4,
        "{} distinct colours",
        distinct.len()
    );
    // The same triangles over the same positions as without colours (up to the shuffle).
    let unshuffled = GenMesh::new(MeshParams {
        colour: true,
        ..params(20_000)
    })
    .unwrap();
    assert_eq!(
        import(ply_bytes(&unshuffled)).mesh.positions,
        import(ply_bytes(&plain)).mesh.positions
    );
}

/// `with_uvs`: one chart a cube face, so the cube's edges are seams: the importer keeps one
/// wedge a face at every edge point (more wedges than vertices), the vertices, triangles and
/// colours are those of the mesh without texture coordinates, and the surface is closed by
/// vertex.
#[test]
fn charted_meshes_have_seams_on_the_cube_edges() {
    let with = |uvs: bool, shuffle: bool| {
        GenMesh::new(MeshParams {
            colour: true,
            shuffle_vertices: shuffle,
            ..params(5_000)
        })
        .unwrap()
        .with_uvs(uvs)
    };
    let charted = with(true, true);
    let n = charted.topology.n;
    assert_eq!(
        charted.vertex_count(),
        6 * (n + 1) * (n + 1) + charted.topology.splits
    );
    let report = import(ply_bytes(&charted));
    let mesh = &report.mesh;
    let plain = import(ply_bytes(&with(false, false))).mesh;
    let vertices = mesh.vertex_starts().vertex_count(mesh.positions.len());
    assert_eq!(vertices, plain.positions.len());
    // A wedge a face at each edge point: 12 (n - 1) edge points twice, 8 corners thrice.
    assert_eq!(mesh.positions.len() as u64, charted.vertex_count());
    assert_eq!(
        mesh.positions.len() - vertices,
        (12 * (n - 1) + 16) as usize
    );
    assert_eq!(*mesh, charted.to_input_mesh());
    let uvs = mesh.uvs.as_ref().expect("texture coordinates read back");
    assert!(uvs.iter().flatten().all(|&x| (0.0..=1.0).contains(&x)));
    // The same triangles over the same positions, with the same colour at each position.
    let by_position = |m: &InputMesh| {
        let colour = |w: u32| m.colors.as_ref().unwrap()[w as usize];
        let mut t: Vec<_> = (m.triangles.iter())
            .map(|t| t.map(|w| (m.positions[w as usize].map(f64::to_bits), colour(w))))
            .collect();
        t.sort();
        t
    };
    assert_eq!(by_position(mesh), by_position(&plain));
    let starts = mesh.vertex_starts();
    let by_vertex = ImportReport {
        mesh: InputMesh {
            triangles: (mesh.triangles.iter())
                .map(|t| t.map(|w| starts.canonical(w)))
                .collect(),
            ..mesh.clone()
        },
        ..report.clone()
    };
    assert_closed(&by_vertex, "charted");
}

/// `--texture`: the header names the PNG written beside the mesh, and the importer reads it
/// as the mesh's one texture, every `v` moved into its band (`shift − v`); without the file
/// the same bytes but the comment.
#[test]
fn a_textured_mesh_names_its_png_and_imports_with_one_band() {
    let mesh = GenMesh::new(params(3000)).unwrap().with_uvs(true);
    let named = mesh.clone().with_texture_file(Some("relief.png".into()));
    let (plain, textured) = (ply_bytes(&mesh), ply_bytes(&named));
    let comment = b"comment TextureFile relief.png\n";
    assert_eq!(textured.len(), plain.len() + comment.len());
    assert!(textured.windows(comment.len()).any(|w| w == comment));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("relief.ply");
    std::fs::write(&path, &textured).unwrap();
    let mut png = std::fs::File::create(dir.path().join("relief.png")).unwrap();
    texture::write_texture_png(16, &mut png).unwrap();
    let report = crate::import::load_mesh(&path).unwrap();
    let t = report.textures.as_ref().expect("a texture");
    assert_eq!(t.textures.len(), 1);
    assert_eq!(t.textures[0].name, "relief.png");
    // The atlas's v lies in (0, 1): −v in (−1, 0), shifted by 1.
    assert_eq!(
        (t.bands[0].start, t.bands[0].span, t.bands[0].shift),
        (0, 1, 1)
    );
    let plain_report = import(plain);
    let (a, b) = (report.mesh.uvs.unwrap(), plain_report.mesh.uvs.unwrap());
    assert_eq!(a.len(), b.len());
    for (got, input) in a.iter().zip(&b) {
        assert_eq!(got[0], input[0]);
        assert!(
            (got[1] - (1.0 - input[1])).abs() < 1e-6,
            "{got:?} {input:?}"
        );
    }
}
