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
    /// `{"mode": "lit"|"patches"|"levels"|"check"}`.
    Mode(Mode),
    /// `{"wait_frames": n}`: draw n frames.
    WaitFrames(u32),
    /// `{"screenshot": "PATH"}`: once the stream has settled for the current view (or after
    /// `SETTLE_FRAMES`), the window's content as PNG.
    Screenshot(PathBuf),
    /// `{"key": "r"}`: as if the key were pressed (`r` reset, `h` overlay on/off, `s` a
    /// screenshot to `tessera-view-NNN.png` in the current directory, at the next frame).
    Key(char),
    /// `{"overlay": true|false}`: show or hide the overlay.
    Overlay(bool),
    /// `{"resize": [width, height]}`: asks for this window size and waits until the window
    /// has it (an error after `RESIZE_FRAMES` frames).
    Resize(u32, u32),
    /// `{"drag":[x0,y0,x1,y1]}` (left button: orbit) or `{"right_drag":[x0,y0,x1,y1]}`
    /// (pan), window pixels: as the mouse would, in one frame (the overlay does not take it).
    Drag(Button, [f64; 4]),
    /// `{"wheel": lines}`: zoom, as the mouse wheel (positive: towards the model).
    Wheel(f64),
}

/// Keys a script may press (`Action::Key`).
pub const KEYS: &[char] = &['r', 'h', 's'];

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
        .filter(|o| o.len() == 1)
        .ok_or("expected an object with exactly one action")?;
    let (name, arg) = object.iter().next().expect("one key");
    let number = |v: &serde_json::Value| {
        v.as_f64()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{name:?} takes a finite number"))
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
                    .map_err(|_| format!("unknown mode {s:?}: lit, patches, levels or check"))?,
            )
        }
        "wait_frames" => Action::WaitFrames(
            arg.as_u64()
                .and_then(|n| u32::try_from(n).ok())
                .ok_or("\"wait_frames\" takes a count of frames")?,
        ),
        "screenshot" => {
            let p = arg.as_str().filter(|s| !s.is_empty());
            Action::Screenshot(PathBuf::from(p.ok_or("\"screenshot\" takes a path")?))
        }
        "key" => {
            let s = arg.as_str().ok_or("\"key\" takes a string")?;
            let mut chars = s.chars().map(|c| c.to_ascii_lowercase());
            match (chars.next(), chars.next()) {
                (Some(c), None) if KEYS.contains(&c) => Action::Key(c),
                _ => return Err(format!("unknown key {s:?}: the keys are {KEYS:?}")),
            }
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
                 key, overlay, resize, drag, right_drag, wheel"
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
{"overlay":false}
{"resize":[300,200]}
{"drag":[1,2,3,4]}
{"right_drag":[5,6,7,8.5]}
{"wheel":-2}
"#;
        assert_eq!(
            parse(text).unwrap(),
            vec![
                Action::Orbit([30.0, 20.0, 2.5]),
                Action::Tolerance(4.0),
                Action::Mode(Mode::Patches),
                Action::WaitFrames(3),
                Action::Screenshot("a.png".into()),
                Action::Key('r'),
                Action::Overlay(false),
                Action::Resize(300, 200),
                Action::Drag(Button::Left, [1.0, 2.0, 3.0, 4.0]),
                Action::Drag(Button::Right, [5.0, 6.0, 7.0, 8.5]),
                Action::Wheel(-2.0),
            ]
        );
    }

    #[test]
    fn a_bad_line_is_named() {
        for (text, wanted) in [
            ("{\"orbit\":[1,2]}", "line 1"),
            (
                "\n{\"mode\":\"lit\"}\n{\"fly\":1}",
                "line 3: unknown action \"fly\"",
            ),
            ("{\"tolerance\":-1}", "line 1: tolerance -1 must be"),
            ("not json", "line 1: not JSON"),
            ("{\"key\":\"q\"}", "unknown key"),
            ("{\"resize\":[0,10]}", "\"resize\" takes"),
            ("{\"mode\":\"x\",\"tolerance\":1}", "exactly one action"),
        ] {
            let e = parse(text).unwrap_err();
            assert!(e.contains(wanted), "{text:?}: {e}");
        }
    }
}
