//! The implicit-surface comparison (docs/performance.md):
//! `examples/implicit.nes` at 1500 x 1000 (NES_BENCH_WIDTH to change),
//! no anti-aliasing. Each row: wall time of the render (shading and shadows
//! included) and, against a reference rendered by interval isolation with
//! an epsilon 1000x tighter, the hit-distance errors and the pixels whose
//! object differs. The seed's `march` is run at a ladder of steps, to show
//! the step at which it stops missing pixels.
//!
//! `cargo bench --bench implicit` (NES_BENCH_MARCH=0 skips the march ladder).

use std::time::Instant;

use nes::scene::{Method, Scene};
use nes::tools::accuracy::{compare_hits, primary_hits};

fn scene(method: Method, epsilon: f64, step: f64) -> Scene {
    let src = std::fs::read_to_string("examples/implicit.nes").unwrap();
    let mut s = nes::compile_source("implicit.nes", &src).unwrap();
    let width: u32 = std::env::var("NES_BENCH_WIDTH")
        .ok()
        .and_then(|w| w.parse().ok())
        .unwrap_or(1500);
    s.camera.height = s.camera.height * width / s.camera.width;
    s.camera.width = width;
    s.settings.samples = 1;
    s.settings.method = method;
    s.settings.epsilon = epsilon;
    s.settings.step = step;
    nes::compile::compute_bounds(&mut s);
    s
}

fn main() {
    let defaults = scene(Method::Auto, 1e-6, 0.01).settings;
    let reference = primary_hits(&scene(Method::Auto, defaults.epsilon / 1000.0, 0.01));
    let probe = scene(Method::Auto, 1e-6, 0.01);
    println!(
        "examples/implicit.nes, {} x {}; reference: auto with epsilon {:.0e}",
        probe.camera.width,
        probe.camera.height,
        defaults.epsilon / 1000.0
    );
    println!(
        "{:<10} {:>8} {:>9} {:>12} {:>12} {:>8} {:>7}",
        "method", "step", "time", "mean |dt|", "max |dt|", "differ", "missed"
    );
    let mut rows = vec![(Method::Auto, defaults.step), (Method::Adaptive, 0.01)];
    if std::env::var("NES_BENCH_MARCH").as_deref() != Ok("0") {
        for step in [0.1, 0.05, 0.02, 0.01, 0.005] {
            rows.push((Method::March, step));
        }
    }
    for (method, step) in rows {
        let s = scene(method, defaults.epsilon, step);
        let start = Instant::now();
        let _ = nes::render(&s);
        let secs = start.elapsed().as_secs_f64();
        let e = compare_hits(&primary_hits(&s), &reference);
        println!(
            "{:<10} {:>8} {:>8.3}s {:>12.2e} {:>12.2e} {:>8} {:>7}",
            method.name(),
            if method == Method::Auto {
                "-".to_string()
            } else {
                step.to_string()
            },
            secs,
            e.mean_distance_error,
            e.max_distance_error,
            e.differing,
            e.missed
        );
    }
}
