//! Animations as a user renders them: `nes render --frames` against stills
//! of the same frames (`--frame K`), in each output format.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::Scratch;

fn nes() -> Command {
    Command::new(env!("CARGO_BIN_EXE_nes"))
}

fn temp_dir(name: &str) -> Scratch {
    Scratch::new(&format!("anim-{name}"))
}

/// A sphere moving right by `time`, and growing with `frame`: both names
/// change the image.
const MOVING: &str = "
camera { position (-5, 0, 0) width 48 height 32 }
light { position (-4, -3, 5) }
object sphere(0.8 + 0.1 * frame) { translate (0, -1 + time, 0) colour #d04040 }
object plane((0, 0, 1), -1.5)
";

fn scene(dir: &Path) -> PathBuf {
    let path = dir.join("moving.nes");
    std::fs::write(&path, MOVING).unwrap();
    path
}

fn run(args: &[&str], scene: &Path, out: &Path) {
    let status = nes()
        .arg("render")
        .arg(scene)
        .args(args)
        .arg("-q")
        .arg("-o")
        .arg(out)
        .status()
        .unwrap();
    assert!(status.success(), "{args:?}");
}

fn rgb(path: &Path) -> Vec<u8> {
    image::open(path).unwrap().to_rgb8().into_raw()
}

#[test]
fn numbered_frames_equal_stills_of_the_same_frame() {
    let dir = temp_dir("numbered");
    let scene = scene(&dir);
    run(
        &["--frames", "2..5", "--fps", "4"],
        &scene,
        &dir.join("f-%03d.png"),
    );
    let mut frames = Vec::new();
    for k in 2..5 {
        let framed = dir.join(format!("f-{k:03}.png"));
        let still = dir.join(format!("still-{k}.png"));
        run(&["--frame", &k.to_string(), "--fps", "4"], &scene, &still);
        assert_eq!(rgb(&framed), rgb(&still), "frame {k}");
        frames.push(rgb(&framed));
    }
    // The frames differ, so the comparison above means something.
    assert_ne!(frames[0], frames[1]);
    assert_ne!(frames[1], frames[2]);
    // 2..5 excludes 5 and starts at 2.
    assert!(!dir.join("f-005.png").exists() && !dir.join("f-001.png").exists());
}

/// An animated PNG holds one frame per number in the range, each shown
/// 1/fps seconds, and its frame k is the still of frame k.
#[test]
fn an_animated_png_holds_every_frame() {
    let dir = temp_dir("apng");
    let scene = scene(&dir);
    let out = dir.join("moving.png");
    run(&["--frames", "0..=3", "--fps", "12"], &scene, &out);
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&out).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let control = reader.info().animation_control.expect("an animated PNG");
    assert_eq!((control.num_frames, control.num_plays), (4, 0));
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    for k in 0..4 {
        let info = reader.next_frame(&mut buf).unwrap();
        let fc = reader.info().frame_control.expect("frame control");
        assert_eq!((fc.delay_num, fc.delay_den), (1, 12));
        let still = dir.join(format!("still-{k}.png"));
        run(&["--frame", &k.to_string(), "--fps", "12"], &scene, &still);
        assert_eq!(&buf[..info.buffer_size()], &rgb(&still)[..], "frame {k}");
    }
    // Nothing but the scene, the animation and the stills: no temporary
    // file (`.moving.png.<pid>.tmp`) is left.
    assert_eq!(
        names_in(&dir),
        [
            "moving.nes",
            "moving.png",
            "still-0.png",
            "still-1.png",
            "still-2.png",
            "still-3.png"
        ]
    );
}

/// The names in a folder, sorted, hidden ones included.
fn names_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn a_gif_holds_every_frame() {
    use image::AnimationDecoder;
    let dir = temp_dir("gif");
    let scene = scene(&dir);
    let out = dir.join("moving.gif");
    run(&["--frames", "0..3", "--fps", "10"], &scene, &out);
    let file = std::io::BufReader::new(std::fs::File::open(&out).unwrap());
    let frames = image::codecs::gif::GifDecoder::new(file)
        .unwrap()
        .into_frames()
        .collect_frames()
        .unwrap();
    assert_eq!(frames.len(), 3);
    // A GIF holds at most 256 colours; the encoder keeps a frame's colours
    // exactly when it has no more (this small scene's frames have fewer),
    // so frame k is the still of frame k byte for byte.
    for (k, frame) in frames.iter().enumerate() {
        let still = dir.join(format!("still-{k}.png"));
        run(&["--frame", &k.to_string(), "--fps", "10"], &scene, &still);
        let still = image::open(&still).unwrap().to_rgb8();
        let colours: std::collections::HashSet<_> = still.pixels().collect();
        assert!(colours.len() <= 256, "frame {k}: {} colours", colours.len());
        let gif = image::DynamicImage::ImageRgba8(frame.buffer().clone()).into_rgb8();
        assert_eq!(gif.dimensions(), (48, 32));
        let differing = gif
            .pixels()
            .zip(still.pixels())
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(differing, 0, "frame {k}: pixels differing from the still");
    }
    assert_ne!(frames[0].buffer(), frames[2].buffer());
    // Each frame shows 1/fps seconds.
    let (num, den) = frames[1].delay().numer_denom_ms();
    assert_eq!(num as f64 / den as f64, 100.0);
}

#[test]
fn bad_animation_requests_are_reported() {
    let dir = temp_dir("bad");
    let scene = scene(&dir);
    for args in [
        vec!["--frames", "5..5"],
        vec!["--frames", "3..1"],
        vec!["--frames", "ten"],
        vec!["--frames", "0..4", "--fps", "0"],
        vec!["--frames", "0..4", "--space", "torus"],
        vec!["--frames", "0..4", "-o", "out.jpeg"],
        vec!["--frames", "0..4", "-o", "out-%03d.gif"],
        vec!["--frame", "1", "--fps=-2"],
    ] {
        let out = nes()
            .arg("render")
            .arg(&scene)
            .args(&args)
            .current_dir(&dir)
            .env("NO_COLOR", "1")
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("E0501"),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    // A frame whose scene is invalid (a negative radius at frame 9) is
    // reported with its frame number and leaves no file.
    let shrinking = dir.join("shrinking.nes");
    std::fs::write(
        &shrinking,
        "camera { position (-5, 0, 0) width 8 height 8 }\nobject sphere(1 - 0.125 * frame)",
    )
    .unwrap();
    let out = nes()
        .arg("render")
        .arg(&shrinking)
        .args(["--frames", "0..12", "-o", "shrink.png"])
        .current_dir(&dir)
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("frame 8"), "{err}");
    // No output, and no temporary file beside it: only the two scenes.
    assert_eq!(names_in(&dir), ["moving.nes", "shrinking.nes"]);
}
