//! Scenes whose right answer is known in closed form: the renderer's pixels
//! must match the geometry to within floating-point error.

use glam::DVec3;
use nes::render::{trace_ray, RenderStats};
use nes::shade::srgb_to_linear;
use nes::trace::intersect::Scratch;
use nes::trace::{Route, Tracer};

mod common;

fn scene(src: &str) -> nes::Scene {
    nes::compile_source("test.nes", src).unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

/// The centre pixel of a lit unit sphere has exactly the Lambert value:
/// colour * (ambient + intensity * cos(angle between normal and light)).
#[test]
fn centre_of_a_lit_sphere_has_the_lambert_value() {
    let s = scene(
        "camera { position (-5, 0, 0) look_at (0, 0, 0) width 21 height 21 fov 30 }
         light { position (-5, 5, 0) intensity 0.8 }
         ambient 0.1
         object sphere(1) { colour (0.5, 0.5, 0.5) }",
    );
    let (img, _) = nes::render(&s);
    // The hit is (-1, 0, 0) with normal (-1, 0, 0); the light is at
    // (-5, 5, 0), so the cosine is 4 / sqrt(41).
    let cos = 4.0 / 41f64.sqrt();
    let expected = srgb_to_linear(0.5) * (0.1 + 0.8 * cos);
    let centre = img.pixel(10, 10);
    for c in centre.to_array() {
        assert!((c - expected).abs() < 1e-9, "{c} vs {expected}");
    }
    // Background beyond the sphere's silhouette.
    assert_eq!(img.pixel(0, 0), DVec3::ZERO);
}

/// A sphere of radius 1 at height 2 under a light at height 10 casts a
/// disc of shadow of radius 10 / sqrt(63) on the floor z = 0.
#[test]
fn a_shadow_falls_where_the_tangent_cone_meets_the_floor() {
    let s = scene(
        "camera { position (-6, 0, 3) look_at (0, 0, 0) }
         light { position (0, 0, 10) }
         ambient 0.2
         object sphere(1) { translate (0, 0, 2) colour white }
         object plane((0, 0, 1), 0) { colour (0.5, 0.5, 0.5) }",
    );
    let tracer = Tracer::new(&s);
    let radius = 10.0 / 63f64.sqrt();
    let floor = srgb_to_linear(0.5);
    let mut scratch = Scratch::default();
    let mut stats = RenderStats::default();
    for angle in [0.3f64, 1.7, 2.9, 4.4] {
        for (r, shadowed) in [(radius - 0.02, true), (radius + 0.02, false)] {
            let target = DVec3::new(r * angle.cos(), r * angle.sin(), 0.0);
            let dir = (target - s.camera.position).normalize();
            let (c, _) = trace_ray(&tracer, dir, &mut scratch, &mut stats);
            // Straight down onto the floor, the light's cosine is 10/|L|.
            let to_light = DVec3::new(0.0, 0.0, 10.0) - target;
            let cos = 10.0 / to_light.length();
            let expected = if shadowed {
                floor * 0.2
            } else {
                floor * (0.2 + cos)
            };
            assert!(
                (c.x - expected).abs() < 1e-9,
                "r = {r}, angle = {angle}: {} vs {expected}",
                c.x
            );
        }
    }
}

/// A sphere written out by hand is recognised as a quadric, takes the same
/// closed-form route as the prelude's sphere, and renders identically.
#[test]
fn a_hand_written_sphere_renders_like_the_prelude_sphere() {
    let setup = "camera { position (-4, 1, 1) look_at (0, 0, 0) width 64 height 48 }
                 light { position (-3, -4, 5) }";
    let prelude = scene(&format!(
        "{setup}\nobject sphere(1.5) {{ translate (0.5, 0, 0) }}"
    ));
    let by_hand = scene(&format!(
        "{setup}\nshape ball = (x - 0.5)^2 + y*y + z^2 - 2.25\nobject ball"
    ));
    for s in [&prelude, &by_hand] {
        assert_eq!(Tracer::new(s).routes(), &[Route::Closed]);
    }
    let (a, _) = nes::render(&prelude);
    let (b, _) = nes::render(&by_hand);
    let worst = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| (*p - *q).abs().max_element())
        .fold(0.0, f64::max);
    assert!(worst < 1e-9, "largest pixel difference {worst}");
    assert!(a.pixels.iter().any(|p| p.x > 0.1), "the sphere is visible");
}

/// A formula multiplied by a constant has the same surface, and draws the
/// same image, whatever the constant: a ball (closed form) and a torus
/// (polynomial route), scaled by 1e160 (its coefficients' squares pass
/// 1e308) and by 1e-200 and 1e-300 (theirs fall below 1e-308, and so does
/// the gradient's square, which the normal is made from).
#[test]
fn a_formula_scaled_by_a_huge_or_tiny_constant_draws_the_same_image() {
    let setup = "camera { position (-4, -2.5, 2) look_at (0, 0, 0) width 64 height 48 }
                 light { position (-3, -4, 5) }";
    for shape in [
        "x^2 + y^2 + z^2 - 1",
        "(x^2 + y^2 + z^2 + 1.44 - 0.16)^2 - 4 * 1.44 * (x^2 + y^2)",
    ] {
        let render = |k: &str| {
            let s = scene(&format!("{setup}\nobject ({shape}) * {k}"));
            let (image, stats) = nes::render(&s);
            (image, stats.undefined_pixels)
        };
        let (plain, _) = render("1");
        assert!(plain.pixels.iter().any(|p| p.x > 0.1), "{shape} is visible");
        for k in ["1e160", "1e-200", "1e-300"] {
            let (scaled, lost_normals) = render(k);
            assert_eq!(
                common::pixels_differing(&plain, &scaled, 1e-6),
                0,
                "{shape} times {k}"
            );
            assert_eq!(lost_normals, 0, "{shape} times {k}: normals lost");
        }
    }
}

/// Every route puts the hit on the surface, within its tolerance, and at
/// the distance the closed form gives.
#[test]
fn every_route_finds_the_sphere_hit_at_the_exact_distance() {
    for method in ["exact", "interval", "march", "adaptive"] {
        let s = scene(&format!(
            "camera {{ position (-5, 0.3, 0.2) look_at (0, 0, 0) }}
             render {{ method {method} step 0.01 epsilon 1e-7 }}
             object sphere(1.2) {{ translate (0.1, 0, 0) }}"
        ));
        let tracer = Tracer::new(&s);
        let o = s.camera.position;
        let mut scratch = Scratch::default();
        for (dy, dz) in [(0.0, 0.0), (-0.1, 0.05), (-0.25, -0.2)] {
            let d = (DVec3::new(0.1, 0.0, 0.0) - o + DVec3::new(0.0, dy, dz)).normalize();
            let hit = tracer.nearest_hit(o, d, 100.0, &mut scratch).expect(method);
            // Closed form: |o + t d - c|^2 = r^2.
            let oc = o - DVec3::new(0.1, 0.0, 0.0);
            let b = oc.dot(d);
            let t = -b - (b * b - oc.length_squared() + 1.44).sqrt();
            let tol = if method == "exact" { 1e-12 } else { 2e-6 };
            assert!((hit.t - t).abs() < tol, "{method}: {} vs {t}", hit.t);
        }
    }
}

/// A ball far away and as large (radius 2e7 at 3e7): its expanded
/// quadratic along a ray has a constant term near 5e14 against a leading
/// 1, which once read as a linear equation and lost every hit.
#[test]
fn a_far_and_huge_ball_is_hit_at_the_exact_distance() {
    let s = scene(
        "camera { position (0, -6, 0) look_at (0, 0, 0) }
         render { method exact max_distance 1e10 }
         object sphere(2e7) { translate (0, 3e7, 0) }",
    );
    let tracer = Tracer::new(&s);
    let o = s.camera.position;
    let c = DVec3::new(0.0, 3e7, 0.0);
    let mut scratch = Scratch::default();
    for (dx, dz) in [(0.0, 0.0), (0.2, 0.1), (-0.5, 0.3)] {
        let d = DVec3::new(dx, 1.0, dz).normalize();
        let hit = tracer.nearest_hit(o, d, 1e10, &mut scratch).expect("a hit");
        let oc = o - c;
        let b = oc.dot(d);
        let t = -b - (b * b - oc.length_squared() + 4e14).sqrt();
        assert!((hit.t - t).abs() < 1e-6 * t, "{} vs {t}", hit.t);
    }
}

/// The rendered image of the three routes agrees on which object each
/// pixel shows, for a scene with a quadric, a box and a torus.
#[test]
fn methods_agree_on_what_each_pixel_shows() {
    let src = |m: &str| {
        format!(
            "camera {{ position (-6, -2, 3) look_at (0, 0, 0) width 48 height 32 }}
             light {{ position (-2, -6, 8) }}
             render {{ method {m} step 0.002 }}
             object torus(1, 0.3) {{ colour red }}
             object box(0.4, 0.4, 0.4) {{ translate (0, 0, 1) colour green }}
             object sphere(0.5) {{ translate (1.5, 1.5, 0) colour blue }}"
        )
    };
    let (reference, _) = nes::render(&scene(&src("auto")));
    // Each object shows in the reference, in its own colour (a positive
    // multiple of its linear colour under the white light), so agreeing
    // with it means something.
    for (name, rgb) in [
        ("torus", [220, 40, 40]),
        ("box", [40, 170, 70]),
        ("sphere", [50, 100, 230]),
    ] {
        let c = DVec3::from_array(rgb.map(|v| srgb_to_linear(v as f64 / 255.0))).normalize();
        let shown = reference
            .pixels
            .iter()
            .filter(|p| p.length() > 0.0 && (p.normalize() - c).length() < 1e-9)
            .count();
        assert!(shown >= 10, "the {name} shows in {shown} pixels");
    }
    for m in ["march", "adaptive", "interval"] {
        let (img, _) = nes::render(&scene(&src(m)));
        let differing = common::pixels_differing(&img, &reference, 0.02);
        assert!(differing <= 2, "{m}: {differing} pixels differ from auto");
    }
}
