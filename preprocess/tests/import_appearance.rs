//! Appearance the importers read beyond per-vertex attributes (issue 47 item 1): OBJ materials
//! (`mtllib`, `usemtl`, `Kd`; `map_Kd` resolved), glTF `baseColorFactor` over several
//! primitives and materials, binary STL facet colours (VisCAM/SolidView and Materialise). Each
//! becomes per-face colour wedges: the corners of two faces of different colours that share a
//! vertex are two wedges of that one vertex.

use std::path::{Path, PathBuf};

use tessera_preprocess::import::{load_mesh, load_mesh_bytes, mtl, stage_mesh, ImportReport};
use tessera_preprocess::mesh::InputMesh;

fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn load(path: &Path) -> ImportReport {
    load_mesh(path).unwrap_or_else(|e| panic!("{e}"))
}

/// The colour of each corner of each triangle, by position (order-independent checks).
fn corner_colours(mesh: &InputMesh) -> Vec<([f64; 3], [u8; 4])> {
    let colors = mesh.colors.as_ref().expect("colours");
    let mut out: Vec<_> = (mesh.triangles.iter().flatten())
        .map(|&w| (mesh.positions[w as usize], colors[w as usize]))
        .collect();
    out.sort_by(|a, b| a.partial_cmp(b).unwrap());
    out.dedup();
    out
}

/// Vertices (distinct positions) and wedges of `mesh`.
fn counts(mesh: &InputMesh) -> (usize, usize) {
    let starts = mesh.vertex_starts();
    (
        starts.vertex_count(mesh.positions.len()),
        mesh.positions.len(),
    )
}

// A unit square of two triangles sharing the diagonal 1-3, for the OBJ tests.
const SQUARE: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

#[test]
fn obj_materials_colour_their_faces_as_wedges() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "two.mtl",
        "newmtl red\nKd 1 0 0\nmap_Kd .\\tex\\red.png\n\nnewmtl green\nKd 0 1 0\nd 0.5\n",
    );
    write(dir.path(), "more.mtl", "newmtl plain\nKs 1 1 1\n");
    let obj = format!(
        "mtllib two.mtl missing.mtl more.mtl\n{SQUARE}usemtl red\nf 1 2 3\nusemtl green\nf 1 3 4\n"
    );
    let path = write(dir.path(), "square.obj", &obj);
    let mesh = load(&path).mesh;
    assert_eq!(mesh.triangles.len(), 2);
    // The diagonal's two vertices have a red and a green wedge each.
    assert_eq!(counts(&mesh), (4, 6), "{mesh:?}");
    let red = [255, 0, 0, 255];
    let green = [0, 255, 0, 128];
    assert_eq!(
        corner_colours(&mesh),
        vec![
            ([0.0, 0.0, 0.0], green),
            ([0.0, 0.0, 0.0], red),
            ([0.0, 1.0, 0.0], green),
            ([1.0, 0.0, 0.0], red),
            ([1.0, 1.0, 0.0], green),
            ([1.0, 1.0, 0.0], red),
        ]
    );
    // The texture is resolved beside the library (`\` as `/`), and recorded by material.
    let materials = mtl::load_libraries(dir.path(), &["two.mtl".into()]).unwrap();
    assert_eq!(
        materials[0].diffuse_map.as_deref(),
        Some(dir.path().join("./tex/red.png").as_path())
    );

    // A material without Kd, or none at all, colours nothing: one colour per vertex, and
    // the faces before any `usemtl` keep the default white.
    let obj = format!("mtllib two.mtl more.mtl\n{SQUARE}f 1 2 3\nusemtl plain\nf 1 3 4\n");
    let mesh = load(&write(dir.path(), "plain.obj", obj)).mesh;
    assert_eq!(mesh.colors, None);
    assert_eq!(counts(&mesh), (4, 4));
    let obj = format!("mtllib two.mtl\n{SQUARE}f 1 2 3\nusemtl green\nf 1 3 4\n");
    let mesh = load(&write(dir.path(), "half.obj", obj)).mesh;
    let colours = corner_colours(&mesh);
    assert!(
        colours.contains(&([1.0, 0.0, 0.0], [255; 4])),
        "{colours:?}"
    );
    assert!(colours.contains(&([0.0, 1.0, 0.0], green)), "{colours:?}");
    assert_eq!(counts(&mesh), (4, 6));
}

#[test]
fn obj_without_its_libraries_reads_as_before() {
    let dir = tempfile::tempdir().unwrap();
    let plain = format!("{SQUARE}f 1 2 3\nf 1 3 4\n");
    let with_missing = format!("mtllib nowhere.mtl\n{SQUARE}usemtl red\nf 1 2 3\nf 1 3 4\n");
    let a = load(&write(dir.path(), "a.obj", &plain));
    let b = load(&write(dir.path(), "b.obj", &with_missing));
    assert_eq!(a, b);
    assert_eq!(a.mesh.colors, None);
    // Bytes from no directory: the library is not looked for.
    write(dir.path(), "red.mtl", "newmtl red\nKd 1 0 0\n");
    let named = format!("mtllib red.mtl\n{SQUARE}usemtl red\nf 1 2 3\nf 1 3 4\n");
    let c = load_mesh_bytes(Path::new("c.obj"), named.as_bytes()).unwrap();
    assert_eq!(c, a);
    // From the file, the library colours it, out of core as in memory.
    let path = write(dir.path(), "d.obj", &named);
    assert_eq!(load(&path).mesh.colors.unwrap(), vec![[255, 0, 0, 255]; 4]);
    let temp = tempfile::tempdir().unwrap();
    let staged = stage_mesh(&path, temp.path(), 1 << 24).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(staged.load().unwrap(), load(&path).mesh);
    // A malformed library is an error naming it and its line.
    write(dir.path(), "bad.mtl", "newmtl red\nKd 1 zero 0\n");
    let bad = format!("mtllib bad.mtl\n{SQUARE}f 1 2 3\n");
    let e = load_mesh(&write(dir.path(), "e.obj", bad))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bad.mtl") && e.contains("line 2") && e.contains("zero"),
        "{e}"
    );
}

/// A primitive of [`gltf`]: its positions, its material, its RGBA8 COLOR_0.
type Primitive = (Vec<[f32; 3]>, Option<usize>, Option<Vec<[u8; 4]>>);

/// A glTF (JSON, data URI) of one mesh whose primitives are `prims`: (positions, material,
/// optional RGBA8 COLOR_0), each a triangle list of its own vertices; `materials` are the
/// base colour factors.
fn gltf(prims: &[Primitive], materials: &[[f32; 4]]) -> Vec<u8> {
    use base64::Engine as _;
    let mut bin = Vec::new();
    let (mut views, mut accessors, mut primitives) = (vec![], vec![], vec![]);
    for (positions, material, colors) in prims {
        let at = bin.len();
        bin.extend(positions.iter().flatten().flat_map(|x| x.to_le_bytes()));
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{at},"byteLength":{}}}"#,
            12 * positions.len()
        ));
        let (lo, hi) = (0..3).fold(([f32::MAX; 3], [f32::MIN; 3]), |(mut lo, mut hi), a| {
            for p in positions {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
            (lo, hi)
        });
        accessors.push(format!(
            r#"{{"bufferView":{},"componentType":5126,"count":{},"type":"VEC3","min":{lo:?},"max":{hi:?}}}"#,
            views.len() - 1,
            positions.len()
        ));
        let mut attributes = format!(r#""POSITION":{}"#, accessors.len() - 1);
        if let Some(colors) = colors {
            let at = bin.len();
            bin.extend(colors.iter().flatten());
            views.push(format!(
                r#"{{"buffer":0,"byteOffset":{at},"byteLength":{}}}"#,
                4 * colors.len()
            ));
            accessors.push(format!(
                r#"{{"bufferView":{},"componentType":5121,"normalized":true,"count":{},"type":"VEC4"}}"#,
                views.len() - 1,
                colors.len()
            ));
            attributes += &format!(r#","COLOR_0":{}"#, accessors.len() - 1);
        }
        let material = material.map_or(String::new(), |m| format!(r#","material":{m}"#));
        primitives.push(format!(r#"{{"attributes":{{{attributes}}}{material}}}"#));
    }
    let materials: Vec<String> = (materials.iter())
        .map(|f| format!(r#"{{"pbrMetallicRoughness":{{"baseColorFactor":{f:?}}}}}"#))
        .collect();
    format!(
        r#"{{"asset":{{"version":"2.0"}},
        "buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],
        "bufferViews":[{}],"accessors":[{}],"materials":[{}],
        "meshes":[{{"primitives":[{}]}}],"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}]}}"#,
        bin.len(),
        base64::engine::general_purpose::STANDARD.encode(&bin),
        views.join(","),
        accessors.join(","),
        materials.join(","),
        primitives.join(",")
    )
    .into_bytes()
}

#[test]
fn gltf_base_color_factors_multiply_colours_per_primitive() {
    let lower = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
    let upper = vec![[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    let far = vec![[2.0, 0.0, 0.0], [3.0, 0.0, 0.0], [3.0, 1.0, 0.0]];
    let half_red = [1.0, 0.0, 0.0, 0.5];
    let blue = [0.0, 0.0, 1.0, 1.0];
    let white = [1.0; 4];
    // Two materials, no COLOR_0: the factors are the colours; the shared diagonal has two
    // wedges a vertex; the default material (none) is white.
    let bytes = gltf(
        &[
            (lower.clone(), Some(0), None),
            (upper.clone(), Some(1), None),
            (far.clone(), None, None),
        ],
        &[half_red, blue],
    );
    let mesh = load_mesh_bytes(Path::new("two.gltf"), &bytes).unwrap().mesh;
    assert_eq!(counts(&mesh), (7, 9));
    let c = corner_colours(&mesh);
    assert!(c.contains(&([1.0, 1.0, 0.0], [255, 0, 0, 128])), "{c:?}");
    assert!(c.contains(&([1.0, 1.0, 0.0], [0, 0, 255, 255])), "{c:?}");
    assert!(c.contains(&([3.0, 1.0, 0.0], [255; 4])), "{c:?}");
    // COLOR_0 times the factor.
    let grey = vec![[200, 100, 50, 255]; 3];
    let bytes = gltf(
        &[
            (lower.clone(), Some(0), Some(grey.clone())),
            (upper.clone(), Some(1), None),
        ],
        &[[0.5, 1.0, 1.0, 1.0], blue],
    );
    let mesh = load_mesh_bytes(Path::new("mixed.gltf"), &bytes)
        .unwrap()
        .mesh;
    let c = corner_colours(&mesh);
    assert!(c.contains(&([1.0, 0.0, 0.0], [100, 100, 50, 255])), "{c:?}");
    assert!(c.contains(&([0.0, 1.0, 0.0], [0, 0, 255, 255])), "{c:?}");
    // White factors (or none) read as before: colours only where every primitive has them.
    let plain = gltf(
        &[(lower.clone(), None, None), (upper.clone(), None, None)],
        &[],
    );
    let whites = gltf(
        &[
            (lower.clone(), Some(0), None),
            (upper.clone(), Some(0), None),
        ],
        &[white],
    );
    let a = load_mesh_bytes(Path::new("a.gltf"), &plain).unwrap();
    assert_eq!(a.mesh.colors, None);
    assert_eq!(a, load_mesh_bytes(Path::new("b.gltf"), &whites).unwrap());
    let coloured = gltf(
        &[
            (lower, Some(0), Some(grey.clone())),
            (upper, Some(0), Some(grey)),
        ],
        &[white],
    );
    let mesh = load_mesh_bytes(Path::new("c.gltf"), &coloured)
        .unwrap()
        .mesh;
    assert_eq!(mesh.colors.unwrap(), vec![[200, 100, 50, 255]; 4]);
}

/// A binary STL of `facets` (three corners and the attribute word) after `header`.
fn stl(header: &[u8], facets: &[([[f32; 3]; 3], u16)]) -> Vec<u8> {
    let mut b = header.to_vec();
    b.resize(80, b' ');
    b.extend((facets.len() as u32).to_le_bytes());
    for (corners, attribute) in facets {
        b.extend([0u8; 12]);
        b.extend(corners.iter().flatten().flat_map(|x| x.to_le_bytes()));
        b.extend(attribute.to_le_bytes());
    }
    b
}

#[test]
fn binary_stl_facet_colours_in_both_conventions() {
    let lower = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
    let upper = [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    let five = |r: u16, g: u16, b: u16, low_is_red: bool| match low_is_red {
        true => r | g << 5 | b << 10,
        false => b | g << 5 | r << 10,
    };
    // VisCAM/SolidView: bit 15 marks a colour, red in the high bits; a clear bit 15 is none.
    let viscam = stl(
        b"binary",
        &[
            (lower, 0x8000 | five(31, 0, 16, false)),
            (upper, five(31, 31, 31, false)),
        ],
    );
    let mesh = load_mesh_bytes(Path::new("v.stl"), &viscam).unwrap().mesh;
    assert_eq!(counts(&mesh), (4, 6));
    let c = corner_colours(&mesh);
    assert!(c.contains(&([1.0, 0.0, 0.0], [255, 0, 132, 255])), "{c:?}");
    assert!(c.contains(&([0.0, 1.0, 0.0], [255; 4])), "{c:?}");
    // Materialise: the header's COLOR= is the object colour (bit 15 set), a clear bit 15 the
    // facet's own colour with red in the low bits.
    let mut header = b"exported COLOR=".to_vec();
    header.extend([10, 20, 30, 255]);
    let magics = stl(&header, &[(lower, 0x8000), (upper, five(0, 31, 8, true))]);
    let mesh = load_mesh_bytes(Path::new("m.stl"), &magics).unwrap().mesh;
    let c = corner_colours(&mesh);
    assert!(c.contains(&([1.0, 0.0, 0.0], [10, 20, 30, 255])), "{c:?}");
    assert!(c.contains(&([0.0, 1.0, 0.0], [0, 255, 66, 255])), "{c:?}");
    assert_eq!(counts(&mesh), (4, 6));
    // Zero attributes (the usual file) read as before: no colours.
    let plain = stl(b"binary", &[(lower, 0), (upper, 0)]);
    let mesh = load_mesh_bytes(Path::new("p.stl"), &plain).unwrap().mesh;
    assert_eq!((counts(&mesh), mesh.colors), ((4, 4), None));
}
