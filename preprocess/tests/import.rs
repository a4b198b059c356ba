//! Importer tests: every format on small files written to a temporary directory, welding and
//! cleaning, and one test per kind of bad input.

use std::io::Write;
use std::path::{Path, PathBuf};

use tessera_preprocess::import::{
    load_mesh, load_mesh_bytes, weld, ImportErrorKind, ImportReport, RawMesh,
};
use tessera_preprocess::mesh::InputMesh;

// ------------------------------------------------------------------------------------ helpers

fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(bytes).unwrap();
    enc.finish().unwrap()
}

fn load(path: &Path) -> ImportReport {
    load_mesh(path).unwrap_or_else(|e| panic!("{e}"))
}

/// The error message for `path`, checked to name the file and contain every fragment.
fn load_err(path: &Path, fragments: &[&str]) -> String {
    let err = match load_mesh(path) {
        Ok(r) => panic!(
            "{} loaded ({} triangles), expected an error",
            path.display(),
            r.mesh.triangles.len()
        ),
        Err(e) => e,
    };
    let msg = err.to_string();
    let name = path.file_name().unwrap().to_str().unwrap();
    assert!(msg.contains(name), "message does not name the file: {msg}");
    for f in fragments {
        assert!(msg.contains(f), "message lacks {f:?}: {msg}");
    }
    msg
}

/// Signed volume: positive for a closed mesh with counter-clockwise (outward) triangles.
fn volume(mesh: &InputMesh) -> f64 {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
            a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0])
        })
        .sum::<f64>()
        / 6.0
}

fn assert_clean(r: &ImportReport) {
    assert_eq!(r.welded_vertices, 0);
    assert_eq!(r.degenerate_triangles, 0);
    assert_eq!(r.duplicate_triangles, 0);
    assert_eq!(r.unreferenced_vertices, 0);
}

const CUBE_POS: [[f64; 3]; 8] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [1.0, 1.0, 1.0],
    [0.0, 1.0, 1.0],
];
/// Outward (counter-clockwise) quads.
const CUBE_QUADS: [[u32; 4]; 6] = [
    [0, 3, 2, 1],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [2, 3, 7, 6],
    [0, 4, 7, 3],
    [1, 2, 6, 5],
];

fn cube_triangles() -> Vec<[u32; 3]> {
    CUBE_QUADS
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect()
}

const TETRA_POS: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];
const TETRA_TRIS: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

fn assert_cube(r: &ImportReport) {
    assert_eq!(r.raw_vertices, 8);
    assert_eq!(r.raw_triangles, 12);
    assert_clean(r);
    assert_eq!(r.mesh.positions, CUBE_POS.to_vec());
    assert_eq!(r.mesh.triangles, cube_triangles());
    assert!((volume(&r.mesh) - 1.0).abs() < 1e-12);
}

fn assert_tetra(mesh: &InputMesh) {
    assert_eq!(mesh.positions, TETRA_POS.to_vec());
    assert_eq!(mesh.triangles, TETRA_TRIS.to_vec());
    assert!((volume(mesh) - 1.0 / 6.0).abs() < 1e-12);
}

// ---------------------------------------------------------------------------- PLY writer

#[derive(Clone, Copy)]
enum Ty {
    S(&'static str),
    L(&'static str, &'static str),
}

struct El {
    name: &'static str,
    props: Vec<(&'static str, Ty)>,
    /// Per record, per property: one value (scalar) or the list items.
    rows: Vec<Vec<Vec<f64>>>,
}

fn encode(ty: &str, v: f64, big: bool, out: &mut Vec<u8>) {
    macro_rules! put {
        ($x:expr) => {
            out.extend_from_slice(&if big {
                $x.to_be_bytes()
            } else {
                $x.to_le_bytes()
            })
        };
    }
    match ty {
        "char" | "int8" => put!(v as i8),
        "uchar" | "uint8" => put!(v as u8),
        "short" | "int16" => put!(v as i16),
        "ushort" | "uint16" => put!(v as u16),
        "int" | "int32" => put!(v as i32),
        "uint" | "uint32" => put!(v as u32),
        "float" | "float32" => put!(v as f32),
        "double" | "float64" => put!(v),
        _ => panic!("type {ty}"),
    }
}

fn ascii(ty: &str, v: f64) -> String {
    match ty {
        "float" | "float32" => format!("{}", v as f32),
        "double" | "float64" => format!("{v}"),
        _ => format!("{}", v as i64),
    }
}

fn ply(format: &str, elements: &[El]) -> Vec<u8> {
    let mut out =
        format!("ply\nformat {format} 1.0\ncomment written by the tessera tests\n").into_bytes();
    for el in elements {
        out.extend(format!("element {} {}\n", el.name, el.rows.len()).bytes());
        for (name, ty) in &el.props {
            let line = match ty {
                Ty::S(t) => format!("property {t} {name}\n"),
                Ty::L(c, i) => format!("property list {c} {i} {name}\n"),
            };
            out.extend(line.bytes());
        }
    }
    out.extend(b"end_header\n");
    let big = format == "binary_big_endian";
    for el in elements {
        for row in &el.rows {
            let mut words = Vec::new();
            for ((_, ty), vals) in el.props.iter().zip(row) {
                match *ty {
                    Ty::S(t) => {
                        if format == "ascii" {
                            words.push(ascii(t, vals[0]));
                        } else {
                            encode(t, vals[0], big, &mut out);
                        }
                    }
                    Ty::L(c, i) => {
                        if format == "ascii" {
                            words.push(vals.len().to_string());
                            words.extend(vals.iter().map(|&v| ascii(i, v)));
                        } else {
                            encode(c, vals.len() as f64, big, &mut out);
                            for &v in vals {
                                encode(i, v, big, &mut out);
                            }
                        }
                    }
                }
            }
            if format == "ascii" {
                out.extend(words.join(" ").bytes());
                out.push(b'\n');
            }
        }
    }
    out
}

fn xyz_props() -> Vec<(&'static str, Ty)> {
    vec![
        ("x", Ty::S("float")),
        ("y", Ty::S("float")),
        ("z", Ty::S("float")),
    ]
}

fn cube_elements() -> Vec<El> {
    vec![
        El {
            name: "vertex",
            props: xyz_props(),
            rows: CUBE_POS
                .iter()
                .map(|p| p.map(|c| vec![c]).to_vec())
                .collect(),
        },
        El {
            name: "face",
            props: vec![("vertex_indices", Ty::L("uchar", "int"))],
            rows: CUBE_QUADS
                .iter()
                .map(|q| vec![q.map(f64::from).to_vec()])
                .collect(),
        },
    ]
}

fn cube_ply(format: &str) -> Vec<u8> {
    ply(format, &cube_elements())
}

/// A tetrahedron with normals, colours, texture coordinates, unknown vertex and face properties
/// and an unknown element with a list, in the given PLY format.
fn attributed_ply(format: &str) -> Vec<u8> {
    let vertex = El {
        name: "vertex",
        props: vec![
            ("x", Ty::S("double")),
            ("confidence", Ty::S("float")),
            ("y", Ty::S("double")),
            ("z", Ty::S("double")),
            ("nx", Ty::S("float")),
            ("ny", Ty::S("float")),
            ("nz", Ty::S("float")),
            ("red", Ty::S("uchar")),
            ("green", Ty::S("uchar")),
            ("blue", Ty::S("uchar")),
            ("alpha", Ty::S("uchar")),
            ("u", Ty::S("float")),
            ("v", Ty::S("float")),
            ("intensity", Ty::S("ushort")),
            ("junk", Ty::L("uchar", "short")),
        ],
        rows: (0..4)
            .map(|i| {
                let p = TETRA_POS[i];
                let k = i as f64;
                vec![
                    vec![p[0]],
                    vec![0.5],
                    vec![p[1]],
                    vec![p[2]],
                    vec![k],
                    vec![-k],
                    vec![0.25],
                    vec![10.0 * k],
                    vec![20.0 * k],
                    vec![30.0 * k],
                    vec![200.0],
                    vec![0.5 * k],
                    vec![0.25],
                    vec![1000.0],
                    vec![-1.0; i],
                ]
            })
            .collect(),
    };
    let face = El {
        name: "face",
        props: vec![
            ("flags", Ty::S("int")),
            ("vertex_index", Ty::L("uint8", "uint")),
            ("texcoord", Ty::L("uchar", "float")),
        ],
        rows: TETRA_TRIS
            .iter()
            .map(|t| vec![vec![7.0], t.map(f64::from).to_vec(), vec![0.5; 6]])
            .collect(),
    };
    let edge = El {
        name: "edge",
        props: vec![
            ("vertex1", Ty::S("int")),
            ("stuff", Ty::L("int", "double")),
            ("vertex2", Ty::S("int")),
        ],
        rows: vec![
            vec![vec![0.0], vec![1.5, 2.5], vec![1.0]],
            vec![vec![1.0], vec![], vec![2.0]],
        ],
    };
    ply(format, &[vertex, edge, face])
}

// ---------------------------------------------------------------------------------- PLY

#[test]
fn ply_ascii_cube_quads_are_fan_triangulated() {
    let dir = tempfile::tempdir().unwrap();
    let r = load(&write(dir.path(), "cube.ply", cube_ply("ascii")));
    assert_cube(&r);
    assert_eq!(r.mesh.normals, None);
    assert_eq!(r.mesh.colors, None);
    assert_eq!(r.mesh.uvs, None);
}

#[test]
fn ply_ascii_and_binary_give_identical_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let ascii = load(&write(dir.path(), "a.ply", cube_ply("ascii")));
    let le = load(&write(
        dir.path(),
        "le.ply",
        cube_ply("binary_little_endian"),
    ));
    let be = load(&write(dir.path(), "be.ply", cube_ply("binary_big_endian")));
    assert_cube(&le);
    assert_eq!(ascii, le);
    assert_eq!(ascii, be);
}

#[test]
fn ply_attributes_and_unknown_properties_in_all_formats() {
    let dir = tempfile::tempdir().unwrap();
    let mut reports = Vec::new();
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        let r = load(&write(
            dir.path(),
            &format!("{format}.ply"),
            attributed_ply(format),
        ));
        assert_tetra(&r.mesh);
        assert_clean(&r);
        let normals = r.mesh.normals.as_ref().expect("normals");
        assert_eq!(normals[2], [2.0, -2.0, 0.25]);
        let colors = r.mesh.colors.as_ref().expect("colors");
        assert_eq!(colors[3], [30, 60, 90, 200]);
        let uvs = r.mesh.uvs.as_ref().expect("uvs");
        assert_eq!(uvs[1], [0.5, 0.25]);
        reports.push(r);
    }
    assert_eq!(reports[0], reports[1]);
    assert_eq!(reports[0], reports[2]);
}

#[test]
fn ply_float_colors_and_st_texture_coordinates() {
    let dir = tempfile::tempdir().unwrap();
    let mut props = xyz_props();
    props.extend([
        ("red", Ty::S("float")),
        ("green", Ty::S("float")),
        ("blue", Ty::S("float")),
        ("s", Ty::S("float")),
        ("t", Ty::S("float")),
    ]);
    let rows = TETRA_POS
        .iter()
        .map(|p| {
            let mut row: Vec<Vec<f64>> = p.iter().map(|&c| vec![c]).collect();
            row.extend([vec![1.0], vec![0.5], vec![0.0], vec![0.75], vec![0.125]]);
            row
        })
        .collect();
    let face = El {
        name: "face",
        props: vec![("vertex_indices", Ty::L("uchar", "int"))],
        rows: TETRA_TRIS
            .iter()
            .map(|t| vec![t.map(f64::from).to_vec()])
            .collect(),
    };
    let bytes = ply(
        "binary_little_endian",
        &[
            El {
                name: "vertex",
                props,
                rows,
            },
            face,
        ],
    );
    let r = load(&write(dir.path(), "fc.ply", bytes));
    assert_eq!(r.mesh.colors.unwrap()[0], [255, 128, 0, 255]);
    assert_eq!(r.mesh.uvs.unwrap()[0], [0.75, 0.125]);
    assert_eq!(r.mesh.normals, None);
}

#[test]
fn ply_gzip_and_case_insensitive_extension() {
    let dir = tempfile::tempdir().unwrap();
    let plain = load(&write(dir.path(), "cube.ply", cube_ply("ascii")));
    let gz = load(&write(dir.path(), "cube.ply.gz", gzip(&cube_ply("ascii"))));
    let upper = load(&write(
        dir.path(),
        "CUBE.PLY.GZ",
        gzip(&cube_ply("binary_big_endian")),
    ));
    assert_eq!(plain, gz);
    assert_eq!(plain, upper);
}

#[test]
fn ply_tristrips_and_crlf_header() {
    let dir = tempfile::tempdir().unwrap();
    // One strip 0 1 2 3 gives (0 1 2), (2 1 3); after the restart, 1 3 2 gives (1 3 2).
    let text =
        "ply\r\nformat ascii 1.0\r\nelement vertex 4\r\nproperty float x\r\nproperty float y\r\n\
                property float z\r\nelement tristrips 1\r\nproperty list int int vertex_indices\r\n\
                end_header\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n1 1 0\r\n8 0 1 2 3 -1 1 3 0\r\n";
    let r = load(&write(dir.path(), "strip.ply", text));
    assert_eq!(r.mesh.triangles, vec![[0, 1, 2], [2, 1, 3], [1, 3, 0]]);
}

// ---------------------------------------------------------------------------------- OFF

fn cube_off() -> String {
    let mut s = String::from("OFF\n# a cube\n8 6 12\n");
    for p in CUBE_POS {
        s += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    s += "\n";
    for q in CUBE_QUADS {
        s += &format!(
            "4 {} {} {} {} 255 0 0 # with a face colour\n",
            q[0], q[1], q[2], q[3]
        );
    }
    s
}

#[test]
fn off_cube_with_comments_and_face_colors() {
    let dir = tempfile::tempdir().unwrap();
    let r = load(&write(dir.path(), "cube.off", cube_off()));
    assert_cube(&r);
    // Every face red: the corners' colour (wedges where faces around a vertex differ).
    assert_eq!(r.mesh.colors, Some(vec![[255, 0, 0, 255]; 8]));
    let gz = load(&write(
        dir.path(),
        "cube.off.gz",
        gzip(cube_off().as_bytes()),
    ));
    assert_eq!(r, gz);
}

#[test]
fn off_counts_on_header_line_and_variants() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = String::from("OFF 4 4 0\n");
    for p in TETRA_POS {
        s += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    for t in TETRA_TRIS {
        s += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    let r = load(&write(dir.path(), "t.off", &s));
    assert_tetra(&r.mesh);

    // COFF (integer and float colours), NOFF, STOFF.
    let mut coff = String::from("COFF\n4 4 0\n");
    let mut noff = String::from("NOFF\n4 4 0\n");
    let mut stoff = String::from("STOFF\n4 4 0\n");
    for (i, p) in TETRA_POS.iter().enumerate() {
        if i % 2 == 0 {
            coff += &format!("{} {} {} 10 20 30 255\n", p[0], p[1], p[2]);
        } else {
            coff += &format!("{} {} {} 1.0 0.5 0.0\n", p[0], p[1], p[2]);
        }
        noff += &format!("{} {} {} 0 0 {i}\n", p[0], p[1], p[2]);
        stoff += &format!("{} {} {} 0.5 {i}\n", p[0], p[1], p[2]);
    }
    for t in TETRA_TRIS {
        for s in [&mut coff, &mut noff, &mut stoff] {
            *s += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
        }
    }
    let c = load(&write(dir.path(), "c.off", coff));
    assert_tetra(&c.mesh);
    assert_eq!(
        c.mesh.colors.unwrap(),
        vec![
            [10, 20, 30, 255],
            [255, 128, 0, 255],
            [10, 20, 30, 255],
            [255, 128, 0, 255]
        ]
    );
    let n = load(&write(dir.path(), "n.off", noff));
    assert_eq!(n.mesh.normals.unwrap()[3], [0.0, 0.0, 3.0]);
    let st = load(&write(dir.path(), "st.off", stoff));
    assert_eq!(st.mesh.uvs.unwrap()[2], [0.5, 2.0]);
}

// ---------------------------------------------------------------------------------- OBJ

#[test]
fn obj_cube_with_quads_groups_and_negative_indices() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = String::from("# cube\nmtllib cube.mtl\no cube\n");
    for p in &CUBE_POS[..4] {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    s += "g bottom\nusemtl red\ns off\nf -4 -1 -2 -3\n"; // 0 3 2 1
    for p in &CUBE_POS[4..] {
        s += &format!("v {:.6} {:.6} {:.6}\n", p[0], p[1], p[2]);
    }
    s += "o rest\n";
    for q in &CUBE_QUADS[1..] {
        s += &format!("f {} {} {} {}\n", q[0] + 1, q[1] + 1, q[2] + 1, q[3] + 1);
    }
    s += "l 1 2\n";
    let r = load(&write(dir.path(), "cube.obj", &s));
    assert_cube(&r);
    assert_eq!(
        (r.mesh.normals, r.mesh.uvs, r.mesh.colors),
        (None, None, None)
    );
    let gz = load(&write(dir.path(), "cube.obj.gz", gzip(s.as_bytes())));
    assert_eq!(gz.mesh.triangles, cube_triangles());
}

#[test]
fn obj_attributes_from_first_corner() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = String::new();
    for (i, p) in TETRA_POS.iter().enumerate() {
        s += &format!(
            "v {} {} {} 1 0.5 0\nvt {i} 0.5\nvn 0 0 {i}\n",
            p[0], p[1], p[2]
        );
    }
    for t in TETRA_TRIS {
        s += &format!(
            "f {0}/{0}/{0} {1}/{1}/{1} {2}/{2}/{2}\n",
            t[0] + 1,
            t[1] + 1,
            t[2] + 1
        );
    }
    // A later corner with a different normal does not override the first.
    s += "vn 1 0 0\nf 1/1/5 2/2/5 3/3/5\n";
    let r = load(&write(dir.path(), "t.obj", &s));
    assert_tetra(&r.mesh);
    assert_eq!(r.duplicate_triangles, 1);
    assert_eq!(r.mesh.uvs.unwrap()[3], [3.0, 0.5]);
    assert_eq!(r.mesh.normals.unwrap()[0], [0.0, 0.0, 0.0]);
    assert_eq!(r.mesh.colors.unwrap()[1], [255, 128, 0, 255]);

    // One corner without a normal: no normals at all.
    let s2 = s.replace("f 1/1/5 2/2/5 3/3/5", "f 1/1 2/2 3/3");
    let r2 = load(&write(dir.path(), "t2.obj", s2));
    assert_eq!(r2.mesh.normals, None);
    assert!(r2.mesh.uvs.is_some());
}

// ---------------------------------------------------------------------------------- STL

fn tetra_stl_ascii() -> String {
    let mut s = String::from("solid tetra\n");
    for t in TETRA_TRIS {
        s += "  facet normal 0 0 0\n    outer loop\n";
        for v in t {
            let p = TETRA_POS[v as usize];
            s += &format!("      vertex {:e} {} {}\n", p[0], p[1], p[2]);
        }
        s += "    endloop\n  endfacet\n";
    }
    s + "endsolid tetra\n"
}

fn tetra_stl_binary(header: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; 80];
    out[..header.len()].copy_from_slice(header);
    out.extend((TETRA_TRIS.len() as u32).to_le_bytes());
    for t in TETRA_TRIS {
        out.extend([0u8; 12]);
        for v in t {
            for c in TETRA_POS[v as usize] {
                out.extend((c as f32).to_le_bytes());
            }
        }
        out.extend([0u8; 2]);
    }
    out
}

fn assert_stl_tetra(r: &ImportReport) {
    assert_eq!(r.raw_vertices, 12);
    assert_eq!(r.raw_triangles, 4);
    assert_eq!(r.welded_vertices, 8);
    assert_eq!(r.mesh.normals, None);
    // Welding keeps vertices in order of first appearance: 0 2 1 3.
    assert_eq!(
        r.mesh.positions,
        vec![TETRA_POS[0], TETRA_POS[2], TETRA_POS[1], TETRA_POS[3]]
    );
    assert!((volume(&r.mesh) - 1.0 / 6.0).abs() < 1e-12);
}

#[test]
fn stl_ascii_and_binary() {
    let dir = tempfile::tempdir().unwrap();
    let ascii = load(&write(dir.path(), "a.stl", tetra_stl_ascii()));
    assert_stl_tetra(&ascii);
    let binary = load(&write(
        dir.path(),
        "b.stl",
        tetra_stl_binary(b"binary tetra"),
    ));
    assert_eq!(ascii, binary);
    // A binary file whose header starts with "solid" is still binary.
    let solid = load(&write(
        dir.path(),
        "s.stl",
        tetra_stl_binary(b"solid but binary"),
    ));
    assert_eq!(ascii, solid);
    let gz_ascii = load(&write(
        dir.path(),
        "a.stl.gz",
        gzip(tetra_stl_ascii().as_bytes()),
    ));
    assert_eq!(ascii, gz_ascii);
    let gz_solid = load(&write(
        dir.path(),
        "s.stl.gz",
        gzip(&tetra_stl_binary(b"solid x")),
    ));
    assert_eq!(ascii, gz_solid);
}

// --------------------------------------------------------------------------------- glTF

/// JSON and binary buffer of a tetrahedron (positions, normals, u16 indices) instanced by
/// three nodes: identity, translated by (10, 0, 0), and mirrored in x then translated by
/// (0, 10, 0).
fn tetra_gltf(uri: Option<&str>) -> (String, Vec<u8>) {
    let mut bin = Vec::new();
    for p in TETRA_POS {
        for c in p {
            bin.extend((c as f32).to_le_bytes());
        }
    }
    for i in 0..4 {
        bin.extend(1f32.to_le_bytes());
        bin.extend(0f32.to_le_bytes());
        bin.extend((i as f32).to_le_bytes());
    }
    for t in TETRA_TRIS {
        for v in t {
            bin.extend((v as u16).to_le_bytes());
        }
    }
    let buffer = match uri {
        Some(u) => format!(r#"{{"byteLength":{},"uri":"{u}"}}"#, bin.len()),
        None => format!(r#"{{"byteLength":{}}}"#, bin.len()),
    };
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{buffer}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":48}},
                       {{"buffer":0,"byteOffset":96,"byteLength":24}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,1]}},
                     {{"bufferView":1,"componentType":5126,"count":4,"type":"VEC3"}},
                     {{"bufferView":2,"componentType":5123,"count":12,"type":"SCALAR"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1}},"indices":2}}]}}],
        "nodes":[{{"mesh":0}},{{"mesh":0,"translation":[10,0,0]}},{{"children":[3],"translation":[0,10,0]}},
                 {{"mesh":0,"scale":[-1,1,1]}}],
        "scenes":[{{"nodes":[0,1,2]}}],"scene":0}}"#
    );
    (json, bin)
}

fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut json = json.as_bytes().to_vec();
    json.resize(json.len().next_multiple_of(4), b' ');
    let mut bin = bin.to_vec();
    bin.resize(bin.len().next_multiple_of(4), 0);
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(&bin);
    out
}

fn assert_gltf_tetras(r: &ImportReport) {
    assert_eq!(r.raw_vertices, 12);
    assert_eq!(r.raw_triangles, 12);
    assert_clean(r);
    let m = &r.mesh;
    assert_eq!(m.positions[..4], TETRA_POS);
    assert_eq!(m.positions[5], [11.0, 0.0, 0.0]);
    assert_eq!(m.positions[9], [-1.0, 10.0, 0.0]);
    assert_eq!(m.triangles[..4], TETRA_TRIS);
    // The mirrored copy is flipped back to counter-clockwise: all three volumes add up.
    assert!(
        (volume(m) - 3.0 / 6.0).abs() < 1e-12,
        "volume {}",
        volume(m)
    );
    let normals = m.normals.as_ref().unwrap();
    let s = 0.5f32.sqrt();
    assert_eq!(normals[1], [s, 0.0, s]);
    assert_eq!(normals[9], [-s, 0.0, s]);
    assert_eq!(m.colors, None);
    assert_eq!(m.uvs, None);
}

#[test]
fn gltf_with_external_buffer_and_glb() {
    let dir = tempfile::tempdir().unwrap();
    let (json, bin) = tetra_gltf(Some("tetra.bin"));
    write(dir.path(), "tetra.bin", &bin);
    let r = load(&write(dir.path(), "tetra.gltf", json));
    assert_gltf_tetras(&r);

    let (json, bin) = tetra_gltf(None);
    let r2 = load(&write(dir.path(), "tetra.glb", glb(&json, &bin)));
    assert_eq!(r, r2);
}

#[test]
fn gltf_bytes_refuse_external_buffers_and_bad_accessors() {
    let (json, bin) = tetra_gltf(None);
    let name = Path::new("tetra.glb");
    let r = load_mesh_bytes(name, &glb(&json, &bin)).unwrap();
    assert_gltf_tetras(&r);
    let message = |json: &str| {
        load_mesh_bytes(name, &glb(json, &bin))
            .unwrap_err()
            .to_string()
    };
    // From bytes there is no directory to find an external buffer in.
    let (external, _) = tetra_gltf(Some("tetra.bin"));
    let m = load_mesh_bytes(Path::new("tetra.gltf"), external.as_bytes())
        .unwrap_err()
        .to_string();
    assert!(
        m.starts_with("tetra.gltf: ") && m.contains("external file"),
        "{m}"
    );
    // An accessor past its buffer view, of the wrong type, or without elements; a node with
    // two parents (a small file could otherwise make the walk exponential).
    for (from, to, fragment) in [
        (
            r#""count":12,"type":"SCALAR""#,
            r#""count":13,"type":"SCALAR""#,
            "buffer view 2 has 24",
        ),
        (
            r#""componentType":5123"#,
            r#""componentType":5126"#,
            "wrong type",
        ),
        (
            r#""count":12,"type":"SCALAR""#,
            r#""count":0,"type":"SCALAR""#,
            "no elements",
        ),
        (
            r#""children":[3]"#,
            r#""children":[3,3]"#,
            "node reached twice",
        ),
        // gltf-json's validation indexed the accessors with this before checking it.
        (
            r#""POSITION":0"#,
            r#""POSITION":7"#,
            "accessor 7 does not exist",
        ),
    ] {
        assert!(json.contains(from));
        let m = message(&json.replacen(from, to, 1));
        assert!(m.starts_with("tetra.glb: ") && m.contains(fragment), "{m}");
    }
}

#[test]
fn glb_declaring_a_length_shorter_than_its_header_is_an_error() {
    // Found by the gltf fuzzer: the gltf crate computed `length - 12` unchecked.
    let (json, bin) = tetra_gltf(None);
    let mut bytes = glb(&json, &bin);
    bytes[8..12].copy_from_slice(&0u32.to_le_bytes());
    let m = load_mesh_bytes(Path::new("short.glb"), &bytes)
        .unwrap_err()
        .to_string();
    assert!(
        m.starts_with("short.glb: ") && m.contains("12-byte header"),
        "{m}"
    );
}

#[test]
fn bytes_in_memory_import_like_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let (json, bin) = tetra_gltf(None);
    for (name, bytes) in [
        ("cube.ply", cube_ply("binary_big_endian")),
        ("cube.ply.gz", gzip(&cube_ply("ascii"))),
        ("cube.off", cube_off().into_bytes()),
        ("tetra.stl", tetra_stl_binary(b"solid x")),
        ("tetra.stl", tetra_stl_ascii().into_bytes()),
        ("tetra.glb", glb(&json, &bin)),
        ("tetra.glb.gz", gzip(&glb(&json, &bin))),
    ] {
        let path = write(dir.path(), name, &bytes);
        assert_eq!(
            load_mesh_bytes(Path::new(name), &bytes).unwrap(),
            load(&path),
            "{name}"
        );
    }
    // Errors name the given name, like a file's.
    let m = load_mesh_bytes(Path::new("bad.off"), b"OFF\n3 1 0\n0 0 0\n")
        .unwrap_err()
        .to_string();
    assert!(m.starts_with("bad.off: ") && m.contains("truncated"), "{m}");
    let m = load_mesh_bytes(Path::new("x.xyz"), b"")
        .unwrap_err()
        .to_string();
    assert!(m.contains("unsupported file type"), "{m}");
}

#[test]
fn ply_face_counts_whose_sum_overflows_are_an_error() {
    // Two face-like elements declaring u64::MAX records each: their sum overflowed (a panic
    // with overflow checks) before the missing records were reported.
    let max = u64::MAX;
    let header = format!(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nelement face {max}\nproperty list uchar int vertex_indices\n\
         element tristrips {max}\nproperty list int int vertex_indices\nend_header\n\
         0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
    );
    let m = load_mesh_bytes(Path::new("sum.ply"), header.as_bytes())
        .unwrap_err()
        .to_string();
    assert!(m.starts_with("sum.ply: ") && m.contains("truncated"), "{m}");
}

// ------------------------------------------------------------------------------ welding

#[test]
fn weld_counts_and_keeps_first_attributes_in_order() {
    let raw = RawMesh {
        positions: vec![
            [0.0, 0.0, 0.0],  // 0
            [9.0, 9.0, 9.0],  // 1 unreferenced
            [1.0, 0.0, 0.0],  // 2
            [0.0, 1.0, 0.0],  // 3
            [1.0, 0.0, 0.0],  // 4 = 2
            [0.0, 0.0, 1.0],  // 5
            [0.0, -0.0, 0.0], // 6 = 0
        ],
        triangles: vec![
            [0, 2, 3],
            [6, 3, 4], // duplicate of the first, other orientation
            [0, 2, 4], // degenerate after welding
            [2, 3, 5],
            [5, 3, 2], // duplicate, reversed
            [0, 5, 3],
            [3, 5, 0], // duplicate, rotated
        ],
        normals: None,
        colors: Some((0..7).map(|i| [i, 0, 0, 255]).collect()),
        uvs: None,
    };
    let r = weld(raw);
    assert_eq!(r.raw_vertices, 7);
    assert_eq!(r.raw_triangles, 7);
    assert_eq!(r.welded_vertices, 2);
    assert_eq!(r.degenerate_triangles, 1);
    assert_eq!(r.duplicate_triangles, 3);
    assert_eq!(r.unreferenced_vertices, 1);
    assert_eq!(
        r.mesh.positions,
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0]
        ]
    );
    assert_eq!(
        r.mesh.colors.unwrap(),
        vec![
            [0, 0, 0, 255],
            [2, 0, 0, 255],
            [3, 0, 0, 255],
            [5, 0, 0, 255]
        ]
    );
    assert_eq!(r.mesh.triangles, vec![[0, 1, 2], [1, 2, 3], [0, 3, 2]]);
}

#[test]
fn weld_many_duplicates_around_one_vertex() {
    // More than 16 triangles share their smallest vertex (the bucket is sorted, not scanned).
    let mut positions = vec![[0.0, 0.0, 0.0]];
    let mut triangles = Vec::new();
    for i in 0..40u32 {
        let a = i as f64;
        positions.push([a.cos(), a.sin(), 0.0]);
        if i > 0 {
            triangles.push([0, i, i + 1]);
        }
    }
    let mut all = triangles.clone();
    all.extend(triangles.iter().rev().map(|t| [t[2], t[1], t[0]]));
    let r = weld(RawMesh {
        positions,
        triangles: all,
        ..Default::default()
    });
    assert_eq!(r.duplicate_triangles, 39);
    assert_eq!(r.mesh.triangles, triangles);
}

#[test]
fn non_manifold_edge_is_kept() {
    let dir = tempfile::tempdir().unwrap();
    // Three triangles on edge 0-1.
    let s = "OFF\n5 3 0\n0 0 0\n1 0 0\n0 1 0\n0 -1 0\n0 0 1\n3 0 1 2\n3 1 0 3\n3 0 1 4\n";
    let r = load(&write(dir.path(), "fin.off", s));
    assert_clean(&r);
    assert_eq!(r.mesh.triangles, vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]]);
}

#[test]
fn welding_applies_to_files() {
    let dir = tempfile::tempdir().unwrap();
    // Vertex 4 repeats vertex 1; face 2 repeats face 0 reversed; face 3 is degenerate.
    let s = "OFF\n6 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 0 0\n5 5 5\n3 0 1 2\n3 0 2 4\n3 2 1 0\n3 0 1 4\n";
    let r = load(&write(dir.path(), "w.off", s));
    assert_eq!(
        (
            r.welded_vertices,
            r.duplicate_triangles,
            r.degenerate_triangles,
            r.unreferenced_vertices
        ),
        (1, 2, 1, 2)
    );
    assert_eq!(r.mesh.positions.len(), 3);
    assert_eq!(r.mesh.triangles, vec![[0, 1, 2]]);
}

// ------------------------------------------------------------------------------- errors

#[test]
fn error_missing_file_and_directory() {
    let dir = tempfile::tempdir().unwrap();
    load_err(&dir.path().join("nothere.ply"), &["cannot read file"]);
    let sub = dir.path().join("sub.obj");
    std::fs::create_dir(&sub).unwrap();
    load_err(&sub, &["cannot read file"]);
}

#[test]
fn error_unknown_extension_lists_supported() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "mesh.3ds", "x");
    load_err(
        &p,
        &[
            "unsupported file type \".3ds\"",
            ".ply",
            ".obj",
            ".off",
            ".stl",
            ".gltf",
            ".glb",
            ".gz",
        ],
    );
    let p = write(dir.path(), "noext", "x");
    load_err(&p, &["unsupported file type"]);
}

#[test]
fn error_malformed_headers() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    load_err(
        &write(d, "magic.ply", "plx\nformat ascii 1.0\nend_header\n"),
        &["line 1: malformed header", "'ply'"],
    );
    load_err(
        &write(d, "empty.ply", ""),
        &["malformed header", "empty file"],
    );
    load_err(
        &write(
            d,
            "count.ply",
            "ply\nformat ascii 1.0\nelement vertex lots\nend_header\n",
        ),
        &["line 3: malformed header", "invalid count 'lots'"],
    );
    load_err(
        &write(
            d,
            "noend.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n",
        ),
        &["malformed header", "end_header"],
    );
    load_err(
        &write(
            d,
            "noxyz.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n",
        ),
        &["malformed header", "x, y or z"],
    );
    load_err(
        &write(
            d,
            "noidx.ply",
            "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\n\
             element face 0\nproperty list uchar int corners\nend_header\n",
        ),
        &["malformed header", "vertex_indices"],
    );
    load_err(
        &write(d, "kw.off", "OFX\n1 0 0\n"),
        &["line 1: malformed header", "'OFX'"],
    );
    load_err(
        &write(d, "counts.off", "OFF\n3\n"),
        &["line 2: malformed header", "missing face count"],
    );
}

#[test]
fn error_unsupported_ply_types_and_formats() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    load_err(
        &write(
            d,
            "int64.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty int64 x\nend_header\n",
        ),
        &["line 4: unsupported PLY property type 'int64'"],
    );
    load_err(
        &write(
            d,
            "fmt.ply",
            "ply\nformat binary_middle_endian 1.0\nend_header\n",
        ),
        &["line 2: unsupported PLY format 'binary_middle_endian'"],
    );
    load_err(
        &write(
            d,
            "fidx.ply",
            "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\n\
             element face 0\nproperty list uchar float vertex_indices\nend_header\n",
        ),
        &["unsupported vertex index type 'float'"],
    );
    load_err(
        &write(d, "bin.off", "OFF BINARY\n"),
        &["unsupported binary OFF"],
    );
}

#[test]
fn error_index_out_of_range() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut elements = cube_elements();
    elements[1].rows[3][0][2] = 90210.0;
    // Line 22: 10 header lines, 8 vertex lines, then the fourth face.
    load_err(
        &write(d, "idx.ply", ply("ascii", &elements)),
        &["line 22: vertex index 90210 out of range (8 vertices)"],
    );
    load_err(
        &write(d, "idx_bin.ply", ply("binary_little_endian", &elements)),
        &["face 3: vertex index 90210 out of range (8 vertices)"],
    );
    elements[1].rows[3][0][2] = -1.0;
    load_err(
        &write(d, "neg.ply", ply("binary_big_endian", &elements)),
        &["face 3: vertex index -1 out of range"],
    );
    load_err(
        &write(d, "idx.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"),
        &["line 6: vertex index 3 out of range (3 vertices)"],
    );
    load_err(
        &write(d, "idx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"),
        &["line 4: vertex index 4 out of range (3 vertices)"],
    );
    load_err(
        &write(d, "rel.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n"),
        &["line 4: vertex index -4 out of range"],
    );
    load_err(
        &write(d, "zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"),
        &["line 4: vertex index 0 is invalid"],
    );
    load_err(
        &write(
            d,
            "vt.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n",
        ),
        &["line 5: texture coordinate index 2 out of range (1 defined)"],
    );
    let (json, bin) = tetra_gltf(None);
    let mut bin = bin;
    bin[96] = 9; // first index
    load_err(
        &write(d, "idx.glb", glb(&json, &bin)),
        &["mesh 0 primitive 0: vertex index 9 out of range (4 vertices)"],
    );
}

#[test]
fn error_non_finite_coordinates() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut elements = cube_elements();
    elements[0].rows[2][1][0] = f64::NAN;
    load_err(
        &write(d, "nan.ply", ply("ascii", &elements)),
        &["line 13: vertex 2 has a non-finite coordinate"],
    );
    elements[0].rows[2][1][0] = f64::INFINITY;
    load_err(
        &write(d, "inf.ply", ply("binary_little_endian", &elements)),
        &["vertex 2 has a non-finite coordinate"],
    );
    load_err(
        &write(d, "inf.obj", "v 0 0 0\nv inf 0 0\n"),
        &["line 2: vertex 1 has a non-finite coordinate"],
    );
    load_err(
        &write(d, "nan.off", "OFF\n2 0 0\n0 0 0\n0 NaN 0\n"),
        &["line 4: vertex 1 has a non-finite coordinate"],
    );
    let mut stl = tetra_stl_binary(b"");
    stl[84 + 50 + 12..84 + 50 + 16].copy_from_slice(&f32::NAN.to_le_bytes());
    load_err(
        &write(d, "nan.stl", stl),
        &["triangle 1: vertex 3 has a non-finite coordinate"],
    );
}

#[test]
fn error_truncated_text() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = String::from_utf8(cube_ply("ascii")).unwrap();
    let cut = text.lines().take(23).collect::<Vec<_>>().join("\n");
    load_err(
        &write(d, "cut.ply", &cut),
        &["data truncated: expected 6 faces, file ends after 5"],
    );
    let cut_mid = &text[..text.len() - 4];
    load_err(
        &write(d, "mid.ply", cut_mid),
        &["data truncated: expected 6 faces, file ends after 5"],
    );
    let cut_vertices = text.lines().take(14).collect::<Vec<_>>().join("\n");
    load_err(
        &write(d, "cutv.ply", cut_vertices),
        &["data truncated: expected 8 vertices, file ends after 4"],
    );
    load_err(
        &write(d, "missing.ply", text.replacen("1 1 0\n", "1 1\n", 1)),
        &["line 13: missing value for property 'z'"],
    );
    load_err(
        &write(d, "extra.ply", text.replacen("1 1 0\n", "1 1 0 0\n", 1)),
        &["line 13: too many values for one vertex"],
    );
    load_err(
        &write(d, "cut.off", &cube_off()[..200]),
        &["data truncated: expected 6 faces, file ends after"],
    );
    load_err(
        &write(d, "cutv.off", "OFF\n4 1 0\n0 0 0\n"),
        &["data truncated: expected 4 vertices, file ends after 1"],
    );
    let stl = tetra_stl_ascii();
    load_err(
        &write(d, "cut.stl", &stl[..stl.len() - 60]),
        &["ASCII STL truncated"],
    );
    load_err(
        &write(d, "bad.stl", stl.replacen("outer loop", "outer lop", 1)),
        &["line 3: expected 'loop', found 'lop'"],
    );
    load_err(
        &write(d, "bad.obj", "v 0 0 zero\n"),
        &["line 1: invalid number 'zero'"],
    );
}

#[test]
fn error_truncated_binary() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bytes = cube_ply("binary_little_endian");
    let header_len = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    // Uncompressed, the file size bounds the counts before anything is read...
    load_err(
        &write(d, "short.ply", &bytes[..header_len + 50]),
        &["binary data truncated: header declares 8 vertices, 6 faces (at least 102 bytes), but only 50 bytes \
           follow the header"],
    );
    // ... and a file that passes that check still ends early.
    load_err(
        &write(d, "cut.ply", &bytes[..bytes.len() - 10]),
        &["binary data truncated: expected 6 faces, file ends after 5"],
    );
    // Compressed, the size is unknown up front: the reader finds the end.
    load_err(
        &write(d, "cut.ply.gz", gzip(&bytes[..header_len + 12 * 3 + 5])),
        &["binary data truncated: expected 8 vertices, file ends after 3"],
    );
    load_err(
        &write(d, "cutf.ply.gz", gzip(&bytes[..bytes.len() - 10])),
        &["binary data truncated: expected 6 faces, file ends after 5"],
    );
    let stl = tetra_stl_binary(b"");
    load_err(
        &write(d, "cut.stl", &stl[..stl.len() - 1]),
        &["binary data truncated: header declares 4 triangles (284 bytes), but the file has only 283 bytes"],
    );
    load_err(
        &write(d, "cut.stl.gz", gzip(&stl[..150])),
        &["binary data truncated: expected 4 triangles, file ends after 1"],
    );
    load_err(
        &write(d, "tiny.stl", [0u8; 20]),
        &["shorter than the 84-byte header"],
    );
}

#[test]
fn error_empty_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut elements = cube_elements();
    elements[1].rows.clear();
    load_err(
        &write(d, "nofaces.ply", ply("ascii", &elements)),
        &["empty mesh", "0 raw triangles"],
    );
    load_err(
        &write(d, "points.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n"),
        &["empty mesh"],
    );
    load_err(
        &write(d, "degenerate.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n1 0 0\n3 0 1 2\n3 2 1 0\n"),
        &["empty mesh: no triangles left after cleaning (2 raw triangles, 2 degenerate, 0 duplicate)"],
    );
    load_err(
        &write(d, "empty.stl", "solid empty\nendsolid empty\n"),
        &["empty mesh"],
    );
    load_err(&write(d, "empty.obj", "# nothing\n"), &["empty mesh"]);
}

#[test]
fn error_absurd_counts_fail_fast() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let header = |format: &str, nv: u64, nf: u64| {
        format!(
            "ply\nformat {format} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n\
             element face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
        )
    };
    let start = std::time::Instant::now();
    // More vertices than 32-bit ids allow.
    load_err(
        &write(
            d,
            "huge.ply",
            header("binary_little_endian", 1_000_000_000_000, 1),
        ),
        &["too large", "1000000000000 vertices"],
    );
    // Bounded by the file size.
    load_err(
        &write(
            d,
            "many.ply",
            header("binary_little_endian", 8, 1_000_000_000_000),
        ),
        &["binary data truncated: header declares 8 vertices, 1000000000000 faces"],
    );
    load_err(
        &write(
            d,
            "many_v.ply",
            header("binary_big_endian", 4_000_000_000, 0),
        ),
        &["binary data truncated"],
    );
    // Unbounded (ASCII, compressed): capped pre-allocation, then the end of the data.
    let mut text = header("ascii", 4_000_000_000, 1_000_000_000_000);
    text += "0 0 0\n";
    load_err(
        &write(d, "many.ply.gz", gzip(text.as_bytes())),
        &["data truncated: expected 4000000000 vertices, file ends after 1"],
    );
    load_err(
        &write(d, "many_ascii.ply", &text),
        &["data truncated: expected 4000000000 vertices, file ends after 1"],
    );
    let mut bin = header("binary_little_endian", 4_000_000_000, 1).into_bytes();
    bin.extend([0u8; 12]);
    load_err(
        &write(d, "many_bin.ply.gz", gzip(&bin)),
        &["binary data truncated: expected 4000000000 vertices, file ends after 1"],
    );
    load_err(
        &write(d, "many.off", "OFF\n4000000000 4000000000 0\n0 0 0\n"),
        &["data truncated: expected 4000000000 vertices"],
    );
    load_err(
        &write(d, "huge.off", "OFF\n5000000000 1 0\n"),
        &["too large", "5000000000 vertices"],
    );
    let mut stl = vec![0u8; 80];
    stl.extend(u32::MAX.to_le_bytes());
    load_err(
        &write(d, "many.stl", &stl),
        &["binary data truncated: header declares 4294967295 triangles"],
    );
    load_err(
        &write(d, "huge.stl.gz", gzip(&stl)),
        &["too large", "4294967295 triangles"],
    );
    stl[80..84].copy_from_slice(&1_000_000_000u32.to_le_bytes());
    load_err(
        &write(d, "many.stl.gz", gzip(&stl)),
        &["binary data truncated: expected 1000000000 triangles, file ends after 0"],
    );
    let elapsed = start.elapsed();
    assert!(
        elapsed.as_secs_f64() < 20.0,
        "absurd counts took {elapsed:?}"
    );
}

#[test]
fn error_bad_gzip_stream() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    load_err(
        &write(d, "plain.ply.gz", cube_ply("ascii")),
        &["bad gzip stream"],
    );
    let gz = gzip(&cube_ply("ascii"));
    let mut corrupt = gz.clone();
    corrupt[10] = 0xff; // first deflate block: reserved block type
    load_err(&write(d, "corrupt.ply.gz", corrupt), &["bad gzip stream"]);
    load_err(
        &write(d, "cut.ply.gz", &gz[..gz.len() / 2]),
        &["bad gzip stream"],
    );
}

#[test]
fn error_gltf_invalid() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    load_err(&write(d, "bad.gltf", "{ not json"), &["glTF:"]);
    let (json, _) = tetra_gltf(Some("missing.bin"));
    load_err(
        &write(d, "nobin.gltf", json),
        &["glTF: cannot load buffers"],
    );
}

#[test]
fn error_kind_is_matchable() {
    let dir = tempfile::tempdir().unwrap();
    let err = load_mesh(&write(
        dir.path(),
        "e.off",
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
    ))
    .unwrap_err();
    assert!(matches!(
        err.kind,
        ImportErrorKind::IndexOutOfRange {
            index: 7,
            count: 3,
            ..
        }
    ));
    assert_eq!(err.path, dir.path().join("e.off"));
}
