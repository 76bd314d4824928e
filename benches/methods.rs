//! Run time against error for every method in every space: the seed scene,
//! each method timed, and each pixel's hit distance compared with the
//! `exact` method's. `cargo bench --bench methods` (600 px wide; set
//! NES_BENCH_WIDTH=1500 for the full size); figures go to
//! docs/performance.md.

use std::time::Instant;

use nes::scene::{Method, Scene, SpaceKind};
use nes::trace::intersect::Scratch;
use nes::trace::Tracer;
use rayon::prelude::*;

fn seed(space: SpaceKind, method: Method) -> Scene {
    let src = std::fs::read_to_string("examples/seed.nes").unwrap();
    let mut s = nes::compile_source("seed.nes", &src).unwrap();
    s.space = space;
    s.settings.method = method;
    let width: u32 = std::env::var("NES_BENCH_WIDTH")
        .ok()
        .and_then(|w| w.parse().ok())
        .unwrap_or(600);
    s.camera.height = s.camera.height * width / s.camera.width;
    s.camera.width = width;
    nes::compile::compute_bounds(&mut s);
    s
}

/// Each pixel's hit: object and distance (NaN for none).
fn hits(scene: &Scene) -> Vec<(i64, f64)> {
    let tracer = Tracer::new(scene);
    let cam = scene.camera;
    let rays = cam.rays();
    (0..cam.height)
        .into_par_iter()
        .flat_map_iter(|y| {
            let tracer = &tracer;
            let mut s = Scratch::default();
            (0..cam.width)
                .map(move |x| {
                    let d = rays.direction(x as f64 + 0.5, y as f64 + 0.5);
                    match tracer.first_hit(
                        cam.position,
                        d,
                        scene.settings.max_distance,
                        false,
                        &mut s,
                    ) {
                        Some(h) => (h.object as i64, h.t),
                        None => (-1, f64::NAN),
                    }
                })
                .collect::<Vec<_>>()
        })
        .collect()
}

fn main() {
    let spaces = [
        (
            "euclidean",
            SpaceKind::Euclidean,
            vec![
                Method::Exact,
                Method::Interval,
                Method::Adaptive,
                Method::March,
            ],
        ),
        (
            "torus",
            SpaceKind::default_named("torus").unwrap(),
            vec![
                Method::Exact,
                Method::Interval,
                Method::Adaptive,
                Method::March,
            ],
        ),
        (
            "sphere",
            SpaceKind::default_named("sphere").unwrap(),
            vec![Method::Exact, Method::Ode, Method::Adaptive, Method::March],
        ),
    ];
    let probe = seed(SpaceKind::Euclidean, Method::Exact);
    println!(
        "seed scene, {} x {}; time = full render with shading and shadows",
        probe.camera.width, probe.camera.height
    );
    println!(
        "{:<10} {:<9} {:>9} {:>12} {:>12} {:>10}",
        "space", "method", "time", "mean |dt|", "max |dt|", "differ"
    );
    for (name, space, methods) in spaces {
        let reference = hits(&seed(space, Method::Exact));
        for m in methods {
            let scene = seed(space, m);
            let start = Instant::now();
            let _ = nes::render(&scene);
            let secs = start.elapsed().as_secs_f64();
            let got = hits(&scene);
            let (mut sum, mut max, mut n, mut differ) = (0.0, 0.0f64, 0usize, 0usize);
            for (a, b) in got.iter().zip(&reference) {
                if a.0 != b.0 {
                    differ += 1;
                } else if a.0 >= 0 {
                    let e = (a.1 - b.1).abs();
                    sum += e;
                    max = max.max(e);
                    n += 1;
                }
            }
            println!(
                "{:<10} {:<9} {:>8.3}s {:>12.2e} {:>12.2e} {:>10}",
                name,
                m.name(),
                secs,
                sum / n.max(1) as f64,
                max,
                differ
            );
        }
    }
}
