//! Every input that ever made the fuzz harness fail (`fuzz/regressions/`,
//! see its README), replayed through the built binary as a user would run
//! it: `nes check`, then a 24 x 16 `nes render`. Each must exit with 0 or
//! 1 (never a panic's 101 or a signal), within a generous 60 s wall clock
//! (a bound against hangs, not a speed test), without "panicked" on
//! stderr. Each run has an address-space limit (as the harness's workers
//! do), so an input that allocates without end fails here instead of
//! exhausting the machine.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const WALL_CLOCK: Duration = Duration::from_secs(60);
const MEMORY_BYTES: u64 = 2 << 30;
/// Regression files stay small; bigger cases are generated in tests (see
/// fuzz/regressions/README.md).
const MAX_FILE_BYTES: u64 = 100 << 10;

fn regressions() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/regressions");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "nes"))
        .collect();
    files.sort();
    files
}

fn on_path(program: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|dir| dir.join(program).is_file()))
}

/// `nes ARGS` under the memory limit: through `prlimit` where it exists,
/// else through the shell's `ulimit -v`.
fn nes(args: &[&str]) -> Command {
    let exe = env!("CARGO_BIN_EXE_nes");
    if on_path("prlimit") {
        let mut c = Command::new("prlimit");
        c.arg(format!("--as={MEMORY_BYTES}"))
            .arg("--core=0")
            .arg("--")
            .arg(exe)
            .args(args);
        c
    } else {
        let mut c = Command::new("sh");
        c.arg("-c")
            .arg(format!(
                "ulimit -v {}; exec \"$0\" \"$@\"",
                MEMORY_BYTES >> 10
            ))
            .arg(exe)
            .args(args);
        c
    }
}

/// What went wrong with one run, if anything.
fn judge(what: &str, mut command: Command, scratch: &Path) -> Option<String> {
    let stderr_path = scratch.join("stderr.txt");
    let stderr = std::fs::File::create(&stderr_path).unwrap();
    let mut child = command
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(stderr)
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break Some(status);
        }
        if start.elapsed() > WALL_CLOCK {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let err = std::fs::read_to_string(&stderr_path).unwrap_or_default();
    // The first lines that are not a backtrace: the message.
    let gist = |text: &str| -> String {
        let frame = |l: &str| {
            l.split_once(':')
                .is_some_and(|(n, _)| n.chars().all(|c| c.is_ascii_digit()))
                || l.starts_with("at ")
                || l.starts_with("note:")
                || l.starts_with("stack backtrace")
        };
        let lines: Vec<&str> = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !frame(l))
            .collect();
        lines[..lines.len().min(2)].join(" | ")
    };
    let Some(status) = status else {
        return Some(format!(
            "{what}: still running after {} s, killed",
            WALL_CLOCK.as_secs()
        ));
    };
    use std::os::unix::process::ExitStatusExt;
    match (status.code(), status.signal()) {
        (Some(0 | 1), _) if !err.contains("panicked") => None,
        (Some(code), _) => Some(format!("{what}: exit code {code}: {}", gist(&err))),
        (_, Some(signal)) => Some(format!("{what}: killed by signal {signal}: {}", gist(&err))),
        _ => Some(format!("{what}: {status}")),
    }
}

#[test]
fn every_input_that_once_failed_checks_and_renders_cleanly() {
    let files = regressions();
    assert!(files.len() >= 5, "only {files:?}");
    let scratch = std::env::temp_dir().join(format!("nes-fuzz-regressions-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get().min(4));
    let queue = std::sync::Mutex::new(files.iter().collect::<Vec<_>>());
    let failures = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for t in 0..threads {
            let (queue, failures, scratch) = (&queue, &failures, &scratch);
            s.spawn(move || {
                let dir = scratch.join(t.to_string());
                std::fs::create_dir_all(&dir).unwrap();
                while let Some(file) = queue.lock().unwrap().pop() {
                    let name = file.file_name().unwrap().to_string_lossy().to_string();
                    let size = std::fs::metadata(file).unwrap().len();
                    let mut found = Vec::new();
                    if size > MAX_FILE_BYTES {
                        found.push(format!(
                            "{name}: {size} bytes, over the {MAX_FILE_BYTES} a regression may have"
                        ));
                    }
                    let path = file.to_str().unwrap();
                    found.extend(judge(
                        &format!("{name}: check"),
                        nes(&["check", path]),
                        &dir,
                    ));
                    let out = dir.join("out.png");
                    let render = nes(&[
                        "render",
                        path,
                        "--width",
                        "24",
                        "--height",
                        "16",
                        "--quiet",
                        "-o",
                        out.to_str().unwrap(),
                    ]);
                    found.extend(judge(&format!("{name}: render"), render, &dir));
                    failures.lock().unwrap().extend(found);
                }
            });
        }
    });
    let _ = std::fs::remove_dir_all(&scratch);
    let mut failures = failures.into_inner().unwrap();
    failures.sort();
    assert!(
        failures.is_empty(),
        "{} of {} regression runs fail:\n{}",
        failures.len(),
        2 * files.len(),
        failures.join("\n")
    );
}
