//! Bad input never panics, hangs or poisons other pixels.

use proptest::prelude::*;

const CAMERA: &str = "camera { position (-4, 0, 0.5) look_at (0, 0, 0) width 24 height 16 }\n";

fn expression() -> impl Strategy<Value = String> {
    let leaf = prop_oneof![
        Just("x".to_string()),
        Just("y".to_string()),
        Just("z".to_string()),
        Just("p".to_string()),
        Just("pi".to_string()),
        (-5.0f64..5.0).prop_map(|v| format!("{v:.3}")),
        Just("0".to_string()),
        Just("(1, 2, 0)".to_string()),
        Just("#ff0000".to_string()),
    ];
    leaf.prop_recursive(4, 24, 3, |inner| {
        let f = prop::sample::select(vec![
            "sin",
            "cos",
            "tan",
            "asin",
            "acos",
            "atan",
            "sinh",
            "cosh",
            "tanh",
            "exp",
            "ln",
            "log",
            "sqrt",
            "abs",
            "sign",
            "length",
            "normalize",
            "sphere",
            "unknown",
        ]);
        let f2 = prop::sample::select(vec![
            "atan2", "min", "max", "pow", "dot", "cross", "torus", "plane",
        ]);
        let op = prop::sample::select(vec!["+", "-", "*", "/", "^"]);
        let f3 = prop::sample::select(vec!["smin", "clamp"]);
        prop_oneof![
            (inner.clone(), op, inner.clone()).prop_map(|(a, o, b)| format!("({a} {o} {b})")),
            (f, inner.clone()).prop_map(|(f, a)| format!("{f}({a})")),
            (f2, inner.clone(), inner.clone()).prop_map(|(f, a, b)| format!("{f}({a}, {b})")),
            (f3, inner.clone(), inner.clone(), inner.clone())
                .prop_map(|(f, a, b, c)| format!("{f}({a}, {b}, {c})")),
            inner.clone().prop_map(|a| format!("-{a}")),
            inner.prop_map(|a| format!("({a}).y")),
        ]
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, .. ProptestConfig::default() })]

    /// Arbitrary bytes: parsing and compiling may fail, never panic.
    #[test]
    fn random_text_never_panics(text in "\\PC{0,200}") {
        let _ = nes::compile_source("fuzz.nes", &text);
    }

    /// Near-miss scene text, cut at random points: never panics, and every
    /// diagnostic's span lies inside the source.
    #[test]
    fn truncated_scenes_never_panic(cut in 0usize..400) {
        let src = include_str!("../examples/csg.nes");
        let mut cut = cut.min(src.len());
        while !src.is_char_boundary(cut) {
            cut -= 1;
        }
        let text = &src[..cut];
        if let Err(e) = nes::compile_source("cut.nes", text) {
            prop_assert!(!e.diagnostics.is_empty());
            for d in &e.diagnostics {
                prop_assert!(d.span().is_some(), "`{}` has no label", d.message);
                for l in &d.labels {
                    prop_assert!(l.span.start <= l.span.end && l.span.end <= text.len());
                }
            }
        }
    }

    /// Random expressions as shapes: they compile or are rejected with
    /// diagnostics; those that compile render to the end without panicking
    /// (one primary ray per pixel, and every non-finite value counted
    /// against at most one pixel each).
    #[test]
    fn random_shapes_compile_or_fail_cleanly_and_render_finite(e in expression()) {
        let src = format!("{CAMERA}light {{ position (-2, -3, 4) }}\nshape s = {e}\nobject s");
        match nes::compile_source("shape.nes", &src) {
            Err(err) => prop_assert!(!err.diagnostics.is_empty()),
            Ok(mut scene) => {
                scene.settings.max_steps = 2000;
                let (img, stats) = nes::render(&scene);
                prop_assert_eq!((img.width, img.height), (24, 16));
                let pixels = (img.width * img.height) as u64;
                prop_assert_eq!(stats.primary_rays, pixels);
                // Every pixel is finite: a non-finite colour fell back to
                // the background.
                prop_assert!(img.pixels.iter().all(|p| p.is_finite()));
                // One sample per pixel: ray by ray, the pixel is that
                // ray's colour, the background where the ray met a
                // non-finite value, and the count is the number of such
                // rays, exactly.
                let tracer = nes::trace::Tracer::new(&scene);
                let rays = scene.camera.rays();
                let mut scratch = nes::trace::intersect::Scratch::default();
                let mut again = nes::RenderStats::default();
                let mut broken = 0;
                for y in 0..img.height {
                    for x in 0..img.width {
                        let d = rays.direction(x as f64 + 0.5, y as f64 + 0.5);
                        let (c, bad) = nes::render::trace_ray(&tracer, d, &mut scratch, &mut again);
                        prop_assert_eq!(img.pixel(x, y), c, "pixel ({}, {})", x, y);
                        if bad {
                            prop_assert_eq!(c, scene.background);
                            broken += 1;
                        }
                    }
                }
                prop_assert_eq!(stats.nonfinite_pixels, broken);
            }
        }
    }
}

/// A shape undefined on half of space (sqrt of a negative, ln of a
/// negative, 1/x at x = 0) leaves the other objects' pixels untouched.
#[test]
fn nan_in_one_object_does_not_leak_into_other_pixels() {
    let base = "camera { position (-6, 0, 0) look_at (0, 0, 0) width 40 height 20 }
                light { position (-5, -5, 5) }
                object sphere(1) { translate (0, 2, 0) colour red }";
    let with_bad = format!(
        "{base}
         shape bad = sqrt(x) + ln(-y) + 1/x - 2
         object bad {{ colour green }}"
    );
    let (clean, _) = nes::render(&nes::compile_source("a.nes", base).unwrap());
    let (dirty, stats) = nes::render(&nes::compile_source("b.nes", &with_bad).unwrap());
    assert!(dirty.pixels.iter().all(|p| p.is_finite()));
    // The sphere sits on the image's left half (y > 0 is left); the bad
    // shape lives where y < 0, on the right. The left half is unchanged,
    // pixel for pixel.
    for y in 0..20 {
        for x in 0..20 {
            assert_eq!(clean.pixel(x, y), dirty.pixel(x, y), "pixel ({x}, {y})");
        }
    }
    // On the right the bad shape shows, in its own colour (a positive
    // multiple of green's linear value under the white light) and nothing
    // else: no NaN turned into some other colour.
    let green = glam::DVec3::from_array(
        [40.0, 170.0, 70.0].map(|v: f64| nes::shade::srgb_to_linear(v / 255.0)),
    );
    let mut shown = 0;
    for y in 0..20 {
        for x in 20..40 {
            let (c, d) = (clean.pixel(x, y), dirty.pixel(x, y));
            assert_eq!(c, glam::DVec3::ZERO, "pixel ({x}, {y})");
            if d != c {
                assert!(
                    (d.normalize() - green.normalize()).length() < 1e-9,
                    "pixel ({x}, {y}) is {d}"
                );
                shown += 1;
            }
        }
    }
    assert!(shown >= 100, "the bad shape shows in only {shown} pixels");
    assert_eq!(stats.primary_rays, 800);
    assert_eq!(stats.nonfinite_pixels, 0);
}

/// Deep nesting and long chains are parsed in linear time and either
/// compile or get a diagnostic; past the limits they are rejected, never a
/// stack overflow. (With backtracking alternatives, 200 nested brackets
/// would take 2^200 steps: this test would not finish.)
#[test]
fn deep_nesting_and_long_chains_are_handled() {
    let camera = "camera { position (-5, 0, 0) }\n";
    let cases = [
        (
            format!("let a = {}1{}\n", "(".repeat(200), ")".repeat(200)),
            true,
        ),
        (
            format!("let a = {}1{}\n", "(".repeat(300), ")".repeat(300)),
            false,
        ),
        (
            format!("shape s = {}x\nobject s\n", "x+".repeat(15_000)),
            true,
        ),
        (format!("let a = {}1\n", "2^".repeat(15_000)), true),
        (format!("let a = {}1\n", "-".repeat(15_000)), true),
        (format!("let a = {}1\n", "-".repeat(30_000)), false),
    ];
    for (body, ok) in cases {
        let result = nes::compile_source("deep.nes", &format!("{camera}{body}"));
        assert_eq!(result.is_ok(), ok, "{}...", &body[..40]);
    }
}

/// Each kind of untrusted pixel is counted, and warned about, and a
/// sound scene has none: searches that run out of steps, hits that the
/// coordinates' precision cannot place within epsilon, and hits where the
/// function's gradient overflows.
#[test]
fn untrusted_pixels_are_counted_by_kind() {
    let camera = "camera { position (-6, -2, 2.5) look_at (0, 0, 0.5) width 40 height 25 }\n\
                  light { position (-3, -6, 8) }\n";
    let render = |body: &str| {
        let scene = nes::compile_source("t.nes", &format!("{camera}{body}")).unwrap();
        let (_, stats) = nes::render(&scene);
        (stats, stats.warnings(&scene.settings))
    };
    let heart =
        "shape heart = (x^2 + 9/4*y^2 + z^2 - 1)^3 - x^2*z^3 - 9/80*y^2*z^3\nobject heart\n";
    let (sound, warnings) = render(heart);
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(
        sound.out_of_steps_pixels + sound.imprecise_pixels + sound.undefined_pixels,
        0
    );

    let (starved, warnings) = render(&format!("render {{ max_steps 2 }}\n{heart}"));
    assert!(starved.out_of_steps_pixels > 0);
    assert!(warnings
        .iter()
        .any(|w| w.code.as_str() == "W0101" && w.text.contains("ran out of steps (max_steps 2)")));
    // A march with a tiny step runs out for want of step, and is told so.
    let (crawling, warnings) = render(&format!(
        "render {{ method march step 1e-5 max_steps 1000 }}\n{heart}"
    ));
    assert!(crawling.out_of_steps_pixels > 0);
    assert!(
        warnings
            .iter()
            .any(|w| w.code.as_str() == "W0101" && w.text.contains("raise `step` (now 1e-5)")),
        "{warnings:?}"
    );

    // 1e12 away the floats are 1e-4 apart: epsilon 1e-6 cannot be met.
    let far = "camera { position (1e12, -5, 0) look_at (1e12, 0, 0) width 40 height 25 }\n\
               shape quartic = x^4 + y^4 + z^4 - 1\nobject quartic { translate (1e12, 0, 0) }\n";
    let scene = nes::compile_source("far.nes", far).unwrap();
    let (_, stats) = nes::render(&scene);
    assert!(stats.imprecise_pixels > 0);
    assert!(stats
        .warnings(&scene.settings)
        .iter()
        .any(|w| w.code.as_str() == "W0102" && w.text.contains("epsilon")));
    let near = far.replace("1e12", "1e3");
    let (_, stats) = nes::render(&nes::compile_source("near.nes", &near).unwrap());
    assert_eq!(stats.imprecise_pixels, 0);

    // Squashed by 1e-300, the sphere's gradient overflows.
    let (flat, warnings) = render("object sphere(1) { scale (1e-300, 1, 1) }\n");
    assert!(flat.undefined_pixels > 0);
    assert!(warnings
        .iter()
        .any(|w| w.code.as_str() == "W0103" && w.text.contains("NaN or infinite")));

    // A colour formula that is NaN on half the ball (sqrt of x < 0): those
    // pixels are counted, the others are not (they were drawn black
    // without a word).
    let (half, warnings) = render("object sphere(1) { colour mix(red, blue, sqrt(x)) }\n");
    let (whole, _) = render("object sphere(1) { colour mix(red, blue, sqrt(abs(x))) }\n");
    assert!(half.undefined_colour_pixels > 0, "{half:?}");
    assert_eq!(whole.undefined_colour_pixels, 0);
    assert!(warnings
        .iter()
        .any(|w| w.code.as_str() == "W0105" && w.text.contains("colour formula is not a number")));

    // Overflowing to -inf inside and +inf outside, the ball's surface
    // cannot be located: its pixels are counted, not silently background.
    let (overflow, warnings) = render("object (x*x + y*y + z*z - 1) * 1e308 * 1e308\n");
    assert!(overflow.overflow_pixels > 50, "{overflow:?}");
    assert!(warnings
        .iter()
        .any(|w| w.code.as_str() == "W0104" && w.text.contains("overflows to infinity")));
    // A pole is no overflow: 1/x changes sign through infinity at x = 0.
    let (pole, _) = render("object 1 / x + 0 * sphere(1)\n");
    assert_eq!(pole.overflow_pixels, 0, "{pole:?}");
}

/// A rotation axis, a direction parameter or a camera vector whose length
/// overflows is still a direction: the same as its scaled-down twin.
#[test]
fn vectors_whose_length_overflows_are_directions() {
    let scene = |axis: &str, up: &str| {
        let src = format!(
            "camera {{ position (-6, 0.5, 1) look_at (0, 0, 0) up {up} width 24 height 16 }}\n\
             light {{ position (-3, -6, 8) }}\n\
             object box(1, 0.5, 0.25) {{ rotate 30 about {axis} }}\n\
             object plane({axis}, -2)\n"
        );
        let scene =
            nes::compile_source("v.nes", &src).unwrap_or_else(|e| panic!("{}", e.render_plain()));
        nes::render(&scene).0
    };
    let huge = scene("(1e300, 1e300, 0)", "(0, 1e300, 1e308)");
    let plain = scene("(1, 1, 0)", "(0, 1e-8, 1)");
    assert!(huge
        .pixels
        .iter()
        .zip(&plain.pixels)
        .all(|(a, b)| (*a - *b).abs().max_element() < 1e-9));
    let zero = "camera { position (-6, 0, 0) }\nobject sphere(1) { rotate 30 about (0, 0, 0) }\n";
    let err = nes::compile_source("z.nes", zero).unwrap_err();
    assert!(err.render_plain().contains("cannot be zero"));
}

/// A surface whose function leaps from -1 to +infinity across it (a power
/// of 1e9, which overflows a nanometre outside) is hit where it is
/// entered, not where the ray leaves it.
#[test]
fn a_surface_whose_function_overflows_is_hit_where_the_ray_enters() {
    let src = "camera { position (-6, -2, 2.5) look_at (0, 0, 0.5) width 40 height 25 }\n\
               shape s = (x^2 + y^2 + (z - 0.5)^2)^1e9 - 1\nobject s\n";
    let scene = nes::compile_source("pow.nes", src).unwrap();
    let tracer = nes::trace::Tracer::new(&scene);
    let mut scratch = nes::trace::intersect::Scratch::default();
    let origin = scene.camera.position;
    let centre = glam::DVec3::new(0.0, 0.0, 0.5);
    for k in 0..50 {
        // Rays through the ball, from its middle outward.
        let aim = centre + glam::DVec3::new(0.0, 0.013 * k as f64, 0.011 * k as f64);
        let d = (aim - origin).normalize();
        let hit = tracer
            .nearest_hit(origin, d, 100.0, &mut scratch)
            .expect("the ray meets the ball");
        // The entry into the unit ball about `centre`.
        let oc = origin - centre;
        let b = oc.dot(d);
        let entry = -b - (b * b - oc.length_squared() + 1.0).sqrt();
        assert!(
            (hit.t - entry).abs() < 1e-5,
            "ray {k}: hit at {}, entry at {entry}",
            hit.t
        );
    }
}

/// `max_steps` bounds one object's searches along a whole ray, however
/// many torus wraps and lattice images the path meets: a loose function
/// in a torus of 285 wraps costs at most a small multiple of it per ray
/// (it was granted again on every wrap, and a 24 x 16 render took two
/// minutes).
#[test]
fn the_step_budget_holds_for_a_whole_ray_in_the_torus() {
    let src = "space torus { min -9 max 9 wraps 285 }\n\
               camera { position (-8.3, 1.8, 1.2) look_at (0, 0, 0) width 12 height 8 }\n\
               render { max_steps 300 }\n\
               shape s1 = atan((atan2(y, z))^(tau * x))\nobject s1\n";
    let scene = nes::compile_source("wraps.nes", src).unwrap();
    let (_, stats) = nes::render(&scene);
    let rays = stats.primary_rays + stats.shadow_rays;
    // A step is one isolation piece: at most 8 interval lanes and 9 point
    // values, and the point evaluations of a final check.
    let most = rays * 300 * 20;
    assert!(
        stats.evaluations <= most,
        "{} evaluations for {rays} rays",
        stats.evaluations
    );
    assert!(stats.out_of_steps_pixels > 0);
}
