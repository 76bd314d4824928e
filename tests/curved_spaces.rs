//! S3 and H3 against closed-form answers: the angular size of a ball,
//! shadows along both arcs of a great circle, the closed form against
//! interval isolation, and the Euclidean limit.

use glam::DVec3;
use nes::trace::intersect::Scratch;
use nes::trace::{Route, Tracer};

fn scene(src: &str) -> nes::Scene {
    nes::compile_source("curved.nes", src).unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

/// The widest angle from +x at which a ray from the origin hits, found by
/// bisection (the ball is straight ahead along +x).
fn angular_radius(tracer: &Tracer, limit: f64) -> f64 {
    let mut s = Scratch::default();
    let hits = |a: f64, s: &mut Scratch| {
        let d = DVec3::new(a.cos(), a.sin(), 0.0);
        tracer.nearest_hit(DVec3::ZERO, d, limit, s).is_some()
    };
    assert!(hits(0.0, &mut s), "the ball is straight ahead");
    let (mut lo, mut hi) = (0.0, 0.5 * std::f64::consts::PI);
    if hits(hi, &mut s) {
        return hi;
    }
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if hits(mid, &mut s) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

fn ball_at(space: &str, r: f64, d: f64, method: &str) -> nes::Scene {
    scene(&format!(
        "{space}\ncamera {{ position (0, 0, 0) }}\nrender {{ max_distance 1000 method {method} }}\nobject sphere({r}) {{ translate ({d}, 0, 0) }}"
    ))
}

/// A ball of radius r whose centre is d straight ahead is seen under the
/// angle a with sin a = sin(r/R) / sin(d/R) in S3 (growing again beyond a
/// quarter of the great circle), sinh(r/R) / sinh(d/R) in H3 and r / d in
/// Euclidean space; by the closed form and by interval isolation.
#[test]
fn a_ball_subtends_the_angle_of_the_closed_form() {
    let (big_r, r) = (5.0, 1.0);
    let quarter = 0.5 * std::f64::consts::PI * big_r;
    let s3 = format!("space s3 {{ radius {big_r} }}");
    let h3 = format!("space h3 {{ radius {big_r} }}");
    let cases: Vec<(&str, f64, f64)> = vec![
        (&s3, 3.0, (r / big_r).sin() / (3.0 / big_r).sin()),
        (&s3, 6.0, (r / big_r).sin() / (6.0 / big_r).sin()),
        (
            &s3,
            quarter + 2.0,
            (r / big_r).sin() / ((quarter + 2.0) / big_r).sin(),
        ),
        (&s3, 13.0, (r / big_r).sin() / (13.0 / big_r).sin()),
        (&h3, 3.0, (r / big_r).sinh() / (3.0 / big_r).sinh()),
        (&h3, 12.0, (r / big_r).sinh() / (12.0 / big_r).sinh()),
        ("", 3.0, r / 3.0),
        ("", 12.0, r / 12.0),
    ];
    for (space, d, sin_a) in cases {
        let expected = sin_a.asin();
        for method in ["auto", "interval"] {
            let sc = ball_at(space, r, d, method);
            let tracer = Tracer::new(&sc);
            let want = if method == "auto" {
                Route::Closed
            } else {
                Route::Interval
            };
            assert_eq!(tracer.routes()[0], want);
            let got = angular_radius(&tracer, 1000.0);
            assert!(
                (got - expected).abs() < 1e-6,
                "{space:?} d = {d} ({method}): {got} rad, closed form {expected}"
            );
        }
    }
    // In S3 a ball about the camera's antipode fills the view: every ray
    // meets it, after pi R - r.
    let sc = ball_at(&s3, r, std::f64::consts::PI * big_r, "auto");
    let tracer = Tracer::new(&sc);
    let mut s = Scratch::default();
    for a in [0.0f64, 0.7, 1.5, 2.5, 3.1] {
        let d = DVec3::new(a.cos(), 0.3 * a.sin(), 0.95 * a.sin()).normalize();
        let hit = tracer.nearest_hit(DVec3::ZERO, d, 1000.0, &mut s);
        let t = hit.expect("the antipodal ball fills the view").t;
        assert!((t - (std::f64::consts::PI * big_r - r)).abs() < 1e-6, "{t}");
    }
}

/// The silhouette in a rendered image has the closed form's radius to
/// within a pixel.
#[test]
fn the_rendered_silhouette_has_the_closed_form_radius() {
    let (big_r, r, d) = (5.0f64, 1.0f64, 11.0f64);
    let expected = ((r / big_r).sin() / (d / big_r).sin()).asin();
    let (w, h, fov) = (201u32, 201u32, 90.0f64);
    let sc = scene(&format!(
        "space s3 {{ radius {big_r} }}\ncamera {{ position (0, 0, 0) fov {fov} width {w} height {h} }}\nbackground black\nambient 1\nobject sphere({r}) {{ translate ({d}, 0, 0) colour white }}"
    ));
    let (img, _) = nes::render(&sc);
    // The middle row: lit pixels are the ball.
    let row = (h / 2) as usize;
    let lit: Vec<usize> = (0..w as usize)
        .filter(|&x| img.pixels[row * w as usize + x].x > 0.5)
        .collect();
    let width_px = (lit.last().unwrap() - lit.first().unwrap() + 1) as f64;
    // Rectilinear: a pixel spans tan(half fov) / half diagonal.
    let per_pixel = (0.5 * fov.to_radians()).tan() / (0.5 * ((w * w + h * h) as f64).sqrt());
    let want = 2.0 * expected.tan() / per_pixel;
    assert!(
        (width_px - want).abs() <= 2.0,
        "silhouette {width_px} px wide, closed form {want}"
    );
}

/// Shadow rays are blocked exactly when the geodesic, computed here in the
/// model on its own, passes within the blocker's radius; in S3 the long
/// arc lights what the short one cannot.
#[test]
fn shadows_follow_both_arcs_of_the_great_circle() {
    let big_r = 4.0f64;
    let sc = scene(&format!(
        "space s3 {{ radius {big_r} }}\ncamera {{ position (-2, 0, 0) }}\nobject sphere(0.6) {{ translate (3, 0, 0) }}"
    ));
    let tracer = Tracer::new(&sc);
    let mut s = Scratch::default();
    // The model, independently: normal coordinates to R^4.
    let exp = |p: DVec3| {
        let t = p.length() / big_r;
        let u = if p.length() > 0.0 {
            p / p.length()
        } else {
            DVec3::X
        };
        (big_r * t.cos(), u * big_r * t.sin())
    };
    let dist = |a: (f64, DVec3), b: (f64, DVec3)| {
        let c = (a.0 * b.0 + a.1.dot(b.1)) / (big_r * big_r);
        big_r * c.clamp(-1.0, 1.0).acos()
    };
    let centre = exp(DVec3::new(3.0, 0.0, 0.0));
    // Points on both sides of the ball from the light: the short arc is
    // blocked beyond it, the long arc (leaving away from the light) before.
    let light = DVec3::new(-3.0, 0.2, 0.1);
    let mut blocked_seen = [0, 0];
    for i in 0..60 {
        let p = DVec3::new(1.0 + 0.07 * i as f64, 0.3 - 0.01 * i as f64, 0.1);
        let paths = tracer.light_paths(p, light);
        let (a, b) = (exp(p), exp(light));
        for (k, path) in paths.into_iter().enumerate() {
            let path = path.expect("S3 has both arcs");
            let (dir, len) = (path.walk, path.length);
            let blocked = tracer.blocked(p, dir, len, &mut s);
            // Points of the arc in the model, from a towards b the short
            // way (k = 0) or the long way (k = 1).
            let angle = dist(a, b) / big_r;
            let along = if k == 0 {
                angle
            } else {
                angle - 2.0 * std::f64::consts::PI
            };
            let closest = (0..=20000)
                .map(|j| {
                    let s = along * j as f64 / 20000.0;
                    // Slerp on the great circle through a and b.
                    let w0 = ((angle - s).sin() / angle.sin(), s.sin() / angle.sin());
                    let x = (w0.0 * a.0 + w0.1 * b.0, a.1 * w0.0 + b.1 * w0.1);
                    dist(x, centre)
                })
                .fold(f64::INFINITY, f64::min);
            if (closest - 0.6).abs() > 1e-3 {
                assert_eq!(
                    blocked,
                    closest < 0.6,
                    "point {p}, arc {k}: closest {closest}"
                );
                blocked_seen[k] += blocked as usize;
            }
        }
    }
    assert!(
        blocked_seen[0] > 0 && blocked_seen[1] > 0,
        "{blocked_seen:?}"
    );
}

/// As the radius grows, S3 and H3 look like Euclidean space: the object
/// seen in each pixel agrees but for a few pixels on silhouettes.
#[test]
fn images_converge_to_euclidean_as_the_radius_grows() {
    let objects = "object sphere(2) { translate (7, 0, 0) }\nobject sphere(0.5) { translate (4.5, -2, 1.6) }\nobject plane((0, 0, 1), -3)\nobject torus(1, 0.3) { rotate 30 about x translate (5, 2.5, -1) }";
    let camera = "camera { position (-4, 0, -1.5) pitch 10 fov 84 width 120 height 80 }";
    let ids = |space: &str| {
        let sc = scene(&format!("{space}\n{camera}\n{objects}"));
        let tracer = Tracer::new(&sc);
        let mut s = Scratch::default();
        let rays = sc.camera.rays();
        let mut out = Vec::new();
        for y in 0..80 {
            for x in 0..120 {
                let d = rays.direction(x as f64 + 0.5, y as f64 + 0.5);
                out.push(
                    tracer
                        .nearest_hit(sc.camera.position, d, 100.0, &mut s)
                        .map(|h| h.object),
                );
            }
        }
        out
    };
    let flat = ids("");
    for curved in ["s3", "h3"] {
        let mut differing = Vec::new();
        for big_r in [30.0, 300.0, 3000.0] {
            let other = ids(&format!("space {curved} {{ radius {big_r} }}"));
            differing.push(flat.iter().zip(&other).filter(|(a, b)| a != b).count());
        }
        eprintln!("{curved}: pixels differing from Euclidean at R = 30, 300, 3000: {differing:?}");
        assert!(
            differing[0] > differing[2] && differing[2] <= 10,
            "{curved}: pixels differing from Euclidean at R = 30, 300, 3000: {differing:?}"
        );
    }
}

/// Bad space parameters get a diagnostic, not a render.
#[test]
fn bad_curvature_radii_are_diagnosed() {
    for (bad, code) in [
        ("space s3 { radius 0 }", "E0301"),
        ("space h3 { radius -2 }", "E0301"),
        ("space h3 { radius 1e9 }", "E0301"),
        ("space s3 { loops 0 }", "E0301"),
        ("space h3 { loops 2 }", "E0104"),
    ] {
        let e = nes::compile_source("bad.nes", bad).expect_err(bad);
        assert!(
            e.diagnostics.iter().any(|d| d.code.as_str() == code),
            "{bad}: {}",
            e.render_plain()
        );
    }
    let e = nes::compile_source(
        "bad.nes",
        "space s3\nobject sphere(1) { translate (1, 0, 0) scale 2 }",
    )
    .expect_err("scale after translate");
    assert!(e.render_plain().contains("scale"), "{}", e.render_plain());
}

/// The closed form and interval isolation see the same object in every
/// pixel of the seed's scene in S3 and H3, each hit on its surface.
#[test]
fn closed_form_and_interval_isolation_agree_per_pixel() {
    let seed = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/seed.nes"))
        .expect("the seed scene");
    for space in ["s3", "h3"] {
        let ids = |method: &str| {
            let src = format!(
                "space {space} {{ radius 8 }}\nrender {{ method {method} }}\n{}",
                seed.replace("width  1500", "width 90")
                    .replace("height 1000", "height 60")
            );
            let sc = scene(&src);
            let tracer = Tracer::new(&sc);
            let mut s = Scratch::default();
            let rays = sc.camera.rays();
            let mut out = Vec::new();
            for y in 0..60 {
                for x in 0..90 {
                    let d = rays.direction(x as f64 + 0.5, y as f64 + 0.5);
                    out.push(
                        tracer
                            .nearest_hit(sc.camera.position, d, 100.0, &mut s)
                            .map(|h| {
                                let f = &sc.objects[h.object].function;
                                (h.object, f.value(h.local, &mut Vec::new()))
                            }),
                    );
                }
            }
            out
        };
        let (closed, searched) = (ids("auto"), ids("interval"));
        let mut hits = 0;
        for (a, b) in closed.iter().zip(&searched) {
            match (a, b) {
                (Some((i, fa)), Some((j, fb))) => {
                    hits += 1;
                    assert_eq!(i, j);
                    // Both on the surface (to epsilon in the distance the
                    // value estimates); along a grazing path their
                    // distances may differ by more.
                    assert!(fa.abs() < 1e-9 && fb.abs() < 1e-5, "{space}: {fa} and {fb}");
                }
                (None, None) => {}
                _ => panic!("{space}: {a:?} vs {b:?}"),
            }
        }
        assert!(hits > 1000, "{space}: {hits}");
    }
}

/// A translated part of a combination is moved by the space's motion, as
/// a whole object would be: the union of a ball and a moved ball is hit
/// where the nearer of the two separate objects is.
#[test]
fn a_moved_part_of_a_combination_is_where_the_moved_object_is() {
    for space in ["space s3 { radius 4 }", "space h3 { radius 2 }"] {
        let union = scene(&format!(
            "{space}\ncamera {{ position (0, 0, 0) }}\nobject union(sphere(0.7), sphere(0.5) rotate 30 about z translate (0.4, 1.2, 0.3)) {{ translate (3, 0, 0) }}"
        ));
        let apart = scene(&format!(
            "{space}\ncamera {{ position (0, 0, 0) }}\nobject sphere(0.7) {{ translate (3, 0, 0) }}\nobject sphere(0.5) {{ rotate 30 about z translate (0.4, 1.2, 0.3) translate (3, 0, 0) }}"
        ));
        let (a, b) = (Tracer::new(&union), Tracer::new(&apart));
        let mut s = Scratch::default();
        let mut hits = 0;
        for i in 0..400 {
            let u = (i % 20) as f64 / 19.0 - 0.5;
            let v = (i / 20) as f64 / 19.0 - 0.5;
            let d = DVec3::new(1.0, 0.9 * u, 0.9 * v).normalize();
            let ha = a.nearest_hit(DVec3::ZERO, d, 50.0, &mut s).map(|h| h.t);
            let hb = b.nearest_hit(DVec3::ZERO, d, 50.0, &mut s).map(|h| h.t);
            match (ha, hb) {
                (Some(x), Some(y)) => {
                    hits += 1;
                    assert!((x - y).abs() < 1e-5, "{space}: {d}: {x} vs {y}");
                }
                (None, None) => {}
                _ => panic!("{space}: {d}: {ha:?} vs {hb:?}"),
            }
        }
        assert!(hits > 50, "{space}: {hits}");
    }
}

/// In H3 a path ends where it leaves the ball of 12 R about the origin,
/// not after 12 R less its start's distance: from a camera 7 R to 11.5 R
/// out, a ball at the origin is hit where the closed form says, at the
/// camera's distance less the ball's radius (rays once ended after
/// 12 R - 7 R = 5 R, and the ball was missing with no warning).
#[test]
fn h3_paths_towards_the_origin_reach_it_from_far_out() {
    for (radius, d) in [(1.0, 7.0), (1.0, 11.5), (10.0, 65.0)] {
        let r = 0.5 * radius;
        let sc = scene(&format!(
            "space h3 {{ radius {radius} }}\ncamera {{ position ({}, 0, 0) look_at (0, 0, 0) }}\nrender {{ max_distance 1000 }}\nobject sphere({r})",
            -d
        ));
        let tracer = Tracer::new(&sc);
        let mut s = Scratch::default();
        let hit = tracer
            .nearest_hit(DVec3::new(-d, 0.0, 0.0), DVec3::X, 1000.0, &mut s)
            .unwrap_or_else(|| panic!("R {radius}, camera at {d}: the ball is missed"));
        assert!(
            (hit.t - (d - r)).abs() < 1e-6 * d,
            "R {radius}, d {d}: hit at {}",
            hit.t
        );
    }
}

/// A smooth union of balls moved in the formula: beyond S3's cut locus
/// their distances' intervals reach +inf, and the blend of two infinities
/// once gave NaN, so the object was said to have no surface (W0005) and
/// drawn as nothing. It has a bound, and rays meet it.
#[test]
fn a_smooth_union_of_moved_balls_in_s3_is_drawn() {
    let s = scene(
        "space s3 { radius 10 }\ncamera { position (-6.5, -4.5, 3.6) look_at (0, 0, 0) }\n\
         object smin(sphere(1) translate (0.8, 0, 0), sphere(0.8) translate (-0.6, 0.5, 0.3), 0.5)\n",
    );
    assert!(s.objects[0].bound.is_some(), "no bound");
    assert!(
        !s.warnings
            .iter()
            .any(|w| w.message.contains("no ray can reach")),
        "{:?}",
        s.warnings.iter().map(|w| &w.message).collect::<Vec<_>>()
    );
    let tracer = Tracer::new(&s);
    let mut scratch = nes::trace::intersect::Scratch::default();
    let origin = s.camera.position;
    let hit = tracer.nearest_hit(origin, s.camera.forward, 100.0, &mut scratch);
    assert!(hit.is_some(), "the camera's central ray misses it");
}

/// A geodesic through the ball about an object's bound that misses the
/// bound's box costs no search: the piece is clipped to the box by its
/// tangent line and error bars. One through the box is searched and hits.
#[test]
fn a_path_past_the_corner_of_a_bound_costs_no_search() {
    for space in ["s3", "h3"] {
        let sc = scene(&format!(
            "space {space} {{ radius 8 }}\ncamera {{ position (-5, 0, 0) }}\n\
             object x^4 + y^4 + z^4 - 1 {{ }}"
        ));
        let tracer = Tracer::new(&sc);
        let bound = sc.objects[0].bound.expect("a bound");
        let corner = bound.max.length();
        assert!(bound.max.max_element() < 1.01, "{space}: {bound:?}");
        let mut s = Scratch::default();
        // Past the box's edge at 1.2 off both axes (1.70 from the centre,
        // inside the ball of radius |corner| = 1.73), from 5 units away.
        let origin = DVec3::new(-5.0, 1.2, 1.2);
        assert!(1.2f64.hypot(1.2) < corner);
        let missed = tracer.nearest_hit(origin, DVec3::X, 100.0, &mut s);
        assert!(missed.is_none(), "{space}: {missed:?}");
        assert_eq!(s.evaluations, 0, "{space}: the corner path was searched");
        let hit = tracer.nearest_hit(DVec3::new(-5.0, 0.3, 0.2), DVec3::X, 100.0, &mut s);
        assert!(hit.is_some() && s.evaluations > 0, "{space}: {hit:?}");
    }
}
