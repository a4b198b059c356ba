//! Simplification with attributes at the command line (issue 47 item 3): a gently curved grid
//! whose colours and texture coordinates vary independently of its shape builds; the colour
//! and UV weights change what the diamonds keep (the finest diamonds' colour and UV errors
//! with the weights at 0 far above the defaults'); the attribute error table is written,
//! reported by `info`, `check` and `bench`, the same with `--memory`; an input without colours
//! or texture coordinates gets no table.

mod cli_support;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use cli_support::{json, tessera};

/// An `n` x `n` grid of quads on a gentle bump, as an ASCII PLY: colours a checker of
/// `cell` x `cell` quads (black and white, unrelated to the bump), texture coordinates a
/// smooth but non-linear map (a sine in u across v), when asked.
fn grid_ply(n: usize, cell: usize, colour: bool, uv: bool) -> String {
    let mut ply = String::from("ply\nformat ascii 1.0\n");
    writeln!(ply, "element vertex {}", (n + 1) * (n + 1)).unwrap();
    ply.push_str("property float x\nproperty float y\nproperty float z\n");
    if colour {
        ply.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    }
    if uv {
        ply.push_str("property float s\nproperty float t\n");
    }
    writeln!(ply, "element face {}", 2 * n * n).unwrap();
    ply.push_str("property list uchar int vertex_indices\nend_header\n");
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
            let z = 0.08 * (std::f64::consts::PI * x).sin() * (std::f64::consts::PI * y).sin();
            write!(ply, "{x} {y} {z}").unwrap();
            if colour {
                // The checker's value at the vertex: the cell of the quad above and right.
                let c = if (i.min(n - 1) / cell + j.min(n - 1) / cell).is_multiple_of(2) {
                    255
                } else {
                    0
                };
                write!(ply, " {c} {c} {c}").unwrap();
            }
            if uv {
                write!(ply, " {} {}", x + 0.05 * (9.0 * y).sin(), y).unwrap();
            }
            ply.push('\n');
        }
    }
    let at = |i: usize, j: usize| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            writeln!(ply, "3 {a} {b} {c}\n3 {a} {c} {d}").unwrap();
        }
    }
    ply
}

fn build(input: &Path, out: &Path, extra: &[&str]) {
    let mut args = vec![
        "build",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let run = tessera(&args);
    assert!(
        run.status.success(),
        "build {extra:?}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
}

fn info(repo: &Path) -> serde_json::Value {
    let out = tessera(&["info", repo.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    json(&out)
}

/// The largest `field` error over the diamonds of the finest level that has any.
fn finest(info: &serde_json::Value, field: &str) -> f64 {
    info["levels"]
        .as_array()
        .unwrap()
        .iter()
        .rev()
        .find_map(|l| l["attribute_errors"][field].as_f64())
        .expect("a level with attribute errors")
}

fn write_input(dir: &Path, name: &str, ply: String) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, ply).unwrap();
    path
}

#[test]
fn weights_keep_appearance_and_the_table_is_stored_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let input = write_input(dir.path(), "grid.ply", grid_ply(96, 12, true, true));
    let weighed = dir.path().join("weighed.tsr");
    let unweighed = dir.path().join("unweighed.tsr");
    build(&input, &weighed, &[]);
    build(
        &input,
        &unweighed,
        &["--colour-weight", "0", "--uv-weight", "0"],
    );
    let (w, u) = (info(&weighed), info(&unweighed));
    for i in [&w, &u] {
        assert!(
            i["sections"]
                .as_array()
                .unwrap()
                .iter()
                .any(|s| s["kind"] == "attribute error table"),
            "{i}"
        );
        // Saturated: the repository's largest is every level's largest.
        for field in ["colour", "normal_degrees", "uv"] {
            let all = i["attribute_errors"][field].as_f64().unwrap();
            let levels = i["levels"].as_array().unwrap();
            let by_level = levels
                .iter()
                .filter_map(|l| l["attribute_errors"][field].as_f64())
                .fold(0.0, f64::max);
            assert_eq!(all, by_level, "{field}");
            // Monotone: each level's largest is at most the coarser level's.
            let per: Vec<f64> = levels
                .iter()
                .filter_map(|l| l["attribute_errors"][field].as_f64())
                .collect();
            assert!(per.windows(2).all(|p| p[0] >= p[1]), "{field}: {per:?}");
        }
    }
    // The weights change what is kept: the finest diamonds' colour and UV errors.
    let (colour_w, colour_u) = (finest(&w, "colour"), finest(&u, "colour"));
    let (uv_w, uv_u) = (finest(&w, "uv"), finest(&u, "uv"));
    eprintln!("finest level: colour {colour_w} vs {colour_u} unweighed, uv {uv_w} vs {uv_u}");
    assert!(
        colour_u > 100.0 && colour_w < 0.25 * colour_u,
        "{colour_w} {colour_u}"
    );
    // The UV map is nearly linear over a diamond: its error is small either way, but what is
    // kept differs.
    assert!(uv_w != uv_u, "{uv_w} {uv_u}");

    // `check --json` reports the drawn cuts' largest errors per tolerance, within the table's.
    let out = tessera(&[
        "check",
        weighed.to_str().unwrap(),
        "--views",
        "4",
        "--tolerances",
        "0.5,8",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let check = json(&out);
    let per_tau = check["attribute_errors"].as_array().expect("per tolerance");
    assert_eq!(per_tau.len(), 2);
    let colour = |k: usize| per_tau[k]["colour"].as_f64().unwrap();
    assert!(colour(0) <= colour(1), "a coarser cut: no smaller error");
    assert!(colour(1) <= w["attribute_errors"]["colour"].as_f64().unwrap());

    // `bench` reports the same for ours at its dense pass's eyes (`check_views`, as `check`'s
    // at a 1080-pixel height): `--error-views 4` gives exactly `check --views 4`'s figures.
    let out = tessera(&[
        "bench",
        weighed.to_str().unwrap(),
        "--source",
        input.to_str().unwrap(),
        "--views",
        "1",
        "--tolerances",
        "0.5,8",
        "--size",
        "96x1080",
        "--samples",
        "200",
        "--frames",
        "1",
        "--error-views",
        "4",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let bench = json(&out);
    assert_eq!(
        bench["attribute_errors"], check["attribute_errors"],
        "{bench}"
    );

    // The out-of-core build writes the same bytes, table included.
    let staged = dir.path().join("staged.tsr");
    build(&input, &staged, &["--memory", "64M"]);
    assert!(
        std::fs::read(&staged).unwrap() == std::fs::read(&weighed).unwrap(),
        "--memory wrote other bytes"
    );
}

#[test]
fn an_input_without_colours_or_uvs_gets_no_table() {
    let dir = tempfile::tempdir().unwrap();
    let input = write_input(dir.path(), "plain.ply", grid_ply(32, 8, false, false));
    let repo = dir.path().join("plain.tsr");
    // The colour and UV weights weigh nothing it has: the same bytes whatever they are.
    build(&input, &repo, &[]);
    let other = dir.path().join("other.tsr");
    build(
        &input,
        &other,
        &["--colour-weight", "3", "--uv-weight", "0"],
    );
    assert!(std::fs::read(&repo).unwrap() == std::fs::read(&other).unwrap());
    let i = info(&repo);
    assert!(i["attribute_errors"].is_null(), "{i}");
    assert!(i["levels"]
        .as_array()
        .unwrap()
        .iter()
        .all(|l| l["attribute_errors"].is_null()));
    let out = tessera(&["check", repo.to_str().unwrap(), "--views", "2", "--json"]);
    assert!(out.status.success());
    assert!(json(&out)["attribute_errors"].is_null());
    // A negative weight is refused with a message, exit 2.
    let bad = tessera(&[
        "build",
        input.to_str().unwrap(),
        "-o",
        dir.path().join("bad.tsr").to_str().unwrap(),
        "--colour-weight=-1",
    ]);
    assert_eq!(
        bad.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&bad.stderr)
    );
    assert!(String::from_utf8_lossy(&bad.stderr).contains("colour weight -1"));
}
