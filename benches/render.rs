//! Whole renders at a small size: the seed scene in each of the three
//! spaces, the implicit examples per method, and compiling a scene. The
//! per-operation, per-ray and per-segment figures are in
//! `benches/hot_paths.rs`.
//!
//! Run with `cargo bench --bench render`. Whole-process figures at full size (1500 x 1000)
//! are measured with `scripts/time-renders.sh` and recorded in
//! docs/performance.md.

use criterion::{criterion_group, criterion_main, Criterion};
use nes::scene::Method;
use std::hint::black_box;

fn scene(path: &str, method: Method, width: u32) -> nes::Scene {
    let src = std::fs::read_to_string(path).unwrap();
    let mut s = nes::compile_source(path, &src).unwrap();
    let aspect = s.camera.height as f64 / s.camera.width as f64;
    s.camera.width = width;
    s.camera.height = (width as f64 * aspect).round() as u32;
    s.settings.method = method;
    s
}

/// The seed scene in the three spaces, 300 x 200, each space's default
/// method and the integrated sphere-space paths.
fn seed_in_three_spaces(c: &mut Criterion) {
    let mut g = c.benchmark_group("seed scene 300 x 200");
    g.sample_size(10);
    for (name, path, method) in [
        ("euclidean", "examples/seed.nes", Method::Auto),
        ("torus", "examples/torus.nes", Method::Auto),
        (
            "sphere R 25, exact",
            "examples/sphere-r25.nes",
            Method::Auto,
        ),
        ("sphere R 25, ode", "examples/sphere-r25.nes", Method::Ode),
    ] {
        let s = scene(path, method, 300);
        g.bench_function(name, |b| b.iter(|| nes::render(black_box(&s))));
    }
    g.finish();
}

fn renders(c: &mut Criterion) {
    let mut g = c.benchmark_group("render 300 px wide");
    g.sample_size(10);
    for (name, path, method) in [
        ("seed, closed form", "examples/seed.nes", Method::Auto),
        ("seed, march forced", "examples/seed.nes", Method::March),
        (
            "heart-and-cube, interval",
            "examples/heart-and-cube.nes",
            Method::Auto,
        ),
        (
            "heart-and-cube, adaptive",
            "examples/heart-and-cube.nes",
            Method::Adaptive,
        ),
        (
            "heart-and-cube, march",
            "examples/heart-and-cube.nes",
            Method::March,
        ),
    ] {
        let s = scene(path, method, 300);
        g.bench_function(name, |b| b.iter(|| nes::render(black_box(&s))));
    }
    g.finish();
}

fn compile(c: &mut Criterion) {
    let src = std::fs::read_to_string("examples/heart-and-cube.nes").unwrap();
    c.bench_function(
        "compile heart-and-cube (parse, simplify, differentiate, bound)",
        |b| b.iter(|| nes::compile_source("h.nes", black_box(&src)).unwrap()),
    );
}

criterion_group!(benches, seed_in_three_spaces, renders, compile);
criterion_main!(benches);
