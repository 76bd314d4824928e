//! Shards and the stitch, as a batch system would run them: the recipes in
//! docs/scale.md, byte-for-byte identity with single renders, and every way
//! a set of shards can be wrong.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::Scratch;

fn nes() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_nes"));
    c.env("NO_COLOR", "1");
    c
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A fresh folder holding a copy of `examples/`.
fn workdir(name: &str) -> Scratch {
    let dir = Scratch::new(&format!("shards-{name}"));
    std::fs::create_dir_all(dir.join("examples")).unwrap();
    for entry in std::fs::read_dir(root().join("examples")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "nes") {
            std::fs::copy(&path, dir.join("examples").join(path.file_name().unwrap())).unwrap();
        }
    }
    dir
}

fn run(cmd: &mut Command) -> std::process::Output {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{cmd:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The fenced block of docs/scale.md whose info string is `lang tag`.
fn recipe(lang: &str, tag: &str) -> String {
    let doc = std::fs::read_to_string(root().join("docs/scale.md")).unwrap();
    let fence = format!("```{lang} {tag}\n");
    let start = doc
        .find(&fence)
        .unwrap_or_else(|| panic!("no {fence} block"))
        + fence.len();
    let end = start + doc[start..].find("```").unwrap();
    doc[start..end].to_string()
}

/// The GNU parallel recipe, run as written (nes on the PATH), makes the
/// file a single render makes, byte for byte. Where `parallel` is missing
/// it is stood in for by `xargs -P`.
#[test]
fn the_gnu_parallel_recipe_equals_a_single_render() {
    let dir = workdir("parallel");
    let bin = Path::new(env!("CARGO_BIN_EXE_nes")).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let shim = r#"
if ! command -v parallel >/dev/null 2>&1; then
  parallel() {
    local cmd=()
    while [ "$1" != ":::" ]; do
      case "$1" in -j) shift ;; *) cmd+=("$1") ;; esac
      shift
    done
    shift
    printf '%s\n' "$@" | xargs -P 2 -I{} "${cmd[@]}"
  }
fi
"#;
    let script = format!(
        "set -euo pipefail\n{shim}\n{}",
        recipe("sh", "parallel-local")
    );
    run(Command::new("bash")
        .arg("-c")
        .arg(&script)
        .current_dir(&dir)
        .env("PATH", path));
    let shards = std::fs::read_dir(dir.join("parts")).unwrap().count();
    assert_eq!(shards, 7, "the recipe renders 7 shards");
    run(nes()
        .args(["render", "examples/implicit.nes", "-q", "-o", "single.png"])
        .current_dir(&dir));
    let stitched = std::fs::read(dir.join("implicit.png")).unwrap();
    let single = std::fs::read(dir.join("single.png")).unwrap();
    assert!(single.len() > 1000);
    assert!(
        stitched == single,
        "the stitched image differs from the single render"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An animation in 7 shards stitches to the same animated PNG, GIF and
/// numbered frames as one `nes render --frames`.
#[test]
fn an_animation_in_shards_equals_a_single_render() {
    let dir = workdir("animation");
    let args = [
        "examples/approach.nes",
        "--frames",
        "0..9",
        "--width",
        "96",
        "-q",
    ];
    for k in 0..7 {
        run(nes()
            .arg("render")
            .args(args)
            .args(["--shard", &format!("{k}/7"), "-o", &format!("p{k}.shard")])
            .current_dir(&dir));
    }
    let shards: Vec<String> = (0..7).map(|k| format!("p{k}.shard")).collect();
    for out in ["anim.png", "anim.gif", "frame-%02d.png"] {
        run(nes()
            .arg("render")
            .args(args)
            .args(["-o", &format!("single-{out}")])
            .current_dir(&dir));
        run(nes()
            .arg("stitch")
            .args(&shards)
            .args(["-o", &format!("stitched-{out}")])
            .current_dir(&dir));
    }
    for name in ["anim.png", "anim.gif"] {
        let a = std::fs::read(dir.join(format!("single-{name}"))).unwrap();
        let b = std::fs::read(dir.join(format!("stitched-{name}"))).unwrap();
        assert!(a == b, "{name} differs");
    }
    for frame in 0..9 {
        let a = std::fs::read(dir.join(format!("single-frame-{frame:02}.png"))).unwrap();
        let b = std::fs::read(dir.join(format!("stitched-frame-{frame:02}.png"))).unwrap();
        assert!(a == b, "frame {frame} differs");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The shards of a still tile its rows, and cost about the same: the
/// most expensive shard (in rays) is within 3x the cheapest, where equal
/// bands of the same scene differ far more.
#[test]
fn shards_tile_the_image() {
    let dir = workdir("tile");
    let mut rows = Vec::new();
    for k in 0..5 {
        let out = run(nes()
            .args(["render", "examples/implicit.nes", "--width", "300"])
            .args(["--shard", &format!("{k}/5"), "-o", &format!("s{k}.shard")])
            .current_dir(&dir));
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        let part = err
            .split("rows ")
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .unwrap_or_else(|| panic!("no rows in {err}"))
            .to_string();
        let (a, b) = part.split_once("..").unwrap();
        rows.push((a.parse::<u32>().unwrap(), b.parse::<u32>().unwrap()));
    }
    assert_eq!(rows[0].0, 0);
    assert_eq!(rows[4].1, 200);
    for pair in rows.windows(2) {
        assert_eq!(pair[0].1, pair[1].0, "{rows:?}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Wrong sets of shards are refused with their own codes, and write
/// nothing.
#[test]
fn missing_doubled_foreign_and_broken_shards_are_reported() {
    let dir = workdir("wrong");
    for k in 0..3 {
        run(nes()
            .args(["render", "examples/seed.nes", "--width", "120", "-q"])
            .args(["--shard", &format!("{k}/3"), "-o", &format!("s{k}.shard")])
            .current_dir(&dir));
    }
    run(nes()
        .args(["render", "examples/hello.nes", "--width", "120", "-q"])
        .args(["--shard", "1/3", "-o", "other.shard"])
        .current_dir(&dir));
    run(nes()
        .args(["render", "examples/seed.nes", "--width", "121", "-q"])
        .args(["--shard", "1/3", "-o", "wider.shard"])
        .current_dir(&dir));
    let bytes = std::fs::read(dir.join("s1.shard")).unwrap();
    std::fs::write(dir.join("cut.shard"), &bytes[..bytes.len() / 2]).unwrap();
    std::fs::write(dir.join("text.shard"), "not a shard\n").unwrap();
    let cases: [(&[&str], &str, &str); 6] = [
        (
            &["s0.shard", "s2.shard"],
            "E0604",
            "1 of 3 shards are missing: 1",
        ),
        (
            &["s0.shard", "s1.shard", "s1.shard", "s2.shard"],
            "E0604",
            "shard 1 of 3 is given twice",
        ),
        (
            &["s0.shard", "other.shard", "s2.shard"],
            "E0603",
            "its scene differs",
        ),
        (
            &["s0.shard", "wider.shard", "s2.shard"],
            "E0603",
            "its settings differs",
        ),
        (&["s0.shard", "cut.shard", "s2.shard"], "E0602", "cut short"),
        (&["text.shard"], "E0602", "does not start with"),
    ];
    for (files, code, text) in cases {
        let out = nes()
            .arg("stitch")
            .args(files)
            .args(["-o", "out.png"])
            .current_dir(&dir)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{files:?}: {err}");
        assert!(err.contains(code) && err.contains(text), "{files:?}: {err}");
        assert!(!dir.join("out.png").exists(), "{files:?} wrote an image");
    }
    // The output may not be one of the shards.
    let out = nes()
        .args([
            "stitch", "s0.shard", "s1.shard", "s2.shard", "-o", "s1.shard",
        ])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(std::fs::read(dir.join("s1.shard")).unwrap(), bytes);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--resume` leaves a complete shard alone (its bytes and time stamp),
/// and renders again one that was cut short.
#[test]
fn resume_skips_complete_shards_and_redoes_broken_ones() {
    let dir = workdir("resume");
    let render = |out: &str| {
        run(nes()
            .args(["render", "examples/seed.nes", "--width", "120"])
            .args(["--shard", "0/2", "--resume", "-o", out])
            .current_dir(&dir))
    };
    render("a.shard");
    let before = std::fs::metadata(dir.join("a.shard"))
        .unwrap()
        .modified()
        .unwrap();
    let good = std::fs::read(dir.join("a.shard")).unwrap();
    let out = render("a.shard");
    assert!(String::from_utf8_lossy(&out.stderr).contains("complete; skipped"));
    let after = std::fs::metadata(dir.join("a.shard"))
        .unwrap()
        .modified()
        .unwrap();
    assert_eq!(before, after, "a complete shard was rewritten");
    std::fs::write(dir.join("b.shard"), &good[..good.len() - 4]).unwrap();
    let out = render("b.shard");
    assert!(!String::from_utf8_lossy(&out.stderr).contains("skipped"));
    assert_eq!(std::fs::read(dir.join("b.shard")).unwrap(), good);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The Slurm recipe is valid bash, and uses the array index as the shard.
#[test]
fn the_slurm_script_is_valid_bash() {
    let script = recipe("sh", "slurm");
    assert!(script.contains("--shard \"$SLURM_ARRAY_TASK_ID/$N\""));
    assert!(script.contains("#SBATCH --array=0-99") && script.contains("N=100"));
    let out = Command::new("bash")
        .args(["-n", "-c", &script])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The Kubernetes recipe parses as YAML: an Indexed Job whose completions
/// match its shard count, and a stitch Job after it.
#[test]
fn the_kubernetes_manifest_is_an_indexed_job() {
    use yaml_rust2::YamlLoader;
    let docs = YamlLoader::load_from_str(&recipe("yaml", "kubernetes")).expect("valid YAML");
    assert_eq!(docs.len(), 2);
    let render = &docs[0];
    assert_eq!(render["kind"].as_str(), Some("Job"));
    assert_eq!(render["spec"]["completionMode"].as_str(), Some("Indexed"));
    let completions = render["spec"]["completions"].as_i64().unwrap();
    let args = render["spec"]["template"]["spec"]["containers"][0]["args"][0]
        .as_str()
        .unwrap();
    assert!(
        args.contains(&format!("--shard \"$JOB_COMPLETION_INDEX/{completions}\"")),
        "{args}"
    );
    let stitch = &docs[1];
    assert_eq!(stitch["kind"].as_str(), Some("Job"));
    assert!(
        stitch["spec"]["template"]["spec"]["containers"][0]["args"][0]
            .as_str()
            .unwrap()
            .starts_with("nes stitch")
    );
}
