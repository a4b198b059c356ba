//! What a new user meets in the first minutes, on a machine without a desktop: headless
//! commands print nothing on stderr that is not tessera's (no window-system probe's "error:"
//! line), and a mesh given where a repository is expected is answered with the `build`
//! command to run.

use std::path::Path;
use std::process::{Command, Output};

/// Runs `tessera` as on a machine with no desktop: no display, no runtime directory.
fn headless(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(args)
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("NODEVICE_SELECT")
        .env_remove("MESA_VK_DEVICE_SELECT")
        .output()
        .expect("run tessera")
}

fn build_small_mesh(dir: &Path) -> (String, String) {
    let mesh = dir.join("mesh.ply");
    let repo = dir.join("mesh.tsr");
    let (mesh, repo) = (mesh.to_str().unwrap(), repo.to_str().unwrap());
    let out = headless(&["gen", "mesh", "--triangles", "20000", "-o", mesh]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = headless(&["build", mesh, "-o", repo]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    (mesh.to_string(), repo.to_string())
}

#[test]
fn headless_gpu_commands_print_nothing_but_their_own_lines_on_stderr() {
    let dir = tempfile::tempdir().unwrap();
    let (mesh, repo) = build_small_mesh(dir.path());
    let png = dir.path().join("frame.png");
    let png = png.to_str().unwrap();
    let runs: [&[&str]; 4] = [
        &["render", &repo, "-o", png, "--size", "160x90"],
        &["render", &repo, "-o", png, "--size", "160x90", "--json"],
        &[
            "check",
            &repo,
            "--gpu",
            "--views",
            "2",
            "--tolerances",
            "1,4",
        ],
        &[
            "bench",
            &repo,
            "--source",
            &mesh,
            "--views",
            "1",
            "--error-views",
            "1",
            "--tolerances",
            "2",
            "--frames",
            "1",
            "--samples",
            "2000",
            "--size",
            "160x90",
        ],
    ];
    for args in runs {
        let out = headless(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success(),
            "tessera {}: exit {:?}\n{stderr}",
            args.join(" "),
            out.status.code()
        );
        // These commands print their results on stdout; on stderr they write only progress
        // bars (drawn on a terminal only) and errors. So anything at all is someone else's.
        assert!(
            stderr.trim().is_empty(),
            "tessera {} printed on stderr:\n{stderr}",
            args.join(" ")
        );
    }
}

#[test]
fn every_command_that_takes_a_repository_names_the_build_for_a_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let (mesh, repo) = build_small_mesh(dir.path());
    // The same mesh under a name that says nothing: recognised by its content.
    let unnamed = dir.path().join("scan-0042");
    std::fs::copy(&mesh, &unnamed).unwrap();
    let unnamed = unnamed.to_str().unwrap();
    let out_png = dir.path().join("x.png");
    let out_tsr = dir.path().join("x.tsr");
    let (out_png, out_tsr) = (out_png.to_str().unwrap(), out_tsr.to_str().unwrap());
    for input in [mesh.as_str(), unnamed] {
        let runs: Vec<Vec<&str>> = vec![
            vec!["info", input],
            vec!["repack", input, "-o", out_tsr],
            vec!["render", input, "-o", out_png],
            vec!["check", input],
            vec!["bench", input, "--source", &mesh],
            vec!["bench", "render", input],
            vec!["bench", "stream", input],
            vec!["bench", "errors", input],
            vec!["bench", "breakdown", input, "--source", &mesh],
            vec!["view", input],
        ];
        for args in runs {
            let out = headless(&args);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(
                out.status.code(),
                Some(2),
                "tessera {}: {stderr}",
                args.join(" ")
            );
            assert!(
                stderr.contains("not a tessera repository")
                    && stderr.contains(&format!("`tessera build {input} -o ")),
                "tessera {} does not name the build to run:\n{stderr}",
                args.join(" ")
            );
            assert!(
                !Path::new(out_tsr).exists() && !Path::new(out_png).exists(),
                "tessera {} left an output behind",
                args.join(" ")
            );
        }
    }
    // A real repository still opens, whatever it is named.
    let renamed = dir.path().join("model.ply");
    std::fs::copy(&repo, &renamed).unwrap();
    let out = headless(&["info", renamed.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn an_interrupted_budgeted_build_says_how_to_resume_and_leaves_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("big.ply");
    let repo = dir.path().join("big.tsr");
    let out = headless(&[
        "gen",
        "mesh",
        "--triangles",
        "1000000",
        "-o",
        mesh.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let child = Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args([
            "build",
            mesh.to_str().unwrap(),
            "-o",
            repo.to_str().unwrap(),
        ])
        .args(["--memory", "32M"])
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Interrupted once its checkpoint exists (the build takes seconds past that point).
    let checkpoint = dir.path().join(".big.tsr.tessera-build");
    let start = std::time::Instant::now();
    while !checkpoint.exists() && start.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    assert!(checkpoint.exists(), "no checkpoint appeared");
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(
        stderr.contains("interrupted") && stderr.contains("--resume"),
        "{stderr}"
    );
    assert!(!repo.exists(), "an interrupted build wrote its output");
    assert!(checkpoint.exists(), "the checkpoint it names is gone");
}

#[test]
fn output_into_a_closed_pipe_ends_quietly() {
    use std::os::unix::process::ExitStatusExt;
    let dir = tempfile::tempdir().unwrap();
    let (_, repo) = build_small_mesh(dir.path());
    // `tessera info REPO | head -0`: the reader is gone before the first line is written.
    let mut fds = [0; 2];
    assert_eq!(unsafe { libc::pipe(fds.as_mut_ptr()) }, 0);
    unsafe { libc::close(fds[0]) };
    let stdout = unsafe { <std::process::Stdio as std::os::fd::FromRawFd>::from_raw_fd(fds[1]) };
    let out = Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(["info", &repo])
        .stdout(stdout)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.signal(),
        Some(libc::SIGPIPE),
        "{:?}: {stderr}",
        out.status
    );
    assert!(stderr.is_empty(), "{stderr}");
}
