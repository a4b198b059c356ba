//! Wedges out of core (issue 47 item 1): `build --memory` keeps texture seams, per-vertex
//! normal and colour seams and normals split at creases as the in-memory build does, so both
//! write the same repository bytes (ARCHITECTURE.md, "The out-of-core build"), under a budget
//! that forces the external weld (1M) and under a roomier one, and after a resume.

mod cli_support;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use cli_support::{bunny, tessera};

/// A UV sphere as an ASCII PLY with texture coordinates (where `uvs`): `segments` columns and
/// a last one at the first's position with u = 1 (the seam), a pole vertex a column at each
/// pole (u in the middle of the column: wedges of one vertex).
fn sphere_ply(rings: usize, segments: usize, uvs: bool) -> String {
    let mut vertices = String::new();
    let mut count = 0;
    let mut vertex = |p: [f64; 3], uv: [f64; 2]| {
        write!(vertices, "{} {} {}", p[0], p[1], p[2]).unwrap();
        match uvs {
            true => writeln!(vertices, " {} {}", uv[0], uv[1]).unwrap(),
            false => writeln!(vertices).unwrap(),
        }
        count += 1;
        count - 1
    };
    let at = |ring: usize, column: usize| {
        let theta = std::f64::consts::PI * ring as f64 / rings as f64;
        let phi = std::f64::consts::TAU * (column % segments) as f64 / segments as f64;
        [
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        ]
    };
    let north: Vec<usize> = (0..segments)
        .map(|j| vertex([0.0, 0.0, 1.0], [(j as f64 + 0.5) / segments as f64, 0.0]))
        .collect();
    let mut grid = vec![vec![0; segments + 1]; rings + 1];
    for (ring, row) in grid.iter_mut().enumerate().take(rings).skip(1) {
        for (column, id) in row.iter_mut().enumerate() {
            let uv = [column as f64 / segments as f64, ring as f64 / rings as f64];
            *id = vertex(at(ring, column), uv);
        }
    }
    let south: Vec<usize> = (0..segments)
        .map(|j| vertex([0.0, 0.0, -1.0], [(j as f64 + 0.5) / segments as f64, 1.0]))
        .collect();
    let mut faces = Vec::new();
    for j in 0..segments {
        faces.push([north[j], grid[1][j], grid[1][j + 1]]);
        faces.push([south[j], grid[rings - 1][j + 1], grid[rings - 1][j]]);
    }
    for ring in 1..rings - 1 {
        for j in 0..segments {
            let [a, b, c, d] = [
                grid[ring][j],
                grid[ring + 1][j],
                grid[ring + 1][j + 1],
                grid[ring][j + 1],
            ];
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    let uv_properties = if uvs {
        "property float u\nproperty float v\n"
    } else {
        ""
    };
    let mut ply = format!(
        "ply\nformat ascii 1.0\nelement vertex {count}\nproperty float x\nproperty float y\n\
         property float z\n{uv_properties}element face {}\n\
         property list uchar int vertex_indices\nend_header\n{vertices}",
        faces.len()
    );
    for f in faces {
        writeln!(ply, "3 {} {} {}", f[0], f[1], f[2]).unwrap();
    }
    ply
}

/// A cube of `n` x `n` quads a face as an ASCII PLY, each face's vertices its own with a
/// colour of its own and (with `normals`) the face's normal: seams on every edge.
fn cube_ply(n: usize, normals: bool) -> String {
    let faces: [[[f64; 3]; 4]; 6] = [
        [[1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [1., 0., 0.]],
        [[0., 0., 0.], [0., 0., 1.], [0., 1., 0.], [-1., 0., 0.]],
        [[0., 1., 0.], [0., 0., 1.], [1., 0., 0.], [0., 1., 0.]],
        [[0., 0., 0.], [1., 0., 0.], [0., 0., 1.], [0., -1., 0.]],
        [[0., 0., 1.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]],
        [[0., 0., 0.], [0., 1., 0.], [1., 0., 0.], [0., 0., -1.]],
    ];
    let (mut vertices, mut triangles) = (String::new(), Vec::new());
    for (f, [origin, u, v, normal]) in faces.iter().enumerate() {
        let base = f * (n + 1) * (n + 1);
        for i in 0..=n {
            for j in 0..=n {
                let (a, b) = (i as f64 / n as f64, j as f64 / n as f64);
                let p = [0, 1, 2].map(|k| origin[k] + a * u[k] + b * v[k]);
                let c = 40 * f as u8;
                write!(vertices, "{} {} {} ", p[0], p[1], p[2]).unwrap();
                if normals {
                    write!(vertices, "{} {} {} ", normal[0], normal[1], normal[2]).unwrap();
                }
                writeln!(vertices, "{c} {} 200", 255 - c).unwrap();
            }
        }
        let at = |i: usize, j: usize| base + i * (n + 1) + j;
        for i in 0..n {
            for j in 0..n {
                triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
    }
    let normal_properties = match normals {
        true => "property float nx\nproperty float ny\nproperty float nz\n",
        false => "",
    };
    let mut ply = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\n{normal_properties}property uchar red\nproperty uchar green\n\
         property uchar blue\nelement face {}\nproperty list uchar int vertex_indices\n\
         end_header\n{vertices}",
        6 * (n + 1) * (n + 1),
        triangles.len()
    );
    for t in triangles {
        writeln!(ply, "3 {} {} {}", t[0], t[1], t[2]).unwrap();
    }
    ply
}

/// `ply` (ASCII, triangles) with a face colour on every face, in bands of 37 faces.
fn with_face_colours(ply: &str) -> String {
    let (header, body) = ply.split_once("end_header\n").unwrap();
    let header = header.replace(
        "property list uchar int vertex_indices\n",
        "property list uchar int vertex_indices\nproperty uchar red\nproperty uchar green\n\
         property uchar blue\n",
    );
    let mut face = 0;
    let body: Vec<String> = body
        .lines()
        .map(|l| match l.starts_with("3 ") && l.split(' ').count() == 4 {
            true => {
                face += 1;
                let band = (face / 37 % 4) as u8;
                format!("{l} {} {} 90", 60 * band, 255 - 60 * band)
            }
            false => l.to_string(),
        })
        .collect();
    format!("{header}end_header\n{}\n", body.join("\n"))
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn succeeds(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The bytes of `build INPUT` with `extra`, in `dir` (temporary files there too).
fn built(input: &Path, dir: &Path, name: &str, extra: &[&str]) -> Vec<u8> {
    let out = dir.join(name);
    let (i, o, t) = (
        input.to_str().unwrap(),
        out.to_str().unwrap(),
        dir.to_str().unwrap(),
    );
    let temp: &[&str] = if extra.contains(&"--memory") {
        &["--temp", t]
    } else {
        &[]
    };
    succeeds(&tessera(&[&["build", i, "-o", o], extra, temp].concat()));
    std::fs::read(out).unwrap()
}

/// `input` built in memory, and out of core under 1M (the external weld) and 64M: the same
/// bytes; returns them.
fn check_same_bytes(input: &Path, dir: &Path, flags: &[&str]) -> Vec<u8> {
    let in_memory = built(input, dir, "memory.tsr", flags);
    for budget in ["1M", "64M"] {
        let staged = built(
            input,
            dir,
            "staged.tsr",
            &[flags, &["--memory", budget]].concat(),
        );
        assert!(
            staged == in_memory,
            "{} {flags:?} --memory {budget}: other bytes than the in-memory build",
            input.display()
        );
    }
    in_memory
}

#[test]
fn seamed_inputs_build_the_same_bytes_out_of_core() {
    let dir = tempfile::tempdir().unwrap();
    let sphere = write(dir.path(), "sphere.ply", &sphere_ply(24, 48, true));
    let leaves = ["--leaf-triangles", "64"];
    let seamed = check_same_bytes(&sphere, dir.path(), &leaves);
    // The seam is kept: the sphere without texture coordinates builds other bytes.
    let plain = write(dir.path(), "plain.ply", &sphere_ply(24, 48, false));
    assert!(built(&plain, dir.path(), "plain.tsr", &leaves) != seamed);
    // Normal and colour seams.
    let cube = write(dir.path(), "cube.ply", &cube_ply(8, true));
    check_same_bytes(&cube, dir.path(), &leaves);
    // Face colours: a face's corners take its colour, kept apart where faces differ.
    let colored = with_face_colours(&sphere_ply(24, 48, false));
    let colored = write(dir.path(), "faces.ply", &colored);
    let faces = check_same_bytes(&colored, dir.path(), &leaves);
    assert!(faces != built(&plain, dir.path(), "plain.tsr", &leaves));
}

#[test]
fn normals_split_at_creases_build_the_same_bytes_out_of_core() {
    let dir = tempfile::tempdir().unwrap();
    // (The scan has no edge sharper than 30 degrees; 20 splits 116 corners' normals.)
    let creased = check_same_bytes(&bunny(), dir.path(), &["--crease-angle", "20"]);
    let smooth = built(&bunny(), dir.path(), "smooth.tsr", &[]);
    assert!(creased != smooth, "the creases made no wedge");
    // Creases and colour seams at once (a cube's edges are both), and colour seams smoothed
    // across (180: no crease).
    let cube = write(dir.path(), "cube.ply", &cube_ply(8, false));
    let leaves = ["--leaf-triangles", "64"];
    let creased = check_same_bytes(
        &cube,
        dir.path(),
        &[&leaves[..], &["--crease-angle", "60"]].concat(),
    );
    assert!(check_same_bytes(&cube, dir.path(), &leaves) != creased);
}

#[test]
fn a_resumed_seamed_build_gives_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let cube = write(dir.path(), "cube.ply", &cube_ply(8, false));
    let flags = ["--leaf-triangles", "64", "--crease-angle", "60"];
    let reference = built(&cube, dir.path(), "memory.tsr", &flags);
    let out = dir.path().join("resumed.tsr");
    let (i, o, t) = (
        cube.to_str().unwrap(),
        out.to_str().unwrap(),
        dir.path().to_str().unwrap(),
    );
    for stage in ["staged", "hierarchy", "leaves"] {
        let _ = std::fs::remove_file(&out);
        let common = [
            &["build", i, "-o", o, "--memory", "1M", "--temp", t][..],
            &flags,
        ]
        .concat();
        succeeds(&tessera(&[&common[..], &["--stop-after", stage]].concat()));
        assert!(!out.exists(), "an output after --stop-after {stage}");
        succeeds(&tessera(&[&common[..], &["--resume"]].concat()));
        assert!(
            std::fs::read(&out).unwrap() == reference,
            "resumed after {stage}: other bytes than the in-memory build"
        );
    }
}
