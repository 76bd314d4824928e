//! The gallery (`examples/gallery/`, README): every scene rendered as a
//! user runs it, at its own size (800 x 500, one sample per pixel).
//! Per scene: the whole `nes render` process's wall time (the best of
//! NES_BENCH_RUNS, default 3), function evaluations per ray, each object's
//! route, and, against a reference by interval isolation with an epsilon
//! 1000x tighter, the pixels whose object differs and the largest
//! hit-distance error. The targets (issue 15): under 1 s per scene, and 0
//! pixels whose object differs.
//!
//! `cargo bench --bench gallery` (NES_BENCH_ONLY=name for one scene).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use nes::scene::{Method, Scene};
use nes::tools::accuracy::{compare_hits, primary_hits};
use nes::trace::Tracer;

fn compile(path: &Path) -> Scene {
    let src = std::fs::read_to_string(path).unwrap();
    nes::compile_source(&path.display().to_string(), &src)
        .unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

fn main() {
    let runs: usize = std::env::var("NES_BENCH_RUNS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(3);
    let only = std::env::var("NES_BENCH_ONLY").ok();
    let mut scenes: Vec<PathBuf> = std::fs::read_dir("examples/gallery")
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "nes"))
        .filter(|p| only.as_deref().is_none_or(|o| p.file_stem().unwrap() == o))
        .collect();
    scenes.sort();
    let out = std::env::temp_dir().join(format!("nes-gallery-bench-{}.png", std::process::id()));
    println!(
        "{:<16} {:>8} {:>9} {:>7} {:>10}  routes",
        "scene", "time", "evals/ray", "differ", "max |dt|"
    );
    let (mut total, mut slowest, mut differing) = (0.0, (0.0, String::new()), 0);
    for path in &scenes {
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let mut best = f64::INFINITY;
        for _ in 0..runs {
            let start = Instant::now();
            let status = Command::new(env!("CARGO_BIN_EXE_nes"))
                .args(["render", "-q", "-o"])
                .arg(&out)
                .arg(path)
                .status()
                .unwrap();
            assert!(status.success(), "{name}: nes render failed");
            best = best.min(start.elapsed().as_secs_f64());
        }
        let scene = compile(path);
        let (_, stats) = nes::render(&scene);
        let per_ray =
            stats.evaluations as f64 / (stats.primary_rays + stats.shadow_rays).max(1) as f64;
        let tracer = Tracer::new(&scene);
        let mut routes: Vec<&str> = tracer.routes().iter().map(|r| r.name()).collect();
        routes.dedup();
        let mut reference = compile(path);
        reference.settings.method = Method::Interval;
        reference.settings.epsilon /= 1000.0;
        nes::compile::compute_bounds(&mut reference);
        let e = compare_hits(&primary_hits(&scene), &primary_hits(&reference));
        println!(
            "{name:<16} {best:>7.3}s {per_ray:>9.1} {:>7} {:>10.1e}  {}",
            e.differing,
            e.max_distance_error,
            routes.join(", ")
        );
        total += best;
        differing += e.differing;
        if best > slowest.0 {
            slowest = (best, name);
        }
    }
    let _ = std::fs::remove_file(&out);
    println!(
        "{} scenes: {total:.2} s in all, slowest {} ({:.3} s), {differing} pixels whose object differs",
        scenes.len(),
        slowest.1,
        slowest.0
    );
}
