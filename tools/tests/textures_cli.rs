//! Textured inputs through the CLI: `gen mesh --uv --texture N` writes a PNG beside the mesh
//! and names it in the PLY; `build --json` reports the textures it read (in memory and under
//! `--memory`) and the files it did not find; `--no-textures` reads none.

use std::path::Path;
use std::process::{Command, Output};

fn tessera(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(args)
        .output()
        .expect("run tessera")
}

fn ok(out: Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "exit {:?}: {}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "not one JSON object ({e}): {}",
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

fn build(mesh: &Path, repo: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "build",
        mesh.to_str().unwrap(),
        "-o",
        repo.to_str().unwrap(),
    ];
    args.extend(extra);
    args.push("--json");
    ok(tessera(&args))
}

#[test]
fn a_generated_texture_is_read_by_build_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("relief.ply");
    let gen = ok(tessera(&[
        "gen",
        "mesh",
        "--triangles",
        "2000",
        "--uv",
        "--texture",
        "64",
        "-o",
        mesh.to_str().unwrap(),
        "--json",
    ]));
    let png = dir.path().join("relief.png");
    assert_eq!(gen["texture"], png.display().to_string());
    assert_eq!(gen["texture_side"], 64);
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(gen["texture_bytes"], bytes.len() as u64);
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    let ply = std::fs::read(&mesh).unwrap();
    let comment = b"comment TextureFile relief.png\n";
    assert!(ply.windows(comment.len()).any(|w| w == comment));

    let repo = dir.path().join("relief.tsr");
    for extra in [&[][..], &["--memory", "64M"][..]] {
        let report = build(&mesh, &repo, extra);
        assert_eq!(report["textures"], 1, "{extra:?}");
        assert_eq!(
            report["missing_textures"],
            serde_json::json!([]),
            "{extra:?}"
        );
    }
    let report = build(&mesh, &repo, &["--no-textures"]);
    assert_eq!(report["textures"], 0);

    // The texture gone: the mesh builds untextured and says which file it did not find.
    std::fs::remove_file(&png).unwrap();
    let report = build(&mesh, &repo, &[]);
    assert_eq!(report["textures"], 0);
    assert_eq!(
        report["missing_textures"],
        serde_json::json!([png.display().to_string()])
    );
}

#[test]
fn gen_mesh_texture_needs_coordinates_and_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("m.ply");
    let out = tessera(&[
        "gen",
        "mesh",
        "--triangles",
        "2000",
        "--texture",
        "64",
        "-o",
        mesh.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--uv"));
    let out = tessera(&[
        "gen",
        "mesh",
        "--triangles",
        "2000",
        "--uv",
        "--texture",
        "0",
        "-o",
        mesh.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--texture 0"));
    assert!(!mesh.exists() && !dir.path().join("m.png").exists());
}

/// A checkpoint keeps the staged mesh, not its textures: a resumed build finds them in the
/// input again, from the staged mesh or from a later stage, and writes the bytes of a build
/// never stopped.
#[test]
fn a_resumed_build_keeps_the_inputs_textures() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("relief.ply");
    ok(tessera(&[
        "gen",
        "mesh",
        "--triangles",
        "20000",
        "--uv",
        "--texture",
        "32",
        "-o",
        mesh.to_str().unwrap(),
        "--json",
    ]));
    let memory = ["--memory", "64M", "--leaf-triangles", "256"];
    let whole = dir.path().join("whole.tsr");
    assert_eq!(build(&mesh, &whole, &memory)["textures"], 1);
    let repo = dir.path().join("resumed.tsr");
    for stage in ["staged", "leaves"] {
        let resume: &[&str] = if stage == "staged" {
            &[]
        } else {
            &["--resume"]
        };
        let stopped = build(
            &mesh,
            &repo,
            &[&memory[..], resume, &["--stop-after", stage]].concat(),
        );
        assert_eq!(stopped["stopped_after"], stage, "{stopped}");
    }
    let report = build(&mesh, &repo, &[&memory[..], &["--resume"]].concat());
    assert_eq!(report["textures"], 1, "{report}");
    assert!(std::fs::read(&repo).unwrap() == std::fs::read(&whole).unwrap());
}
