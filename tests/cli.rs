//! The `nes` binary as a user runs it: exit codes, messages, files.

use std::process::Command;

fn nes() -> Command {
    Command::new(env!("CARGO_BIN_EXE_nes"))
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("nes-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
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
    assert_eq!(names_in(&dir), ["hello.png"]);
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

    // A folder where the file should go: the temporary file beside it is
    // written, the rename over the folder fails, and the temporary file
    // (`.x.png.<pid>.tmp`) is removed. The folder is left as it was.
    let dir = temp_dir("unwritable");
    std::fs::create_dir_all(dir.join("x.png")).unwrap();
    let out = nes()
        .args(["render", "examples/hello.nes", "--width", "8", "-q", "-o"])
        .arg(dir.join("x.png"))
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("E0402") && err.contains("x.png"), "{err}");
    assert_eq!(names_in(&dir), ["x.png"], "something was left behind");
    assert!(dir.join("x.png").is_dir());
    assert_eq!(names_in(&dir.join("x.png")), Vec::<String>::new());
}

/// The names in a folder, sorted, hidden ones included.
fn names_in(dir: &std::path::Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn bad_command_line_values_are_reported() {
    let dir = temp_dir("bad-values");
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
        // Run from an empty folder, so that an output written under its
        // default name would show.
        let args: Vec<String> = args
            .iter()
            .map(|a| match a.strip_prefix("examples/") {
                Some(file) => format!("{}/examples/{file}", env!("CARGO_MANIFEST_DIR")),
                None => a.to_string(),
            })
            .collect();
        let out = nes()
            .args(&args)
            .current_dir(&dir)
            .env("NO_COLOR", "1")
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        // A folder that cannot be watched is a failure to act, not a bad
        // value.
        let code = if args.iter().any(|a| a.contains("/no/such/folder/scene.nes")) {
            "E0502"
        } else {
            "E0501"
        };
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(code), "{args:?}: {err}");
        assert_eq!(
            names_in(&dir),
            Vec::<String>::new(),
            "{args:?} wrote a file"
        );
    }
}
