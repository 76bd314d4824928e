//! Benchmarks of the hot paths and of whole renders at a small size.
//!
//! Run with `cargo bench`. Whole-process figures at full size (1500 x 1000)
//! are measured with `scripts/time-renders.sh` and recorded in
//! docs/performance.md.

use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec3;
use nes::expr::Interval;
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

fn evaluation(c: &mut Criterion) {
    let s = scene("examples/heart-and-cube.nes", Method::Auto, 10);
    let heart = &s.objects[0].function;
    let p = DVec3::new(0.1, 1.4, 0.7);
    let mut slots = Vec::new();
    let mut islots = Vec::new();
    let mut g = c.benchmark_group(format!("heart ({} instructions)", heart.value.len()));
    g.bench_function("point value", |b| {
        b.iter(|| heart.value(black_box(p), &mut slots))
    });
    g.bench_function("point value and gradient", |b| {
        b.iter(|| heart.value_and_gradient(black_box(p), &mut slots))
    });
    let box_inputs = [
        Interval::new(0.0, 0.1),
        Interval::new(1.4, 1.5),
        Interval::new(0.6, 0.7),
    ];
    g.bench_function("interval value", |b| {
        b.iter(|| heart.value.eval(black_box(&box_inputs), &mut islots))
    });
    g.finish();
}

criterion_group!(benches, renders, compile, evaluation);
criterion_main!(benches);
