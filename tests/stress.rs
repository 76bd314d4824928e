//! Numerical stress: inputs at the edges of what the renderer must handle,
//! each checked against an independent computation (closed-form geometry),
//! never against the renderer itself.

use glam::DVec3;
use nes::trace::intersect::Scratch;
use nes::trace::Tracer;

fn scene(src: &str) -> nes::Scene {
    nes::compile_source("stress.nes", src).unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

fn hit(scene: &nes::Scene, o: DVec3, d: DVec3) -> Option<nes::trace::Hit> {
    let tracer = Tracer::new(scene);
    let mut s = Scratch::default();
    tracer.nearest_hit(o, d.normalize(), scene.settings.max_distance, &mut s)
}

/// The nearest positive root of |o + t d - c|^2 = r^2.
fn sphere_hit(o: DVec3, d: DVec3, c: DVec3, r: f64) -> Option<f64> {
    let d = d.normalize();
    let oc = o - c;
    let b = oc.dot(d);
    let q = oc.length_squared() - r * r;
    let disc = b * b - q;
    if disc < 0.0 {
        return None;
    }
    // The stable form: no cancellation when the root is small.
    let s = -b - disc.sqrt().copysign(b);
    let (t1, t2) = (q / s, s);
    let (lo, hi) = (t1.min(t2), t1.max(t2));
    [lo, hi].into_iter().find(|&t| t > 0.0)
}

/// Objects a million units away, written both as a quadric and as a
/// non-polynomial shape: hits within a relative 1e-12 of the true distance.
#[test]
fn objects_far_from_the_origin_keep_their_precision() {
    let c = DVec3::new(1e6, 2e6, -5e5);
    let o = c + DVec3::new(-10.0, 0.3, 0.2);
    for shape in ["sphere(1)", "exp(x^2 + y^2 + z^2 - 1) - 1"] {
        let s = scene(&format!(
            "camera {{ position ({}, {}, {}) look_at ({}, {}, {}) }}\n\
             render {{ max_distance 100 }}\n\
             shape s = {shape}\nobject s {{ translate ({}, {}, {}) }}",
            o.x, o.y, o.z, c.x, c.y, c.z, c.x, c.y, c.z
        ));
        let want = sphere_hit(o, DVec3::X, c, 1.0).unwrap();
        let got = hit(&s, o, DVec3::X).expect(shape).t;
        assert!(
            (got - want).abs() <= 1e-6 + 1e-12 * want,
            "{shape}: {got} vs {want}"
        );
    }
}

/// A sphere of radius 1e-6 seen from 5 units: found, at the right distance.
#[test]
fn tiny_objects_are_found() {
    for shape in ["sphere(1e-6)", "exp(x^2 + y^2 + z^2 - 1e-12) - 1"] {
        let s = scene(&format!(
            "camera {{ position (-5, 0, 0) }}\nrender {{ epsilon 1e-9 }}\nshape s = {shape}\nobject s"
        ));
        let o = DVec3::new(-5.0, 2e-7, -1e-7);
        let want = sphere_hit(o, DVec3::X, DVec3::ZERO, 1e-6).unwrap();
        let got = hit(&s, o, DVec3::X).expect(shape).t;
        assert!((got - want).abs() < 1e-8, "{shape}: {got} vs {want}");
    }
}

/// A cone's apex has a zero gradient: the normal there falls back to a
/// stable direction, and no pixel turns NaN.
#[test]
fn a_zero_gradient_at_the_hit_gives_a_finite_normal() {
    // x^2 + y^2 - z^2 = 0, apex at the origin, seen along its axis's
    // perpendicular straight through the apex.
    let s = scene(
        "camera { position (-5, 0, 0) look_at (0, 0, 0) width 21 height 21 }\n\
         light { position (-4, 3, 5) }\n\
         shape cone2 = x^2 + y^2 - z^2\nobject cone2",
    );
    let h = hit(&s, DVec3::new(-5.0, 0.0, 0.0), DVec3::X).expect("the apex is hit");
    assert!(h.point.length() < 1e-5, "{}", h.point);
    let tracer = Tracer::new(&s);
    let n = tracer.normal(&h, &mut Scratch::default());
    assert!(n.is_finite() && (n.length() - 1.0).abs() < 1e-9, "{n}");
    let (img, stats) = nes::render(&s);
    assert!(img.pixels.iter().all(|p| p.is_finite()));
    assert_eq!(stats.nonfinite_pixels, 0);
}

/// Functions undefined on part of space: each pixel is either the right
/// object or the background, never poisoned (the red sphere shows exactly
/// where its closed-form hit is not covered, and the defined shape exactly
/// where the unit sphere's closed form puts it), and no pixel is counted
/// as non-finite.
#[test]
fn partly_undefined_functions_stay_local_and_are_counted() {
    for (shape, undefined_somewhere) in [
        ("sqrt(x) + y^2 + z^2 - 1", true),
        ("1/x + y^2 + z^2 - 4", true),
        ("ln(z + 2) + x^2 + y^2 - 1", true),
        ("x^2 + y^2 + z^2 - 1", false),
    ] {
        let s = scene(&format!(
            "camera {{ position (-6, 0.2, 0.1) look_at (0, 0, 0) width 30 height 20 }}\n\
             light {{ position (-5, -5, 5) }}\n\
             object sphere(0.5) {{ translate (0, 3, 0) colour red }}\n\
             shape s = {shape}\nobject s {{ colour green }}"
        ));
        let (img, stats) = nes::render(&s);
        assert!(img.pixels.iter().all(|p| p.is_finite()), "{shape}");
        // Where the gradient is not finite the normal falls back to the
        // view direction, so no hit's colour is non-finite: no pixel fell
        // back to the background, here or where the function is defined
        // everywhere.
        assert_eq!(stats.nonfinite_pixels, 0, "{shape}");
        // Lit by a white light, a pixel is its object's linear colour
        // times a positive number: each pixel is red, green or the black
        // background, never a mixture.
        let red = linear([220, 40, 40]);
        let green = linear([40, 170, 70]);
        let along = |p: DVec3, c: DVec3| {
            p.length() > 0.0 && (p.normalize() - c.normalize()).length() < 1e-9
        };
        let rays = s.camera.rays();
        let mut greens = 0;
        for y in 0..20 {
            for x in 0..30 {
                let p = img.pixel(x, y);
                let d = rays.direction(x as f64 + 0.5, y as f64 + 0.5);
                let o = s.camera.position;
                let at_red = sphere_hit(o, d, DVec3::new(0.0, 3.0, 0.0), 0.5);
                let (is_red, is_green) = (along(p, red), along(p, green));
                assert!(
                    is_red || is_green || p == DVec3::ZERO,
                    "{shape}: pixel ({x}, {y}) is {p}"
                );
                greens += usize::from(is_green);
                // The red sphere shows exactly where its closed-form hit is
                // not covered by the green shape.
                assert_eq!(
                    is_red,
                    at_red.is_some() && !is_green,
                    "{shape}: pixel ({x}, {y}) is {p}, red sphere at {at_red:?}"
                );
                if !undefined_somewhere {
                    // The unit sphere, in front of the red one wherever
                    // both are on the ray.
                    let at_green = sphere_hit(o, d, DVec3::ZERO, 1.0);
                    let green_in_front = match (at_green, at_red) {
                        (Some(g), Some(r)) => g < r,
                        (g, _) => g.is_some(),
                    };
                    assert_eq!(is_green, green_in_front, "{shape}: pixel ({x}, {y})");
                }
            }
        }
        assert!(greens >= 30, "{shape}: the shape shows in {greens} pixels");
    }
}

/// An 8-bit sRGB colour as linear light.
fn linear(c: [u8; 3]) -> DVec3 {
    DVec3::from_array(c.map(|v| nes::shade::srgb_to_linear(v as f64 / 255.0)))
}

/// Rays exactly parallel to a lattice axis in the torus never drift off
/// their line: after 50 wraps along x the ray meets the sphere copy on its
/// own row, at the distance the lattice gives.
#[test]
fn torus_rays_parallel_to_an_axis_stay_on_their_row() {
    let s = scene(
        "space torus { min -5 max 5 wraps 100 }\n\
         camera { position (0, 0, 0) }\n\
         render { max_distance 1000 }\n\
         object sphere(0.5) { translate (0, 3, 2) }",
    );
    // Along +x at height y = 3, z = 2: the sphere copies at x = 0, 10, ...
    let o = DVec3::new(1.0, 3.0, 2.0);
    let h = hit(&s, o, DVec3::X).expect("a copy ahead");
    assert!((h.t - (10.0 - 1.0 - 0.5)).abs() < 1e-9, "{}", h.t);
    // Offset by 0.6 in z: the ray passes every copy at distance 0.6 > 0.5.
    let miss = hit(&s, DVec3::new(1.0, 3.0, 2.6), DVec3::X);
    assert!(miss.is_none(), "{miss:?}");
}

/// An object touching a face of the torus cell, and a camera on a face:
/// the sphere is whole across the face (periodic), hit where the lattice
/// says.
#[test]
fn torus_faces_are_seamless() {
    let s = scene(
        "space torus { min -5 max 5 wraps 20 }\n\
         camera { position (-5, 0, 0) }\n\
         object sphere(1) { translate (4.5, 0, 0) }",
    );
    // The camera on the face x = -5, beside the sphere's copy across the
    // face (centre -5.5), looking along -y at it.
    let o = DVec3::new(-5.0, 3.0, 0.0);
    let d = DVec3::NEG_Y;
    let want = sphere_hit(o, d, DVec3::new(-5.5, 0.0, 0.0), 1.0)
        .expect("the copy across the face is in the way");
    let got = hit(&s, o, d).expect("hit across the face").t;
    assert!((got - want).abs() < 1e-9, "{got} vs {want}");
}

/// In the sphere space a path returns to its start after one loop, 2 pi R,
/// for any radius; the exact path and the integrated one agree.
#[test]
fn sphere_space_paths_close_after_one_loop() {
    for radius in [1e-3, 1.0, 25.0, 1e6, 1e9] {
        for path in ["exact", "ode"] {
            let s = scene(&format!(
                "space sphere {{ radius {radius} }}\ncamera {{ position (0, 0, 0) }}\nrender {{ method {path} }}"
            ));
            let space = s.build_space();
            let o = DVec3::new(0.3, -0.2, 0.1);
            for d in [DVec3::X, DVec3::new(0.6, 0.0, 0.8), DVec3::Z, DVec3::NEG_Z] {
                let mut end = None;
                let full = std::f64::consts::TAU * radius;
                space.walk(o, d, full, &mut |seg| {
                    let (_, t1) = seg.range();
                    if t1 >= full * (1.0 - 1e-12) {
                        end = Some(seg.point(t1));
                    }
                    std::ops::ControlFlow::Continue(())
                });
                let end = end.expect("the walk reaches the loop's end");
                assert!(end.is_finite(), "R {radius} {path} {d}");
                // Exact: rounding only. Integrated: the tolerance (1e-8
                // per step) accumulated over the loop.
                let allowed = if path == "exact" { 1e-12 } else { 1e-6 };
                assert!(
                    (end - o).length() <= allowed * radius.max(1.0),
                    "R {radius} {path} {d}: ends at {end}, started at {o}"
                );
            }
        }
    }
}

/// The integrator near the coordinates' poles, where the geodesic
/// equations' `cot u` term blows up: a great circle passing 1e-6 rad from
/// the pole still closes, stays within its promised error of the exact
/// circle (global error over a whole loop at most 50x the per-step
/// tolerance), and the step-size control recovers from its rejections
/// instead of collapsing (fewer rejected steps than accepted ones). The
/// `ode` path itself starts every ray 45 degrees from the poles, which is
/// why it needs the fewest steps of all.
#[test]
fn the_integrator_keeps_its_tolerance_near_the_poles() {
    use nes::space::IntegratedLoop;
    use std::f64::consts::{FRAC_PI_4, TAU};
    for tolerance in [1e-4, 1e-6, 1e-8, 1e-10] {
        let reference = IntegratedLoop::new(FRAC_PI_4, tolerance).stats;
        for closest in [FRAC_PI_4, 0.2, 1e-2, 1e-4, 1e-6] {
            let path = IntegratedLoop::new(closest, tolerance);
            let stats = path.stats;
            let mut worst: f64 = 0.0;
            for i in 0..=4000 {
                let t = TAU * i as f64 / 4000.0;
                let p = path.point(t);
                assert!(p.is_finite(), "closest {closest}, tolerance {tolerance}");
                worst = worst.max((p - path.exact_point(t)).length());
            }
            assert!(
                worst <= 50.0 * tolerance,
                "closest {closest}, tolerance {tolerance}: {worst:e} off the circle"
            );
            assert!(stats.rejected < stats.accepted, "{closest}: {stats:?}");
            assert!(stats.accepted >= reference.accepted, "{closest}: {stats:?}");
        }
    }
    // The render's own loop (on a unit sphere) is the 45-degree path.
    let s = scene("space sphere { radius 1 }\ncamera { position (0, 0, 0) }\nrender { method ode tolerance 1e-8 }");
    let space = s.build_space();
    assert_eq!(
        space.integrator_stats(),
        Some(IntegratedLoop::new(FRAC_PI_4, 1e-8).stats)
    );
}

/// Vertical, near-vertical and horizontal rays in the sphere space, on
/// both paths: every path is a circle of radius R through the start, so
/// the chord from the start to the point at distance t is
/// 2 R sin(t / 2R), whichever circle the tilt picks; no point is NaN.
#[test]
fn sphere_space_rays_at_every_tilt_follow_circles_of_radius_r() {
    let radius = 3.0;
    for path in ["exact", "ode"] {
        let s = scene(&format!(
            "space sphere {{ radius {radius} }}\ncamera {{ position (0, 0, 0) }}\nrender {{ method {path} tolerance 1e-10 }}"
        ));
        let space = s.build_space();
        let o = DVec3::new(0.4, -0.3, 0.2);
        for tilt in [0.0, 1e-15, 1e-10, 1e-6, 1e-3] {
            for d in [
                DVec3::new(tilt, 0.0, 1.0),
                DVec3::new(0.0, tilt, -1.0),
                DVec3::new(1.0, tilt, 0.0),
            ] {
                let d = d.normalize();
                let mut checked = 0;
                space.walk(o, d, std::f64::consts::TAU * radius, &mut |seg| {
                    let (a, b) = seg.range();
                    for t in [a, 0.5 * (a + b), b] {
                        let p = seg.point(t);
                        assert!(p.is_finite(), "{path} {d} at {t}");
                        let chord = 2.0 * radius * (t / (2.0 * radius)).sin().abs();
                        assert!(
                            ((p - o).length() - chord).abs() < 1e-6,
                            "{path} {d} at {t}: {} from the start, chord {chord}",
                            (p - o).length()
                        );
                        checked += 1;
                    }
                    std::ops::ControlFlow::Continue(())
                });
                assert!(checked >= 3, "{path} {d}");
            }
        }
    }
}
