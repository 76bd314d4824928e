//! The `nes` binary as a user runs it: exit codes, messages, files.

use std::ffi::OsStr;
use std::process::Command;

mod common;
use common::Scratch;

fn nes() -> Command {
    Command::new(env!("CARGO_BIN_EXE_nes"))
}

fn temp_dir(name: &str) -> Scratch {
    Scratch::new(&format!("cli-{name}"))
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
fn warnings_are_shown_and_denied_on_request() {
    let dir = temp_dir("warnings");
    let scene = dir.join("radians.nes");
    std::fs::write(
        &scene,
        "camera { position (-5, 0, 0) width 16 height 10 }\nobject cube(1) rotate 0.7854 about z\n",
    )
    .unwrap();
    let out_png = dir.join("radians.png");
    let out = nes()
        .arg("render")
        .arg(&scene)
        .arg("-q")
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("W0001") && err.contains("`rotate 45`"),
        "{err}"
    );
    assert!(out_png.exists());
    let checked = nes().arg("check").arg(&scene).output().unwrap();
    let said = String::from_utf8_lossy(&checked.stdout);
    assert!(
        said.contains("ok (1 object, 0 lights, 1 warning)"),
        "{said}"
    );
    std::fs::remove_file(&out_png).unwrap();
    let out = nes()
        .args(["render", "--deny-warnings", "-q"])
        .arg(&scene)
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("1 warning, denied by --deny-warnings"),
        "{err}"
    );
    assert!(
        !out_png.exists(),
        "a denied warning must stop the render before it writes"
    );
}

/// Pixels that cannot be trusted are a warning after the render; with
/// `--deny-warnings` the command fails, the whole image written.
#[test]
fn untrusted_pixels_are_denied_on_request() {
    let dir = temp_dir("pixel-warnings");
    let scene = dir.join("steps.nes");
    std::fs::write(
        &scene,
        "camera { position (0, -6, 2) look_at (0, 0, 0) width 40 height 25 }\n\
         render { max_steps 2 }\nobject sphere(1) + 0.2 * sin(9 * x)\n",
    )
    .unwrap();
    let png = dir.join("steps.png");
    let run = |deny: bool| {
        let mut cmd = nes();
        if deny {
            cmd.arg("--deny-warnings");
        }
        let out = cmd
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(&png)
            .arg("-q")
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stderr).to_string(),
        )
    };
    let (code, err) = run(false);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains("warning[W0101]: ") && err.contains(" pixels ran out of steps (max_steps 2)"),
        "{err}"
    );
    std::fs::remove_file(&png).unwrap();
    let (code, err) = run(true);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("denied by --deny-warnings"), "{err}");
    let image = image::open(&png).expect("the image is written whole");
    assert_eq!((image.width(), image.height()), (40, 25));
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
        err.contains("E0501") && err.contains("/nonexistent-dir is not a folder that exists"),
        "{err}"
    );

    // A folder where the file should go is refused before any work, and
    // left as it was.
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
    assert!(
        err.contains("E0501") && err.contains("x.png is a folder"),
        "{err}"
    );
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
        // A negative number is a value out of range, not an unknown flag.
        vec!["render", "examples/hello.nes", "--width", "-5"],
        vec!["render", "examples/hello.nes", "--step", "-0.5"],
        vec!["accuracy", "examples/hello.nes", "--height", "-2"],
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
        // Budgets and ranges decided before any work.
        vec!["render", "examples/hello.nes", "--frames", "0..=4294967295"],
        vec![
            "render",
            "examples/hello.nes",
            "--frames",
            "0..200000",
            "-o",
            "a.gif",
        ],
        vec!["rays", "examples/hello.nes", "--width", "40", "--row", "50"],
        vec![
            "rays",
            "examples/hello.nes",
            "--width",
            "40",
            "--column",
            "40",
        ],
        vec![
            "render",
            "examples/hello.nes",
            "--width",
            "40000",
            "--space",
            "euclidean,s3",
        ],
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
        // A missing folder is named before anything is watched: the image
        // would go there too.
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("E0501"), "{args:?}: {err}");
        if args.iter().any(|a| a.contains("/no/such/folder/scene.nes")) {
            assert!(
                err.contains("/no/such/folder is not a folder that exists"),
                "{err}"
            );
        }
        assert_eq!(
            names_in(&dir),
            Vec::<String>::new(),
            "{args:?} wrote a file"
        );
    }
}

/// No output may overwrite the scene, however its path is spelled (the
/// same file by identity, a hard link included), for any command that
/// writes; the scene survives byte for byte.
#[test]
fn no_output_overwrites_the_scene_file() {
    let dir = temp_dir("own-input");
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    let scene = dir.join("s.nes");
    let text = std::fs::read("examples/hello.nes").unwrap();
    std::fs::write(&scene, &text).unwrap();
    std::fs::hard_link(&scene, dir.join("link.nes")).unwrap();
    let spellings = ["s.nes", "./s.nes", "sub/../s.nes", "link.nes"];
    for spelling in spellings {
        for args in [
            vec!["render", "s.nes", "--width", "20", "-o", spelling],
            vec![
                "render", "s.nes", "--width", "20", "--shard", "0/2", "-o", spelling,
            ],
            vec![
                "render", "s.nes", "--width", "20", "--frames", "0..2", "-o", spelling,
            ],
            vec!["rays", "s.nes", "--width", "20", "--mark", spelling],
            vec!["rays", "s.nes", "--width", "20", "-o", spelling],
        ] {
            let out = nes()
                .args(&args)
                .current_dir(&dir)
                .env("NO_COLOR", "1")
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
            assert!(err.contains("is the scene file itself"), "{args:?}: {err}");
            assert_eq!(
                std::fs::read(&scene).unwrap(),
                text,
                "{args:?} changed the scene"
            );
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Writing to a pipe or a device writes into it, and never replaces the
/// node with a file (`-o /dev/null` once turned /dev/null into a PNG). A
/// FIFO in a temporary folder stands in for the device, so that a
/// regression cannot damage the machine.
#[cfg(unix)]
#[test]
fn a_pipe_target_is_written_in_place_not_replaced() {
    use std::io::Read;
    use std::os::unix::fs::FileTypeExt;
    let dir = temp_dir("fifo-target");
    let fifo = dir.join("pipe.png");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    // A reader that does not block, opened first, so that the writer's open
    // succeeds and a regression (no writer at all) cannot hang the test.
    use std::os::unix::fs::OpenOptionsExt;
    const O_NONBLOCK: i32 = 0o4000;
    let mut reader = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(O_NONBLOCK)
        .open(&fifo)
        .unwrap();
    let out = nes()
        .args(["render", "examples/hello.nes", "--width", "20", "-q", "-o"])
        .arg(&fifo)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut bytes = Vec::new();
    let _ = reader.read_to_end(&mut bytes);
    assert!(
        bytes.starts_with(b"\x89PNG"),
        "the PNG went through the pipe"
    );
    let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
    assert!(kind.is_fifo(), "the pipe was replaced by a file");
    assert_eq!(names_in(&dir), ["pipe.png"]);
    // A folder is an error, and stays a folder.
    let out = nes()
        .args(["render", "examples/hello.nes", "--width", "20", "-q", "-o"])
        .arg(&dir)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(dir.is_dir());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A byte-order mark (Notepad's default) is accepted, and a diagnostic
/// after it points at the right column; a file that is not UTF-8 is
/// reported with the line and column of its first bad byte.
#[test]
fn byte_order_marks_are_accepted_and_bad_bytes_are_located() {
    let dir = temp_dir("encodings");
    let good = dir.join("bom.nes");
    let mut bytes = "\u{feff}".as_bytes().to_vec();
    bytes.extend_from_slice(&std::fs::read("examples/hello.nes").unwrap());
    std::fs::write(&good, &bytes).unwrap();
    let out = nes().arg("check").arg(&good).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let typo = dir.join("typo.nes");
    std::fs::write(
        &typo,
        "\u{feff}camera { position (1, 0, 0) }\nobject sphre(1)\n",
    )
    .unwrap();
    let out = nes()
        .arg("check")
        .arg(&typo)
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("typo.nes:2:8]"), "{err}");

    let latin1 = dir.join("latin1.nes");
    std::fs::write(&latin1, b"camera { position (1, 0, 0) }\n// caf\xe9\n").unwrap();
    let out = nes()
        .arg("check")
        .arg(&latin1)
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    // miette wraps long messages: read them as one line of words.
    let err = String::from_utf8_lossy(&out.stderr).replace('│', " ");
    let err = err.split_whitespace().collect::<Vec<_>>().join(" ");
    assert_eq!(out.status.code(), Some(1));
    assert!(
        err.contains("E0403") && err.contains("line 2, column 7"),
        "{err}"
    );

    // Old Mac line endings (a lone \r), and a mix of all three: the
    // location and the excerpt name the right line.
    for (name, text) in [
        (
            "cr",
            &b"camera { position (1, 0, 0) }\r\robject sphre(1)\r"[..],
        ),
        (
            "mixed",
            &b"camera { position (1, 0, 0) }\r\n\robject sphere(1)\nobject sphre(1)\r"[..],
        ),
        (
            "cr-latin1",
            &b"camera { position (1, 0, 0) }\r// \xe9t\xe9\r"[..],
        ),
    ] {
        let path = dir.join(format!("{name}.nes"));
        std::fs::write(&path, text).unwrap();
        let out = nes()
            .arg("check")
            .arg(&path)
            .env("NO_COLOR", "1")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr).replace('│', " ");
        let words = err.split_whitespace().collect::<Vec<_>>().join(" ");
        assert_eq!(out.status.code(), Some(1), "{name}: {err}");
        match name {
            "cr" => assert!(
                err.contains("cr.nes:3:8]") && words.contains("3 object sphre(1)"),
                "{err}"
            ),
            "mixed" => assert!(
                err.contains("mixed.nes:4:8]") && words.contains("4 object sphre(1)"),
                "{err}"
            ),
            _ => assert!(words.contains("line 2, column 4"), "{err}"),
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Thread counts are bounded before any thread starts.
#[test]
fn absurd_thread_counts_are_refused() {
    for n in ["0", "5000"] {
        let out = nes()
            .args([
                "render",
                "examples/hello.nes",
                "--width",
                "8",
                "-q",
                "--threads",
                n,
            ])
            .args(["-o", "/nonexistent-dir/never.png"])
            .env("NO_COLOR", "1")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{n}: {err}");
        assert!(
            err.contains("cannot start") && err.contains("1 to 256"),
            "{n}: {err}"
        );
    }
}

/// `nes ARGS` under an address-space limit of `kilobytes` (`ulimit -v`),
/// with two malloc arenas: each thread's arena reserves 64 MB of address
/// space, and the limits are on what nes uses, not on how many threads
/// race.
fn nes_under_limit(kilobytes: u64, args: &[&OsStr]) -> std::process::Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {kilobytes} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_nes"))
        .args(args)
        .env("MALLOC_ARENA_MAX", "2")
        .output()
        .unwrap()
}

/// A torus scene whose light is written very far away, or whose cell is
/// tiny, renders under a 1 GiB address-space limit (both used to allocate
/// object copies in proportion to distance / cell size and abort).
#[test]
fn torus_scenes_with_a_far_light_or_a_tiny_cell_render_in_bounded_memory() {
    let dir = temp_dir("torus-memory");
    let scenes = [
        (
            "far-light",
            "space torus { min -10 max 10 }\ncamera { position (-4, 0, -1.5) look_at (7, 0, -1.5) width 48 height 32 }\n\
             light { position (1e40, 0, 0) }\nobject sphere(2) { translate (7, 0, 0) }\nobject plane((0, 0, 1), -3)\n",
        ),
        (
            "tiny-cell",
            "space torus { min -1e-12 max 1e-12 }\ncamera { position (0, 0, 0) look_at (1, 0, 0) width 48 height 32 }\n\
             light { position (0, -8, 6) }\nobject sphere(2) { translate (7, 0, 0) }\n",
        ),
    ];
    for (name, text) in scenes {
        let scene = dir.join(format!("{name}.nes"));
        std::fs::write(&scene, text).unwrap();
        let compiled = nes::compile_source(name, text).unwrap();
        let tracer = nes::trace::Tracer::new(&compiled);
        // The cell and one cell beyond each face: at most 5 shifts an axis.
        assert!(tracer.image_counts().iter().all(|&n| n <= 125), "{name}");
        let out = dir.join(format!("{name}.png"));
        let run = nes_under_limit(
            1_048_576,
            &[
                "render".as_ref(),
                scene.as_os_str(),
                "-q".as_ref(),
                "-o".as_ref(),
                out.as_os_str(),
            ],
        );
        assert!(
            run.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        assert_eq!(image::open(&out).unwrap().width(), 48);
    }
}

/// A union of 100 or 300 balls moved in H3 (each ball dozens of
/// operations) compiles under a 1 GiB address-space limit: the near
/// copies of its whole formula that its cells' descent made took
/// gigabytes (100 balls aborted here; a trial's 1000 balls aborted at 9
/// GB), and a descent's shorter formulas are now bounded.
#[test]
fn a_union_of_many_balls_in_h3_compiles_in_bounded_memory() {
    let dir = temp_dir("h3-union-memory");
    for n in [100, 300] {
        let scene = dir.join(format!("balls-{n}.nes"));
        std::fs::write(
            &scene,
            format!(
                "space h3 {{ radius 10 }}\nlet n = {n}\n\
                 camera {{ position (-9, -7, 6) look_at (0, 0, 0) width 48 height 30 }}\n\
                 object min(k in 0..{n}, let t = k * tau / n in (sphere(0.25 + 2 / n) \
                 translate (2.5 * cos(3 * t), 2.5 * sin(2 * t), 1.5 * sin(5 * t))))\n"
            ),
        )
        .unwrap();
        let run = nes_under_limit(1_048_576, &["check".as_ref(), scene.as_os_str()]);
        assert!(
            run.status.success(),
            "{n} balls: {}",
            String::from_utf8_lossy(&run.stderr)
        );
    }
}

/// Under an address-space limit too tight for the compile thread's
/// 512 MB stack (or the workers' 96 MB), a small scene still renders, on
/// smaller stacks: it panicked ("spawning the nes-main thread") under
/// `ulimit -v 600000`, and under 150 000 rayon had no pool. (Below about
/// 400 MB, glibc's per-thread malloc arenas, 64 MB of address space each,
/// may leave too little for the render itself.)
#[test]
fn a_small_scene_renders_under_a_tight_address_space_limit() {
    let dir = temp_dir("tight-limit");
    let out = dir.join("small.png");
    for limit in [600_000, 450_000] {
        let args = [
            "render",
            "examples/hello.nes",
            "--width",
            "40",
            "--height",
            "25",
            "-q",
            "-o",
        ];
        let mut args: Vec<&OsStr> = args.iter().map(OsStr::new).collect();
        args.push(out.as_os_str());
        let run = nes_under_limit(limit, &args);
        assert!(
            run.status.success(),
            "{limit}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        assert_eq!(image::open(&out).unwrap().width(), 40);
    }
}

/// An image larger than the process may allocate is refused before any
/// work, with a message and exit code 1, and no file: under a 1.2 GB
/// address-space limit an 8000 x 8000 render once aborted (exit 134) on
/// its pixel buffer's allocation.
#[test]
fn an_image_larger_than_memory_allows_is_refused_before_work() {
    let dir = temp_dir("memory-limit");
    let out = dir.join("big.png");
    let args = [
        "render",
        "examples/hello.nes",
        "--width",
        "8000",
        "--height",
        "8000",
        "-o",
    ];
    let mut args: Vec<&OsStr> = args.iter().map(OsStr::new).collect();
    args.push(out.as_os_str());
    let run = nes_under_limit(1_200_000, &args);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("8000 x 8000 image needs about"), "{stderr}");
    assert!(!out.exists());
}

/// A formula of 12 000 nested `let`s, each with its own name, is checked
/// under a 1.5 GiB address-space limit (of which the compile thread's
/// stack reserves 512 MB) and says it is fine; it needs about 55 MB. The
/// shape-call search once copied the names in scope at every level: 2 GB
/// for this file.
#[test]
fn nested_lets_with_distinct_names_are_checked_in_bounded_memory() {
    let dir = temp_dir("nested-lets");
    let mut text = String::from("shape s = ");
    for k in 0..12_000 {
        text.push_str(&format!("let a{k} = x + 1 in "));
    }
    text.push_str("x^2 + y^2 + z^2 - 1\nobject s\ncamera { position (0, -5, 0) look_at (0, 0, 0) }\nlight { position (3, -3, 3) }\n");
    let scene = dir.join("lets.nes");
    std::fs::write(&scene, &text).unwrap();
    let run = nes_under_limit(1_572_864, &["check".as_ref(), scene.as_os_str()]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

/// SIGTERM (a batch system's stop) and SIGHUP (a closed terminal) end a
/// render as Ctrl-C does: exit code 130, "interrupted", and no temporary
/// file left behind, whether the command stops by itself (an animation)
/// or is ended at once (an animation shard).
#[test]
fn termination_signals_leave_no_temporary_files() {
    let scene_text = "camera { position (-6, 0, 2) look_at (0, 0, 0) width 400 height 300 }\n\
                      light { position (-3, -6, 8) }\n\
                      shape heart = (x^2 + 9/4*y^2 + z^2 - 1)^3 - x^2*z^3 - 9/80*y^2*z^3\n\
                      object heart { rotate time * 10 about z }\n";
    for (signal, extra) in [
        ("TERM", &["-o", "anim.png"][..]),
        ("HUP", &["--shard", "0/1", "-o", "anim.shard"][..]),
    ] {
        let dir = temp_dir(&format!("signal-{signal}"));
        std::fs::write(dir.join("s.nes"), scene_text).unwrap();
        let child = nes()
            .current_dir(&dir)
            .args(["render", "s.nes", "--frames", "0..500", "-q"])
            .args(extra)
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // Wait until the output's temporary file exists: the render is on.
        let started = std::time::Instant::now();
        while !names_in(&dir).iter().any(|n| n.ends_with(".tmp")) {
            assert!(
                started.elapsed().as_secs() < 60,
                "{signal}: no temporary file appeared"
            );
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        let sent = Command::new("kill")
            .arg(format!("-{signal}"))
            .arg(child.id().to_string())
            .status()
            .unwrap();
        assert!(sent.success());
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(130), "{signal}: {stderr}");
        assert!(stderr.contains("interrupted"), "{signal}: {stderr}");
        assert_eq!(names_in(&dir), ["s.nes"], "{signal}");
    }
}

/// `--space` takes space names in any case (panels are labelled `S3`,
/// `H3`), and still refuses a name that is no space.
#[test]
fn space_names_on_the_command_line_are_case_insensitive() {
    let dir = temp_dir("space-case");
    let out = dir.join("three.png");
    let run = nes()
        .args([
            "render",
            "examples/hello.nes",
            "--width",
            "24",
            "--space",
            "Euclidean,S3,H3",
            "-o",
        ])
        .arg(&out)
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    let panels = image::open(&out).unwrap();
    assert!(panels.width() > 3 * 24, "{}", panels.width());
    let run = nes()
        .args([
            "render",
            "examples/hello.nes",
            "--width",
            "24",
            "--space",
            "S4",
            "-o",
        ])
        .arg(dir.join("bad.png"))
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert!(
        err.contains("E0501") && err.contains("unknown space `S4`"),
        "{err}"
    );
    assert!(!dir.join("bad.png").exists());
}

/// An output path is checked before any work: a file the scene imports, a
/// name that says another format, an existing file nes did not write, or
/// a numbered frame that is the scene, is refused and survives byte for
/// byte; an image nes wrote is replaced; a numbered animation that fails
/// part way leaves none of its frames.
#[test]
fn no_output_destroys_a_file_nes_did_not_write() {
    let dir = temp_dir("foreign-output");
    let hello = std::fs::read_to_string("examples/hello.nes").unwrap();
    std::fs::write(dir.join("lib.nes"), "shape ball = sphere(1)\n").unwrap();
    std::fs::write(
        dir.join("s.nes"),
        format!("import \"lib.nes\"\n{hello}\nobject ball {{ translate (0, 2, 1) }}\n"),
    )
    .unwrap();
    std::fs::write(dir.join("notes.txt"), "keep me\n").unwrap();
    std::fs::write(dir.join("notes.png"), "not an image\n").unwrap();
    std::fs::write(dir.join("part.shard"), "not a shard\n").unwrap();
    std::fs::write(dir.join("frame-0001.png"), &hello).unwrap();
    let run = |args: &[&str]| {
        nes()
            .args(args)
            .current_dir(&dir)
            .env("NO_COLOR", "1")
            .output()
            .unwrap()
    };
    // Each command line, split at spaces, and what its message says.
    let refused = [
        ("render s.nes -o lib.nes", "a file the scene imports"),
        ("render s.nes -o notes.txt", "does not name a PNG"),
        ("render s.nes -o out.jpg", "does not name a PNG"),
        ("render s.nes -o notes.png", "exists and is not"),
        (
            "render s.nes --shard 0/2 -o part.shard",
            "exists and is not",
        ),
        (
            "render s.nes --shard 0/2 -o lib.nes",
            "a file the scene imports",
        ),
        (
            "render s.nes --frames 0..3 -o frame-%04d.png",
            "exists and is not",
        ),
        (
            "render s.nes --frames 0..3 -o f-%d%d.png",
            "cannot tell how",
        ),
        ("rays s.nes --mark notes.txt", "does not name a PNG"),
        (
            "probe s.nes --pixel 1,1 -o notes.txt",
            "does not name a PNG",
        ),
        ("accuracy s.nes --width 8 -o notes.png", "exists and is not"),
    ];
    for (line, message) in refused {
        let args: Vec<&str> = line.split(' ').collect();
        let out = run(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(message), "{args:?}: {err}");
        // Refused before any work: nothing measured or drawn.
        assert!(!err.contains("measuring"), "{args:?}: {err}");
    }
    assert_eq!(
        std::fs::read_to_string(dir.join("notes.txt")).unwrap(),
        "keep me\n"
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("notes.png")).unwrap(),
        "not an image\n"
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("part.shard")).unwrap(),
        "not a shard\n"
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("frame-0001.png")).unwrap(),
        hello
    );
    assert!(std::fs::read_to_string(dir.join("lib.nes"))
        .unwrap()
        .starts_with("shape ball"));
    // An image nes wrote is replaced: rendering twice works.
    for _ in 0..2 {
        let out = run(&["render", "s.nes", "--width", "16", "-o", "image.png"]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    // A field of view that leaves its range at frame 2 fails there; frames
    // 0 and 1, written before, are removed.
    std::fs::write(
        dir.join("grow.nes"),
        hello.replace("fov      60", "fov      60 + 60 * frame"),
    )
    .unwrap();
    let out = run(&[
        "render",
        "grow.nes",
        "--width",
        "16",
        "--frames",
        "0..4",
        "-o",
        "g-%04d.png",
    ]);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let left: Vec<String> = names_in(&dir)
        .into_iter()
        .filter(|n| n.starts_with("g-"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A scene path that is a pipe or a device is refused at once, not read:
/// a FIFO would block for ever and `/dev/zero` would fill the memory.
#[cfg(unix)]
#[test]
fn a_scene_that_is_a_pipe_or_a_device_is_refused() {
    let dir = temp_dir("fifo-scene");
    let fifo = dir.join("scene.nes");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    for scene in [fifo.as_path(), std::path::Path::new("/dev/zero")] {
        // `timeout` ends a regression instead of hanging the suite.
        let out = Command::new("timeout")
            .arg("20")
            .arg(env!("CARGO_BIN_EXE_nes"))
            .arg("check")
            .arg(scene)
            .env("NO_COLOR", "1")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{scene:?}: {err}");
        assert!(err.contains("not a regular file"), "{scene:?}: {err}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_unknown_nes_jit_setting_is_warned_of_once_and_changes_nothing() {
    let run = |setting: &str| {
        nes()
            .env("NES_JIT", setting)
            .args(["check", "examples/hello.nes"])
            .output()
            .unwrap()
    };
    let bogus = run("bogus");
    assert!(bogus.status.success());
    let stderr = String::from_utf8_lossy(&bogus.stderr);
    assert_eq!(stderr.matches("NES_JIT").count(), 1, "{stderr}");
    assert!(stderr.contains("\"bogus\""), "{stderr}");
    for known in ["off", "ON", "0", "yes"] {
        let out = run(known);
        assert!(out.status.success());
        assert!(
            out.stderr.is_empty(),
            "{known}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// Every command runs on a thread with a large stack: a file nested as
/// deep as the limits allow (15 000 unary minuses, under the 20 000
/// operators) overflowed the main thread's stack in `render` while
/// checking that the output is no source file, and aborted.
#[test]
fn a_deeply_nested_formula_renders_with_the_default_threads() {
    let dir = temp_dir("deep");
    let scene = dir.join("deep.nes");
    let minuses = "-".repeat(15_000);
    std::fs::write(
        &scene,
        format!(
            "camera {{ position (-6, -4, 3) look_at (0, 0, 0) width 40 height 30 }}\n\
             light {{ position (-6, -7, 9) }}\n\
             object {minuses} x^2 + y^2 + z^2 - 1\n"
        ),
    )
    .unwrap();
    let out = dir.join("deep.png");
    let run = nes()
        .args(["render", "-q"])
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(image::image_dimensions(&out).unwrap(), (40, 30));
}

/// `--step` is held to the scene's epsilon as `step` in the file is, also
/// for the panels of `--space`; a step above it renders.
#[test]
fn a_step_flag_below_epsilon_is_refused_before_any_work() {
    let dir = temp_dir("step-flag");
    let out = dir.join("out.png");
    for spaces in [None, Some("euclidean,s3")] {
        let mut cmd = nes();
        cmd.args([
            "render",
            "examples/hello.nes",
            "--method",
            "march",
            "--step",
            "1e-7",
            "-q",
            "-o",
        ])
        .arg(&out);
        if let Some(s) = spaces {
            cmd.args(["--space", s]);
        }
        let run = cmd.output().unwrap();
        assert!(!run.status.success(), "{spaces:?}");
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(err.contains("--step") && err.contains("epsilon"), "{err}");
        assert!(!out.exists(), "{spaces:?}: an image was written");
    }
    let ok = nes()
        .args([
            "render",
            "examples/hello.nes",
            "--method",
            "march",
            "--step",
            "0.02",
            "--width",
            "40",
            "-q",
            "-o",
        ])
        .arg(&out)
        .status()
        .unwrap();
    assert!(ok.success() && out.exists());
}

/// A panel of `--space` that compiles the scene again for its space shows
/// the warnings that space gives, under a line naming the panel: W0006 for
/// a smooth union of moved balls, whose bound in S3 is the whole space,
/// was silent (a trial's panel took 280 times the Euclidean one's time).
#[test]
fn a_panel_shows_the_warnings_of_its_space() {
    let dir = temp_dir("panel-warnings");
    let scene = dir.join("blob.nes");
    std::fs::write(
        &scene,
        "camera { position (-7, -3, 3) look_at (0, 0, 0) width 24 height 16 }\n\
         light { position (-4, -6, 8) }\n\
         object smin(sphere(0.7), sphere(0.5) translate (0.8, 0, 0.3), 0.4) { translate (0, 3.2, 0) }\n",
    )
    .unwrap();
    let run = |spaces: &str| {
        let out = nes()
            .args(["render", "--space", spaces, "-o"])
            .arg(dir.join("out.png"))
            .arg(&scene)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let err = run("euclidean,s3");
    let at = err
        .find("in the S3 R = 10 panel:")
        .unwrap_or_else(|| panic!("{err}"));
    assert!(err[at..].contains("W0006"), "{err}");
    assert!(!run("euclidean").contains("W0006"));
}

/// `-o` naming a symbolic link to an image writes the image where the
/// link points and leaves the link, as `cp` does (the rename replaced the
/// link with a file).
#[cfg(unix)]
#[test]
fn an_output_through_a_symbolic_link_keeps_the_link() {
    let dir = temp_dir("symlink-output");
    let target = dir.join("target.png");
    let link = dir.join("link.png");
    let first = nes()
        .args(["render", "examples/hello.nes", "--width", "20", "-q", "-o"])
        .arg(&target)
        .status()
        .unwrap();
    assert!(first.success());
    std::os::unix::fs::symlink("target.png", &link).unwrap();
    let second = nes()
        .args(["render", "examples/hello.nes", "--width", "30", "-q", "-o"])
        .arg(&link)
        .status()
        .unwrap();
    assert!(second.success());
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(image::open(&target).unwrap().width(), 30);
    let mut names = names_in(&dir);
    names.sort();
    assert_eq!(names, ["link.png", "target.png"]);
}

/// A huge `--fps` is refused with the number written short (a trial's
/// `--fps 1e308` printed all 309 digits).
#[test]
fn a_huge_fps_is_refused_in_few_digits() {
    let run = nes()
        .args([
            "render",
            "examples/hello.nes",
            "--fps",
            "1e308",
            "-q",
            "-o",
            "/dev/null",
        ])
        .output()
        .unwrap();
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("got 1e308"), "{err}");
    // A negative rate reaches the same check, not the parser's
    // "unexpected argument '-1'".
    let run = nes()
        .args([
            "render",
            "examples/hello.nes",
            "--fps",
            "-1",
            "-o",
            "/dev/null",
        ])
        .output()
        .unwrap();
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("--fps must be above 0") && err.contains("got -1"),
        "{err}"
    );
}

/// Output into a pipe whose reader has gone (`nes probe ... | head -1`)
/// ends the command quietly, as it ends `cat`: killed by SIGPIPE, not a
/// panic's exit code 101 and its message.
#[cfg(unix)]
#[test]
fn a_closed_pipe_ends_a_command_quietly() {
    use std::os::unix::process::ExitStatusExt;
    let dir = temp_dir("closed-pipe");
    let plot = dir.join("probe.png");
    let plot = plot.to_str().unwrap();
    for args in [
        vec![
            "probe",
            "examples/seed.nes",
            "--pixel",
            "750,500",
            "-o",
            plot,
        ],
        vec!["explain", "examples/seed.nes"],
    ] {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let (err_reader, err_writer) = std::io::pipe().unwrap();
        let mut child = nes()
            .args(&args)
            .stdout(writer)
            .stderr(err_writer)
            .spawn()
            .unwrap();
        let mut err = String::new();
        std::io::Read::read_to_string(&mut { err_reader }, &mut err).unwrap();
        let status = child.wait().unwrap();
        assert_eq!(status.signal(), Some(13), "{args:?}: {status:?}, {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        // The plot is written before the table that found the pipe closed.
        if args[0] == "probe" {
            assert!(std::path::Path::new(plot).exists(), "no plot: {err}");
        }
    }
}
