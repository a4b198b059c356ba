//! The chunked reader against the gltf crate's own readers, on every element type and
//! layout the reader accepts: strided and packed views, normalised colours and texture
//! coordinates of each width, sparse substitutions with and without a base view, strips,
//! fans, and chunks smaller than the accessors.

use super::*;

/// A glTF under construction: one buffer, accessors appended to it.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<String>,
    accessors: Vec<String>,
}

impl Builder {
    /// A view over `bytes` (with `stride` when given).
    fn view(&mut self, bytes: &[u8], stride: Option<usize>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let stride = stride.map_or(String::new(), |s| format!(r#","byteStride":{s}"#));
        self.views.push(format!(
            r#"{{"buffer":0,"byteOffset":{},"byteLength":{}{stride}}}"#,
            self.bin.len(),
            bytes.len()
        ));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn accessor(&mut self, json: String) -> usize {
        self.accessors.push(json);
        self.accessors.len() - 1
    }

    fn gltf(&self, primitives: &[String]) -> Vec<u8> {
        use base64::Engine as _;
        format!(
            r#"{{"asset":{{"version":"2.0"}},
            "buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],
            "bufferViews":[{}],"accessors":[{}],
            "meshes":[{{"primitives":[{}]}}],"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}]}}"#,
            self.bin.len(),
            base64::engine::general_purpose::STANDARD.encode(&self.bin),
            self.views.join(","),
            self.accessors.join(","),
            primitives.join(",")
        )
        .into_bytes()
    }
}

fn le<T: Copy, const N: usize>(items: &[[T; N]], bytes: impl Fn(T) -> Vec<u8>) -> Vec<u8> {
    items.iter().flatten().flat_map(|&x| bytes(x)).collect()
}

/// `items` laid out with `stride` bytes between elements (padding after each).
fn strided(packed: &[u8], size: usize, stride: usize) -> Vec<u8> {
    packed
        .chunks(size)
        .flat_map(|e| {
            let mut e = e.to_vec();
            e.resize(stride, 0xAB);
            e
        })
        .collect()
}

/// What the gltf crate's readers give for the mesh's every primitive, concatenated: the
/// reference the chunked reader must equal.
fn reference(bytes: &[u8]) -> RawMesh {
    use base64::Engine as _;
    let document = Gltf::from_slice(bytes).unwrap().document;
    let ::gltf::buffer::Source::Uri(uri) = document.buffers().next().unwrap().source() else {
        panic!("a data URI");
    };
    let bin = base64::engine::general_purpose::STANDARD
        .decode(uri.split_once(";base64,").unwrap().1)
        .unwrap();
    let mut mesh = RawMesh {
        normals: Some(Vec::new()),
        colors: Some(Vec::new()),
        uvs: Some(Vec::new()),
        ..RawMesh::default()
    };
    for prim in document.meshes().next().unwrap().primitives() {
        let reader = prim.reader(|_| Some(&bin[..]));
        let base = mesh.positions.len() as u32;
        let positions: Vec<_> = reader.read_positions().unwrap().collect();
        let n = positions.len();
        mesh.positions
            .extend(positions.iter().map(|p| p.map(f64::from)));
        let normals = mesh.normals.as_mut().unwrap();
        // Normals come out unit length (zero stays zero).
        normals.extend(reader.read_normals().unwrap().map(|n| {
            let n = n.map(f64::from);
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if len > 0.0 {
                n.map(|x| (x / len) as f32)
            } else {
                [0.0; 3]
            }
        }));
        normals.resize(base as usize + n, [0.0; 3]);
        let colors = mesh.colors.as_mut().unwrap();
        colors.extend(reader.read_colors(0).unwrap().into_rgba_u8());
        colors.resize(base as usize + n, [0, 0, 0, 255]);
        let uvs = mesh.uvs.as_mut().unwrap();
        uvs.extend(reader.read_tex_coords(0).unwrap().into_f32());
        uvs.resize(base as usize + n, [0.0; 2]);
        let indices: Vec<u32> = match reader.read_indices() {
            Some(i) => i.into_u32().collect(),
            None => (0..n as u32).collect(),
        };
        let k = indices.len();
        let triangles: Vec<[u32; 3]> = match prim.mode() {
            Mode::Triangles => indices
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]])
                .collect(),
            Mode::TriangleStrip => (2..k)
                .map(|i| {
                    let (a, b, c) = (indices[i - 2], indices[i - 1], indices[i]);
                    if i % 2 == 0 {
                        [a, b, c]
                    } else {
                        [b, a, c]
                    }
                })
                .collect(),
            _ => (2..k)
                .map(|i| [indices[0], indices[i - 1], indices[i]])
                .collect(),
        };
        mesh.triangles
            .extend(triangles.into_iter().map(|t| t.map(|i| base + i)));
    }
    mesh
}

/// Equal lists, or the first difference named.
fn same<T: PartialEq + std::fmt::Debug>(what: &str, read: &[T], expected: &[T]) {
    assert_eq!(read.len(), expected.len(), "{what}: lengths");
    if let Some(i) = (0..read.len()).find(|&i| read[i] != expected[i]) {
        panic!("{what} {i}: read {:?}, expected {:?}", read[i], expected[i]);
    }
}

#[test]
fn chunked_reading_gives_what_the_gltf_crate_reads() {
    let n = 3 * CHUNK / 2 + 7; // more than a chunk, not a multiple of one
    let positions: Vec<[f32; 3]> = (0..n)
        .map(|i| [i as f32, (i * 7 % 13) as f32 * 0.5, -(i as f32) / 3.0])
        .collect();
    let normals: Vec<[f32; 3]> = (0..n).map(|i| [0.0, 1.0, i as f32 * 0.01]).collect();
    let f32le = |x: f32| x.to_le_bytes().to_vec();
    let mut b = Builder::default();
    // Positions strided (16 bytes apart), with a sparse substitution of two of them.
    let pv = b.view(&strided(&le(&positions, f32le), 12, 16), Some(16));
    let si = b.view(
        &le(&[[3u16], [n as u16 - 1]], |x: u16| x.to_le_bytes().to_vec()),
        None,
    );
    let sv = b.view(&le(&[[9.0f32, 9.0, 9.0], [-1.0, -2.0, -3.0]], f32le), None);
    let pos = b.accessor(format!(
        r#"{{"bufferView":{pv},"componentType":5126,"count":{n},"type":"VEC3","min":[0,0,0],"max":[1,1,1],
        "sparse":{{"count":2,"indices":{{"bufferView":{si},"componentType":5123}},
        "values":{{"bufferView":{sv}}}}}}}"#
    ));
    // Normals: fewer elements than positions (the rest default to zero).
    let nv = b.view(&le(&normals[..n - 5], f32le), None);
    let nor = b.accessor(format!(
        r#"{{"bufferView":{nv},"componentType":5126,"count":{},"type":"VEC3"}}"#,
        n - 5
    ));
    // Colours: u16 RGB, strided; then f32 RGBA (out of range too), packed; then u8 RGBA.
    let c16: Vec<[u16; 3]> = (0..n)
        .map(|i| [(i as u16).wrapping_mul(97), 65535, 255])
        .collect();
    let cv = b.view(
        &strided(&le(&c16, |x: u16| x.to_le_bytes().to_vec()), 6, 8),
        Some(8),
    );
    let col16 = b.accessor(format!(
        r#"{{"bufferView":{cv},"componentType":5123,"normalized":true,"count":{n},"type":"VEC3"}}"#
    ));
    let cf: Vec<[f32; 4]> = (0..n)
        .map(|i| [i as f32 / n as f32, -0.5, 1.5, 0.25])
        .collect();
    let cfv = b.view(&le(&cf, f32le), None);
    let colf = b.accessor(format!(
        r#"{{"bufferView":{cfv},"componentType":5126,"count":{n},"type":"VEC4"}}"#
    ));
    // Texture coordinates: u8 and u16 normalised, f32.
    let t8: Vec<[u8; 2]> = (0..n).map(|i| [i as u8, 255 - i as u8]).collect();
    let t8v = b.view(&strided(&le(&t8, |x: u8| vec![x]), 2, 4), Some(4));
    let uv8 = b.accessor(format!(
        r#"{{"bufferView":{t8v},"componentType":5121,"normalized":true,"count":{n},"type":"VEC2"}}"#
    ));
    let t16: Vec<[u16; 2]> = (0..n).map(|i| [(i as u16).wrapping_mul(31), 7]).collect();
    let t16v = b.view(&le(&t16, |x: u16| x.to_le_bytes().to_vec()), None);
    let uv16 = b.accessor(format!(
        r#"{{"bufferView":{t16v},"componentType":5123,"normalized":true,"count":{n},"type":"VEC2"}}"#
    ));
    // Indices: u32 triangles (a trailing pair ignored), u16 strip, u8 fan; and a sparse
    // accessor with no base view (zeros).
    let tri: Vec<[u32; 1]> = (0..3 * (n as u32 - 2) + 2)
        .map(|i| [(i * 5) % n as u32])
        .collect();
    let tv = b.view(&le(&tri, |x: u32| x.to_le_bytes().to_vec()), None);
    let tris = b.accessor(format!(
        r#"{{"bufferView":{tv},"componentType":5125,"count":{},"type":"SCALAR"}}"#,
        tri.len()
    ));
    let strip: Vec<[u16; 1]> = (0..n as u16).rev().map(|i| [i]).collect();
    let stv = b.view(&le(&strip, |x: u16| x.to_le_bytes().to_vec()), None);
    let strips = b.accessor(format!(
        r#"{{"bufferView":{stv},"componentType":5123,"count":{n},"type":"SCALAR"}}"#
    ));
    let fan: Vec<[u8; 1]> = (0..200u8).map(|i| [i]).collect();
    let fv = b.view(&le(&fan, |x: u8| vec![x]), None);
    let fans = b.accessor(format!(
        r#"{{"bufferView":{fv},"componentType":5121,"count":200,"type":"SCALAR"}}"#
    ));
    let zi = b.view(&le(&[[1u8], [150]], |x: u8| vec![x]), None);
    let zv = b.view(&le(&[[0.5f32, 0.5, 0.5], [2.0, 2.0, 2.0]], f32le), None);
    let zeros = b.accessor(format!(
        r#"{{"componentType":5126,"count":200,"type":"VEC3","min":[0,0,0],"max":[1,1,1],
        "sparse":{{"count":2,"indices":{{"bufferView":{zi},"componentType":5121}},
        "values":{{"bufferView":{zv}}}}}}}"#
    ));
    let prim = |pos: usize, nor: usize, col: usize, uv: usize, ix: Option<usize>, mode: u32| {
        let indices = ix.map_or(String::new(), |i| format!(r#","indices":{i}"#));
        format!(
            r#"{{"attributes":{{"POSITION":{pos},"NORMAL":{nor},"COLOR_0":{col},"TEXCOORD_0":{uv}}}{indices},"mode":{mode}}}"#
        )
    };
    let primitives = [
        prim(pos, nor, col16, uv8, Some(tris), 4),
        prim(pos, nor, colf, uv16, Some(strips), 5),
        prim(zeros, zeros, colf, uv16, Some(fans), 6),
        prim(zeros, nor, col16, uv8, None, 4),
    ];
    let bytes = b.gltf(&primitives);
    let read = read(&bytes, None, false).unwrap().0;
    let expected = reference(&bytes);
    same("positions", &read.positions, &expected.positions);
    same(
        "normals",
        read.normals.as_ref().unwrap(),
        expected.normals.as_ref().unwrap(),
    );
    same(
        "colours",
        read.colors.as_ref().unwrap(),
        expected.colors.as_ref().unwrap(),
    );
    same(
        "uvs",
        read.uvs.as_ref().unwrap(),
        expected.uvs.as_ref().unwrap(),
    );
    same("triangles", &read.triangles, &expected.triangles);
    // The layouts above were read: the substitutions and the normalisations show.
    assert_eq!(read.positions[3], [9.0; 3]);
    assert_eq!(read.normals.as_ref().unwrap()[n - 1], [0.0; 3]);
    assert_eq!(read.colors.as_ref().unwrap()[n + 1], [0, 0, 255, 63]);
}
