//! Save-to-preview latency of `nes watch` (docs/performance.md): from the
//! moment a save of `examples/seed.nes` (640 x 400) lands on disk to the
//! moment the first preview image is in place, over 50 edits, each from
//! an idle watcher. `cargo bench --bench watch`.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

const EDITS: usize = 50;

fn main() {
    let dir = std::env::temp_dir().join(format!("nes-watch-bench-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let seed = std::fs::read_to_string("examples/seed.nes").unwrap();
    let scene = dir.join("seed.nes");
    let output = dir.join("seed.png");
    let edit = |i: usize| seed.replace("(0, -8, 6)", &format!("({}, -8, 6)", i % 7));
    std::fs::write(&scene, edit(0)).unwrap();

    let mut child = Command::new(env!("CARGO_BIN_EXE_nes"))
        .args(["watch", "--width", "640"])
        .arg(&scene)
        .arg("-o")
        .arg(&output)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let full = Arc::new(Mutex::new(0usize));
    {
        let full = full.clone();
        let stderr = child.stderr.take().unwrap();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if line.contains(", full ") {
                    *full.lock().unwrap() += 1;
                }
            }
        });
    }
    let wait_full = |n: usize| {
        let start = Instant::now();
        while *full.lock().unwrap() < n {
            assert!(start.elapsed() < Duration::from_secs(30), "no render");
            std::thread::sleep(Duration::from_millis(2));
        }
    };
    wait_full(1);

    let mut latencies = Vec::new();
    for i in 1..=EDITS {
        // Idle first, so that each save meets a waiting watcher.
        std::thread::sleep(Duration::from_millis(150));
        let before = std::fs::read(&output).unwrap();
        std::fs::write(&scene, edit(i)).unwrap();
        let saved = Instant::now();
        loop {
            if std::fs::read(&output).is_ok_and(|b| b != before) {
                break;
            }
            assert!(saved.elapsed() < Duration::from_secs(10), "no preview");
            std::thread::sleep(Duration::from_micros(500));
        }
        latencies.push(saved.elapsed().as_secs_f64() * 1e3);
        wait_full(i + 1);
    }
    let _ = child.kill();
    let _ = child.wait();
    let _ = std::fs::remove_dir_all(&dir);

    latencies.sort_by(f64::total_cmp);
    let at = |q: f64| latencies[((latencies.len() - 1) as f64 * q).round() as usize];
    println!(
        "nes watch, examples/seed.nes at 640 x 400, {EDITS} saves: save to first preview \
         min {:.0} ms, median {:.0} ms, p90 {:.0} ms, max {:.0} ms",
        at(0.0),
        at(0.5),
        at(0.9),
        at(1.0)
    );
}
