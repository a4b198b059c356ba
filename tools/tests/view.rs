//! `tessera view`: a script run in a real window under Xvfb (lavapipe) takes screenshots with
//! model pixels, fewer triangles at a higher tolerance, a patches mode unlike the lit one, a
//! reset key back to the first view and an overlay drawn into the window; the X server shows
//! what the viewer captures; without a display, or with a bad script line, it exits 2 with a
//! message.

use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

mod view_support;

use view_support::{
    bunny_repository, differing_pixels, model_pixels, ok, tessera, xvfb_run, XVFB, XVFB_ARGS,
};

#[test]
fn view_runs_a_script_in_a_window_under_xvfb() {
    if !xvfb_run() {
        eprintln!("skipped: xvfb-run is not installed (Debian package `xvfb`)");
        return;
    }
    let _xvfb = XVFB.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let repo = bunny_repository(dir.path());
    let shot = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let script = [
        r#"{"overlay":false}"#.to_string(),
        r#"{"orbit":[30,20,1.2]}"#.to_string(),
        r#"{"tolerance":1}"#.to_string(),
        format!(r#"{{"screenshot":"{}"}}"#, shot("lit1.png")),
        r#"{"tolerance":16}"#.to_string(),
        format!(r#"{{"screenshot":"{}"}}"#, shot("lit16.png")),
        r#"{"tolerance":1}"#.to_string(),
        r#"{"mode":"patches"}"#.to_string(),
        format!(r#"{{"screenshot":"{}"}}"#, shot("patches1.png")),
        r#"{"mode":"lit"}"#.to_string(),
        r#"{"flat":true}"#.to_string(),
        format!(r#"{{"screenshot":"{}"}}"#, shot("flat1.png")),
        r#"{"flat":false}"#.to_string(),
        r#"{"orbit":[150,-30,3]}"#.to_string(),
        r#"{"wait_frames":3}"#.to_string(),
        r#"{"key":"r"}"#.to_string(),
        format!(r#"{{"screenshot":"{}"}}"#, shot("reset.png")),
        r#"{"overlay":true}"#.to_string(),
        format!(r#"{{"screenshot":"{}"}}"#, shot("overlay.png")),
        r#"{"overlay":false}"#.to_string(),
        r#"{"resize":[640,360]}"#.to_string(),
        format!(r#"{{"screenshot":"{}"}}"#, shot("wide.png")),
        r#"{"resize":[480,360]}"#.to_string(),
        r#"{"key":"r"}"#.to_string(),
        r#"{"drag":[100,180,250,200]}"#.to_string(),
        format!(r#"{{"screenshot":"{}"}}"#, shot("dragged.png")),
        r#"{"key":"r"}"#.to_string(),
        r#"{"right_drag":[240,180,300,140]}"#.to_string(),
        format!(r#"{{"screenshot":"{}"}}"#, shot("panned.png")),
        r#"{"key":"r"}"#.to_string(),
        r#"{"wheel":-4}"#.to_string(),
        format!(r#"{{"screenshot":"{}"}}"#, shot("zoomed_out.png")),
        // The screenshot key: the window as it is, to tessera-view-001.png in the viewer's
        // current directory (a tenth record, its path absolute).
        r#"{"key":"p"}"#.to_string(),
    ]
    .join("\n");
    let script_path = dir.path().join("s.jsonl");
    std::fs::write(&script_path, script).unwrap();
    let started = std::time::Instant::now();
    // Bounded: a viewer that hung would otherwise hold CI until its hard limit (exit 124).
    let out = Command::new("timeout")
        .args(["-k", "10", "300", "xvfb-run", "-a", "-s", XVFB_ARGS])
        .arg(env!("CARGO_BIN_EXE_tessera"))
        .args([
            "view",
            repo.to_str().unwrap(),
            "--size",
            "480x360",
            "--orbit",
            "30,20,1.2",
            "--backend",
            "vulkan",
            "--script",
            script_path.to_str().unwrap(),
            "--json",
        ])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let key_shot = image::open(dir.path().join("tessera-view-001.png"))
        .expect("the screenshot key wrote tessera-view-001.png")
        .to_rgba8();
    assert!(model_pixels(&key_shot) > 1000);
    eprintln!(
        "view ran {:.1} s\n{}{}",
        started.elapsed().as_secs_f64(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    ok(&out);
    let records: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("one JSON object a line"))
        .collect();
    assert_eq!(
        records.len(),
        11,
        "one record per screenshot, the key's included"
    );
    assert_eq!(
        records[10]["path"].as_str().map(PathBuf::from),
        Some(dir.path().join("tessera-view-001.png"))
    );
    for r in &records {
        for key in [
            "path",
            "triangles",
            "patches",
            "tolerance",
            "gpu_ms",
            "resident_bytes",
        ] {
            assert!(r.get(key).is_some(), "{key} missing from {r}");
        }
        assert_eq!(r["settled"], true, "{r}");
    }
    let images: Vec<image::RgbaImage> = records
        .iter()
        .map(|r| {
            let path = r["path"].as_str().unwrap();
            assert!(std::fs::read(path).unwrap().starts_with(b"\x89PNG"));
            image::open(path).unwrap().to_rgba8()
        })
        .collect();
    let [lit1, lit16, patches1, flat1, reset, overlay, wide, dragged, panned, zoomed_out, _key] =
        &images[..]
    else {
        unreachable!()
    };
    assert_eq!(lit1.dimensions(), (480, 360), "the window's size");
    let n = (480 * 360) as usize;
    let model = model_pixels(lit1);
    assert!(model > n / 20, "{model} model pixels of {n}");
    assert!(model_pixels(lit16) > n / 20, "τ 16 draws the model too");
    let triangles = |i: usize| records[i]["triangles"].as_u64().unwrap();
    assert!(
        triangles(1) < triangles(0),
        "τ 16 draws {} triangles, τ 1 {}",
        triangles(1),
        triangles(0)
    );
    assert!(
        differing_pixels(lit1, patches1) > model / 4,
        "patches ≠ lit"
    );
    // Flat shading: the same cut (the bunny's computed normals ignored), shaded otherwise.
    assert_eq!(triangles(3), triangles(0));
    assert_eq!(model_pixels(flat1), model);
    assert!(
        differing_pixels(lit1, flat1) > model / 4,
        "flat ≠ lit: {} of {model} model pixels differ",
        differing_pixels(lit1, flat1)
    );
    // `R` comes back to the first view: the same cut, the same image.
    assert_eq!(triangles(4), triangles(0));
    assert_eq!(differing_pixels(lit1, reset), 0, "reset view ≠ first view");
    // The overlay is part of the window's content.
    assert!(
        differing_pixels(reset, overlay) > n / 50,
        "no overlay drawn"
    );
    // Resized: the surface and canvas follow the window; the 480×360 image is letterboxed
    // into 640×360 (black bars of 80 pixels each side), the model drawn between them.
    assert_eq!(wide.dimensions(), (640, 360));
    let bar = |x: u32| (0..360).all(|y| wide.get_pixel(x, y).0 == [0, 0, 0, 255]);
    assert!(
        bar(0) && bar(79) && bar(560) && bar(639),
        "no letterbox bars"
    );
    assert!(!bar(80) || !bar(320));
    assert!(model_pixels(wide) > n / 20);
    // The mouse's navigation, scripted: an orbit drag, a pan drag and the wheel move the view.
    for (name, image) in [
        ("drag", dragged),
        ("right drag", panned),
        ("wheel", zoomed_out),
    ] {
        assert_eq!(image.dimensions(), (480, 360));
        assert!(
            model_pixels(image) > n / 50,
            "{name}: the model left the view"
        );
        assert!(
            differing_pixels(lit1, image) > n / 20,
            "{name} did not move the view"
        );
    }
    assert!(
        triangles(9) < triangles(0),
        "zoomed out: {} triangles, not fewer than {}",
        triangles(9),
        triangles(0)
    );
    assert!(
        started.elapsed().as_secs() < 120,
        "the script took {:?}",
        started.elapsed()
    );
}

/// The mapped top-level window of `size` on the X server `display`, as it shows it (RGBA);
/// then, if `close`, asks it to close as a window manager would (WM_DELETE_WINDOW).
fn grab_window(display: &str, size: (u16, u16), close: bool) -> image::RgbaImage {
    use x11rb::connection::Connection;
    use x11rb::protocol::xproto::{
        ClientMessageEvent, ConnectionExt, EventMask, ImageFormat, MapState,
    };
    let (conn, screen) = x11rb::connect(Some(display)).expect("connect to Xvfb");
    let root = conn.setup().roots[screen].root;
    let windows: Vec<u32> = conn
        .query_tree(root)
        .unwrap()
        .reply()
        .unwrap()
        .children
        .into_iter()
        .filter(|&w| {
            let mapped = conn
                .get_window_attributes(w)
                .unwrap()
                .reply()
                .unwrap()
                .map_state
                == MapState::VIEWABLE;
            let g = conn.get_geometry(w).unwrap().reply().unwrap();
            mapped && (g.width, g.height) == size
        })
        .collect();
    assert_eq!(windows.len(), 1, "one mapped {size:?} window");
    let reply = conn
        .get_image(ImageFormat::Z_PIXMAP, windows[0], 0, 0, size.0, size.1, !0)
        .unwrap()
        .reply()
        .unwrap();
    if close {
        let atom = |name: &[u8]| conn.intern_atom(false, name).unwrap().reply().unwrap().atom;
        let (protocols, delete) = (atom(b"WM_PROTOCOLS"), atom(b"WM_DELETE_WINDOW"));
        let event = ClientMessageEvent::new(32, windows[0], protocols, [delete, 0, 0, 0, 0]);
        // Checked: a round trip, the server has sent it on.
        conn.send_event(false, windows[0], EventMask::NO_EVENT, event)
            .unwrap()
            .check()
            .unwrap();
    }
    let (w, h) = (size.0 as u32, size.1 as u32);
    assert_eq!(reply.depth, 24);
    assert_eq!(reply.data.len(), (4 * w * h) as usize, "32 bits a pixel");
    // Depth 24 in 32 bits, least significant byte first: B, G, R, unused.
    let rgba = reply
        .data
        .chunks_exact(4)
        .flat_map(|p| [p[2], p[1], p[0], 255])
        .collect();
    image::RgbaImage::from_raw(w, h, rgba).unwrap()
}

/// On Vulkan (lavapipe) and GL (llvmpipe through EGL): `.ci/run` installs both.
#[test]
fn the_x_display_shows_what_the_viewer_captures() {
    if !xvfb_run() {
        eprintln!("skipped: xvfb-run is not installed (Debian package `xvfb`)");
        return;
    }
    for backend in ["vulkan", "gl"] {
        x_display_matches_the_capture(backend);
    }
}

fn x_display_matches_the_capture(backend: &str) {
    let _xvfb = XVFB.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let repo = bunny_repository(dir.path());
    let (shot, info) = (dir.path().join("still.png"), dir.path().join("display"));
    // The screenshot, then frames of the same still view while the test reads the window and
    // closes it (the window manager's close: WM_DELETE_WINDOW).
    let script = format!(
        "{{\"overlay\":false}}\n{{\"screenshot\":{:?}}}\n{{\"wait_frames\":1000000}}\n",
        shot.to_str().unwrap()
    );
    let script_path = dir.path().join("still.jsonl");
    let stderr_path = dir.path().join("stderr.txt");
    std::fs::write(&script_path, script).unwrap();
    let child = Command::new("xvfb-run")
        .args(["-a", "-s", XVFB_ARGS, "sh", "-c"])
        .arg(r#"printf '%s\n%s\n%s\n' "$DISPLAY" "$XAUTHORITY" "$$" > "$0.part" && mv "$0.part" "$0" && exec "$@""#)
        .arg(&info)
        .arg(env!("CARGO_BIN_EXE_tessera"))
        .args(["view", repo.to_str().unwrap(), "--size", "400x300", "--backend", backend])
        .arg("--script")
        .arg(&script_path)
        .stdout(std::process::Stdio::piped())
        .stderr(std::fs::File::create(&stderr_path).unwrap())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !shot.exists() && started.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(5));
    }
    let grabbed = shot.exists().then(|| {
        let text = std::fs::read_to_string(&info).unwrap();
        let mut lines = text.lines();
        let (display, auth) = (lines.next().unwrap(), lines.next().unwrap_or(""));
        std::env::set_var("XAUTHORITY", auth);
        grab_window(display, (400, 300), true)
    });
    let mut child = child;
    let closing = Instant::now();
    let mut sent = 1;
    while child.try_wait().unwrap().is_none() {
        if closing.elapsed() > Duration::from_secs(sent) && grabbed.is_some() {
            // Not closed yet: ask again (and count it: once should do).
            sent += 1;
            eprintln!("{backend}: close sent again");
            let text = std::fs::read_to_string(&info).unwrap();
            let _ = grab_window(text.lines().next().unwrap(), (400, 300), true);
        }
        if closing.elapsed() > Duration::from_secs(60) {
            // The viewer (the shell's pid: it exec'd), then xvfb-run.
            let text = std::fs::read_to_string(&info).unwrap_or_default();
            if let Some(pid) = text.lines().nth(2) {
                let _ = Command::new("kill").arg(pid).status();
            }
            child.kill().unwrap();
            panic!(
                "{backend}: the viewer did not exit after its window was closed\n{}",
                std::fs::read_to_string(&stderr_path).unwrap_or_default()
            );
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let out = child.wait_with_output().unwrap();
    let stderr = std::fs::read_to_string(&stderr_path).unwrap();
    eprintln!("{stderr}");
    let grabbed = grabbed.expect("the viewer wrote its screenshot");
    // Closed mid-script: a clean exit 2 saying so (never a crash).
    assert_eq!(out.status.code(), Some(2), "{backend}: {stderr}");
    assert!(
        stderr.contains("the window was closed before the script ended"),
        "{stderr}"
    );
    let captured = image::open(&shot).unwrap().to_rgba8();
    assert!(model_pixels(&captured) > 400 * 300 / 20, "{backend}");
    let off = grabbed
        .pixels()
        .zip(captured.pixels())
        .filter(|(p, q)| (0..3).any(|c| p.0[c].abs_diff(q.0[c]) > 1))
        .count();
    assert_eq!(
        off, 0,
        "pixels of the X display unlike the viewer's capture"
    );
}

#[test]
fn view_without_a_display_exits_2_saying_so() {
    let dir = tempfile::tempdir().unwrap();
    let out = tessera()
        .args(["view", dir.path().join("missing.tsr").to_str().unwrap()])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("no display") && stderr.contains("DISPLAY"),
        "{stderr}"
    );
}

#[test]
fn view_names_a_bad_script_line_and_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("bad.jsonl");
    std::fs::write(&script, "{\"tolerance\":2}\n{\"soar\":true}\n").unwrap();
    let out = tessera()
        .args(["view", "any.tsr", "--script", script.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("line 2") && stderr.contains("unknown action \"soar\""),
        "{stderr}"
    );
}

/// `demo --view` opens the demo model in the viewer once the demo is done (here a small demo
/// and a script that takes one screenshot), and without a display says so before the demo's
/// long part (exit 2 at once).
#[test]
fn demo_view_opens_the_demo_model_in_the_viewer() {
    let dir = tempfile::tempdir().unwrap();
    let started = Instant::now();
    let out = tessera()
        .args(["demo", "--view", "--no-frames"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("no display"), "{stderr}");
    assert!(
        started.elapsed() < Duration::from_secs(10),
        "not said up front"
    );
    if !xvfb_run() {
        eprintln!("skipped the window part: xvfb-run is not installed (apt-get install xvfb)");
        return;
    }
    let _one = XVFB.lock().unwrap_or_else(|e| e.into_inner());
    let shot = dir.path().join("demo.png");
    let script = dir.path().join("s.jsonl");
    std::fs::write(
        &script,
        format!(r#"{{"screenshot":"{}"}}"#, shot.to_str().unwrap()),
    )
    .unwrap();
    let out = Command::new("timeout")
        .args(["-k", "10", "300", "xvfb-run", "-a", "-s", XVFB_ARGS])
        .arg(env!("CARGO_BIN_EXE_tessera"))
        .args([
            "demo",
            "--subdivisions",
            "4",
            "--views",
            "4",
            "--no-frames",
            "--backend",
            "vulkan",
            "--view",
            "--view-script",
            script.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    ok(&out);
    let image = image::open(&shot).unwrap().to_rgba8();
    assert!(
        model_pixels(&image) > 1000,
        "{} model pixels",
        model_pixels(&image)
    );
}

/// A mesh given instead of a repository: exit 2, naming the `build` command to run (before
/// any display is needed).
#[test]
fn view_given_a_mesh_names_the_build_command() {
    let bunny = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/bunny00.off");
    let out = tessera()
        .args(["view", bunny.to_str().unwrap()])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("not a tessera repository") && stderr.contains("tessera build"),
        "{stderr}"
    );
}
