//! Wedges at the command line (issue 47 item 1): an OBJ with hard edges and texture seams
//! builds, `tessera check --gpu` is clean (crack checks by global id and the pixel check), and
//! the out-of-core build refuses what it cannot keep yet (an OBJ's corners with their own
//! `vt` or `vn`: exit 2, naming the missing feature) rather than write other bytes than the
//! in-memory build. Wedges it keeps: `wedges_memory.rs`.

mod cli_support;

use std::fmt::Write as _;
use std::path::Path;

use cli_support::{json, tessera};

/// A cube face: its normal, its u and v axes and its origin.
type Face = ([f64; 3], [f64; 3], [f64; 3], [f64; 3]);

/// A cube of `n` x `n` quads a face as an OBJ: `v` shared along the edges, a `vn` a face (hard
/// edges) and a texture chart a face (`vt` a corner: a seam on every edge). With `seams` off,
/// corners name the vertex's own `vt` (one a vertex) and no normal: nothing to keep apart.
fn cube_obj(n: usize, seams: bool) -> String {
    let faces: [Face; 6] = [
        ([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [1., 0., 0.]),
        ([-1., 0., 0.], [0., 0., 1.], [0., 1., 0.], [0., 0., 0.]),
        ([0., 1., 0.], [0., 0., 1.], [1., 0., 0.], [0., 1., 0.]),
        ([0., -1., 0.], [1., 0., 0.], [0., 0., 1.], [0., 0., 0.]),
        ([0., 0., 1.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]),
        ([0., 0., -1.], [0., 1., 0.], [1., 0., 0.], [0., 0., 0.]),
    ];
    let mut obj = String::new();
    let mut vertex_of = std::collections::HashMap::new();
    let (mut vertices, mut texcoords) = (0, 0);
    for (f, (normal, u, v, origin)) in faces.iter().enumerate() {
        writeln!(obj, "vn {} {} {}", normal[0], normal[1], normal[2]).unwrap();
        let mut corner = vec![vec![String::new(); n + 1]; n + 1];
        for (i, row) in corner.iter_mut().enumerate() {
            for (j, c) in row.iter_mut().enumerate() {
                let (a, b) = (i as f64 / n as f64, j as f64 / n as f64);
                let p = [0, 1, 2].map(|k| origin[k] + a * u[k] + b * v[k]);
                let key = p.map(|x| (x * n as f64).round() as i64);
                let id = *vertex_of.entry(key).or_insert_with(|| {
                    writeln!(obj, "v {} {} {}", p[0], p[1], p[2]).unwrap();
                    vertices += 1;
                    writeln!(obj, "vt {} {}", p[0] + p[2], p[1]).unwrap();
                    texcoords += 1;
                    vertices
                });
                *c = if seams {
                    writeln!(obj, "vt {} {}", (f as f64 + a) / 6.0, b).unwrap();
                    texcoords += 1;
                    format!("{id}/{texcoords}/{}", f + 1)
                } else {
                    // The vertex's own texture coordinate was written with it.
                    format!("{id}/{id}")
                };
            }
        }
        for i in 0..n {
            for j in 0..n {
                let [a, b, c, d] = [
                    &corner[i][j],
                    &corner[i + 1][j],
                    &corner[i + 1][j + 1],
                    &corner[i][j + 1],
                ];
                writeln!(obj, "f {a} {b} {c}\nf {a} {c} {d}").unwrap();
            }
        }
    }
    obj
}

fn write_cube(dir: &Path, name: &str, seams: bool) -> String {
    let path = dir.join(name);
    std::fs::write(&path, cube_obj(12, seams)).unwrap();
    path.to_str().unwrap().to_string()
}

fn succeeds(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn a_cube_with_seams_builds_and_checks_clean_on_the_gpu() {
    let dir = tempfile::tempdir().unwrap();
    let cube = write_cube(dir.path(), "cube.obj", true);
    let repo = dir.path().join("cube.tsr");
    let repo = repo.to_str().unwrap();
    succeeds(&tessera(&[
        "build",
        &cube,
        "-o",
        repo,
        "--leaf-triangles",
        "64",
    ]));
    let out = tessera(&["check", repo, "--gpu", "--views", "8", "--json"]);
    succeeds(&out);
    let report = json(&out);
    assert_eq!(report["cracks"], 0, "{report}");
    assert_eq!(report["position_mismatches"], 0, "{report}");
}

#[test]
fn the_out_of_core_build_refuses_seams_and_builds_the_same_bytes_without() {
    let dir = tempfile::tempdir().unwrap();
    let temp = dir.path().to_str().unwrap();
    let seamed = write_cube(dir.path(), "seamed.obj", true);
    let out_path = dir.path().join("seamed.tsr");
    let out = tessera(&[
        "build",
        &seamed,
        "-o",
        out_path.to_str().unwrap(),
        "--memory",
        "64M",
        "--temp",
        temp,
    ]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("does not stage those corners"), "{stderr}");
    assert!(!out_path.exists(), "no output after a refusal");

    // The same cube without seams: the same bytes either way.
    let plain = write_cube(dir.path(), "plain.obj", false);
    let built = |name: &str, extra: &[&str]| {
        let path = dir.path().join(name);
        let args = [&["build", &plain, "-o", path.to_str().unwrap()][..], extra].concat();
        succeeds(&tessera(&args));
        std::fs::read(path).unwrap()
    };
    let in_memory = built("memory.tsr", &[]);
    let staged = built("staged.tsr", &["--memory", "64M", "--temp", temp]);
    assert!(in_memory == staged, "the two builds differ");
}

#[test]
fn a_crease_angle_splits_computed_normals_in_memory_and_out_of_core() {
    let dir = tempfile::tempdir().unwrap();
    let temp = dir.path().to_str().unwrap();
    // No normals: they are computed, split at the cube's edges.
    let cube = write_cube(dir.path(), "plain.obj", false);
    let repo = dir.path().join("creased.tsr");
    let repo = repo.to_str().unwrap();
    let build = |extra: &[&str]| {
        let args = [
            &["build", &cube, "-o", repo, "--leaf-triangles", "64"][..],
            extra,
        ]
        .concat();
        tessera(&args)
    };
    succeeds(&build(&["--crease-angle", "60"]));
    let smooth = dir.path().join("smooth.tsr");
    let out = tessera(&["build", &cube, "-o", smooth.to_str().unwrap()]);
    succeeds(&out);
    assert!(
        std::fs::metadata(repo).unwrap().len() > std::fs::metadata(&smooth).unwrap().len(),
        "the creased cube stores its edges' wedges"
    );
    succeeds(&tessera(&["check", repo, "--gpu", "--views", "8"]));
    // Out of core: the same wedges, the same bytes.
    let in_memory = std::fs::read(repo).unwrap();
    succeeds(&build(&[
        "--crease-angle",
        "60",
        "--memory",
        "1M",
        "--temp",
        temp,
    ]));
    assert!(
        std::fs::read(repo).unwrap() == in_memory,
        "other bytes out of core"
    );
    // Out of range.
    let out = build(&["--crease-angle", "0"]);
    assert_eq!(out.status.code(), Some(2));
}
