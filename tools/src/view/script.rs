//! `tessera view --script FILE`: one JSON object a line, each one action run in the real
//! window, in order; blank lines and lines starting with `#` are skipped. The whole file is
//! parsed before the window opens: a bad line is an error naming its number (exit 2).

use std::path::{Path, PathBuf};

use super::pointer::Button;
use crate::cmd_render::Mode;

/// One scripted action.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// `{"orbit":[az_deg, el_deg, dist_radii]}`: the orbit camera around the model's centre
    /// (pan cleared), as `render --orbit`.
    Orbit([f64; 3]),
    /// `{"tolerance": px}`.
    Tolerance(f32),
    /// `{"mode": "lit"|"patches"|"levels"|"check"|"color"|"normals"}`.
    Mode(Mode),
    /// `{"wait_frames": n}`: draw n frames.
    WaitFrames(u32),
    /// `{"screenshot": "PATH"}`: once the stream has settled for the current view (or after
    /// `SETTLE_FRAMES`), the window's content as PNG.
    Screenshot(PathBuf),
    /// `{"key": "w", "frames": 30}`: as if the key were pressed and held for that many frames
    /// (default 1); `KEYS` lists the keys (docs/cli.md says what each does).
    Key(char, u32),
    /// `{"overlay": true|false}`: show or hide the overlay.
    Overlay(bool),
    /// `{"resize": [width, height]}`: asks for this window size and waits until the window
    /// has it (an error after `RESIZE_FRAMES` frames).
    Resize(u32, u32),
    /// `{"drag":[x0,y0,x1,y1]}` (left button: orbit, or look in fly mode) or
    /// `{"right_drag":[x0,y0,x1,y1]}` (pan), window pixels: as the mouse would, in one frame
    /// (the overlay does not take it).
    Drag(Button, [f64; 4]),
    /// `{"wheel": lines}`: zoom towards the pivot (positive: closer).
    Wheel(f64),
    /// `{"wheel_at": [x, y, lines]}`: the wheel with the cursor at (x, y), window pixels:
    /// zoom towards the surface under it.
    WheelAt([f64; 3]),
    /// `{"double_click": [x, y]}`: the pivot moves to the surface under (x, y).
    DoubleClick([f64; 2]),
    /// `{"target_ms": ms}`: hold this frame time (`{"target": "off"}` returns to the slider).
    TargetMs(f64),
    /// `{"budget_triangles": n}`: hold this triangle count.
    BudgetTriangles(u64),
    /// `{"target": "off"}`.
    TargetOff,
    /// `{"freeze": true|false}`: freeze the cut (or let it follow the camera again).
    Freeze(bool),
    /// `{"fly": true|false}`.
    Fly(bool),
    /// `{"wireframe": true|false}`.
    Wireframe(bool),
    /// `{"flat": true|false}`: face normals in the lit and normals modes (`--flat`).
    Flat(bool),
    /// `{"culling": {"frustum": bool, "cones": bool}}` (a missing key keeps its setting).
    Culling(Option<bool>, Option<bool>),
    /// `{"export": "PATH"}`: the current cut (all of the model at the view's resolution) as
    /// a binary PLY.
    Export(PathBuf),
    /// `{"play": "PATH"}`: fly a camera path (`bench stream --path`'s format) frame by frame.
    Play(PathBuf),
    /// `{"gpu_budget": mib}`: the streaming renderer remade under this budget (as the
    /// overlay's "apply"; a budget too small ends the script with the error).
    GpuBudget(f64),
    /// `{"open": "PATH"}`: open another repository, as dropping it on the window does (a file
    /// that is not one ends the script with the error).
    Open(PathBuf),
}

/// Keys a script may press (`Action::Key`): reset, overlay, screenshot, fly, freeze, export,
/// bookmark, record path, the bookmarks 1-9 and the moves.
pub const KEYS: &[char] = &[
    'r', 'h', 'p', 'f', 'c', 'x', 'b', 'k', '1', '2', '3', '4', '5', '6', '7', '8', '9', 'w', 'a',
    's', 'd', 'q', 'e',
];

/// Reads and parses a script file.
pub fn load(path: &Path) -> anyhow::Result<Vec<Action>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| anyhow::anyhow!("cannot read the script {}: {e}", path.display()))?;
    parse(&text).map_err(|e| anyhow::anyhow!("script {}: {e}", path.display()))
}

/// Parses a script's text; the error names the line.
pub fn parse(text: &str) -> Result<Vec<Action>, String> {
    let mut actions = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        actions.push(parse_line(line).map_err(|e| format!("line {}: {e}: {line}", i + 1))?);
    }
    Ok(actions)
}

fn parse_line(line: &str) -> Result<Action, String> {
    let value: serde_json::Value =
        serde_json::from_str(line).map_err(|e| format!("not JSON ({e})"))?;
    let object = value
        .as_object()
        .filter(|o| {
            o.len() == 1 || (o.len() == 2 && o.contains_key("key") && o.contains_key("frames"))
        })
        .ok_or("expected an object with exactly one action")?;
    let (name, arg) = object
        .iter()
        .find(|(k, _)| k.as_str() != "frames")
        .ok_or("expected an object with exactly one action")?;
    let number = |v: &serde_json::Value| {
        v.as_f64()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{name:?} takes a finite number"))
    };
    let flag = |v: &serde_json::Value| v.as_bool().ok_or(format!("{name:?} takes true or false"));
    let path = |v: &serde_json::Value| {
        v.as_str()
            .filter(|s| !s.is_empty())
            .map(PathBuf::from)
            .ok_or(format!("{name:?} takes a path"))
    };
    let point = |v: &serde_json::Value, n: usize, what: &str| -> Result<Vec<f64>, String> {
        let a = v
            .as_array()
            .filter(|a| a.len() == n)
            .ok_or_else(|| format!("{name:?} takes {what}"))?;
        a.iter().map(number).collect()
    };
    Ok(match name.as_str() {
        "orbit" => {
            let a = arg
                .as_array()
                .filter(|a| a.len() == 3)
                .ok_or("\"orbit\" takes [azimuth_deg, elevation_deg, distance_radii]")?;
            let v = [number(&a[0])?, number(&a[1])?, number(&a[2])?];
            if v[2] <= 0.0 {
                return Err(format!("orbit distance {} must be positive", v[2]));
            }
            Action::Orbit(v)
        }
        "tolerance" => {
            let t = number(arg)?;
            if t < 0.0 {
                return Err(format!("tolerance {t} must be ≥ 0"));
            }
            Action::Tolerance(t as f32)
        }
        "mode" => {
            let s = arg.as_str().ok_or("\"mode\" takes a string")?;
            Action::Mode(
                <Mode as clap::ValueEnum>::from_str(s, true)
                    .map_err(|_| format!("unknown mode {s:?}: lit, patches, levels, check, color or normals"))?,
            )
        }
        "wait_frames" => Action::WaitFrames(
            arg.as_u64()
                .and_then(|n| u32::try_from(n).ok())
                .ok_or("\"wait_frames\" takes a count of frames")?,
        ),
        "screenshot" => Action::Screenshot(path(arg)?),
        "key" => {
            let s = arg.as_str().ok_or("\"key\" takes a string")?;
            let mut chars = s.chars().map(|c| c.to_ascii_lowercase());
            let frames = match object.get("frames") {
                None => 1,
                Some(f) => f
                    .as_u64()
                    .and_then(|n| u32::try_from(n).ok())
                    .filter(|&n| n >= 1)
                    .ok_or("\"frames\" takes a count of frames ≥ 1")?,
            };
            match (chars.next(), chars.next()) {
                (Some(c), None) if KEYS.contains(&c) => Action::Key(c, frames),
                _ => return Err(format!("unknown key {s:?}: the keys are {KEYS:?}")),
            }
        }
        "wheel_at" => {
            let v = point(arg, 3, "[x, y, lines]")?;
            Action::WheelAt([v[0], v[1], v[2]])
        }
        "double_click" => {
            let v = point(arg, 2, "[x, y]")?;
            Action::DoubleClick([v[0], v[1]])
        }
        "target_ms" => {
            let ms = number(arg)?;
            if ms <= 0.0 {
                return Err(format!("target_ms {ms} must be positive"));
            }
            Action::TargetMs(ms)
        }
        "budget_triangles" => Action::BudgetTriangles(
            arg.as_u64()
                .filter(|&n| n >= 1)
                .ok_or("\"budget_triangles\" takes a count ≥ 1")?,
        ),
        "target" if arg.as_str() == Some("off") => Action::TargetOff,
        "target" => return Err("\"target\" takes \"off\"".into()),
        "freeze" => Action::Freeze(flag(arg)?),
        "fly" => Action::Fly(flag(arg)?),
        "wireframe" => Action::Wireframe(flag(arg)?),
        "flat" => Action::Flat(flag(arg)?),
        "culling" => {
            let o = arg
                .as_object()
                .filter(|o| o.keys().all(|k| k == "frustum" || k == "cones"))
                .ok_or("\"culling\" takes {\"frustum\": bool, \"cones\": bool}")?;
            let get = |k: &str| o.get(k).map(flag).transpose();
            Action::Culling(get("frustum")?, get("cones")?)
        }
        "export" => Action::Export(path(arg)?),
        "play" => Action::Play(path(arg)?),
        "open" => Action::Open(path(arg)?),
        "gpu_budget" => {
            let mib = number(arg)?;
            if mib <= 0.0 {
                return Err(format!("gpu_budget {mib} must be positive (MiB)"));
            }
            Action::GpuBudget(mib)
        }
        "overlay" => Action::Overlay(arg.as_bool().ok_or("\"overlay\" takes true or false")?),
        "drag" | "right_drag" => {
            let a = arg
                .as_array()
                .filter(|a| a.len() == 4)
                .ok_or_else(|| format!("{name:?} takes [x0, y0, x1, y1]"))?;
            let line = [
                number(&a[0])?,
                number(&a[1])?,
                number(&a[2])?,
                number(&a[3])?,
            ];
            let button = if name == "drag" {
                Button::Left
            } else {
                Button::Right
            };
            Action::Drag(button, line)
        }
        "wheel" => Action::Wheel(number(arg)?),
        "resize" => {
            let size = arg
                .as_array()
                .filter(|a| a.len() == 2)
                .and_then(|a| {
                    let side = |v: &serde_json::Value| {
                        v.as_u64()
                            .filter(|&n| (1..=16384).contains(&n))
                            .map(|n| n as u32)
                    };
                    Some((side(&a[0])?, side(&a[1])?))
                })
                .ok_or("\"resize\" takes [width, height], 1 to 16384 pixels")?;
            Action::Resize(size.0, size.1)
        }
        other => {
            return Err(format!(
                "unknown action {other:?}: orbit, tolerance, mode, wait_frames, screenshot, \
                 key, overlay, resize, drag, right_drag, wheel, wheel_at, double_click, \
                 target_ms, budget_triangles, target, freeze, fly, wireframe, flat, culling, export, \
                 play, open, gpu_budget"
            ))
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_action() {
        let text = r#"
# a comment
{"orbit":[30,20,2.5]}
{"tolerance":4}
{"mode":"patches"}
{"wait_frames":3}
{"screenshot":"a.png"}
{"key":"R"}
{"key":"w","frames":30}
{"overlay":false}
{"resize":[300,200]}
{"drag":[1,2,3,4]}
{"right_drag":[5,6,7,8.5]}
{"wheel":-2}
{"wheel_at":[10,20,3]}
{"double_click":[5,6]}
{"target_ms":30}
{"budget_triangles":50000}
{"target":"off"}
{"freeze":true}
{"fly":false}
{"wireframe":true}
{"culling":{"cones":false}}
{"export":"cut.ply"}
{"play":"path.json"}
{"open":"other.tsr"}
{"gpu_budget":64}
"#;
        assert_eq!(
            parse(text).unwrap(),
            vec![
                Action::Orbit([30.0, 20.0, 2.5]),
                Action::Tolerance(4.0),
                Action::Mode(Mode::Patches),
                Action::WaitFrames(3),
                Action::Screenshot("a.png".into()),
                Action::Key('r', 1),
                Action::Key('w', 30),
                Action::Overlay(false),
                Action::Resize(300, 200),
                Action::Drag(Button::Left, [1.0, 2.0, 3.0, 4.0]),
                Action::Drag(Button::Right, [5.0, 6.0, 7.0, 8.5]),
                Action::Wheel(-2.0),
                Action::WheelAt([10.0, 20.0, 3.0]),
                Action::DoubleClick([5.0, 6.0]),
                Action::TargetMs(30.0),
                Action::BudgetTriangles(50_000),
                Action::TargetOff,
                Action::Freeze(true),
                Action::Fly(false),
                Action::Wireframe(true),
                Action::Culling(None, Some(false)),
                Action::Export("cut.ply".into()),
                Action::Play("path.json".into()),
                Action::Open("other.tsr".into()),
                Action::GpuBudget(64.0),
            ]
        );
    }

    #[test]
    fn a_bad_line_is_named() {
        for (text, wanted) in [
            ("{\"orbit\":[1,2]}", "line 1"),
            (
                "\n{\"mode\":\"lit\"}\n{\"soar\":1}",
                "line 3: unknown action \"soar\"",
            ),
            ("{\"tolerance\":-1}", "line 1: tolerance -1 must be"),
            ("not json", "line 1: not JSON"),
            ("{\"key\":\"z\"}", "unknown key"),
            ("{\"key\":\"w\",\"frames\":0}", "\"frames\" takes"),
            ("{\"budget_triangles\":0}", "takes a count"),
            ("{\"culling\":{\"near\":true}}", "\"culling\" takes"),
            ("{\"resize\":[0,10]}", "\"resize\" takes"),
            ("{\"mode\":\"x\",\"tolerance\":1}", "exactly one action"),
        ] {
            let e = parse(text).unwrap_err();
            assert!(e.contains(wanted), "{text:?}: {e}");
        }
    }
}
