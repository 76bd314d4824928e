//! Criterion benchmarks of the hot paths, each reported per unit of work
//! (criterion's "elements" throughput), so that figures compare across
//! expressions and scenes:
//!
//! - expression evaluation per tape operation: point value, value and
//!   gradient, interval value, and 8 intervals at once in lanes, over a
//!   box and along a line (in the line's parameter); the slope test's two
//!   forms: the interval gradient over a box, and one dual-number pass
//!   along a line;
//! - intersection per ray: closed form, interval root isolation and the
//!   seed's march, for rays that reach the object;
//! - each space's path per segment: a straight line, torus wraps, sphere
//!   arcs (one per loop), integrated sphere steps and a metric's (Nil);
//! - a metric's geodesic equation per evaluation, as the integrator
//!   solves it and as one symbolic expression;
//! - interval sine per interval: one, and 8 in lanes, narrow or with
//!   one lane a whole period wide (sums of sin(k x) for large k).
//!
//! `cargo bench --bench hot_paths`; figures in docs/performance.md.

use std::ops::ControlFlow;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::DVec3;
use nes::expr::{Dual, Interval, IntervalLanes, Number};
use nes::trace::intersect::Scratch;
use nes::trace::Tracer;
use std::hint::black_box;

const SHAPES: &str = "
shape ball(r: positive) = x^2 + y^2 + z^2 - r^2
shape heart = (x^2 + 9/4*y^2 + z^2 - 1)^3 - x^2*z^3 - 9/80*y^2*z^3
shape rounded_cube = x^8 + y^8 + z^8 - 1
shape ring(major: positive, minor: positive) = (sqrt(x^2 + y^2) - major)^2 + z^2 - minor^2
";

/// One object at the origin seen from (-4, 0, 0), with `method`.
fn single(object: &str, method: &str) -> nes::Scene {
    let src = format!(
        "{SHAPES}\ncamera {{ position (-4, 0, 0) look_at (0, 0, 0) width 64 height 64 }}\n\
         render {{ method {method} step 0.01 }}\nobject {object}"
    );
    nes::compile_source("bench.nes", &src).expect("bench scene compiles")
}

fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(30)
}

fn evaluation(c: &mut Criterion) {
    for object in ["ball(1)", "heart", "rounded_cube", "ring(1.1, 0.35)"] {
        let scene = single(object, "interval");
        let f = &scene.objects[0].function;
        let name = object.split('(').next().unwrap();
        let mut g = c.benchmark_group(format!("evaluate {name}, per operation"));
        let p = DVec3::new(0.31, -0.42, 0.27);
        let mut slots = Vec::new();
        g.throughput(Throughput::Elements(f.value_tape.operations() as u64));
        g.bench_function(format!("point ({} ops)", f.value_tape.operations()), |b| {
            b.iter(|| f.value(black_box(p), &mut slots))
        });
        let box_inputs = [
            Interval::new(0.30, 0.32),
            Interval::new(-0.43, -0.41),
            Interval::new(0.26, 0.28),
        ];
        let mut islots = Vec::new();
        g.bench_function("interval", |b| {
            b.iter(|| f.value_tape.eval(black_box(&box_inputs), &mut islots))
        });
        let lanes = [
            IntervalLanes::<8>::from_fn(|k| {
                Interval::new(0.30 + 0.01 * k as f64, 0.31 + 0.01 * k as f64)
            }),
            IntervalLanes::<8>::from_fn(|_| Interval::new(-0.43, -0.41)),
            IntervalLanes::<8>::from_fn(|_| Interval::new(0.26, 0.28)),
        ];
        let mut lslots = Vec::new();
        g.throughput(Throughput::Elements(8 * f.value_tape.operations() as u64));
        g.bench_function("8 intervals in lanes", |b| {
            b.iter(|| f.value_tape.eval(black_box(&lanes), &mut lslots))
        });
        // Along the line through p in direction (1, 2, 2)/3, pieces of the
        // same size as the boxes above.
        let mut forms = Vec::new();
        f.value_tape
            .line_forms(p, DVec3::new(1.0, 2.0, 2.0) / 3.0, 0.2, &mut forms);
        let piece = Interval::new(0.0, 0.02);
        let line_lanes =
            IntervalLanes::<8>::from_fn(|k| Interval::new(0.02 * k as f64, 0.02 * (k + 1) as f64));
        g.bench_function("8 intervals in lanes along a line", |b| {
            b.iter(|| {
                f.value_tape
                    .eval_on_line(&forms, black_box(line_lanes), &mut lslots)
            })
        });
        g.throughput(Throughput::Elements(f.value_tape.operations() as u64));
        g.bench_function("interval along a line", |b| {
            b.iter(|| {
                f.value_tape
                    .eval_on_line(&forms, black_box(piece), &mut islots)
            })
        });
        let mut dslots = Vec::new();
        g.bench_function(
            "slope test: interval value and slope along a line (dual)",
            |b| {
                b.iter(|| {
                    f.value_tape
                        .eval_on_line(&forms, Dual::variable(black_box(piece)), &mut dslots)
                })
            },
        );
        let mut gradient = [Interval::point(0.0); 4];
        g.bench_function(
            "slope test: interval value and gradient over a box (per value op)",
            |b| {
                b.iter(|| {
                    f.gradient_tape
                        .eval_into(black_box(&box_inputs), &mut islots, &mut gradient)
                })
            },
        );
        g.throughput(Throughput::Elements(f.gradient_tape.operations() as u64));
        g.bench_function(
            format!(
                "point value and gradient ({} ops)",
                f.gradient_tape.operations()
            ),
            |b| b.iter(|| f.value_and_gradient(black_box(p), &mut slots)),
        );
        g.finish();
    }
}

/// Directions from the camera of `scene` that hit its one object.
fn hitting_rays(scene: &nes::Scene) -> Vec<DVec3> {
    let tracer = Tracer::new(scene);
    let rays = scene.camera.rays();
    let mut s = Scratch::default();
    let mut out = Vec::new();
    for y in 0..scene.camera.height {
        for x in 0..scene.camera.width {
            let d = rays.direction(x as f64 + 0.5, y as f64 + 0.5);
            if tracer
                .nearest_hit(scene.camera.position, d, 100.0, &mut s)
                .is_some()
            {
                out.push(d);
            }
        }
    }
    out
}

fn intersection(c: &mut Criterion) {
    let mut g = c.benchmark_group("intersect, per ray that hits");
    for (object, method, label) in [
        ("ball(1)", "auto", "sphere, closed form"),
        ("ball(1)", "interval", "sphere, interval isolation"),
        ("heart", "auto", "heart, interval isolation"),
        ("heart", "march", "heart, march step 0.01"),
        ("rounded_cube", "auto", "rounded cube, interval isolation"),
        ("ring(1.1, 0.35)", "auto", "ring, interval isolation"),
    ] {
        let scene = single(object, method);
        let rays = hitting_rays(&scene);
        let tracer = Tracer::new(&scene);
        let mut s = Scratch::default();
        let o = scene.camera.position;
        g.throughput(Throughput::Elements(rays.len() as u64));
        g.bench_function(label, |b| {
            b.iter(|| {
                for d in &rays {
                    black_box(tracer.nearest_hit(o, *d, 100.0, &mut s));
                }
            })
        });
    }
    g.finish();
}

fn space_paths(c: &mut Criterion) {
    let mut g = c.benchmark_group("space path, per segment");
    for (label, space, method, length) in [
        ("euclidean line", "space euclidean", "auto", 100.0),
        (
            "torus wraps (cell 1, 100 units)",
            "space torus { min 0 max 1 wraps 1000 }",
            "auto",
            100.0,
        ),
        (
            "sphere arc (R 5, one loop)",
            "space sphere { radius 5 }",
            "exact",
            10.0 * std::f64::consts::PI,
        ),
        (
            "sphere integrated steps (R 5, one loop)",
            "space sphere { radius 5 }",
            "ode",
            10.0 * std::f64::consts::PI,
        ),
        (
            "Nil integrated steps (10 units)",
            "space metric { g [(1 + y^2/4, -x*y/4, y/2), (-x*y/4, 1 + x^2/4, -x/2), (y/2, -x/2, 1)] }",
            "auto",
            10.0,
        ),
    ] {
        let src = format!(
            "{space}\ncamera {{ position (0.1, 0.2, 0.3) }}\nrender {{ method {method} max_distance {length} }}"
        );
        let scene = nes::compile_source("bench.nes", &src).expect("bench scene compiles");
        let space = scene.build_space();
        let o = DVec3::new(0.1, 0.2, 0.3);
        let d = DVec3::new(0.8, 0.36, 0.48);
        let mut segments = 0u64;
        space.walk(o, d, length, &mut |_| {
            segments += 1;
            ControlFlow::Continue(())
        });
        g.throughput(Throughput::Elements(segments));
        g.bench_function(format!("{label}: {segments} segments"), |b| {
            b.iter(|| {
                let mut end = DVec3::ZERO;
                space.walk(black_box(o), black_box(d), length, &mut |seg| {
                    end = seg.point(seg.range().1);
                    ControlFlow::Continue(())
                });
                end
            })
        });
    }
    g.finish();
}

/// A metric space's geodesic equation per evaluation: as the integrator
/// evaluates it (the entries and the lowered equation, compiled where the
/// machine allows, solved numerically) and as the one symbolic expression
/// with the inverse metric in it, interpreted.
fn metric_rates(c: &mut Criterion) {
    let mut g = c.benchmark_group("metric geodesic equation, per evaluation");
    for (label, metric) in [
        ("Nil", "g [(1, 0, 0), (0, 1 + x^2, -x), (0, -x, 1)]"),
        (
            "Nil, symmetric",
            "g [(1 + y^2/4, -x*y/4, y/2), (-x*y/4, 1 + x^2/4, -x/2), (y/2, -x/2, 1)]",
        ),
        (
            "lens",
            "g conformal(1 + 0.8 * exp(-((x - 3)^2 + y^2 + z^2) / 0.8))",
        ),
    ] {
        let src = format!("space metric {{ {metric} }}\ncamera {{ position (0.1, 0.2, 0.3) }}");
        let scene = nes::compile_source("bench.nes", &src).expect("bench scene compiles");
        let nes::space::SpaceKind::Metric(m) = &scene.space else {
            unreachable!("a metric space")
        };
        let (p, v) = (DVec3::new(0.3, -0.2, 0.4), DVec3::new(0.6, 0.0, 0.8));
        g.throughput(Throughput::Elements(1));
        g.bench_function(format!("{label}: numeric solve"), |b| {
            b.iter(|| m.0.acceleration_at(black_box(p), black_box(v)))
        });
        g.bench_function(format!("{label}: one symbolic expression"), |b| {
            b.iter(|| m.0.symbolic_acceleration(black_box(p), black_box(v)))
        });
    }
    g.finish();
}

fn trigonometry(c: &mut Criterion) {
    let mut g = c.benchmark_group("interval sine, per interval");
    let narrow: [Interval; 8] =
        std::array::from_fn(|k| Interval::new(0.37 * k as f64 - 1.1, 0.37 * k as f64 - 1.0));
    let mut one_wide = narrow;
    one_wide[3] = Interval::new(-2.0, 7.0);
    g.throughput(Throughput::Elements(8));
    g.bench_function("scalar, narrow", |b| {
        b.iter(|| black_box(narrow).map(|i| i.sin()))
    });
    for (label, set) in [("narrow", narrow), ("one lane wide", one_wide)] {
        let lanes = IntervalLanes::<8>::from_fn(|k| set[k]);
        g.bench_function(format!("8 lanes, {label}"), |b| {
            b.iter(|| black_box(lanes).sin())
        });
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = config();
    targets = evaluation, intersection, space_paths, metric_rates, trigonometry
}
criterion_main!(benches);
