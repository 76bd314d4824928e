//! `nes probe`: the numbers it reports for one pixel's ray, checked
//! against closed-form geometry and against the function itself.

use glam::DVec3;

mod common;
use common::Scratch;

fn scene(src: &str) -> nes::Scene {
    nes::compile_source("probe.nes", src).unwrap_or_else(|e| panic!("{e:?}"))
}

/// The roots of |o + t d - c|^2 = r^2.
fn sphere_roots(o: DVec3, d: DVec3, c: DVec3, r: f64) -> Vec<f64> {
    let oc = o - c;
    let b = oc.dot(d);
    let disc = b * b - (oc.length_squared() - r * r);
    if disc < 0.0 {
        return vec![];
    }
    vec![-b - disc.sqrt(), -b + disc.sqrt()]
}

#[test]
fn roots_are_the_closed_form_crossings_and_the_stop_is_the_first() {
    let s = scene(
        "camera { position (-4, 0, 0) width 64 height 48 }\n\
         object sphere(1.5) { translate (3, 0.2, 0.1) }\n\
         object sphere(0.5) { translate (6, -0.3, 0) }",
    );
    let probe = nes::tools::probe::probe(&s, 32, 24, Some(20.0)).unwrap();
    let (o, d) = (probe.origin, probe.direction);
    let big = sphere_roots(o, d, DVec3::new(3.0, 0.2, 0.1), 1.5);
    let small = sphere_roots(o, d, DVec3::new(6.0, -0.3, 0.0), 0.5);
    // The ray passes through both spheres, the small one behind the big.
    assert_eq!((big.len(), small.len()), (2, 2));
    assert!(small[0] > big[1]);
    for (object, want) in [&big, &small].into_iter().enumerate() {
        let got = &probe.objects[object].roots;
        assert_eq!(got.len(), 2, "object {object}: {got:?}");
        for (got, want) in got.iter().zip(want) {
            assert!(
                (got - want).abs() < 1e-8,
                "object {object}: {got} vs {want}"
            );
        }
    }
    let (t, object) = probe.stop.expect("the ray hits the big sphere");
    assert_eq!(object, 0);
    assert!(
        (t - big[0]).abs() < 1e-6,
        "stopped at {t}, first root {}",
        big[0]
    );
}

/// In the sphere space the path is a circle, so the roots are not those
/// of the straight line; each is checked against the function at points
/// of the path on either side of it.
#[test]
fn roots_are_where_the_function_changes_sign_along_a_bent_path() {
    let s = scene(
        "space sphere { radius 10 }\n\
         camera { position (-4, 0, 0) pitch 25 width 70 height 50 }\n\
         object sphere(1.5) { translate (6, 1.5, -0.5) }\n\
         object plane((0, 0, 1), -3)",
    );
    let tracer = nes::trace::Tracer::new(&s);
    let mut checked = 0;
    let mut sphere_roots = 0;
    // The first four pixels see the floor, the last three the sphere
    // (the path bends down, so it shows higher in the image than
    // straight lines would put it).
    for ((x, y), hit) in [
        ((35, 25), 1),
        ((35, 10), 1),
        ((20, 40), 1),
        ((50, 5), 1),
        ((25, 20), 0),
        ((20, 30), 0),
        ((28, 12), 0),
    ] {
        let probe = nes::tools::probe::probe(&s, x, y, None).unwrap();
        for (i, o) in probe.objects.iter().enumerate() {
            let f = &s.objects[i].function;
            for &r in &o.roots {
                let around = nes::space::points_along(
                    tracer.space(),
                    probe.origin,
                    probe.direction,
                    &[r - 1e-6, r + 1e-6],
                );
                let mut slots = Vec::new();
                let before = f.value(around[0].unwrap(), &mut slots);
                let after = f.value(around[1].unwrap(), &mut slots);
                assert!(
                    before.signum() != after.signum(),
                    "pixel ({x}, {y}), object {i}: no sign change at {r}: {before}, {after}"
                );
                checked += 1;
            }
        }
        // The ray stopped at the nearest root of the object it hit, and
        // before the first root of any other.
        let (t, i) = probe.stop.expect("every chosen pixel sees an object");
        assert_eq!(i, hit, "pixel ({x}, {y})");
        let first = probe.objects[i].roots.first().copied().expect("a root");
        assert!((t - first).abs() < 1e-5, "({x}, {y}): {t} vs {first}");
        for o in &probe.objects {
            assert!(o.roots.iter().all(|&r| r >= first - 1e-5), "({x}, {y})");
        }
        if hit == 0 {
            // In and out of the sphere.
            assert_eq!(probe.objects[0].roots.len(), 2, "({x}, {y})");
            sphere_roots += 2;
        }
    }
    assert_eq!(sphere_roots, 6);
    assert!(checked >= 10, "only {checked} roots");
}

/// The report's figure 19: a march whose step is larger than a thin
/// object steps over it. The probe shows it: the function dips below zero
/// (two roots) while every sample the march took is positive, and the ray
/// goes on to the wall behind.
#[test]
fn the_probe_shows_why_a_march_missed() {
    let s = scene(
        "camera { position (-4, 0, 0) width 9 height 9 fov 10 }\n\
         render { method march step 0.5 }\n\
         object sphere(0.1) { translate (0.23, 0, 0) }\n\
         object plane((-1, 0, 0), -6)",
    );
    let probe = nes::tools::probe::probe(&s, 4, 4, Some(12.0)).unwrap();
    let thin = &probe.objects[0];
    assert_eq!(thin.roots.len(), 2, "{:?}", thin.roots);
    assert!(!thin.samples.is_empty());
    assert!(
        thin.samples.iter().all(|&(_, v)| v > 0.0),
        "{:?}",
        thin.samples
    );
    assert_eq!(probe.stop.map(|(_, i)| i), Some(1), "the wall behind");
    // The default method finds it.
    let s = scene(
        "camera { position (-4, 0, 0) width 9 height 9 fov 10 }\n\
         object sphere(0.1) { translate (0.23, 0, 0) }\n\
         object plane((-1, 0, 0), -6)",
    );
    let probe = nes::tools::probe::probe(&s, 4, 4, Some(12.0)).unwrap();
    assert_eq!(probe.stop.map(|(_, i)| i), Some(0));
}

/// A ray through a polynomial's bound that passes the surface by: the
/// polynomial route's samples are shown (once reported as "not
/// searched"), and each is the function's value at its point.
#[test]
fn the_probe_shows_the_polynomial_routes_samples_on_a_miss() {
    // Chmutov's octic and a ray that passes between its lobes (the
    // gallery's camera, pixel (150, 20)).
    let s = scene(
        "camera { position (-4.6, -3.2, 2.6) look_at (0, 0, 0) fov 38 width 800 height 500 }\n\
         shape T8(t) = 128*t^8 - 256*t^6 + 160*t^4 - 32*t^2 + 1\n\
         object T8(x) + T8(y) + T8(z)",
    );
    let probe = nes::tools::probe::probe(&s, 150, 20, Some(10.0)).unwrap();
    assert_eq!(probe.stop, None);
    let octic = &probe.objects[0];
    assert!(octic.roots.is_empty(), "{:?}", octic.roots);
    assert!(octic.samples.len() >= 9, "{:?}", octic.samples);
    let t8 =
        |t: f64| 128.0 * t.powi(8) - 256.0 * t.powi(6) + 160.0 * t.powi(4) - 32.0 * t * t + 1.0;
    let f = |p: DVec3| t8(p.x) + t8(p.y) + t8(p.z);
    for &(t, v) in &octic.samples {
        let want = f(probe.origin + t * probe.direction);
        assert!(
            (v - want).abs() <= 1e-9 * (1.0 + want.abs()),
            "at {t}: {v} vs {want}"
        );
        assert!(v > 0.0, "at {t}: {v}");
    }
}

/// A union met part by part evaluates each part, which equals the union
/// only near its zeros: the samples are shown at the union's own value
/// (a part's value at a point where another part is smaller once showed
/// as the union's).
#[test]
fn a_unions_samples_are_the_unions_values() {
    let s = scene(
        "camera { position (-4.6, -3.2, 3.3) look_at (0, 0, 0) fov 38 width 80 height 50 }\n\
         shape torus(R, r) = (x^2 + y^2 + z^2 + R^2 - r^2)^2 - 4*R^2*(x^2 + y^2)\n\
         object min(torus(1.2, 0.35), length((x - 0.9, y, z - 0.4)) - 0.6)",
    );
    let probe = nes::tools::probe::probe(&s, 40, 25, Some(12.0)).unwrap();
    let union = &probe.objects[0];
    assert_eq!(union.route, nes::trace::Route::Union);
    assert!(!union.samples.is_empty());
    let torus =
        |p: DVec3| (p.length_squared() + 1.44 - 0.1225).powi(2) - 5.76 * (p.x * p.x + p.y * p.y);
    let ball = |p: DVec3| (p - DVec3::new(0.9, 0.0, 0.4)).length() - 0.6;
    for &(t, v) in &union.samples {
        let p = probe.origin + t * probe.direction;
        let want = torus(p).min(ball(p));
        assert!(
            (v - want).abs() <= 1e-9 * (1.0 + want.abs()),
            "at {t}: {v} vs {want}"
        );
    }
}

#[test]
fn a_pixel_outside_the_image_is_an_error() {
    let s = scene("camera { position (0, 0, 0) width 10 height 5 }\nobject sphere(1)");
    assert!(nes::tools::probe::probe(&s, 10, 0, None).is_err());
    assert!(nes::tools::probe::probe(&s, 0, 5, None).is_err());
    assert!(nes::tools::probe::probe(&s, 9, 4, None).is_ok());
}

#[test]
fn the_command_prints_the_table_and_writes_the_plot() {
    let dir = Scratch::new("probe");
    let out = dir.join("p.png");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_nes"))
        .args([
            "probe",
            "examples/seed.nes",
            "--pixel",
            "75,50",
            "--width",
            "150",
            "-o",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(run.status.success());
    let text = String::from_utf8_lossy(&run.stdout);
    // The stop it prints is the library's probe of the same pixel, at the
    // same image width.
    let src = std::fs::read_to_string("examples/seed.nes").unwrap();
    let mut seed = scene(&src);
    seed.camera.height = seed.camera.height * 150 / seed.camera.width;
    seed.camera.width = 150;
    let probe = nes::tools::probe::probe(&seed, 75, 50, None).unwrap();
    let (t, object) = probe.stop.expect("the centre pixel sees a sphere");
    let printed: f64 = text
        .split("stopped at t = ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .unwrap_or_else(|| panic!("{text}"))
        .parse()
        .unwrap();
    assert!((printed - t).abs() < 1e-8, "printed {printed}, probe {t}");
    assert!(
        text.contains(&format!("on object {}", object + 1)),
        "{text}"
    );
    assert!(image::open(&out).unwrap().width() > 0);
    let svg = std::fs::read_to_string(dir.join("p.svg")).unwrap();
    assert!(svg.contains("<svg"), "{svg}");
    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_nes"))
        .args(["probe", "examples/seed.nes", "--pixel", "2000,1"])
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("outside"));
}

/// A function undefined on part of the ray: the curve breaks there
/// instead of carrying NaN into the plot, roots are found where it is
/// defined, and drawing it succeeds.
#[test]
fn undefined_stretches_break_the_curve_and_do_not_poison_roots() {
    let s = scene(
        "camera { position (-4, 0, 0) width 9 height 9 fov 10 }\n\
         shape half(r: positive) = sqrt(x) - r\n\
         object half(1.2)",
    );
    let probe = nes::tools::probe::probe(&s, 4, 4, Some(8.0)).unwrap();
    let o = &probe.objects[0];
    assert!(
        o.curve.iter().any(|(_, v)| v.is_nan()),
        "x < 0 is undefined"
    );
    // sqrt(x) = 1.2 at x = 1.44, 5.44 from the camera along +x.
    assert_eq!(o.roots.len(), 1, "{:?}", o.roots);
    assert!((o.roots[0] - 5.44).abs() < 1e-6, "{:?}", o.roots);
    let (t, _) = probe.stop.expect("the surface is hit");
    assert!((t - 5.44).abs() < 1e-5);
    let dir = Scratch::new("probe-nan");
    nes::tools::probe::plot(&probe, &dir.join("p.png"), &dir.join("p.svg")).unwrap();
    // Both files are written and readable. (Whether the curve breaks is
    // not visible here: the SVG holds integer coordinates either way.)
    assert!(image::open(dir.join("p.png")).is_ok());
    let svg = std::fs::read_to_string(dir.join("p.svg")).unwrap();
    assert!(svg.contains("<svg"), "{svg}");
    assert!(!svg.contains("NaN"), "{svg}");
}

/// A `--distance` past the ray's end is cut to it, and the table says so
/// (a trial's 1e308 was shown as 100 with no word).
#[test]
fn a_distance_past_the_rays_end_is_cut_and_said() {
    let s = scene(
        "camera { position (0, 0, 0) width 10 height 5 }\nobject sphere(1) translate (5, 0, 0)",
    );
    let probe = nes::tools::probe::probe(&s, 5, 2, Some(1e308)).unwrap();
    assert_eq!(probe.extent, 100.0);
    assert_eq!(probe.cut_from, Some(1e308));
    assert!(probe.to_string().contains("asked for 1e308"), "{probe}");
    let probe = nes::tools::probe::probe(&s, 5, 2, Some(20.0)).unwrap();
    assert_eq!((probe.extent, probe.cut_from), (20.0, None));
}
