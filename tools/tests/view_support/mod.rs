//! What the viewer's tests share: the binary, Xvfb, a repository of the bunny, pixel counts.
#![allow(dead_code)] // each test file uses its own part

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;

/// Xvfb's arguments: `-noreset`, or the server resets when its last client leaves and
/// signals xvfb-run, which can make xvfb-run's own clean-up fail (exit 5).
pub const XVFB_ARGS: &str = "-screen 0 1024x768x24 -noreset";

/// One Xvfb at a time: parallel `xvfb-run -a` may pick the same display number.
pub static XVFB: Mutex<()> = Mutex::new(());

pub fn tessera() -> Command {
    Command::new(env!("CARGO_BIN_EXE_tessera"))
}

pub fn ok(out: &Output) {
    assert!(
        out.status.success(),
        "status {:?}\nstdout {}\nstderr {}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

pub fn bunny_repository(dir: &Path) -> PathBuf {
    let bunny = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/bunny00.off");
    let repo = dir.join("bunny.tsr");
    ok(&tessera()
        .args([
            "build",
            bunny.to_str().unwrap(),
            "-o",
            repo.to_str().unwrap(),
        ])
        .output()
        .unwrap());
    repo
}

/// Whether `xvfb-run` is on the PATH.
pub fn xvfb_run() -> bool {
    Command::new("sh")
        .args(["-c", "command -v xvfb-run"])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Pixels that are neither the renderer's background nor the letterbox's black.
pub fn model_pixels(image: &image::RgbaImage) -> usize {
    image
        .pixels()
        .filter(|p| {
            let [r, g, b, _] = p.0;
            let background =
                (r.abs_diff(28) <= 2) && (g.abs_diff(31) <= 2) && (b.abs_diff(38) <= 2);
            !background && (r, g, b) != (0, 0, 0)
        })
        .count()
}

pub fn differing_pixels(a: &image::RgbaImage, b: &image::RgbaImage) -> usize {
    assert_eq!(a.dimensions(), b.dimensions());
    a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count()
}
