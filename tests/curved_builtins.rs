//! The geometric builtins of S3 and H3 (`geodesic_distance`,
//! `plane_distance`, `busemann`, and the prelude's `horosphere` and
//! `equidistant`) against closed forms computed here.

use glam::DVec3;
use nes::trace::intersect::Scratch;
use nes::trace::Tracer;

fn tracer_hits(src: &str, dirs: &[DVec3]) -> Vec<Option<f64>> {
    let scene =
        nes::compile_source("b.nes", src).unwrap_or_else(|e| panic!("{}", e.render_plain()));
    let tracer = Tracer::new(&scene);
    let mut s = Scratch::default();
    dirs.iter()
        .map(|d| {
            tracer
                .nearest_hit(DVec3::ZERO, *d, 100.0, &mut s)
                .map(|h| h.t)
        })
        .collect()
}

fn directions() -> Vec<DVec3> {
    (0..40)
        .map(|i| {
            let a = i as f64 * 2.399963;
            let r = 0.45 * ((i as f64 + 0.5) / 40.0).sqrt();
            DVec3::new(1.0, r * a.cos(), r * a.sin()).normalize()
        })
        .collect()
}

/// `geodesic_distance(c) - r` is the geodesic ball `sphere(r) translate c`:
/// every ray meets both at the same distance (the ball in closed form).
#[test]
fn geodesic_distance_draws_the_geodesic_ball() {
    for space in ["", "space s3 { radius 3 }", "space h3 { radius 2 }"] {
        let formula = format!(
            "{space}\ncamera {{ position (0, 0, 0) }}\nshape b = geodesic_distance((3, 0.4, -0.2)) - 0.8\nobject b"
        );
        let ball = format!(
            "{space}\ncamera {{ position (0, 0, 0) }}\nobject sphere(0.8) {{ translate (3, 0.4, -0.2) }}"
        );
        let dirs = directions();
        let (a, b) = (tracer_hits(&formula, &dirs), tracer_hits(&ball, &dirs));
        let mut hits = 0;
        for (x, y) in a.iter().zip(&b) {
            match (x, y) {
                (Some(s), Some(t)) => {
                    hits += 1;
                    assert!((s - t).abs() < 1e-5, "{space:?}: {s} vs {t}");
                }
                (None, None) => {}
                _ => panic!("{space:?}: {x:?} vs {y:?}"),
            }
        }
        assert!(hits > 5, "{space:?}: {hits}");
    }
}

/// A horosphere of H3 through the point 2 along +x, seen from the origin:
/// along the unit direction w the geodesic meets it where
/// cosh(t/R) - (w.u) sinh(t/R) = e^(-2/R). An equidistant surface 1 above
/// the plane z = 0: where sinh(t/R) w.z = sinh(1/R).
#[test]
fn horospheres_and_equidistant_surfaces_are_where_their_closed_forms_say() {
    let big_r: f64 = 2.0;
    let dirs = directions();
    let horo = tracer_hits(
        "space h3 { radius 2 }\ncamera { position (0, 0, 0) }\nobject horosphere((1, 0, 0), 2)",
        &dirs,
    );
    for (w, t) in dirs.iter().zip(&horo) {
        let c = w.x;
        // (1 - c) E^2 - 2 e^(-d/R) E + (1 + c) = 0 with E = e^(t/R).
        let k = (-2.0 / big_r).exp();
        let disc = k * k - (1.0 - c * c);
        let want = (disc >= 0.0).then(|| big_r * ((k - disc.sqrt()) / (1.0 - c)).ln());
        match (t, want) {
            (Some(t), Some(want)) => {
                // On the surface: the Busemann function there is -2 to
                // the search's tolerance (where the ray grazes, t itself
                // is less certain).
                let tau = t / big_r;
                let b = big_r * (tau.cosh() - c * tau.sinh()).ln();
                assert!((b + 2.0).abs() < 1e-5, "{w}: b = {b} at {t}");
                assert!((t - want).abs() < 1e-3, "{w}: {t} vs {want}");
            }
            (None, None) => {}
            other => panic!("{w}: {other:?}"),
        }
    }
    let up: Vec<DVec3> = dirs.iter().map(|d| DVec3::new(d.y, d.z, d.x)).collect();
    let eq = tracer_hits(
        "space h3 { radius 2 }\ncamera { position (0, 0, 0) }\nobject equidistant((0, 0, 1), 1)",
        &up,
    );
    for (w, t) in up.iter().zip(&eq) {
        let want = big_r * ((1.0 / big_r).sinh() / w.z).asinh();
        let t = t.expect("every upward ray meets it");
        let height = big_r * ((t / big_r).sinh() * w.z).asinh();
        assert!((height - 1.0).abs() < 1e-5, "{w}: {height} at {t}");
        assert!((t - want).abs() < 1e-3, "{w}: {t} vs {want}");
    }
    // In flat space both are planes.
    let flat = tracer_hits(
        "camera { position (0, 0, 0) }\nobject horosphere((1, 0, 0), 2)",
        &dirs,
    );
    for (w, t) in dirs.iter().zip(&flat) {
        assert!((t.unwrap() - 2.0 / w.x).abs() < 1e-6);
    }
}

/// S3 has no points at infinity: a horosphere there is an error, with the
/// place and a hint.
#[test]
fn a_horosphere_in_s3_is_diagnosed() {
    let e = nes::compile_source(
        "b.nes",
        "space s3\ncamera { position (0, 0, 0) }\nobject horosphere((1, 0, 0), 2)",
    )
    .expect_err("no horospheres in S3");
    let text = e.render_plain();
    assert!(text.contains("infinity"), "{text}");
}
