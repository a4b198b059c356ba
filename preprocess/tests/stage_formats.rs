//! The out-of-core import of every mesh format (`import::stage_mesh`): OFF, STL, OBJ (its
//! texture coordinates and normals by face corner too) and glTF (a GLB's binary chunk and
//! external buffers read by chunks) stream through the same readers as
//! the in-memory import and give the same mesh, ids, attributes and counts, and hold a
//! bounded heap while they do (this binary counts its allocations).

use std::alloc::{GlobalAlloc, Layout, System};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use tessera_preprocess::import::{load_mesh, stage_mesh};

mod stage_support;

/// The system allocator, counting the bytes held and their peak.
struct Counting;

static HELD: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc(layout);
        if !p.is_null() {
            let held = HELD.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(held, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        HELD.fetch_sub(layout.size(), Ordering::Relaxed);
        System.dealloc(p, layout)
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Tests run one at a time here: the heap peak is the process's.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn testdata(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata")
        .join(name)
}

/// Stages `path` within `budget` and checks it against `load_mesh`; returns the heap's peak
/// above what was held before, while staging.
fn same_as_load_mesh(path: &Path, budget: usize) -> usize {
    let dir = tempfile::tempdir().unwrap();
    let before = HELD.load(Ordering::Relaxed);
    PEAK.store(before, Ordering::Relaxed);
    let staged = stage_mesh(path, dir.path(), budget).unwrap();
    let heap = PEAK.load(Ordering::Relaxed) - before;
    stage_support::assert_same_as_load_mesh(staged, path, dir.path());
    heap
}

/// A grid of `n` × `n` quads over a bump, with a seam of duplicated vertices down the middle
/// (welding merges them), attributes that vary per vertex (the same on both copies of the
/// seam, `attribute_ids`: different ones would be wedges, which staging refuses), and a
/// degenerate triangle.
struct Grid {
    positions: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
}

fn grid(n: usize) -> Grid {
    let mut positions = Vec::new();
    let side = n + 2; // one column twice: the seam
    let seam = n / 2;
    let column = |i: usize| if i <= seam { i } else { i - 1 };
    for j in 0..=n {
        for i in 0..side {
            let (x, y) = (column(i) as f64 / n as f64, j as f64 / n as f64);
            let z = 0.1 * ((x * 7.0).sin() * (y * 5.0).cos());
            positions.push([x, y, z]);
        }
    }
    let at = |i: usize, j: usize| (j * side + i) as u32;
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..side - 1 {
            if i == seam {
                continue; // between the seam's two copies
            }
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    triangles.push([at(0, 0), at(0, 0), at(1, 1)]);
    Grid {
        positions,
        triangles,
    }
}

/// For each vertex, the first vertex at its position: what its attributes derive from.
fn attribute_ids(g: &Grid) -> Vec<usize> {
    let mut first = std::collections::HashMap::new();
    (g.positions.iter().enumerate())
        .map(|(i, p)| *first.entry(p.map(f64::to_bits)).or_insert(i))
        .collect()
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

/// OFF with the given prefix (`""`, `"C"`, `"N"`, `"ST"`, `"STCN"` …).
fn off(g: &Grid, prefix: &str) -> String {
    let mut s = format!(
        "{prefix}OFF\n{} {} 0\n",
        g.positions.len(),
        g.triangles.len()
    );
    let ids = attribute_ids(g);
    for (i, p) in g.positions.iter().enumerate() {
        let i = ids[i];
        write!(s, "{} {} {}", p[0], p[1], p[2]).unwrap();
        if prefix.contains('N') {
            write!(s, " 0 {} 1", (i % 7) as f64 / 7.0).unwrap();
        }
        if prefix.contains('C') {
            write!(s, " {} {} 200", i % 256, (3 * i) % 256).unwrap();
        }
        if prefix.contains("ST") {
            write!(s, " {} 0.25", (i % 11) as f64 / 11.0).unwrap();
        }
        s.push('\n');
    }
    for t in &g.triangles {
        writeln!(s, "3 {} {} {}", t[0], t[1], t[2]).unwrap();
    }
    s
}

fn stl_ascii(g: &Grid) -> String {
    let mut s = String::from("solid grid\n");
    for t in &g.triangles {
        s += " facet normal 0 0 1\n  outer loop\n";
        for &v in t {
            let p = g.positions[v as usize];
            // f32 values, as binary STL stores them, so both kinds agree.
            writeln!(
                s,
                "   vertex {} {} {}",
                p[0] as f32, p[1] as f32, p[2] as f32
            )
            .unwrap();
        }
        s += "  endloop\n endfacet\n";
    }
    s + "endsolid grid\n"
}

fn stl_binary(g: &Grid) -> Vec<u8> {
    let mut b = vec![0u8; 80];
    b.extend((g.triangles.len() as u32).to_le_bytes());
    for t in &g.triangles {
        b.extend([0u8; 12]);
        for &v in t {
            for x in g.positions[v as usize] {
                b.extend((x as f32).to_le_bytes());
            }
        }
        b.extend([0u8; 2]);
    }
    b
}

/// The grid as glTF: positions (`f32`), with `attributes` normals (`f32`) and colours (`u8`
/// RGBA) too, interleaved in one strided view; `u32` indices; instanced by two nodes, the
/// second mirrored in x and moved (its triangles flipped back). `external`: the JSON and its
/// `.bin` apart (written beside it by the caller); otherwise a GLB.
fn gltf(g: &Grid, attributes: bool, external: Option<&str>) -> (Vec<u8>, Vec<u8>) {
    let n = g.positions.len();
    let stride = if attributes { 28 } else { 12 };
    let mut bin = Vec::new();
    let ids = attribute_ids(g);
    for (i, p) in g.positions.iter().enumerate() {
        let i = ids[i];
        bin.extend(p.iter().flat_map(|&x| (x as f32).to_le_bytes()));
        if attributes {
            let normal = [0.0f32, (i % 3) as f32, 1.0];
            bin.extend(normal.iter().flat_map(|x| x.to_le_bytes()));
            bin.extend([(i % 251) as u8, (i % 7) as u8, 200, 255]);
        }
    }
    let index_at = bin.len();
    bin.extend(g.triangles.iter().flatten().flat_map(|i| i.to_le_bytes()));
    let vertex_view =
        format!(r#"{{"buffer":0,"byteOffset":0,"byteLength":{index_at},"byteStride":{stride}}}"#);
    let index_view = format!(
        r#"{{"buffer":0,"byteOffset":{index_at},"byteLength":{}}}"#,
        bin.len() - index_at
    );
    let (attrs, extra) = if attributes {
        (
            r#","NORMAL":1,"COLOR_0":2"#,
            format!(
                r#",{{"bufferView":0,"byteOffset":12,"componentType":5126,"count":{n},"type":"VEC3"}},
                {{"bufferView":0,"byteOffset":24,"componentType":5121,"normalized":true,"count":{n},"type":"VEC4"}}"#
            ),
        )
    } else {
        ("", String::new())
    };
    let uri = external.map_or(String::new(), |u| format!(r#","uri":"{u}""#));
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{}{uri}}}],
        "bufferViews":[{vertex_view},{index_view}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":{n},"type":"VEC3","min":[-9,-9,-9],"max":[9,9,9]}}{extra},
                     {{"bufferView":1,"componentType":5125,"count":{},"type":"SCALAR"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0{attrs}}},"indices":{}}}]}}],
        "nodes":[{{"mesh":0}},{{"mesh":0,"scale":[-1,1,1],"translation":[3,0,0]}}],
        "scenes":[{{"nodes":[0,1]}}]}}"#,
        bin.len(),
        3 * g.triangles.len(),
        if attributes { 3 } else { 1 },
    );
    if external.is_some() {
        return (json.into_bytes(), bin);
    }
    let mut json = json.into_bytes();
    json.resize(json.len().next_multiple_of(4), b' ');
    bin.resize(bin.len().next_multiple_of(4), 0);
    let mut glb = Vec::new();
    glb.extend(b"glTF");
    glb.extend(2u32.to_le_bytes());
    glb.extend(((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
    glb.extend((json.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&json);
    glb.extend((bin.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(&bin);
    (glb, Vec::new())
}

/// What an OBJ's face corners carry besides the vertex.
#[derive(Clone, Copy, PartialEq)]
enum Corners {
    Plain,
    /// `v//vn`, a normal per vertex, in vertex order.
    Normals,
    /// `v/vt/vn`: texture coordinates shared by four vertices each and listed backwards,
    /// normals by vertex; a vertex's corners disagree: wedges in memory, refused staged.
    Both,
    /// `v/vt` on every corner but the last face's: no vertex keeps one.
    MostlyTextured,
}

/// OBJ: `colors` on every vertex (`Some(true)`), on every vertex but the last
/// (`Some(false)`), or none; face corners as `corners` says.
fn obj(g: &Grid, colors: Option<bool>, corners: Corners) -> String {
    let mut s = String::from("# grid\no grid\n");
    let n = g.positions.len();
    let ids = attribute_ids(g);
    for (i, p) in g.positions.iter().enumerate() {
        write!(s, "v {} {} {}", p[0], p[1], p[2]).unwrap();
        let last = i + 1 == n;
        if colors == Some(true) || (colors == Some(false) && !last) {
            write!(s, " {} 0.5 1", (ids[i] % 10) as f64 / 10.0).unwrap();
        }
        s.push('\n');
        if corners != Corners::Plain {
            writeln!(s, "vn 0 0 {}", 1.0 + ids[i] as f64).unwrap();
        }
        if i % 4 == 0 && corners != Corners::Plain {
            writeln!(s, "vt {} 0.25", i as f64 / n as f64).unwrap();
        }
    }
    let texcoords = n.div_ceil(4);
    s += "g faces\ns off\n";
    for (f, t) in g.triangles.iter().enumerate() {
        s += "f";
        for (k, &v) in t.iter().enumerate() {
            let v1 = v as usize + 1;
            // Backwards, and shifted by the face so a vertex's corners differ.
            let vt = texcoords - (v as usize / 4 + f + k) % texcoords;
            match corners {
                Corners::Plain => write!(s, " {v1}").unwrap(),
                Corners::Normals => write!(s, " {v1}//{v1}").unwrap(),
                Corners::Both => write!(s, " {v1}/{vt}/{}", (v as usize + f) % n + 1).unwrap(),
                Corners::MostlyTextured if f + 1 == g.triangles.len() => {
                    write!(s, " {v1}").unwrap()
                }
                Corners::MostlyTextured => write!(s, " {v1}/{vt}").unwrap(),
            }
        }
        s.push('\n');
    }
    s
}

#[test]
fn off_stl_and_obj_stage_as_they_load() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let g = grid(40);
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    for prefix in ["", "C", "N", "ST", "STCN"] {
        files.push((format!("{prefix}grid.off"), off(&g, prefix).into_bytes()));
    }
    files.push(("ascii.stl".into(), stl_ascii(&g).into_bytes()));
    files.push(("binary.stl".into(), stl_binary(&g)));
    let objs = [
        ("plain.obj", None, Corners::Plain),
        ("colored.obj", Some(true), Corners::Plain),
        // The last vertex without a colour: no vertex keeps one.
        ("almost.obj", Some(false), Corners::Plain),
        ("normals.obj", None, Corners::Normals),
        ("both.obj", Some(true), Corners::Both),
        ("mostly.obj", None, Corners::MostlyTextured),
    ];
    for (name, colors, corners) in objs {
        files.push((name.into(), obj(&g, colors, corners).into_bytes()));
    }
    files.push(("plain.glb".into(), gltf(&g, false, None).0));
    files.push(("attributes.glb".into(), gltf(&g, true, None).0));
    let (json, bin) = gltf(&g, true, Some("grid%20data.bin"));
    write(dir.path(), "grid data.bin", &bin);
    files.push(("external.gltf".into(), json));
    let gz: Vec<(String, Vec<u8>)> = files
        .iter()
        .map(|(name, bytes)| (format!("{name}.gz"), gzip(bytes)))
        .collect();
    for (name, bytes) in files.iter().chain(&gz) {
        let path = write(dir.path(), name, bytes);
        if name.starts_with("both.obj") {
            // An OBJ's corners that disagree: wedges in memory, which staging refuses (for
            // now: seams in the other formats stage, `tools/tests/wedges_memory.rs`).
            let wedges = load_mesh(&path).unwrap().mesh;
            assert!(!wedges.vertex_starts().is_identity());
            let staging = tempfile::tempdir().unwrap();
            let refused = stage_mesh(&path, staging.path(), 64 << 10)
                .err()
                .expect("refused");
            assert!(
                refused.to_string().contains("does not stage those corners"),
                "{refused}"
            );
            continue;
        }
        // 64 KiB: the weld's sorts spill.
        same_as_load_mesh(&path, 64 << 10);
    }
    // The attributes came through where the files have them.
    let loaded = |name: &str| load_mesh(&dir.path().join(name)).unwrap().mesh;
    assert!(loaded("STCNgrid.off").colors.is_some() && loaded("STCNgrid.off").uvs.is_some());
    assert!(loaded("colored.obj").colors.is_some());
    assert!(loaded("almost.obj").colors.is_none());
    assert!(loaded("normals.obj").normals.is_some());
    let both = loaded("both.obj");
    assert!(both.normals.is_some() && both.uvs.is_some() && both.colors.is_some());
    assert!(loaded("mostly.obj").uvs.is_none());
    let external = load_mesh(&dir.path().join("external.gltf")).unwrap();
    assert!(external.mesh.normals.is_some() && external.mesh.colors.is_some());
    assert_eq!(external.raw_vertices, 2 * g.positions.len());
}

#[test]
fn a_real_scan_streams_as_stl_off_obj_and_glb_within_a_bounded_heap() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    // The dragon (0.87 M triangles, 0.44 M vertices) written out in each format.
    let mesh = load_mesh(&testdata("mesh/dragon_vrip.ply.gz"))
        .unwrap()
        .mesh;
    let g = Grid {
        positions: mesh.positions.iter().map(|p| p.map(f64::from)).collect(),
        triangles: mesh.triangles.clone(),
    };
    drop(mesh);
    let files = [
        write(dir.path(), "dragon.stl", &stl_binary(&g)),
        write(dir.path(), "dragon.off", off(&g, "").as_bytes()),
        write(dir.path(), "dragon.glb", &gltf(&g, false, None).0),
        write(
            dir.path(),
            "dragon.obj",
            obj(&g, None, Corners::Normals).as_bytes(),
        ),
    ];
    drop(g);
    for path in &files {
        // Read whole, the binary STL takes 72 MiB of heap (2.6 M positions of 24 bytes and
        // its triangles); staged at a 1 MiB budget each file takes about 5 MiB (the readers'
        // and writers' buffers, the sorts' runs and merge heads).
        let heap = same_as_load_mesh(path, 1 << 20);
        eprintln!(
            "{path:?}: heap peak {:.1} MiB",
            heap as f64 / (1 << 20) as f64
        );
        assert!(
            heap < 16 << 20,
            "{path:?}: the heap peaked {:.1} MiB above the start",
            heap as f64 / (1 << 20) as f64
        );
    }
}
