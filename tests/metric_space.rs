//! Metric spaces written in the scene against exact answers: flat space
//! in a curved chart, the upper half-space model of H3, S3 in a
//! stereographic chart, Nil's closed-form geodesic flow; the image of a
//! flat metric; what is counted when paths end early.

#[path = "common/nil.rs"]
#[allow(dead_code)]
mod nil;

use glam::DVec3;
use nes::space::points_along;
use nes::trace::intersect::Scratch;
use nes::trace::Tracer;

mod common;

fn scene(src: &str) -> nes::Scene {
    nes::compile_source("metric.nes", src).unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

/// A scene in the metric space `block` with one small object far away
/// (so rays run their whole length) and the camera at `camera`.
fn metric_scene(block: &str, camera: DVec3) -> nes::Scene {
    scene(&format!(
        "camera {{ position ({}, {}, {}) look_at ({}, {}, {}) width 8 height 8 }}\n\
         space metric {{ {block} }}\n\
         render {{ tolerance 1e-10 }}\n\
         object sphere(0.01) {{ translate (500, 500, 500) }}\n",
        camera.x,
        camera.y,
        camera.z,
        camera.x + 1.0,
        camera.y,
        camera.z
    ))
}

/// Deterministic unit vectors spread over the sphere.
fn directions(n: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let a = golden * i as f64;
            DVec3::new(r * a.cos(), r * a.sin(), z)
        })
        .collect()
}

/// Flat space in cylindrical coordinates (x = r, y = angle, z = height):
/// its geodesics are Euclidean straight lines, mapped through the chart.
#[test]
fn flat_space_in_cylindrical_coordinates_has_straight_geodesics() {
    let start = DVec3::new(3.0, 0.4, -1.0);
    let sc = metric_scene("g diag(1, x^2, 1)  domain x > 0.01", start);
    let tracer = Tracer::new(&sc);
    let euclidean = |c: DVec3| DVec3::new(c.x * c.y.cos(), c.x * c.y.sin(), c.z);
    let (s, c) = start.y.sin_cos();
    let (e_r, e_a) = (DVec3::new(c, s, 0.0), DVec3::new(-s, c, 0.0));
    let ts: Vec<f64> = (1..=20).map(|k| 0.4 * k as f64).collect();
    let mut worst: f64 = 0.0;
    for d in directions(40) {
        let line = d.x * e_r + d.y * e_a + d.z * DVec3::Z;
        let p0 = euclidean(start);
        // Stay clear of the axis, where the chart is singular.
        if (0..=80).any(|k| {
            let p = p0 + line * (0.1 * k as f64);
            (p.x * p.x + p.y * p.y).sqrt() < 0.3
        }) {
            continue;
        }
        for (t, p) in ts.iter().zip(points_along(tracer.space(), start, d, &ts)) {
            let p = p.expect("the path reaches its length");
            worst = worst.max((euclidean(p) - (p0 + line * *t)).length());
        }
    }
    assert!(
        worst < 1e-6,
        "largest distance from the straight line: {worst}"
    );
}

/// The hyperbolic distance in the upper half-space model.
fn half_space_distance(p: DVec3, q: DVec3) -> f64 {
    (1.0 + (p - q).length_squared() / (2.0 * p.z * q.z)).acosh()
}

/// The upper half-space `(dx^2 + dy^2 + dz^2) / z^2` is H3: a geodesic's
/// length is the hyperbolic distance between its ends.
#[test]
fn half_space_geodesics_are_as_long_as_the_hyperbolic_distance() {
    let start = DVec3::new(0.3, -0.2, 1.5);
    let sc = metric_scene("g conformal(1 / z)  domain z > 0", start);
    let tracer = Tracer::new(&sc);
    let ts: Vec<f64> = (1..=12).map(|k| 0.5 * k as f64).collect();
    let mut worst: f64 = 0.0;
    for d in directions(30) {
        for (t, p) in ts.iter().zip(points_along(tracer.space(), start, d, &ts)) {
            let p = p.expect("the path reaches its length");
            worst = worst.max((half_space_distance(start, p) - t).abs());
        }
    }
    assert!(worst < 1e-6, "largest error in distance: {worst}");
}

/// The unit 3-sphere in a stereographic chart, `4 (dx^2 + dy^2 + dz^2) /
/// (1 + |p|^2)^2`: a geodesic shorter than pi is as long as the spherical
/// distance between its ends.
#[test]
fn stereographic_s3_geodesics_are_as_long_as_the_spherical_distance() {
    let on_sphere = |u: DVec3| {
        let n = u.length_squared();
        let k = 1.0 / (1.0 + n);
        [2.0 * u.x * k, 2.0 * u.y * k, 2.0 * u.z * k, (1.0 - n) * k]
    };
    let distance = |a: [f64; 4], b: [f64; 4]| {
        let dot: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
        dot.clamp(-1.0, 1.0).acos()
    };
    let start = DVec3::new(0.2, 0.1, -0.3);
    let sc = metric_scene("g conformal(2 / (1 + x^2 + y^2 + z^2))", start);
    let tracer = Tracer::new(&sc);
    let ts: Vec<f64> = (1..=10).map(|k| 0.3 * k as f64).collect();
    let mut worst: f64 = 0.0;
    for d in directions(30) {
        for (t, p) in ts.iter().zip(points_along(tracer.space(), start, d, &ts)) {
            let p = p.expect("the path reaches its length");
            worst = worst.max((distance(on_sphere(start), on_sphere(p)) - t).abs());
        }
    }
    assert!(worst < 1e-6, "largest error in distance: {worst}");
}

/// Nil, `dx^2 + dy^2 + (dz - x dy)^2`: rays agree with the closed-form
/// geodesic flow of "Ray-marching Thurston geometries" to 1e-6, and the
/// unit-speed constraint drifts by less than 1e-8.
#[test]
fn nil_rays_follow_the_closed_form_flow() {
    let start = DVec3::new(0.5, -1.0, 0.25);
    let sc = metric_scene("g [(1, 0, 0), (0, 1 + x^2, -x), (0, -x, 1)]", start);
    let tracer = Tracer::new(&sc);
    let frame_to_chart = |d: DVec3| {
        // The frame Gram-Schmidt makes of d/dx, d/dy, d/dz at `start`:
        // e1 = d/dx; e2 = d/dy / sqrt(1 + x^2); e3 = the unit vector
        // orthogonal to both, (0, x, 1 + x^2) / sqrt(1 + x^2).
        let x = start.x;
        let s = (1.0 + x * x).sqrt();
        DVec3::new(d.x, d.y / s + d.z * x / s, d.z * s)
    };
    let ts: Vec<f64> = (1..=10).map(|k| k as f64).collect();
    let mut worst: f64 = 0.0;
    for d in directions(30) {
        let v = frame_to_chart(d);
        for (t, p) in ts.iter().zip(points_along(tracer.space(), start, d, &ts)) {
            let p = p.expect("the path reaches its length");
            let (exact, _) = nil::nil_geodesic(start.to_array(), v.to_array(), *t);
            worst = worst.max((p - DVec3::from_array(exact)).length());
        }
    }
    assert!(
        worst < 1e-6,
        "largest distance from the closed form: {worst}"
    );
    let report = tracer
        .space()
        .path_report()
        .expect("a metric space reports");
    assert!(report.paths >= 30, "{report:?}");
    assert!(report.max_drift < 1e-8, "{report:?}");
    assert_eq!(report.ended_early(), 0, "{report:?}");
}

const SEED: &str = "\
camera { position (-4, 0, -1.5) yaw 0 pitch 10 fov 84 width 96 height 64 }
light { position (0, -8, 6) colour white }
ambient 0.15
background black
object sphere(2)   { translate (7, 0, 0)       colour rgb(255, 145, 71) }
object sphere(0.5) { translate (4.5, -2, 1.6)  colour rgb(79, 158, 245) }
object sphere(0.5) { translate (6.7, 3, -2.3)  colour rgb(198, 91, 124) }
object plane((0, 0, 1), -3) { colour rgb(200, 200, 200) }
";

/// How many pixels of two images differ by more than 2/255 in a channel.
fn differing_pixels(a: &nes::Image, b: &nes::Image) -> usize {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| {
            let (p, q) = (nes::shade::to_srgb8(**p), nes::shade::to_srgb8(**q));
            p.iter().zip(&q).any(|(x, y)| x.abs_diff(*y) > 2)
        })
        .count()
}

/// A flat metric, in Cartesian coordinates and scaled by a constant (the
/// camera's frame is made orthonormal, so the field of view keeps its
/// meaning, and lengths scale), renders the Euclidean image: every pixel but a few on
/// silhouettes, where a hit within epsilon of the edge may go either way.
#[test]
fn flat_metrics_render_the_euclidean_image() {
    for (metric, scale, shadows) in [
        ("g diag(1, 1, 1)", 1.0, "euclidean"),
        ("g conformal(2.5)", 2.5, "euclidean"),
        // A chart unit is a tenth of an arc: samples spaced by arc length
        // alone were 1.25 chart units apart and passed the small balls by.
        ("g conformal(0.1)", 0.1, "euclidean"),
        // Shadow paths found by shooting, where they are straight lines.
        ("g diag(1, 1, 1)", 1.0, "geodesic"),
    ] {
        // Rays end after max_distance of arc length: in the scaled chart,
        // after a 2.5th of it.
        let (euclidean, _) = nes::render(&scene(&format!(
            "{SEED}render {{ max_distance {} }}\n",
            60.0 / scale
        )));
        let src = format!(
            "{SEED}space metric {{ {metric} }}\nrender {{ max_distance 60 shadows {shadows} }}\n"
        );
        let (image, stats) = nes::render(&scene(&src));
        let bad = differing_pixels(&euclidean, &image);
        assert!(
            bad <= image.pixels.len() / 200,
            "{metric}: {bad} of {} pixels differ",
            image.pixels.len()
        );
        let report = stats.integration.expect("a metric space reports");
        if shadows == "euclidean" {
            assert_eq!(report.paths, 96 * 64, "{metric}: {report:?}");
        }
        assert_eq!(report.ended_early(), 0, "{metric}: {report:?}");
        assert_eq!(report.shooting_failed, 0, "{metric}: {report:?}");
    }
}

/// A sphere written in cylindrical chart coordinates is hit where the
/// Euclidean ray meets it.
#[test]
fn hits_in_a_curved_chart_are_where_the_euclidean_ray_meets_the_surface() {
    let src = "camera { position (6, 0.5, 0.2) look_at (5, 0.5, 0.2) width 8 height 8 }\n\
               space metric { g diag(1, x^2, 1)  domain x > 0.01 }\n\
               shape ball = (x*cos(y) - 3)^2 + (x*sin(y) - 1)^2 + z^2 - 1\n\
               object ball { colour white }\n";
    let sc = scene(src);
    let tracer = Tracer::new(&sc);
    let start = sc.camera.position;
    let p0 = DVec3::new(start.x * start.y.cos(), start.x * start.y.sin(), start.z);
    let (s, c) = start.y.sin_cos();
    let (e_r, e_a) = (DVec3::new(c, s, 0.0), DVec3::new(-s, c, 0.0));
    let centre = DVec3::new(3.0, 1.0, 0.0);
    let mut s_ = Scratch::default();
    let mut hits = 0;
    for d in directions(400) {
        let line = d.x * e_r + d.y * e_a + d.z * DVec3::Z;
        // The first meeting of the line with the unit sphere at `centre`.
        let oc = p0 - centre;
        let b = oc.dot(line);
        let disc = b * b - (oc.length_squared() - 1.0);
        let exact = (disc > 1e-3).then(|| -b - disc.sqrt()).filter(|&t| t > 0.0);
        let got = tracer.nearest_hit(start, d, 20.0, &mut s_).map(|h| h.t);
        match (exact, got) {
            (Some(e), Some(g)) => {
                assert!((e - g).abs() < 1e-5, "{d}: exact {e}, found {g}");
                hits += 1;
            }
            (None, None) => {}
            // Grazing rays (disc near 0) are left out above.
            (None, Some(g)) if disc > -1e-3 => {
                let _ = g;
            }
            (e, g) => panic!("{d}: exact {e:?}, found {g:?}"),
        }
    }
    assert!(hits > 10, "the test must hit the sphere: {hits}");
}

/// Paths that leave the chart's domain end there, are counted, and the
/// render says so.
#[test]
fn paths_leaving_the_domain_are_counted_and_reported() {
    let src = "camera { position (0, 0, 2) look_at (0, 0, 0) up (1, 0, 0) width 16 height 16 }\n\
               space metric { g conformal(1 / z)  domain z > 0.5 }\n\
               object sphere(0.2) { translate (0, 0, 40) }\n";
    let (_, stats) = nes::render(&scene(src));
    let report = stats.integration.expect("a metric space reports");
    assert!(report.left_domain > 0, "{report:?}");
    assert_eq!(report.left_domain, report.ended_early(), "{report:?}");
    let warnings = stats.warnings(&scene(src).settings);
    assert!(
        warnings
            .iter()
            .any(|w| w.code.as_str() == "W0108" && w.text.contains("left the chart's domain")),
        "{warnings:?}"
    );
}

/// Where the metric is tiny (lengths e^-20 at the camera) a short arc is a
/// long way in the chart: a path is not ended as singular because its
/// steps are short in arc length.
#[test]
fn a_tiny_metric_at_the_camera_is_not_singular() {
    let src = "space metric { g conformal(exp(5*x)) }\n\
               camera { position (-4, 0, 0) look_at (0, 0, 0) width 16 height 10 }\n\
               object sphere(0.5) { translate (-3, 0, 0) }\n";
    let (_, stats) = nes::render(&scene(src));
    let report = stats.integration.expect("a metric space reports");
    assert_eq!(report.singular, 0, "{report:?}");
    assert_eq!(report.ended_early(), 0, "{report:?}");
}

/// The acceleration the integrator evaluates (derivatives of the metric,
/// solved numerically) equals the one symbolic expression of the geodesic
/// equation, and for Nil the hand-derived equation
/// `x'' = -y' (z' - x y')`, `y'' = x' (z' - x y')`,
/// `z'' = x' y' + x x' (z' - x y')`.
#[test]
fn the_geodesic_equation_matches_its_symbolic_form_and_nils_by_hand() {
    let metrics = [
        "g [(1, 0, 0), (0, 1 + x^2, -x), (0, -x, 1)]",
        "g [(1 + y^2/4, -x*y/4, y/2), (-x*y/4, 1 + x^2/4, -x/2), (y/2, -x/2, 1)]",
        "g diag(exp(2*z), exp(-2*z), 1)",
        "g conformal(1 + 0.5*exp(-(x^2 + y^2 + z^2)))",
        "g [(2 + sin(y), 0.3*x, 0), (0.3*x, 3, 0.1*z), (0, 0.1*z, 1 + x^2)]",
    ];
    for (i, metric) in metrics.iter().enumerate() {
        let sc = metric_scene(metric, DVec3::new(0.1, 0.2, 0.3));
        let nes::space::SpaceKind::Metric(m) = &sc.space else {
            panic!("a metric space");
        };
        for d in directions(20) {
            let p = d * 0.7 + DVec3::new(0.1, -0.2, 0.15);
            let v = DVec3::new(d.z, -d.x, 0.5 * d.y);
            let a = m.0.acceleration_at(p, v);
            let symbolic = m.0.symbolic_acceleration(p, v);
            assert!(
                (a - symbolic).length() <= 1e-10 * (1.0 + a.length()),
                "{metric} at {p}: {a} against {symbolic}"
            );
            if i == 0 {
                let w = v.z - p.x * v.y;
                let by_hand = DVec3::new(-v.y * w, v.x * w, v.x * v.y + p.x * v.x * w);
                assert!((a - by_hand).length() < 1e-12, "{p}: {a} against {by_hand}");
            }
        }
    }
}

/// A render in which no path comes near an object says so, instead of
/// leaving a blank image unexplained.
#[test]
fn an_image_no_path_reaches_is_warned_about() {
    let src = "camera { position (0, 0, 0) look_at (1, 0, 0) width 16 height 10 }\n\
               space metric { g diag(1, 1, 1) }\n\
               object sphere(0.5) { translate (-5, 0, 0) }\n";
    let sc = scene(src);
    let (_, stats) = nes::render(&sc);
    let warnings = stats.warnings(&sc.settings);
    assert!(
        warnings
            .iter()
            .any(|w| w.code.as_str() == "W0107"
                && w.text.starts_with("no path came near any object")),
        "{warnings:?}"
    );
    // With the ball ahead, no such warning.
    let (_, stats) = nes::render(&scene(&src.replace("(-5, 0, 0)", "(5, 0, 0)")));
    assert!(
        stats.warnings(&sc.settings).is_empty(),
        "{:?}",
        stats.warnings(&sc.settings)
    );
}

/// The upper half-space metric renders what the exact `space h3` renders:
/// a ball of radius r whose centre is d ahead of the camera (straight up
/// from the chart's (0, 0, 1) in the half-space, along z in H3's normal
/// coordinates) is, in the half-space chart, the Euclidean ball about
/// (0, 0, e^d cosh r) of radius e^d sinh r. Ray by ray, both hit or both
/// miss, at the same distance.
#[test]
fn the_half_space_metric_sees_what_exact_h3_sees() {
    let (r, d) = (0.6f64, 2.0f64);
    let (c, radius) = (d.exp() * r.cosh(), d.exp() * r.sinh());
    let exact = scene(&format!(
        "camera {{ position (0, 0, 0) look_at (0, 0, 1) up (1, 0, 0) width 8 height 8 }}\n\
         space h3 {{ radius 1 }}\n\
         object sphere({r}) {{ translate (0, 0, {d}) }}\n"
    ));
    let chart = scene(&format!(
        "camera {{ position (0, 0, 1) look_at (0, 0, 2) up (1, 0, 0) width 8 height 8 }}\n\
         space metric {{ g conformal(1 / z)  domain z > 0 }}\n\
         render {{ tolerance 1e-10 }}\n\
         shape ball = x^2 + y^2 + (z - {c})^2 - {radius}^2\n\
         object ball\n"
    ));
    let (a, b) = (Tracer::new(&exact), Tracer::new(&chart));
    let mut s = Scratch::default();
    let (mut hits, mut misses) = (0, 0);
    for i in 0..30 {
        for j in 0..30 {
            // Directions within 0.5 rad of straight ahead; the ball's
            // angular radius is asin(sinh r / sinh d), about 0.18.
            let (u, v) = (-0.5 + i as f64 / 29.0, -0.5 + j as f64 / 29.0);
            let dir = DVec3::new(u.sin(), v.sin(), 1.0).normalize();
            let ta = a.nearest_hit(DVec3::ZERO, dir, 20.0, &mut s).map(|h| h.t);
            let tb = b
                .nearest_hit(DVec3::new(0.0, 0.0, 1.0), dir, 20.0, &mut s)
                .map(|h| h.t);
            match (ta, tb) {
                (Some(x), Some(y)) => {
                    assert!((x - y).abs() < 1e-5, "{dir}: exact {x}, chart {y}");
                    hits += 1;
                }
                (None, None) => misses += 1,
                (x, y) => {
                    // Only a ray grazing the silhouette may differ.
                    let angle = dir.z.acos();
                    let edge = (r.sinh() / d.sinh()).asin();
                    assert!(
                        (angle - edge).abs() < 2e-3,
                        "{dir}: exact {x:?}, chart {y:?}"
                    );
                }
            }
        }
    }
    assert!(hits > 20 && misses > 20, "{hits} hits, {misses} misses");
}

/// A render whose paths drift from unit speed by more than 1e-6 says so,
/// and one whose paths hold it does not: the half-space's rays diving
/// towards z = 0, its boundary at infinity, integrated to tolerance 1e-3
/// drift to 2.3e-4 at 40 x 25, and to 1.4e-9 at the default 1e-8
/// (measured).
#[test]
fn a_large_drift_is_warned_about() {
    let src = "camera { position (0, 0, 1) look_at (2, 0, 2.5) width 40 height 25 }\n\
               space metric { g conformal(1 / z)  domain z > 0 }\n\
               object sphere(0.3) { translate (1.5, 0, 1) }\n";
    let drift_warned = |src: &str| {
        let sc = scene(src);
        let (_, stats) = nes::render(&sc);
        let report = stats.integration.expect("a metric space reports");
        let warned = stats.warnings(&sc.settings).iter().any(|w| {
            w.code.as_str() == "W0110" && w.text.starts_with("the unit-speed constraint drifted")
        });
        (report.max_drift, warned)
    };
    let (drift, warned) = drift_warned(&format!("render {{ tolerance 1e-3 }}\n{src}"));
    assert!(drift > 1e-6 && warned, "{drift:e}");
    let (drift, warned) = drift_warned(src);
    assert!(drift < 1e-6 && !warned, "{drift:e}");
}

/// Far from every object a path needs no samples, so its steps grow as
/// the error control allows: flat space with `max_distance 1e300` once
/// took about 266 000 steps a path (each capped at 32 samples) before it
/// left the chart's reach; the image is the Euclidean one either way.
#[test]
fn paths_far_from_every_object_take_long_steps() {
    let src = "camera { position (-6, -2, 2.5) look_at (0, 0, 0.5) width 40 height 25 }\n\
               light { position (-3, -6, 8) }\n\
               space metric { g diag(1, 1, 1) steps 10000000 }\n\
               render { max_distance 1e300 }\n\
               object sphere(1)\n";
    let sc = scene(src);
    let (image, stats) = nes::render(&sc);
    let report = stats.integration.expect("a metric space reports");
    let per_path = report.accepted as f64 / report.paths as f64;
    assert!(per_path < 200.0, "{per_path} steps a path: {report:?}");
    let euclid = scene(&src.replace("space metric { g diag(1, 1, 1) steps 10000000 }\n", ""));
    let (want, _) = nes::render(&euclid);
    let differ = common::pixels_differing(&image, &want, 0.02);
    assert!(
        differ <= 3,
        "{differ} pixels differ from the Euclidean image"
    );
}

/// A tight tolerance far out in a chart is met, not turned into an early
/// end: Nil's metric grows as x^2 / 4, so 60 units out `g(v, v)` is a sum
/// of terms near 1000 whose rounding (about 2e-13) exceeds a step's share
/// of a 1e-11 tolerance. That rounding is not the integrator's to control;
/// counting it against every step shrank them to nothing, and 376 of
/// 256 000 paths of the Nil example at 640 x 400 ended as "singular".
#[test]
fn a_tight_tolerance_far_out_in_a_chart_ends_no_path_early() {
    let src = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/metric/nil.nes"
    ))
    .expect("the Nil example");
    let src = src
        .replace("camera {", "render { tolerance 1e-11 }\ncamera {")
        .replace("width  640", "width 64")
        .replace("height 400", "height 40");
    let sc = scene(&src);
    let (_, stats) = nes::render(&sc);
    let report = stats.integration.expect("a metric space reports");
    assert_eq!(report.ended_early(), 0, "{report:?}");
    assert!(report.max_drift < 1e-10, "{report:?}");
}

/// The compiled integrator and the interpreter draw the same image, byte
/// for byte (`NES_JIT=off` turns compilation off), and `nes explain` says
/// which one ran.
#[test]
fn the_compiled_and_the_interpreted_integrator_draw_the_same_image() {
    let dir = common::Scratch::new("metric-jit");
    let render = |jit: &str, name: &str| {
        let out = dir.join(name);
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_nes"))
            .env("NES_JIT", jit)
            .args([
                "render",
                "examples/metric/nil.nes",
                "--width",
                "48",
                "-q",
                "-o",
            ])
            .arg(&out)
            .status()
            .expect("nes runs");
        assert!(status.success());
        std::fs::read(&out).expect("the image")
    };
    let compiled = render("on", "compiled.png");
    let interpreted = render("off", "interpreted.png");
    assert!(compiled == interpreted, "the two images differ");
    let explain = |jit: &str| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_nes"))
            .env("NES_JIT", jit)
            .args(["explain", "examples/metric/nil.nes"])
            .output()
            .expect("nes runs");
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    assert!(explain("on").contains("compiled to machine code"));
    assert!(explain("off").contains("(interpreted)"));
}

/// A metric with a kink (a Luneburg lens written with `if`: the index is
/// continuous, its gradient jumps at the lens's surface) is crossed, not
/// turned into early ends: no step straddling the jump meets the
/// tolerance, so one step of the shortest length is taken across. Before,
/// 3 014 of 16 000 paths at 160 x 100 ended there as "singular", showing
/// the background in speckles.
#[test]
fn a_kink_in_the_metric_is_crossed() {
    let src = "let R = 1.5\n\
               space metric { g conformal(if (x-4)^2 + y^2 + z^2 < R^2 then sqrt(2 - ((x-4)^2 + y^2 + z^2)/R^2) else 1) }\n\
               camera { position (-2, 0, 0.3) look_at (4, 0, 0) fov 50 width 40 height 25 }\n\
               light { position (-2, -3, 4) }\n\
               object sphere(0.3) { translate (9, 0.8, 0) colour red }\n\
               object plane((0, 0, 1), -1.5)\n";
    let sc = scene(src);
    let (_, stats) = nes::render(&sc);
    let report = stats.integration.expect("a metric space reports");
    assert_eq!(report.ended_early(), 0, "{report:?}");
    assert!(report.forced > 0 && report.max_drift < 1e-6, "{report:?}");
    assert!(report
        .summary()
        .contains("steps taken across a kink or jump"));
}

/// Every metric example holds the unit-speed drift under 1e-8 at the
/// default tolerance, the bound: the drift's share enters the
/// step control. (A slip that accepted steps the drift refused let H2 x R
/// drift to 4e18 at 320 x 200.)
#[test]
fn every_metric_example_holds_the_drift() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/metric");
    let mut seen = 0;
    for entry in std::fs::read_dir(dir).expect("the metric examples") {
        let path = entry.expect("an entry").path();
        let src = std::fs::read_to_string(&path).expect("a scene");
        let mut sc = scene(&src);
        sc.camera.width = 64;
        sc.camera.height = 40;
        let (_, stats) = nes::render(&sc);
        let report = stats.integration.expect("a metric space reports");
        assert!(report.max_drift < 1e-8, "{}: {report:?}", path.display());
        seen += 1;
    }
    assert!(seen >= 5, "{seen} examples");
}
