//! `render --two-sided`: both sides of an open scan are drawn (and the default draws only
//! front faces, as its normal cones cull).

mod cli_support;
use cli_support::tessera;

use std::path::Path;

#[test]
fn two_sided_draws_the_back_of_an_open_scan() {
    let scan = Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/mesh/lion-head.off");
    assert!(scan.exists(), "run tools/fetch-testdata.sh first");
    let dir = tempfile::tempdir().unwrap();
    let repo = dir.path().join("lion.tsr");
    assert!(tessera(&[
        "build",
        scan.to_str().unwrap(),
        "-o",
        repo.to_str().unwrap()
    ])
    .status
    .success());
    let mut covered = Vec::new();
    for (name, extra) in [("one", None), ("two", Some("--two-sided"))] {
        let png = dir.path().join(format!("{name}.png"));
        let mut args = vec![
            "render",
            repo.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--size",
            "320x180",
        ];
        args.extend(extra);
        let out = tessera(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let image = image::open(&png).unwrap().to_rgba8();
        let background = *image.get_pixel(0, 0);
        covered.push(image.pixels().filter(|p| **p != background).count());
    }
    // The default orbit sees the scan's open side too: two-sided covers strictly more.
    assert!(
        covered[1] > covered[0],
        "model pixels: one-sided {}, two-sided {}",
        covered[0],
        covered[1]
    );
}
