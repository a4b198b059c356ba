//! The CLI contract pipeline scripts rely on: JSON keys, exit codes, no partial outputs.

use std::path::Path;
use std::process::{Command, Output};

fn tessera(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(args)
        .output()
        .expect("run tessera")
}

fn json(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not one JSON object ({e}): {}\nstderr: {}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        )
    })
}

/// A closed octahedron, subdivided a few times so the hierarchy has levels.
fn write_octahedron_off(path: &Path) {
    let v = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let f = [
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    let mut verts: Vec<[f64; 3]> = v.to_vec();
    let mut faces: Vec<[usize; 3]> = f.to_vec();
    for _ in 0..5 {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        for t in &faces {
            let mut m = [0; 3];
            for k in 0..3 {
                let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
                m[k] = *mid.entry((a, b)).or_insert_with(|| {
                    let p: Vec<f64> = (0..3).map(|i| 0.5 * (verts[a][i] + verts[b][i])).collect();
                    let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                    verts.push([p[0] / l, p[1] / l, p[2] / l]);
                    verts.len() - 1
                });
            }
            next.extend([
                [t[0], m[0], m[2]],
                [t[1], m[1], m[0]],
                [t[2], m[2], m[1]],
                m,
            ]);
        }
        faces = next;
    }
    let mut s = format!("OFF\n{} {} 0\n", verts.len(), faces.len());
    for p in &verts {
        s += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    for t in &faces {
        s += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    std::fs::write(path, s).unwrap();
}

#[test]
fn build_info_check_speak_json_and_exit_zero() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("octa.off");
    let repo = dir.path().join("octa.tsr");
    write_octahedron_off(&input);
    let out = tessera(&[
        "build",
        input.to_str().unwrap(),
        "-o",
        repo.to_str().unwrap(),
        "--leaf-triangles",
        "64",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let b = json(&out);
    for key in [
        "input_triangles",
        "input_vertices",
        "tetrahedra",
        "diamonds",
        "depth",
        "seconds",
        "repository_bytes",
    ] {
        assert!(b.get(key).is_some(), "build --json lacks {key}: {b}");
    }
    assert_eq!(b["input_triangles"], 8 * 1024);
    assert_eq!(
        b["repository_bytes"].as_u64().unwrap(),
        std::fs::metadata(&repo).unwrap().len()
    );

    let out = tessera(&["info", repo.to_str().unwrap(), "--json"]);
    assert!(out.status.success());
    assert_eq!(json(&out)["tetrahedra"], b["tetrahedra"]);

    let out = tessera(&[
        "check",
        repo.to_str().unwrap(),
        "--views",
        "8",
        "--tolerances",
        "0.5,2,8",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let c = json(&out);
    assert_eq!(c["cuts_checked"], 24);
    for key in [
        "cracks",
        "nonmanifold_introduced",
        "monotonicity_violations",
    ] {
        assert_eq!(c[key], 0, "{c}");
    }
    assert!(c["min_triangles"].as_u64().unwrap() > 0);
}

#[test]
fn bad_inputs_exit_two_with_a_message_and_leave_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let cases: &[(&str, &[u8], &str)] = &[
        ("missing_header.ply", b"not a ply file\n", "ply"),
        ("bad_index.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "7"),
        ("nan.off", b"OFF\n3 1 0\nnan 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "nan"),
        ("truncated.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n", "truncat"),
        ("empty.off", b"OFF\n0 0 0\n", "empty"),
        ("huge.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n", "huge.ply"),
        ("unknown.xyz", b"1 2 3\n", "xyz"),
    ];
    for (name, bytes, needle) in cases {
        let input = dir.path().join(name);
        std::fs::write(&input, bytes).unwrap();
        let output = dir.path().join(format!("{name}.tsr"));
        let out = tessera(&[
            "build",
            input.to_str().unwrap(),
            "-o",
            output.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr).to_lowercase();
        assert_eq!(out.status.code(), Some(2), "{name}: {stderr}");
        assert!(
            stderr.contains(name),
            "{name}: message does not name the file: {stderr}"
        );
        assert!(
            stderr.contains(needle),
            "{name}: message does not say '{needle}': {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
        assert!(!output.exists(), "{name}: an output file was left behind");
        let leftovers: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
            .collect();
        assert!(
            leftovers.is_empty(),
            "{name}: temporary files left: {leftovers:?}"
        );
    }
    let out = tessera(&[
        "build",
        dir.path().join("nope.ply").to_str().unwrap(),
        "-o",
        "x.tsr",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope.ply"));
}

#[test]
fn corrupt_repositories_are_rejected_with_exit_two() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("octa.off");
    let repo = dir.path().join("octa.tsr");
    write_octahedron_off(&input);
    assert!(tessera(&[
        "build",
        input.to_str().unwrap(),
        "-o",
        repo.to_str().unwrap()
    ])
    .status
    .success());
    let bytes = std::fs::read(&repo).unwrap();
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("truncated", bytes[..bytes.len() / 2].to_vec()),
        ("flipped", {
            let mut b = bytes.clone();
            let n = b.len();
            b[n / 3] ^= 0x40;
            b
        }),
        ("version", {
            let mut b = bytes.clone();
            b[8] = 99;
            b
        }),
        ("empty", Vec::new()),
    ];
    for (name, data) in cases {
        let path = dir.path().join(format!("{name}.tsr"));
        std::fs::write(&path, data).unwrap();
        for cmd in ["info", "check"] {
            let out = tessera(&[cmd, path.to_str().unwrap()]);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{cmd} {name}: {stderr}");
            assert!(stderr.contains("error"), "{cmd} {name}: {stderr}");
            assert!(!stderr.contains("panicked"), "{cmd} {name}: {stderr}");
        }
    }
}
