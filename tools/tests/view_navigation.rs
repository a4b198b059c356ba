//! `tessera view` navigation and tools in a real window under Xvfb (lavapipe): a double-click
//! picks the pivot on the surface, a fly key moves the eye, fly mode looks around from the
//! eye, the wheel zooms towards the cursor, a frozen cut stays the same seen from elsewhere,
//! the exported cut re-imports with its triangle count and closed, the triangle budget holds
//! within 5 %, bookmarks and recorded paths round-trip, a camera path plays, and another
//! repository opens in the window (as a dropped file does).

mod view_support;

use std::path::Path;
use std::process::Command;

use view_support::{
    bunny_repository, differing_pixels, model_pixels, ok, xvfb_run, XVFB, XVFB_ARGS,
};

fn distance(a: &serde_json::Value, b: &serde_json::Value) -> f64 {
    let v = |x: &serde_json::Value, i: usize| x[i].as_f64().unwrap();
    (0..3)
        .map(|i| (v(a, i) - v(b, i)).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Undirected edges used by other than exactly two triangles.
fn unpaired_edges(triangles: &[[u32; 3]]) -> usize {
    let mut uses = std::collections::HashMap::<(u32, u32), u32>::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    uses.values().filter(|&&n| n != 2).count()
}

#[test]
fn view_navigates_freezes_exports_and_holds_a_triangle_budget() {
    navigates("vulkan");
}

/// The same on wgpu's GL backend (llvmpipe through EGL).
#[test]
fn view_navigates_on_gl_too() {
    navigates("gl");
}

fn navigates(backend: &str) {
    if !xvfb_run() {
        eprintln!("skipped: xvfb-run is not installed (Debian package `xvfb`)");
        return;
    }
    let _xvfb = XVFB.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let repo = bunny_repository(dir.path());
    let lion = dir.path().join("lion.tsr");
    let lion_head =
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/lion-head.off");
    ok(&Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args([
            "build",
            lion_head.to_str().unwrap(),
            "-o",
            lion.to_str().unwrap(),
        ])
        .output()
        .unwrap());
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let shot = |name: &str| format!(r#"{{"screenshot":"{}"}}"#, at(name));
    let path_file = dir.path().join("path.json");
    std::fs::write(
        &path_file,
        r#"{"keyframes":[{"eye":[0.3,0.1,0.3],"target":[0,0,0]},{"eye":[-0.3,0.1,0.3],"target":[0,0,0]}],"frames_between":10}"#,
    )
    .unwrap();
    let script = [
        r#"{"overlay":false}"#.to_string(),
        shot("start.png"),
        r#"{"double_click":[240,180]}"#.into(),
        shot("picked.png"),
        r#"{"key":"r"}"#.into(),
        r#"{"key":"w","frames":20}"#.into(),
        shot("flew.png"),
        r#"{"key":"r"}"#.into(),
        r#"{"fly":true}"#.into(),
        r#"{"drag":[240,180,300,150]}"#.into(),
        shot("looked.png"),
        r#"{"fly":false}"#.into(),
        r#"{"key":"r"}"#.into(),
        r#"{"freeze":true}"#.into(),
        r#"{"orbit":[210,20,1.2]}"#.into(),
        shot("frozen.png"),
        r#"{"freeze":false}"#.into(),
        shot("unfrozen.png"),
        r#"{"key":"r"}"#.into(),
        r#"{"wheel_at":[240,180,5]}"#.into(),
        shot("zoomed.png"),
        r#"{"key":"r"}"#.into(),
        format!(r#"{{"export":"{}"}}"#, at("cut.ply")),
        format!(r#"{{"export":"{}"}}"#, at("cut.glb")),
        r#"{"budget_triangles":20000}"#.into(),
        r#"{"wait_frames":120}"#.into(),
        shot("budget.png"),
        r#"{"target":"off"}"#.into(),
        r#"{"tolerance":1}"#.into(),
        r#"{"key":"b"}"#.into(),
        r#"{"orbit":[120,10,2]}"#.into(),
        r#"{"key":"b"}"#.into(),
        r#"{"key":"1"}"#.into(),
        shot("bookmark1.png"),
        r#"{"key":"k"}"#.into(),
        r#"{"key":"d","frames":5}"#.into(),
        r#"{"key":"k"}"#.into(),
        format!(r#"{{"play":"{}"}}"#, path_file.display()),
        shot("played.png"),
        r#"{"gpu_budget":12}"#.into(),
        shot("budget12.png"),
        // Another repository, as a file dropped on the window opens it.
        format!(r#"{{"open":"{}"}}"#, lion.display()),
        shot("opened.png"),
    ]
    .join("\n");
    let script_path = dir.path().join("s.jsonl");
    std::fs::write(&script_path, script).unwrap();
    let bookmarks = dir.path().join("marks.json");
    let recorded = dir.path().join("recorded.json");
    let out = Command::new("timeout")
        .args(["-k", "10", "300", "xvfb-run", "-a", "-s", XVFB_ARGS])
        .arg(env!("CARGO_BIN_EXE_tessera"))
        .args(["view", repo.to_str().unwrap(), "--size", "480x360"])
        .args(["--orbit", "30,20,1.2", "--backend", backend, "--json"])
        .args(["--script", script_path.to_str().unwrap()])
        .args(["--bookmarks", bookmarks.to_str().unwrap()])
        .args(["--record", recorded.to_str().unwrap()])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    eprintln!("{}{stderr}", String::from_utf8_lossy(&out.stdout));
    ok(&out);
    let records: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("one JSON object a line"))
        .collect();
    let names = [
        "start",
        "picked",
        "flew",
        "looked",
        "frozen",
        "unfrozen",
        "zoomed",
        "budget",
        "bookmark1",
        "played",
        "budget12",
        "opened",
    ];
    assert_eq!(records.len(), names.len());
    let r = |name: &str| &records[names.iter().position(|n| *n == name).unwrap()];
    let image = |name: &str| {
        image::open(r(name)["path"].as_str().unwrap())
            .unwrap()
            .to_rgba8()
    };
    let start = image("start");
    let n = (480 * 360) as usize;
    assert!(model_pixels(&start) > n / 20);
    let (eye0, pivot0) = (&r("start")["eye"], &r("start")["pivot"]);

    // Double-click: the pivot moves onto the surface in front of the centre, the eye stays.
    let picked = r("picked");
    assert!(distance(&picked["eye"], eye0) < 1e-9, "{picked}");
    assert!(
        distance(&picked["pivot"], pivot0) > 1e-3,
        "the pivot did not move"
    );
    assert!(
        distance(&picked["pivot"], eye0) < distance(pivot0, eye0),
        "the surface under the centre is nearer than the model's centre"
    );
    assert_eq!(
        differing_pixels(&start, &image("picked")),
        0,
        "a pivot alone moves nothing"
    );

    // W held for 20 frames: the eye flew towards the model.
    let flew = r("flew");
    assert!(
        distance(&flew["eye"], pivot0) < 0.95 * distance(eye0, pivot0),
        "{flew}"
    );
    assert!(differing_pixels(&start, &image("flew")) > n / 20);

    // Fly mode: a drag turns the view around the eye.
    let looked = r("looked");
    assert_eq!(looked["fly"], true);
    assert!(distance(&looked["eye"], eye0) < 1e-9);
    assert!(differing_pixels(&start, &image("looked")) > n / 20);

    // A frozen cut: the first view's cut, drawn from behind.
    let (frozen, unfrozen) = (r("frozen"), r("unfrozen"));
    assert_eq!(frozen["frozen"], true);
    assert_eq!(
        frozen["triangles"],
        r("start")["triangles"],
        "the frozen cut"
    );
    assert_eq!(frozen["patches"], r("start")["patches"]);
    assert_eq!(unfrozen["frozen"], false);
    assert_ne!(
        frozen["patches"], unfrozen["patches"],
        "the back view's own cut"
    );
    assert!(differing_pixels(&image("frozen"), &image("unfrozen")) > 0);

    // The wheel at the centre: towards the surface there, the pivot moved with it.
    let zoomed = r("zoomed");
    assert!(distance(&zoomed["eye"], &picked["pivot"]) < distance(eye0, &picked["pivot"]));
    assert!(distance(&zoomed["pivot"], pivot0) > 1e-3);

    // The export: the cut of the first view, whole, closed like the bunny, and read back by
    // tessera's own importer with the triangles it was written with.
    let exported: usize = stderr
        .lines()
        .find_map(|l| l.strip_prefix("exported ")?.split(' ').next()?.parse().ok())
        .expect("the export's message");
    for file in ["cut.ply", "cut.glb"] {
        let mesh = tessera_preprocess::import::load_mesh(Path::new(&at(file)))
            .unwrap()
            .mesh;
        assert_eq!(mesh.triangles.len(), exported, "{file}");
        assert!(exported >= r("start")["triangles"].as_u64().unwrap() as usize);
        assert_eq!(
            unpaired_edges(&mesh.triangles),
            0,
            "{file}: the exported cut is not closed"
        );
    }

    // The triangle budget.
    let budget = r("budget");
    let t = budget["triangles"].as_f64().unwrap();
    assert!(
        (t / 20000.0 - 1.0).abs() <= 0.05,
        "{t} triangles for a budget of 20000"
    );
    assert_ne!(budget["tolerance"], 1.0);

    // Bookmarks: two saved, the first one is the first view.
    let marks: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&bookmarks).unwrap()).unwrap();
    assert_eq!(marks["keyframes"].as_array().unwrap().len(), 2);
    assert!(distance(&r("bookmark1")["eye"], eye0) < 1e-9);
    assert_eq!(differing_pixels(&start, &image("bookmark1")), 0);

    // The recorded path: a camera a frame while recording, in the format bench stream flies.
    let path: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&recorded).unwrap()).unwrap();
    assert!(path["keyframes"].as_array().unwrap().len() >= 5, "{path}");
    // The played path ends on its last keyframe.
    let played = r("played");
    assert!(distance(&played["eye"], &serde_json::json!([-0.3, 0.1, 0.3])) < 1e-9);

    // The streaming renderer remade under 12 MiB: every allocation within it, the view drawn.
    let b12 = r("budget12");
    assert!(b12["resident_bytes"].as_u64().unwrap() <= 12 << 20, "{b12}");
    assert!(model_pixels(&image("budget12")) > n / 50);

    // The lion head replaced the bunny, at its own initial view.
    let opened = image("opened");
    assert!(model_pixels(&opened) > n / 50);
    assert!(differing_pixels(&start, &opened) > n / 20);
    assert_ne!(r("opened")["eye"], r("start")["eye"]);
    assert!(stderr.contains("opened "), "{stderr}");
}
