//! Camera paths as files: keyframes (eye, target) flown with `frames_between` frames from one
//! to the next (linear), then the last camera held `pause_frames` frames. `bench stream
//! --path` flies them; `tessera view` records them (`K`), plays them (`{"play": ..}`) and
//! keeps its bookmarks in this format (so `bench stream` can fly the bookmarks).

use std::path::Path;

use anyhow::{bail, Context};
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraPath {
    pub keyframes: Vec<Keyframe>,
    #[serde(default = "default_between")]
    pub frames_between: usize,
    #[serde(default)]
    pub pause_frames: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Keyframe {
    pub eye: [f64; 3],
    pub target: [f64; 3],
}

fn default_between() -> usize {
    30
}

impl CameraPath {
    /// Reads and checks a path file: at least one keyframe, `frames_between` ≥ 1, finite
    /// positions, no eye on its target.
    pub fn load(file: &Path) -> anyhow::Result<CameraPath> {
        let text = std::fs::read_to_string(file)
            .with_context(|| format!("cannot read the camera path {}", file.display()))?;
        let path: CameraPath = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a camera path", file.display()))?;
        path.check()
            .with_context(|| format!("camera path {}", file.display()))?;
        Ok(path)
    }

    /// The checks of `load`.
    fn check(&self) -> anyhow::Result<()> {
        if self.keyframes.is_empty() || self.frames_between == 0 {
            bail!("needs at least one keyframe and frames_between ≥ 1");
        }
        let bad = |k: &Keyframe| {
            !(k.eye.iter().chain(&k.target).all(|x| x.is_finite())) || k.eye == k.target
        };
        if let Some(i) = self.keyframes.iter().position(bad) {
            bail!("keyframe {i} has a non-finite position or its eye on its target");
        }
        Ok(())
    }

    /// Every frame's (eye, target), keyframes included, the pause at the end.
    pub fn frames(&self) -> Vec<Keyframe> {
        let Some(&first) = self.keyframes.first() else {
            return Vec::new();
        };
        let mut out = vec![first];
        for pair in self.keyframes.windows(2) {
            for k in 1..=self.frames_between {
                let s = k as f64 / self.frames_between as f64;
                let lerp = |a: [f64; 3], b: [f64; 3]| [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * s);
                out.push(Keyframe {
                    eye: lerp(pair[0].eye, pair[1].eye),
                    target: lerp(pair[0].target, pair[1].target),
                });
            }
        }
        let last = *out.last().expect("one keyframe");
        out.extend(std::iter::repeat_n(last, self.pause_frames));
        out
    }

    /// Writes the path as JSON (a temporary file renamed over `file` when complete).
    pub fn save(&self, file: &Path) -> anyhow::Result<()> {
        let text = serde_json::to_string_pretty(self)?;
        crate::output::write_bytes(text.as_bytes(), file)
            .with_context(|| format!("cannot write the camera path {}", file.display()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_interpolate_and_pause_and_a_saved_path_loads_back() {
        let path = CameraPath {
            keyframes: vec![
                Keyframe {
                    eye: [0.0, 0.0, 1.0],
                    target: [0.0; 3],
                },
                Keyframe {
                    eye: [2.0, 0.0, 1.0],
                    target: [1.0, 0.0, 0.0],
                },
            ],
            frames_between: 4,
            pause_frames: 2,
        };
        let f = path.frames();
        assert_eq!(f.len(), 1 + 4 + 2);
        assert_eq!(f[2].eye, [1.0, 0.0, 1.0]);
        assert_eq!(f[6], path.keyframes[1]);
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("p.json");
        path.save(&file).unwrap();
        assert_eq!(CameraPath::load(&file).unwrap(), path);
        std::fs::write(&file, r#"{"keyframes":[]}"#).unwrap();
        let e = format!("{:#}", CameraPath::load(&file).unwrap_err());
        assert!(e.contains("at least one keyframe"), "{e}");
    }
}
