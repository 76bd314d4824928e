//! The non-Euclidean spaces against independent computations.

use glam::DVec3;
use nes::trace::intersect::Scratch;
use nes::trace::Tracer;

fn scene(src: &str) -> nes::Scene {
    nes::compile_source("space.nes", src).unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

/// Directions spread over a cone around +x.
fn directions(n: usize) -> Vec<DVec3> {
    (0..n)
        .map(|i| {
            let a = i as f64 * 2.399963;
            let r = 0.9 * ((i as f64 + 0.5) / n as f64).sqrt();
            DVec3::new(1.0, r * a.cos(), r * a.sin()).normalize()
        })
        .collect()
}

/// In the torus a ray meets the first lattice copy of each object that the
/// straight line meets in R^3: the same hit distance as a Euclidean scene
/// holding the copies, computed in closed form. Checked from inside the
/// cell, from a camera on a face and from one on a corner, with an object
/// that crosses a face.
#[test]
fn the_torus_equals_the_scene_repeated_on_the_lattice() {
    // The small sphere reaches y = 5.3, across the face y = 5.
    let objects = "object sphere(1.5) { translate (3, 1, 0.5) }\nobject sphere(0.7) { translate (-4.2, 4.6, 0) }\n";
    let mut copies = String::new();
    for i in -4..=4 {
        for j in -4..=4 {
            for k in -4..=4 {
                let off = DVec3::new(i as f64, j as f64, k as f64) * 10.0;
                copies += &format!(
                    "object sphere(1.5) {{ translate ({}, {}, {}) }}\nobject sphere(0.7) {{ translate ({}, {}, {}) }}\n",
                    3.0 + off.x, 1.0 + off.y, 0.5 + off.z, -4.2 + off.x, 4.6 + off.y, off.z
                );
            }
        }
    }
    let flat = scene(&format!(
        "camera {{ position (0, 0, 0) }}\nrender {{ max_distance 30 }}\n{copies}"
    ));
    let b = Tracer::new(&flat);
    for o in [
        DVec3::new(-2.0, 0.0, 0.0),
        DVec3::new(-5.0, 0.0, 0.0),
        DVec3::new(-5.0, 5.0, -5.0),
    ] {
        let torus = scene(&format!(
            "space torus {{ min -5 max 5 wraps 1000 }}\ncamera {{ position ({}, {}, {}) }}\nrender {{ max_distance 30 }}\n{objects}",
            o.x, o.y, o.z
        ));
        let a = Tracer::new(&torus);
        let mut s = Scratch::default();
        let mut hits = 0;
        for d in directions(300) {
            let ht = a.nearest_hit(o, d, 30.0, &mut s).map(|h| h.t);
            let he = b.nearest_hit(o, d, 30.0, &mut s).map(|h| h.t);
            match (ht, he) {
                (Some(x), Some(y)) => {
                    assert!(
                        (x - y).abs() < 1e-9,
                        "camera {o}, {d}: torus {x}, lattice {y}"
                    );
                    hits += 1;
                }
                (None, None) => {}
                other => panic!("camera {o}, {d}: {other:?}"),
            }
        }
        assert!(hits > 30, "camera {o}: only {hits} rays hit");
    }
}

/// After 10^5 face crossings the hit agrees with the exact lattice
/// computation: no drift.
#[test]
fn the_torus_does_not_drift_after_a_hundred_thousand_wraps() {
    let torus = scene(
        "space torus { min 0 max 1 wraps 400000 }
         camera { position (0.5, 0.2, 0.5) look_at (1, 0.2, 0.5) }
         render { max_distance 1e6 }
         object sphere(0.0502) { translate (0.5, 0.5, 0.5) }",
    );
    let tracer = Tracer::new(&torus);
    let o = DVec3::new(0.5, 0.2, 0.5);
    let n = 150_000.0;
    let d = DVec3::new(n, 0.3, 1e-7).normalize();
    let hit = tracer
        .nearest_hit(o, d, 1e6, &mut Scratch::default())
        .expect("the ray meets a copy");
    // Exact: the first copy at (k + 0.5, 0.5, 0.5) (other rows are at
    // least 0.7 away) whose sphere the line meets, solved in a frame at the
    // copy so that nothing cancels: the line passes its centre's plane
    // x = k + 0.5 at t_k.
    let r2 = 0.0502f64 * 0.0502;
    let mut exact = None;
    for k in 0..(n as i64) {
        let c = DVec3::new(k as f64 + 0.5, 0.5, 0.5);
        let t_k = (c.x - o.x) / d.x;
        let local = DVec3::new(0.0, o.y + t_k * d.y - c.y, o.z + t_k * d.z - c.z);
        let b = local.dot(d);
        let disc = b * b - (local.length_squared() - r2);
        if disc >= 0.0 {
            exact = Some(t_k - b - disc.sqrt());
            break;
        }
    }
    let exact = exact.unwrap();
    assert!(exact > 1e5, "the hit should be far: {exact}");
    assert!(
        (hit.t - exact).abs() < 1e-6,
        "torus {} vs exact {exact}",
        hit.t
    );
}

const SEED_OBJECTS: &str = "
    light { position (0, -8, 6) }
    object sphere(2)   { translate (7, 0, 0) }
    object sphere(0.5) { translate (4.5, -2, 1.6) }
    object plane((0, 0, 1), -3)
";

fn seed_in(space: &str) -> nes::Scene {
    scene(&format!(
        "{space}\ncamera {{ position (-4, 0, -1.5) pitch 10 fov 84 width 60 height 40 }}\n{SEED_OBJECTS}"
    ))
}

fn mean_difference(a: &nes::Image, b: &nes::Image) -> f64 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| (*p - *q).abs().max_element())
        .sum::<f64>()
        / a.pixels.len() as f64
}

/// As R grows the sphere space's image converges to the Euclidean one.
#[test]
fn the_sphere_space_converges_to_euclidean_space() {
    let (flat, _) = nes::render(&seed_in("space euclidean"));
    assert!(shows_objects(&flat), "the Euclidean image shows the scene");
    let mut last = f64::INFINITY;
    let mut first = None;
    for radius in ["1e2", "1e3", "1e5", "1e8"] {
        let (img, stats) = nes::render(&seed_in(&format!("space sphere {{ radius {radius} }}")));
        assert_eq!(stats.nonfinite_pixels, 0);
        let diff = mean_difference(&img, &flat);
        assert!(diff <= last, "R = {radius}: {diff} after {last}");
        first.get_or_insert(diff);
        last = diff;
    }
    assert!(last < 1e-3, "at R = 1e8 the mean difference is {last}");
    // The curvature shows at R = 100 (paths bend by about 0.1 rad over
    // the 10 units to the spheres): the images do converge, they are not
    // simply the same.
    let first = first.unwrap();
    assert!(
        first > 1e-3 && first > 10.0 * last,
        "R = 100: {first}, R = 1e8: {last}"
    );
}

/// Tiny and huge radii meet no NaN and give the geometry's image: with
/// R = 1e-3 every ray circles within 2 mm of the camera and sees only the
/// background; with R = 1e9 the image is the Euclidean one.
#[test]
fn extreme_radii_give_the_expected_images() {
    let (tiny, stats) = nes::render(&seed_in("space sphere { radius 1e-3 }"));
    assert_eq!(stats.nonfinite_pixels, 0);
    assert!(
        tiny.pixels.iter().all(|p| *p == DVec3::ZERO),
        "a tiny sphere space shows only the background"
    );
    let (flat, _) = nes::render(&seed_in("space euclidean"));
    assert!(shows_objects(&flat));
    // Up to the largest radius allowed: paths anchored at their start keep
    // full precision (with the circle's centre 1e13 away they used to lose
    // it and draw speckles).
    for radius in ["1e9", "1e13", "1e15", "1e16", "1e100"] {
        let (huge, stats) = nes::render(&seed_in(&format!("space sphere {{ radius {radius} }}")));
        assert_eq!(stats.nonfinite_pixels, 0, "R = {radius}");
        assert_eq!(stats.imprecise_pixels, 0, "R = {radius}");
        let worst = huge
            .pixels
            .iter()
            .zip(&flat.pixels)
            .map(|(p, q)| (*p - *q).abs().max_element())
            .fold(0.0, f64::max);
        assert!(worst < 0.02, "R = {radius}: a pixel differs by {worst}");
    }
    // Beyond it, and beyond what `method ode` can place, an error says so.
    let too_big = "space sphere { radius 1e101 }\ncamera { position (0, 0, 0) }\n";
    let err = nes::compile_source("big.nes", too_big).unwrap_err();
    assert!(
        err.render_plain().contains("at most 1e100"),
        "{}",
        err.render_plain()
    );
    let ode =
        "space sphere { radius 1e13 }\ncamera { position (0, 0, 0) }\nrender { method ode }\n";
    let err = nes::compile_source("ode.nes", ode).unwrap_err();
    assert!(
        err.render_plain().contains("beyond a radius of 1e9"),
        "{}",
        err.render_plain()
    );
}

/// More than a tenth of the pixels are not the (black) background.
fn shows_objects(img: &nes::Image) -> bool {
    img.pixels.iter().filter(|p| **p != DVec3::ZERO).count() > img.pixels.len() / 10
}

/// Same scene, same ray: every method finds the same hit, within its
/// tolerance, in the sphere space and in the torus.
#[test]
fn the_methods_agree_in_every_space() {
    for (space, methods) in [
        (
            "space sphere { radius 12 }",
            vec!["exact", "interval", "march", "adaptive", "ode"],
        ),
        (
            "space torus { min -10 max 10 wraps 50 }",
            vec!["exact", "interval", "march", "adaptive"],
        ),
    ] {
        let src = |m: &str| {
            format!(
                "{space}\ncamera {{ position (-4, 0, -1.5) pitch 10 }}\nrender {{ method {m} step 0.002 epsilon 1e-9 tolerance 1e-11 }}\n{SEED_OBJECTS}"
            )
        };
        let reference = scene(&src("exact"));
        let reference = Tracer::new(&reference);
        let o = DVec3::new(-4.0, 0.0, -1.5);
        let rays = directions(40);
        let mut s = Scratch::default();
        for m in &methods[1..] {
            let sc = scene(&src(m));
            let tracer = Tracer::new(&sc);
            let mut compared = 0;
            for d in &rays {
                let want = reference.nearest_hit(o, *d, 100.0, &mut s);
                let got = tracer.nearest_hit(o, *d, 100.0, &mut s);
                match (want, got) {
                    (Some(w), Some(g)) => {
                        assert_eq!(w.object, g.object, "{space} {m} {d}");
                        assert!(
                            (w.t - g.t).abs() < 1e-5,
                            "{space} {m} {d}: {} vs {}",
                            g.t,
                            w.t
                        );
                        compared += 1;
                    }
                    (None, None) => {}
                    other => panic!("{space} {m} {d}: {other:?}"),
                }
            }
            assert!(compared > 20, "{space} {m}: {compared}");
        }
    }
}
