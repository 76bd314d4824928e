//! The language's constructs for the shapes people write: functions,
//! local names, moved shapes, conditions, piecewise builtins, sums and
//! lists. Each is checked against the same formula written out by hand
//! (or computed in Rust) at many points; jumps are checked not to be
//! taken for roots along rays whose true first hit is known; and every
//! example in docs/language.md renders.

use glam::DVec3;
use nes::trace::intersect::Scratch;
use nes::trace::Tracer;

mod common;

/// Points spread over [-2.5, 2.5]^3, none on a grid plane.
fn points() -> Vec<DVec3> {
    let mut out = Vec::new();
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 5.0 - 2.5
    };
    for _ in 0..400 {
        out.push(DVec3::new(next(), next(), next()));
    }
    out
}

/// `a` and `b` compile to functions that agree at every sample point.
fn same_function(a: &str, b: &str) {
    agree(
        &common::compile(a),
        &common::compile(b),
        &format!("{a} against {b}"),
    );
}

/// Two compiled functions that agree at every sample point, `what` naming
/// them in a failure.
fn agree(fa: &nes::expr::Implicit, fb: &nes::expr::Implicit, what: &str) {
    let mut slots = Vec::new();
    for p in points() {
        let (va, vb) = (fa.value(p, &mut slots), fb.value(p, &mut slots));
        let tolerance = 1e-12 * (1.0 + va.abs().max(vb.abs()));
        assert!(
            (va - vb).abs() <= tolerance || (va.is_nan() && vb.is_nan()),
            "{what}: {va} against {vb} at {p}"
        );
    }
}

/// `expr` agrees with the Rust function `want` at every sample point.
fn computes(expr: &str, want: impl Fn(DVec3) -> f64) {
    let f = common::compile(expr);
    let mut slots = Vec::new();
    for p in points() {
        let (got, w) = (f.value(p, &mut slots), want(p));
        assert!(
            (got - w).abs() <= 1e-12 * (1.0 + w.abs()),
            "{expr} = {got}, want {w} at {p}"
        );
    }
}

#[test]
fn local_names_moved_shapes_and_functions_mean_their_formulas() {
    same_function(
        "let r = sqrt(x^2 + y^2) in (r - 2)^2 + z^2 - 0.25",
        "(sqrt(x^2 + y^2) - 2)^2 + z^2 - 0.25",
    );
    // An inner name shadows an outer one (the outer once won).
    same_function("let r = 0.1 in let r = 2 in sphere(r)", "sphere(2)");
    same_function("let k = 5 in sum(k in 1..3, k * x)", "1 * x + 2 * x");
    same_function("sphere(1) at (x - 2, y, z)", "(x - 2)^2 + y^2 + z^2 - 1");
    same_function("sphere(1) translate (2, 0, 0)", "(x - 2)^2 + y^2 + z^2 - 1");
    // A quarter turn about z maps (1, 0, 0) to (0, 1, 0): the box is seen
    // at the point turned back.
    same_function(
        "box(1, 2, 0.5) rotate 90 about z",
        "box(1, 2, 0.5) at (y, -x, z)",
    );
    same_function(
        "box(1, 2, 0.5) scale (2, 1, 1)",
        "box(1, 2, 0.5) at (x / 2, y, z)",
    );
    // Transforms apply in the order written, as for solids.
    same_function(
        "sphere(1) translate (1, 0, 0) rotate 90 about z",
        "x^2 + (y - 1)^2 + z^2 - 1",
    );
    same_function(
        "smin(sphere(0.6) translate (1, 0, 0), sphere(0.5), 0.3)",
        "smin((x - 1)^2 + y^2 + z^2 - 0.36, sphere(0.5), 0.3)",
    );
    // A function giving a vector, used as a point.
    let src = "fn mirror(q: vector) = (abs(q.x), q.y, q.z)\nshape s = sphere(0.5) at mirror(p - (0, 0, 0))\ncamera { position (-5, 0, 0) }\nobject s";
    let scene =
        nes::compile_source("fn.nes", src).unwrap_or_else(|e| panic!("{}", e.render_plain()));
    let f = &scene.objects[0].function;
    let mut slots = Vec::new();
    for p in points() {
        let want = p.x.abs().powi(2) + p.y * p.y + p.z * p.z - 0.25;
        assert!((f.value(p, &mut slots) - want).abs() < 1e-12);
    }
}

/// A scene's own shape replaces the builtin of that name where the scene
/// writes it, and nowhere else: the builtins built on it (`cube` on `box`)
/// keep the prelude's, and a scene's constants do not leak into their
/// bodies.
#[test]
fn a_scene_that_defines_box_keeps_the_builtin_cube() {
    let with = |defs: &str| {
        let src = format!(
            "{defs}\ncamera {{ position (-5, 0, 0) }}\nobject cube(1)\nobject box(1, 2, 3) translate (0, 9, 0)"
        );
        let scene = nes::compile_source("case.nes", &src)
            .unwrap_or_else(|e| panic!("{defs}: {}", e.render_plain()));
        (
            scene.objects[0].function.clone(),
            scene.objects[1].function.clone(),
        )
    };
    let (cube, _) = with("");
    let (cube_beside_box, own_box) =
        with("shape box(a, b, c) = x^2 + y^2 + z^2 - 0.09\nlet half = 0.2");
    agree(&cube, &cube_beside_box, "cube beside a scene's own box");
    let mut slots = Vec::new();
    let p = DVec3::new(0.0, 9.0, 0.0);
    assert_eq!(
        own_box.value(p, &mut slots),
        -0.09,
        "the scene's own box is used where it writes box"
    );
}

#[test]
fn sums_products_and_lists_unroll_into_their_terms() {
    same_function(
        "sum(i in 0..4, (x - i)^2)",
        "x^2 + (x - 1)^2 + (x - 2)^2 + (x - 3)^2",
    );
    same_function("sum(i in 1..=3, i * x)", "6 * x");
    same_function("product(k in 1..=3, y - k)", "(y - 1) * (y - 2) * (y - 3)");
    same_function("sum(i in 3..3, x) + z", "z");
    same_function(
        "min(c in [(1, 0, 0), (0, 2, 0)], length(p - c))",
        "min(length(p - (1, 0, 0)), length(p - (0, 2, 0)))",
    );
    same_function("max(c in [0.5, -1, 2], x * c)", "max(0.5 * x, -x, 2 * x)");
    // A range may end at a shape's parameter; its length is known at each use.
    let src = "shape waves(n) = z - sum(i in 1..=n, sin(i * x) / i)\ncamera { position (-5, 0, 0) }\nobject waves(3)";
    let scene =
        nes::compile_source("waves.nes", src).unwrap_or_else(|e| panic!("{}", e.render_plain()));
    let written = common::compile("z - sin(x) - sin(2 * x) / 2 - sin(3 * x) / 3");
    agree(
        &scene.objects[0].function,
        &written,
        "waves(3) against it written out",
    );
    let src = "let cs = [(1, 0, 0), (0, 2, 0)]\nshape s = sum(c in cs, length(p - c)) + cs[1].y\ncamera { position (-5, 0, 0) }\nobject s";
    let scene =
        nes::compile_source("list.nes", src).unwrap_or_else(|e| panic!("{}", e.render_plain()));
    let f = &scene.objects[0].function;
    let mut slots = Vec::new();
    for p in points() {
        let want = (p - DVec3::X).length() + (p - 2.0 * DVec3::Y).length() + 2.0;
        assert!((f.value(p, &mut slots) - want).abs() < 1e-12);
    }
}

#[test]
fn conditions_and_piecewise_builtins_compute_their_values() {
    computes("floor(2 * x) + ceil(y) + round(z)", |p| {
        (2.0 * p.x).floor() + p.y.ceil() + (p.z + 0.5).floor()
    });
    // The real cube root, of negative arguments too.
    computes("cbrt(x) + cbrt(-8)", |p| p.x.cbrt() - 2.0);
    computes("sec(x) + csc(y) + cot(z)", |p| {
        1.0 / p.x.cos() + 1.0 / p.y.sin() + p.z.cos() / p.z.sin()
    });
    computes("asinh(x) + asinh(-1e9 * y)", |p| {
        p.x.asinh() + (-1e9 * p.y).asinh()
    });
    computes("acosh(1 + x^2) + atanh(y / 3)", |p| {
        (1.0 + p.x * p.x).acosh() + (p.y / 3.0).atanh()
    });
    // smin's mirror: the larger where the two differ by k or more, a
    // rounded blend above both in between.
    computes("smax(x, y, 0.5)", |p| {
        let h = (0.5 + (p.x - p.y) / (2.0 * 0.5)).clamp(0.0, 1.0);
        p.y * (1.0 - h) + p.x * h + 0.5 * h * (1.0 - h)
    });

    computes("fract(x) + mod(y, 0.7)", |p| {
        (p.x - p.x.floor()) + 0.7 * (p.y / 0.7 - (p.y / 0.7).floor())
    });
    computes("step(0.2, x) + smoothstep(-1, 1, y)", |p| {
        let t = ((p.y + 1.0) / 2.0).clamp(0.0, 1.0);
        (if p.x >= 0.2 { 1.0 } else { 0.0 }) + t * t * (3.0 - 2.0 * t)
    });
    computes("mix(x, y, z)", |p| p.x + (p.y - p.x) * p.z);
    computes("if x > 0 and not y < 0 then x * y else z - 1", |p| {
        if p.x > 0.0 && p.y >= 0.0 {
            p.x * p.y
        } else {
            p.z - 1.0
        }
    });
    computes("if x < 0 or z > 1 then -x else x", |p| {
        if p.x < 0.0 || p.z > 1.0 {
            -p.x
        } else {
            p.x
        }
    });
    // The branch not taken never poisons the value: sqrt of a negative
    // number there is not seen.
    computes("if x > 0 then sqrt(x) else sqrt(-x)", |p| p.x.abs().sqrt());
}

/// The first hit of a ray on the scene's only shape, with `method`.
fn first_hit(shape: &str, method: &str, origin: DVec3, direction: DVec3) -> Option<f64> {
    let src = format!(
        "camera {{ position (-9, 0, 0) }}\nrender {{ method {method} step 0.01 }}\nshape s = {shape}\nobject s"
    );
    let scene = nes::compile_source("jump.nes", &src)
        .unwrap_or_else(|e| panic!("{shape}: {}", e.render_plain()));
    let tracer = Tracer::new(&scene);
    let mut s = Scratch::default();
    tracer
        .nearest_hit(origin, direction.normalize(), 20.0, &mut s)
        .map(|h| h.t)
}

#[test]
fn a_pole_is_not_a_root() {
    // A pole leaps from -inf to +inf, so |f| / |grad f| there is small, but
    // f is not 0: the interval searches ("auto" picks one for these) see
    // the slope unbounded, the marches see |f| grow as they close in.
    for method in ["auto", "interval", "march", "adaptive"] {
        let o = DVec3::new(-2.0, 0.1, 0.2);
        // tan(x) has poles at -pi/2 and pi/2 and its first root ahead at 0.
        let t = first_hit("tan(x)", method, o, DVec3::X).expect("a root at 0");
        assert!(
            (t - 2.0).abs() < 1e-6,
            "{method}: tan hit at x = {}",
            -2.0 + t
        );
        for pole in ["1 / x", "1 / (x^2 + y^2 + z^2 - 1)"] {
            let t = first_hit(pole, method, o, DVec3::X);
            assert!(
                t.is_none(),
                "{method}: the pole of {pole} taken for a root at t = {t:?}"
            );
        }
    }
}

#[test]
fn a_jump_across_zero_is_not_a_root() {
    let o = DVec3::new(0.7, 0.1, 0.2);
    for method in ["auto", "interval", "march", "adaptive"] {
        // fract(x) - 1/2 crosses zero at x = k + 1/2 and jumps from 1/2 to
        // -1/2 at the integers: from x = 0.7 the first root is at 1.5.
        let t = first_hit("fract(x) - 0.5", method, o, DVec3::X).expect("a root at 1.5");
        assert!((t - 0.8).abs() < 1e-3, "{method}: hit at x = {}", 0.7 + t);
        // A stair, solid below z = floor(x) / 2 + 1/4: a ray along z = 0.1
        // from x = -0.5 starts inside it (under the step at 1/4 - 1/2) and
        // leaves through the riser at x = 0, where the formula jumps from
        // -0.35 to 0.15 without vanishing: no root, so no hit.
        let stair = "0.5 * floor(x) + 0.25 - z";
        let from = DVec3::new(-0.5, 0.0, 0.1);
        let t = first_hit(stair, method, from, DVec3::X);
        assert!(
            t.is_none(),
            "{method}: the stair's riser taken for a root at t = {t:?}"
        );
        // A continuous `if` has its roots where either branch vanishes.
        let tent = "if x > 1 then 2 - x else x";
        let t = first_hit(tent, method, DVec3::new(0.5, 0.0, 0.0), DVec3::X).expect("a root at 2");
        assert!(
            (t - 1.5).abs() < 1e-3,
            "{method}: tent hit at x = {}",
            0.5 + t
        );
        // A discontinuous one has none at its boundary.
        let t = first_hit("if x > 1 then -1 else 1", method, o, DVec3::X);
        assert!(
            t.is_none(),
            "{method}: a step taken for a root at t = {t:?}"
        );
    }
}

#[test]
fn a_branch_cut_or_a_bounded_pole_is_not_a_root() {
    for method in ["auto", "interval", "march", "adaptive"] {
        // A helicoid: atan2(y, x) jumps from -pi to pi across the negative
        // x axis, where z - atan2(y, x) changes sign without vanishing.
        let helicoid = "z - atan2(y, x)";
        let across_cut = first_hit(helicoid, method, DVec3::new(-1.0, -2.0, 0.5), DVec3::Y);
        assert!(
            across_cut.is_none_or(|t| t > 4.0),
            "{method}: the branch cut taken for a root at t = {across_cut:?}"
        );
        // Where x > 0 the helicoid is met where atan2(y, 1) = 0.5.
        let t = first_hit(helicoid, method, DVec3::new(1.0, -2.0, 0.5), DVec3::Y)
            .expect("a root at y = tan(0.5)");
        assert!(
            (t - (2.0 + 0.5f64.tan())).abs() < 1e-3,
            "{method}: helicoid hit at y = {}",
            t - 2.0
        );
        // atan(1/x) jumps from -pi/2 to pi/2 at x = 0 with a bounded
        // range: the first root ahead is where 2 atan(1/x) = 0.5.
        let t = first_hit(
            "z - 2 * atan(1 / x)",
            method,
            DVec3::new(-2.0, 0.0, 0.5),
            DVec3::X,
        )
        .expect("a root at x = 1 / tan(0.25)");
        assert!(
            (t - (2.0 + 1.0 / 0.25f64.tan())).abs() < 1e-3,
            "{method}: atan(1/x) hit at x = {}",
            t - 2.0
        );
    }
}

#[test]
fn every_language_example_in_the_docs_renders() {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/language.md"))
        .expect("docs/language.md");
    let blocks: Vec<&str> = doc
        .split("```nes\n")
        .skip(1)
        .map(|b| b.split("```").next().unwrap())
        .collect();
    assert!(blocks.len() >= 4, "the language examples are marked ```nes");
    for block in blocks {
        let src = format!(
            "camera {{ position (-7, -4, 4) look_at (0, 0, 0) }}\nlight {{ position (-4, -6, 8) }}\n{block}"
        );
        let scene = nes::compile_source("doc.nes", &src)
            .unwrap_or_else(|e| panic!("{block}\n{}", e.render_plain()));
        let mut scene = scene;
        scene.camera.width = 48;
        scene.camera.height = 36;
        let (image, _) = nes::render::render(&scene);
        let lit = image.pixels.iter().filter(|p| p.length() > 0.02).count();
        assert!(lit > 20, "{block}: only {lit} pixels show anything");
    }
}

/// The colour at the image's centre of a hemisphere bowl (a sphere clipped
/// open at z = 0.3) seen from `camera`.
fn bowl_centre(camera: &str) -> DVec3 {
    let src = format!(
        "object sphere(1) {{ colour #2050e0  inside #e05020  clip z < 0.3 }}\ncamera {{ position {camera} look_at (0, 0, 0) }}\nlight {{ position (0, -1, 6) }}\nlight {{ position (0, -1, -6) }}"
    );
    let mut scene =
        nes::compile_source("bowl.nes", &src).unwrap_or_else(|e| panic!("{}", e.render_plain()));
    scene.camera.width = 33;
    scene.camera.height = 33;
    let (image, _) = nes::render::render(&scene);
    image.pixel(16, 16)
}

#[test]
fn the_inside_of_an_open_surface_has_its_own_colour() {
    // From above, through the opening, the ray meets the bowl's inner side.
    let c = bowl_centre("(0, -0.5, 5)");
    assert!(c.x > 2.0 * c.z, "inside seen from above: {c}");
    // From below it meets the outer side.
    let c = bowl_centre("(0, -0.5, -5)");
    assert!(c.z > 2.0 * c.x, "outside seen from below: {c}");
}

/// The function of the scene's only object, written as `object SOLID`.
fn object_function(solid: &str) -> nes::expr::Implicit {
    let src = format!("camera {{ position (-5, 0, 0) }}\nobject {solid}");
    let scene =
        nes::compile_source("object.nes", &src).unwrap_or_else(|e| panic!("{}", e.render_plain()));
    scene.objects[0].function.clone()
}

#[test]
fn an_object_may_be_a_builtin_of_formulas() {
    let direct = object_function(
        "smin(sphere(1), cube(0.7) translate (1.2, 0, 0), 0.4) translate (0, 1, 0)",
    );
    let named =
        common::compile("smin(sphere(1), cube(0.7) translate (1.2, 0, 0), 0.4) at (x, y - 1, z)");
    let half = object_function("max(sphere(1.2), z)");
    agree(
        &direct,
        &named,
        "smin(...) drawn against it at a moved point",
    );
    let mut slots = Vec::new();
    for p in points() {
        // `z < 0` as a formula is `-(0 - z)`: positive (outside) below.
        let want = (p.length_squared() - 1.44).max(p.z);
        assert!((half.value(p, &mut slots) - want).abs() < 1e-12);
    }
}

#[test]
fn an_object_may_be_any_formula() {
    let cases = [
        // A shape with an operator after it starts a formula.
        (
            "sphere(1) + 0.1 * sin(9 * x)",
            "sphere(1) + 0.1 * sin(9 * x)",
        ),
        // A parenthesised formula, moved as a solid is.
        (
            "(x^2 + y^2 + z^2 - 1) translate (1, 0, 0)",
            "(x - 1)^2 + y^2 + z^2 - 1",
        ),
        ("sphere(1) at (x - 2, y, z)", "(x - 2)^2 + y^2 + z^2 - 1"),
        // The parts of a combination may be formulas too.
        ("union(sphere(1), x - 1)", "min(x^2 + y^2 + z^2 - 1, x - 1)"),
        (
            "difference(cube(1), z^2 - 0.25)",
            "max(cube(1), 0.25 - z^2)",
        ),
        // A combination followed by an operator is a formula, and inside
        // one `union`, `intersection` and `difference` mean what they do
        // between solids.
        (
            "union(sphere(1), cube(0.7) translate (1.2, 0, 0)) - 0.1",
            "min(x^2 + y^2 + z^2 - 1, cube(0.7) at (x - 1.2, y, z)) - 0.1",
        ),
        (
            "0.5 * intersection(x, y, difference(sphere(2), sphere(1)))",
            "0.5 * max(x, y, x^2 + y^2 + z^2 - 4, 1 - (x^2 + y^2 + z^2))",
        ),
    ];
    for (solid, formula) in cases {
        let (direct, written) = (object_function(solid), common::compile(formula));
        agree(
            &direct,
            &written,
            &format!("object {solid} against {formula}"),
        );
    }
}

/// Work, not time: a formula whose jumps sit on exact integers
/// (`mod(floor(x), 2)`, constant between them) must not make every piece
/// look non-monotone. It took 14 000 evaluations per ray, with pixels out
/// of steps, before jump slopes ignored ranges only rounding wide.
#[test]
fn a_jump_of_a_jump_costs_no_more_than_a_jump() {
    let src = "camera { position (-5, -4, 3.5) look_at (0, 0, 0) }\nlight { position (-4, -6, 8) }\nshape s = max(z - 0.3 * mod(floor(x), 2), abs(x) - 2, abs(y) - 2, -z - 0.3)\nobject s";
    let mut scene =
        nes::compile_source("board.nes", src).unwrap_or_else(|e| panic!("{}", e.render_plain()));
    scene.camera.width = 60;
    scene.camera.height = 45;
    let (_, stats) = nes::render::render(&scene);
    let per_ray = stats.evaluations as f64 / (stats.primary_rays + stats.shadow_rays) as f64;
    assert_eq!(stats.out_of_steps_pixels, 0);
    assert!(per_ray < 500.0, "{per_ray} evaluations per ray");
}

#[test]
fn imported_definitions_mean_what_they_say_and_each_file_is_read_once() {
    let path = "tests/data/imports/main.nes";
    let source = std::fs::read_to_string(path).unwrap();
    let scene =
        nes::compile_source(path, &source).unwrap_or_else(|e| panic!("{}", e.render_plain()));
    // lib/common.nes is imported by main.nes and by lib/shapes.nes.
    let names: Vec<String> = scene
        .imports
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    assert_eq!(
        names,
        [
            "tests/data/imports/lib/shapes.nes",
            "tests/data/imports/lib/common.nes"
        ]
    );
    let written = common::compile("(sqrt(x^2 + y^2) - 2)^2 + z^2 - 0.25 + 0.05 * sin(8 * x)");
    agree(
        &scene.objects[0].function,
        &written,
        "the imported ring against it written out",
    );
}

/// The colour field of the scene's only object, written `colour COLOUR`.
fn colour_field(solid: &str, colour: &str) -> nes::scene::ColourField {
    let src = format!("camera {{ position (-5, 0, 0) }}\nobject {solid} {{ colour {colour} }}");
    let scene =
        nes::compile_source("colour.nes", &src).unwrap_or_else(|e| panic!("{}", e.render_plain()));
    match &scene.objects[0].colour {
        nes::scene::Paint::Field(f) => (**f).clone(),
        nes::scene::Paint::Flat(c) => panic!("{colour} is one colour, {c}"),
    }
}

#[test]
fn curvatures_from_the_symbolic_hessian_match_closed_forms() {
    let close = |got: f64, want: f64, what: &str| {
        assert!(
            (got - want).abs() < 1e-9 * (1.0 + want.abs()),
            "{what}: {got}, want {want}"
        );
    };
    let mut slots = Vec::new();
    // A sphere of radius 2, however written or scaled: mean 1/2, Gaussian
    // 1/4 (at 1e100 the squared gradient alone would overflow).
    for solid in [
        "sphere(2)",
        "sqrt(x^2 + y^2 + z^2) - 2",
        "(x^2 + y^2 + z^2)^2 - 16",
        "1e100 * (x^2 + y^2 + z^2 - 4)",
        "1e-100 * (x^2 + y^2 + z^2 - 4)",
    ] {
        let field = colour_field(solid, "diverging(mean_curvature + gauss_curvature)");
        for p in points() {
            let on = 2.0 * p.normalize();
            let (mean, gauss) = field.curvatures(on, &mut slots).unwrap();
            close(mean, 0.5, &format!("{solid}: mean at {on}"));
            close(gauss, 0.25, &format!("{solid}: Gaussian at {on}"));
        }
    }
    // A torus of radii R = 2, r = 0.5 at tube angle t: Gaussian
    // cos t / (r (R + r cos t)), mean (R + 2 r cos t) / (2 r (R + r cos t)).
    let field = colour_field("torus(2, 0.5)", "viridis(gauss_curvature)");
    let (big, small) = (2.0, 0.5);
    for k in 0..24 {
        let (t, around) = (k as f64 * 0.27, k as f64 * 0.61);
        let rho = big + small * t.cos();
        let on = glam::DVec3::new(rho * around.cos(), rho * around.sin(), small * t.sin());
        let (mean, gauss) = field.curvatures(on, &mut slots).unwrap();
        close(
            gauss,
            t.cos() / (small * rho),
            &format!("torus Gaussian at t = {t}"),
        );
        close(
            mean,
            (big + 2.0 * small * t.cos()) / (2.0 * small * rho),
            &format!("torus mean at t = {t}"),
        );
    }
}

#[test]
fn a_colour_field_gives_each_pixel_the_colour_its_geometry_dictates() {
    // Looking along +x at a unit sphere, flat-shaded: the centre pixel's
    // normal is (-1, 0, 0), so (0.5 + 0.5 n.x, 0.5 + 0.5 n.y, 0.5 + 0.5 n.z)
    // is (0, 0.5, 0.5) in sRGB. viridis at 0 and 1 are its ends.
    let src = "camera { position (-5, 0, 0) look_at (0, 0, 0) width 41 height 41 }\n\
               render { shading flat }\n\
               object sphere(1) { colour (0.5 + 0.5 * normal.x, 0.5 + 0.5 * normal.y, 0.5 + 0.5 * normal.z) }";
    let scene =
        nes::compile_source("normal.nes", src).unwrap_or_else(|e| panic!("{}", e.render_plain()));
    let (image, _) = nes::render(&scene);
    let centre = image.pixel(20, 20);
    let want = glam::DVec3::new(0.0, 0.5, 0.5)
        .to_array()
        .map(nes::shade::srgb_to_linear);
    assert!(
        (centre - glam::DVec3::from(want)).abs().max_element() < 0.02,
        "centre {centre}"
    );
    // The inside of a clipped bowl, seen from above through its opening,
    // is painted by the same field: at the bottom (0, 0, -1) the position
    // colour ((x + 1) / 2, (y + 1) / 2, (z + 1) / 2) is (0.5, 0.5, 0).
    let src = "camera { position (0, 0.001, 5) look_at (0, 0, 0) width 41 height 41 fov 20 }\n\
               render { shading flat }\n\
               object sphere(1) { clip z < 0.3 colour ((x + 1) / 2, (y + 1) / 2, (z + 1) / 2) }";
    let scene =
        nes::compile_source("bowl.nes", src).unwrap_or_else(|e| panic!("{}", e.render_plain()));
    let (image, _) = nes::render(&scene);
    let want = [0.5, 0.5, 0.0].map(nes::shade::srgb_to_linear);
    let bottom = image.pixel(20, 20);
    assert!(
        (bottom - glam::DVec3::from(want)).abs().max_element() < 0.02,
        "inside bottom {bottom}"
    );
    let field = colour_field("sphere(1)", "viridis(z)");
    let srgb = |c: glam::DVec3| c.to_array().map(|v| v.powf(1.0 / 2.2));
    let (low, high) = (
        field.linear_colour(glam::DVec3::NEG_Z, glam::DVec3::NEG_Z, &mut Vec::new()),
        field.linear_colour(glam::DVec3::Z, glam::DVec3::Z, &mut Vec::new()),
    );
    // #440154 and #fde725 within the fit's error.
    for (got, want) in [
        (srgb(low), [0x44, 0x01, 0x54]),
        (srgb(high), [0xfd, 0xe7, 0x25]),
    ] {
        for (g, w) in got.iter().zip(want) {
            assert!(
                (g - w as f64 / 255.0).abs() < 0.03,
                "viridis end {got:?}, want {want:?}"
            );
        }
    }
}

#[test]
fn colour_maps_and_choices_are_colours_wherever_colours_go() {
    let src = "let c = viridis(0.3)\n\
               camera { position (-5, 0, 0) }\n\
               background diverging(-1)\n\
               object x\n\
               object sphere(1) { colour c }\n\
               object sphere(1) { colour if z > 0 then red else (0, 0, 1) }\n\
               object sum(k in 0..2, sphere(0.5) at (x - k, y, z))";
    let scene =
        nes::compile_source("maps.nes", src).unwrap_or_else(|e| panic!("{}", e.render_plain()));
    let linear = |c: [f64; 3]| glam::DVec3::from(c.map(nes::shade::srgb_to_linear));
    let near = |a: glam::DVec3, b: glam::DVec3| (a - b).abs().max_element() < 1e-9;
    // diverging(-1) is halfway from grey to blue: t / (1 + |t|) = -1/2.
    let half_blue = [
        0.865 + (0.230 - 0.865) / 2.0,
        0.865 + (0.299 - 0.865) / 2.0,
        0.865 + (0.754 - 0.865) / 2.0,
    ];
    assert!(
        near(scene.background, linear(half_blue)),
        "{}",
        scene.background
    );
    let mut slots = Vec::new();
    // `object x` is the plane x = 0; `object sum(...)` the written-out sum.
    let written = |f: &str| common::compile(f);
    agree(&scene.objects[0].function, &written("x"), "object x");
    agree(
        &scene.objects[3].function,
        &written("(x^2 + y^2 + z^2 - 0.25) + ((x - 1)^2 + y^2 + z^2 - 0.25)"),
        "object sum(...)",
    );
    let nes::scene::Paint::Flat(c) = scene.objects[1].colour else {
        panic!("viridis(0.3) is one colour")
    };
    let viridis = |t: f64| {
        let coefficients = [
            [0.2777273272234177, 0.005407344544966578, 0.3340998053353061],
            [0.1050930431085774, 1.404613529898575, 1.384590162594685],
            [-0.3308618287255563, 0.214847559468213, 0.09509516302823659],
            [-4.634230498983486, -5.799100973351585, -19.33244095627987],
            [6.228269936347081, 14.17993336680509, 56.69055260068105],
            [4.776384997670288, -13.74514537774601, -65.35303263337234],
            [-5.435455855934631, 4.645852612178535, 26.3124352495832],
        ];
        [0, 1, 2].map(|i| coefficients.iter().rev().fold(0.0, |acc, c| acc * t + c[i]))
    };
    assert!(near(c, linear(viridis(0.3))), "{c}");
    // The choice varies with z: red (220, 40, 40) above, blue below.
    let side = &scene.objects[2];
    let (top, bottom) = (glam::DVec3::Z, glam::DVec3::NEG_Z);
    let red = [220.0, 40.0, 40.0].map(|b: f64| b / 255.0);
    assert!(near(
        side.colour.at(&side.function, top, &mut slots).0,
        linear(red)
    ));
    assert!(near(
        side.colour.at(&side.function, bottom, &mut slots).0,
        linear([0.0, 0.0, 1.0])
    ));
    // A vector and a colour blend where t varies: at z = 1 the blend is
    // the colour, at z = 0 the vector.
    let field = colour_field("sphere(1)", "mix((1, 0, 0), #0000ff, z)");
    assert!(near(
        field.linear_colour(top, top, &mut slots),
        linear([0.0, 0.0, 1.0])
    ));
    let side_point = glam::DVec3::X;
    assert!(near(
        field.linear_colour(side_point, side_point, &mut slots),
        linear([1.0, 0.0, 0.0])
    ));
}

/// Colours add, scale and tint in sRGB, as `mix` blends them: a constant
/// result is one colour (clamped to 0..1), and by a number that varies a
/// colour field.
#[test]
fn colours_add_scale_and_tint() {
    let linear = |c: [f64; 3]| glam::DVec3::from(c.map(nes::shade::srgb_to_linear));
    let near = |a: glam::DVec3, b: glam::DVec3| (a - b).abs().max_element() < 1e-9;
    // red is (220, 40, 40), blue (50, 100, 230), grey (128, 128, 128).
    let srgb = |b: [f64; 3]| b.map(|v| v / 255.0);
    let (red, blue, grey) = (
        srgb([220.0, 40.0, 40.0]),
        srgb([50.0, 100.0, 230.0]),
        srgb([128.0, 128.0, 128.0]),
    );
    let flat = |colour: &str| {
        let src =
            format!("camera {{ position (-5, 0, 0) }}\nobject sphere(1) {{ colour {colour} }}");
        let scene = nes::compile_source("c.nes", &src)
            .unwrap_or_else(|e| panic!("{colour}: {}", e.render_plain()));
        match scene.objects[0].colour {
            nes::scene::Paint::Flat(c) => c,
            _ => panic!("{colour} is one colour"),
        }
    };
    let each = |f: &dyn Fn(usize) -> f64| [0, 1, 2].map(f);
    assert!(near(flat("red * 0.5"), linear(each(&|i| red[i] * 0.5))));
    assert!(near(
        flat("0.5 * red + 0.5 * blue"),
        linear(each(&|i| (red[i] + blue[i]) / 2.0))
    ));
    assert!(near(
        flat("red * grey"),
        linear(each(&|i| red[i] * grey[i]))
    ));
    assert!(near(
        flat("blue / 2 - red"),
        linear(each(&|i| (blue[i] / 2.0 - red[i]).max(0.0)))
    ));
    assert!(near(flat("white * 3"), linear([1.0; 3])));
    // A vector of fractions is a colour here too, and the sum is clamped.
    assert!(near(
        flat("red + (0.9, 0, 0)"),
        linear([1.0, red[1], red[2]])
    ));
    assert!(near(
        flat("(0, 0.5, 0) + blue / 2"),
        linear(each(&|i| [0.0, 0.5, 0.0][i] + blue[i] / 2.0))
    ));
    let mut slots = Vec::new();
    let field = colour_field("sphere(1)", "white * (0.5 + 0.5 * z)");
    for z in [-1.0, 0.0, 1.0] {
        let p = glam::DVec3::new((1.0f64 - z * z).sqrt(), 0.0, z);
        let v = 0.5 + 0.5 * z;
        assert!(
            near(field.linear_colour(p, p, &mut slots), linear([v; 3])),
            "z = {z}"
        );
    }
    for wrong in ["red ^ 2", "red + 1", "-red", "red / blue", "red / 0"] {
        let src =
            format!("camera {{ position (-5, 0, 0) }}\nobject sphere(1) {{ colour {wrong} }}");
        assert!(
            nes::compile_source("c.nes", &src).is_err(),
            "{wrong} compiled"
        );
    }
}

/// Ten thousand nested `let`s compile in little memory: each adds one
/// name to the scope it is in (copying the scope at every level took
/// memory growing with the square of the depth, past 4 GB here).
#[test]
fn deeply_nested_lets_compile() {
    let lets: String = (0..10_000).map(|i| format!("let a{i} = {i} in ")).collect();
    let src = format!(
        "camera {{ position (-5, 0, 0) }}\nobject {lets}(x - a9999 + 9999)^2 + y^2 + z^2 - 1"
    );
    let scene = nes::compile_source("lets.nes", &src).unwrap_or_else(|e| {
        panic!(
            "{}",
            e.render_plain()
                .lines()
                .take(5)
                .collect::<Vec<_>>()
                .join("\n")
        )
    });
    agree(
        &scene.objects[0].function,
        &common::compile("sphere(1)"),
        "10 000 lets",
    );
}
