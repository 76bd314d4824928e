//! Run time against error for every method in every space: the seed scene,
//! each method timed, and each pixel's hit distance compared with the
//! `exact` method's. `cargo bench --bench methods` (600 px wide; set
//! NES_BENCH_WIDTH=1500 for the full size); figures go to
//! docs/performance.md.

use std::time::Instant;

use nes::scene::{Method, Scene};
use nes::space::SpaceKind;
use nes::tools::accuracy::{compare_hits, primary_hits};

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
        let reference = primary_hits(&seed(space.clone(), Method::Exact));
        for m in methods {
            let scene = seed(space.clone(), m);
            let start = Instant::now();
            let _ = nes::render(&scene);
            let secs = start.elapsed().as_secs_f64();
            let e = compare_hits(&primary_hits(&scene), &reference);
            println!(
                "{:<10} {:<9} {:>8.3}s {:>12.2e} {:>12.2e} {:>10}",
                name,
                m.name(),
                secs,
                e.mean_distance_error,
                e.max_distance_error,
                e.differing
            );
        }
    }
}
