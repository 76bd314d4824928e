//! The `nes` binary as a user runs it: exit codes, messages, files.

use std::process::Command;

fn nes() -> Command {
    Command::new(env!("CARGO_BIN_EXE_nes"))
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("nes-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn render_writes_a_png_of_the_requested_size() {
    let dir = temp_dir("render");
    let out = dir.join("hello.png");
    let status = nes()
        .args(["render", "examples/hello.nes", "--width", "40", "-q", "-o"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let img = image::open(&out).unwrap();
    // The scene is 640 x 400: the height follows the aspect ratio.
    assert_eq!((img.width(), img.height()), (40, 25));
    // No temporary file is left beside it.
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(leftovers.len(), 1, "{leftovers:?}");
}

#[test]
fn check_reports_diagnostics_and_fails() {
    let dir = temp_dir("check");
    let scene = dir.join("broken.nes");
    std::fs::write(
        &scene,
        "camera { position (1, 0, 0) fov 400 }\nobject sphre(1)\n",
    )
    .unwrap();
    let out = nes()
        .arg("check")
        .arg(&scene)
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("E0301") && err.contains("E0101"), "{err}");
    assert!(err.contains("did you mean `sphere`?"), "{err}");
    assert!(err.contains("2 errors"), "{err}");
}

#[test]
fn check_accepts_a_good_scene() {
    let out = nes().args(["check", "examples/seed.nes"]).output().unwrap();
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("ok (4 objects, 1 light)"));
}

#[test]
fn a_missing_scene_file_is_reported() {
    let out = nes()
        .args(["check", "no/such/file.nes"])
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("E0401") && err.contains("no/such/file.nes"),
        "{err}"
    );
}

#[test]
fn an_unwritable_output_is_reported_and_nothing_is_left_behind() {
    let out = nes()
        .args([
            "render",
            "examples/hello.nes",
            "--width",
            "8",
            "-o",
            "/nonexistent-dir/x.png",
        ])
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("E0402") && err.contains("/nonexistent-dir/x.png"),
        "{err}"
    );
}

#[test]
fn bad_command_line_values_are_reported() {
    for args in [
        vec!["render", "examples/hello.nes", "--width", "0"],
        vec!["render", "examples/hello.nes", "--method", "magic"],
        vec!["render", "examples/hello.nes", "--samples", "0"],
        // watch checks the same values before it starts, and its own.
        vec!["watch", "examples/hello.nes", "--width", "0"],
        vec!["watch", "examples/hello.nes", "--method", "magic"],
        vec!["watch", "examples/hello.nes", "--serve", "not-an-address"],
        vec!["watch", "/no/such/folder/scene.nes"],
        vec!["explain", "examples/hello.nes", "--method", "magic"],
        vec!["render", "examples/torus.nes", "--method", "ode"],
        vec![
            "probe",
            "examples/seed.nes",
            "--pixel",
            "1,1",
            "--method",
            "ode",
        ],
        vec!["rays", "examples/seed.nes", "--method", "ode"],
        vec!["explain", "examples/torus.nes", "--method", "ode"],
    ] {
        let out = nes().args(&args).env("NO_COLOR", "1").output().unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        // A folder that cannot be watched is a failure to act, not a bad
        // value.
        let code = if args.contains(&"/no/such/folder/scene.nes") {
            "E0502"
        } else {
            "E0501"
        };
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(code), "{args:?}: {err}");
    }
}
