//! The polynomial route: surfaces that are polynomials in x, y, z are
//! solved along straight paths from their coefficients in the path's
//! parameter. Each test knows the answer independently: a closed form,
//! or the interval route, which is guaranteed and computed another way.

use glam::DVec3;
use nes::expr::Proxy;
use nes::trace::intersect::Scratch;
use nes::trace::{Route, Tracer};

mod common;

fn scene(shape: &str, method: &str) -> nes::Scene {
    let src = format!(
        "camera {{ position (-9, 0, 0) }}\nrender {{ method {method} }}\nshape s = {shape}\nobject s"
    );
    nes::compile_source("poly.nes", &src)
        .unwrap_or_else(|e| panic!("{shape}: {}", e.render_plain()))
}

fn hit(tracer: &Tracer, origin: DVec3, direction: DVec3, s: &mut Scratch) -> Option<f64> {
    tracer
        .nearest_hit(origin, direction.normalize(), 100.0, s)
        .map(|h| h.t)
}

/// A scene with `camera`'s settings and the gallery's key light, then
/// `rest`.
fn lit(camera: &str, rest: &str) -> String {
    format!("camera {{ {camera} }}\nlight {{ position (-6, -7, 9) }}\n{rest}")
}

/// The smallest positive root of |o + t d - c|^2 = r^2.
fn sphere_hit(o: DVec3, d: DVec3, c: DVec3, r: f64) -> Option<f64> {
    let d = d.normalize();
    let o = o - c;
    let b = o.dot(d);
    let disc = b * b - (o.length_squared() - r * r);
    if disc < 0.0 {
        return None;
    }
    let q = disc.sqrt();
    [-b - q, -b + q].into_iter().find(|&t| t > 0.0)
}

/// Eight balls in a row, multiplied: a polynomial of degree 16 whose
/// zero set is their union. Along any ray, the first hit is the nearest
/// ball's entry, which a quadratic gives.
#[test]
fn a_degree_16_product_of_balls_is_hit_at_the_nearest_ball() {
    let centres: Vec<DVec3> = (0..8)
        .map(|k| DVec3::new(-3.5 + k as f64, 0.0, 0.0))
        .collect();
    let shape = centres
        .iter()
        .map(|c| format!("((x - ({}))^2 + y^2 + z^2 - 0.16)", c.x))
        .collect::<Vec<_>>()
        .join(" * ");
    let scene = scene(&shape, "auto");
    let tracer = Tracer::new(&scene);
    assert_eq!(tracer.routes()[0], Route::Polynomial);
    assert_eq!(scene.objects[0].function.degree, Some(16));
    let mut s = Scratch::default();
    let mut hits = 0;
    for k in 0..200 {
        let a = k as f64 * 0.731;
        let origin = DVec3::new(-2.0 + 3.0 * (a * 0.37).sin(), 6.0 * a.cos(), 6.0 * a.sin());
        let target = DVec3::new(
            4.0 * (a * 1.3).sin(),
            0.2 * (a * 2.1).cos(),
            0.2 * (a * 0.7).sin(),
        );
        let d = (target - origin).normalize();
        let want = centres
            .iter()
            .filter_map(|&c| sphere_hit(origin, d, c, 0.4))
            .fold(None, |m: Option<f64>, t| Some(m.map_or(t, |m| m.min(t))));
        let got = hit(&tracer, origin, d, &mut s);
        match (got, want) {
            (Some(g), Some(w)) => {
                hits += 1;
                assert!((g - w).abs() < 1e-6, "ray {k}: {g} vs {w}")
            }
            (None, None) => {}
            _ => panic!("ray {k}: {got:?} vs {want:?}"),
        }
    }
    assert!(hits > 100, "only {hits} rays hit");
}

/// `(|p|^2 - 1)^2` is zero on the unit sphere and positive elsewhere:
/// every hit is a double root, which the route finds (a touching hit);
/// lifted by 1e-4 it has no zero, and no ray hits it.
#[test]
fn double_roots_are_hits_and_near_misses_are_not() {
    let touching = scene("(x^2 + y^2 + z^2 - 1)^2", "auto");
    let lifted = scene("(x^2 + y^2 + z^2 - 1)^2 + 1e-4", "auto");
    let (t1, t2) = (Tracer::new(&touching), Tracer::new(&lifted));
    assert_eq!(t1.routes()[0], Route::Polynomial);
    let mut s = Scratch::default();
    for k in 0..50 {
        let a = k as f64 * 0.41;
        let origin = DVec3::new(-5.0, 2.0 * a.sin(), 2.0 * a.cos());
        let d = DVec3::new(1.0, -0.3 * a.sin(), -0.3 * a.cos()).normalize();
        let want = sphere_hit(origin, d, DVec3::ZERO, 1.0);
        let got = hit(&t1, origin, d, &mut s);
        match (got, want) {
            (Some(g), Some(w)) => assert!((g - w).abs() < 1e-5, "ray {k}: {g} vs {w}"),
            (None, None) => {}
            _ => panic!("ray {k}: {got:?} vs {want:?}"),
        }
        assert_eq!(hit(&t2, origin, d, &mut s), None, "ray {k}");
    }
}

/// Textbook polynomial surfaces, from many directions: the polynomial
/// route finds the same first hit as guaranteed interval isolation.
#[test]
fn polynomial_and_interval_routes_find_the_same_hits() {
    let surfaces = [
        // Chmutov octic.
        "128*x^8 - 256*x^6 + 160*x^4 - 32*x^2 + 1 + 128*y^8 - 256*y^6 + 160*y^4 - 32*y^2 + 1 + 128*z^8 - 256*z^6 + 160*z^4 - 32*z^2 + 1",
        // Taubin's heart.
        "(x^2 + 9/4*y^2 + z^2 - 1)^3 - x^2*z^3 - 9/80*y^2*z^3",
        // Goursat's surface.
        "x^4 + y^4 + z^4 - 1.5*(x^2 + y^2 + z^2) + 0.8",
        // A torus as a quartic.
        "(x^2 + y^2 + z^2 + 1 - 0.09)^2 - 4*(x^2 + y^2)",
    ];
    for shape in surfaces {
        let exact = scene(shape, "auto");
        let interval = scene(shape, "interval");
        let (te, ti) = (Tracer::new(&exact), Tracer::new(&interval));
        assert_eq!(te.routes()[0], Route::Polynomial, "{shape}");
        assert_eq!(ti.routes()[0], Route::Interval, "{shape}");
        let f = &exact.objects[0].function;
        let mut s = Scratch::default();
        let mut slots = Vec::new();
        let mut hits = 0;
        for k in 0..400 {
            let a = k as f64 * 0.6180339887;
            let origin = DVec3::new(-6.0 * (a * 3.0).cos(), 6.0 * a.sin(), 4.0 * (a * 1.7).cos());
            let target = DVec3::new(
                0.9 * (a * 5.0).sin(),
                0.9 * (a * 2.3).cos(),
                0.9 * (a * 7.1).sin(),
            );
            let d = (target - origin).normalize();
            let got = hit(&te, origin, d, &mut s);
            let want = hit(&ti, origin, d, &mut s);
            match (got, want) {
                (Some(g), Some(w)) => {
                    hits += 1;
                    let at = |t: f64| f.value_and_gradient(origin + t * d, &mut Vec::new());
                    assert!(
                        (g - w).abs() < 1e-5,
                        "{shape}, ray {k}: {g} vs {w}: {:?} {:?}",
                        at(g),
                        at(w)
                    );
                    let (v, grad) = f.value_and_gradient(origin + g * d, &mut slots);
                    assert!(v.abs() <= 1e-5 * grad.length(), "{shape}, ray {k}: f = {v}");
                }
                (None, None) => {}
                _ => panic!("{shape}, ray {k}: {got:?} vs {want:?}"),
            }
        }
        assert!(hits > 100, "{shape}: only {hits} rays hit");
    }
}

/// Near the heart's singular points the polynomial is within its
/// coefficients' error of zero over a stretch of each ray; with a tight
/// epsilon the route once took such a place for a hit, and then (passing
/// over it a step at a time) missed the heart behind it. Every pixel of
/// the rows through that region hits what interval isolation hits.
#[test]
fn flat_places_neither_hit_nor_hide_the_surface() {
    let src = std::fs::read_to_string("examples/implicit.nes").unwrap();
    let mut exact = nes::compile_source("implicit.nes", &src).unwrap();
    exact.settings.epsilon = 1e-9;
    let mut interval = exact.clone();
    interval.settings.method = nes::scene::Method::Interval;
    let (te, ti) = (Tracer::new(&exact), Tracer::new(&interval));
    assert_eq!(te.routes()[1], Route::Polynomial);
    assert_eq!(ti.routes()[1], Route::Interval);
    let cam = exact.camera;
    let rays = cam.rays();
    let mut s = Scratch::default();
    let mut heart = 0;
    // Rows 485 to 510 of the 1500 x 1000 image, every pixel.
    for y in 485..510 {
        for x in 0..cam.width {
            let d = rays.direction(x as f64 + 0.5, y as f64 + 0.5);
            let a = te.nearest_hit(cam.position, d, 100.0, &mut s);
            let b = ti.nearest_hit(cam.position, d, 100.0, &mut s);
            match (a, b) {
                (Some(a), Some(b)) => {
                    assert_eq!(a.object, b.object, "pixel {x},{y}: {a:?} vs {b:?}");
                    assert!(
                        (a.t - b.t).abs() < 1e-6,
                        "pixel {x},{y}: {} vs {}",
                        a.t,
                        b.t
                    );
                    heart += usize::from(a.object == 1);
                }
                (None, None) => {}
                _ => panic!("pixel {x},{y}: {a:?} vs {b:?}"),
            }
        }
    }
    assert!(heart > 1000, "{heart} heart pixels");
}

/// Apery's sextic for Boy's surface, whose automatic bound is about 100
/// units across: over such a range the coefficients' error hides values
/// near the surface, and shadow rays once took the surface they leave for
/// a touching hit, drawing a dark outline along the silhouette (about 500
/// pixels at 800 x 500). Solved again over a short stretch, the image is
/// the one a clip around the surface gives.
#[test]
fn a_loose_bound_changes_no_pixel_of_a_polynomial() {
    let boy = "64*(1 - z)^3*z^3 - 48*(1 - z)^2*z^2*(3*x^2 + 3*y^2 + 2*z^2) + 12*(1 - z)*z*(27*(x^2 + y^2)^2 - 24*z^2*(x^2 + y^2) + 36*sqrt(2)*y*z*(y^2 - 3*x^2) + 4*z^4) + (9*x^2 + 9*y^2 - 2*z^2)*(-81*(x^2 + y^2)^2 - 72*z^2*(x^2 + y^2) + 108*sqrt(2)*x*z*(x^2 - 3*y^2) + 4*z^4)";
    let src = |clip: &str| {
        lit(
            "position (-6.53, -4.66, 4.75) look_at (0.2, 0, 1) fov 38 width 320 height 200",
            &format!("light {{ position (6, -2, 4) intensity 0.35 }}\nobject {boy} {{ {clip} }}\n"),
        )
    };
    let render = |clip: &str| {
        let sc = nes::compile_source("boy.nes", &src(clip)).unwrap();
        nes::render(&sc).0
    };
    let (loose, clipped) = (
        render(""),
        render("clip (sphere(2.2) translate (0.2, 0, 1))"),
    );
    let differ = common::pixels_differing(&loose, &clipped, 0.02);
    assert!(
        differ <= 4,
        "{differ} pixels differ from the clipped render"
    );
}

/// Metaballs, `1 - sum s / |p - c|^2`, are a rational function whose
/// denominators are sums of squares: the polynomial route solves the
/// numerator, which has the function's sign wherever it is defined.
/// Routes agree on the image, and the numerator's sign is the function's
/// at points all over.
#[test]
fn a_rational_function_is_solved_through_its_numerator() {
    let blobs = "1 - 0.5 / (x^2 + y^2 + z^2) - 0.3 / ((x - 1.1)^2 + (y - 0.3)^2 + (z - 0.2)^2) - 0.35 / ((x + 0.6)^2 + (y - 0.9)^2 + (z + 0.2)^2)";
    let src = |method: &str| {
        lit(
            "position (-5, -3.5, 2.8) look_at (0, 0, 0) fov 38 width 160 height 100",
            &format!("render {{ method {method} }}\nobject {blobs}\n"),
        )
    };
    let auto = nes::compile_source("blobs.nes", &src("auto")).unwrap();
    let f = &auto.objects[0].function;
    assert!(
        (f.proxy == Proxy::Numerator) && f.degree == Some(6),
        "{:?}",
        f.degree
    );
    assert_eq!(
        Route::for_object(&auto.objects[0], auto.settings.method, true),
        Route::Polynomial
    );
    let numerator = f.line_tape.as_ref().expect("the numerator's tape");
    let mut slots = Vec::new();
    let mut out = [0.0];
    for i in 0..2000 {
        let k = i as f64;
        let p = DVec3::new((k * 0.37).sin(), (k * 0.61).cos(), (k * 0.23).sin()) * 2.5;
        let v = f.value(p, &mut Vec::new());
        numerator.eval_into(&[p.x, p.y, p.z], &mut slots, &mut out);
        assert!(
            v.signum() == out[0].signum() || v.abs() < 1e-12,
            "{p}: f {v}, numerator {}",
            out[0]
        );
    }
    let interval = nes::compile_source("blobs.nes", &src("interval")).unwrap();
    let differ = common::pixels_differing(&nes::render(&auto).0, &nes::render(&interval).0, 0.02);
    assert!(
        differ <= 2,
        "{differ} pixels differ from interval isolation"
    );
}

/// Metaballs are as often written with `length(p - c)^2` as with the sum
/// of squares: the square of a square root of a sum of squares is that sum,
/// so both forms are one graph and take the polynomial route. A square root
/// of something that may be negative is not squared away: `sqrt(x)^2` is
/// undefined where `x < 0`, and the formula keeps its square root.
#[test]
fn a_squared_length_is_a_polynomial() {
    let fields = |field: &str| {
        format!(
            "shape field(cx, cy, cz, s) = {field}\n\
             object 1 - field(0, 0, 0, 0.5) - field(1.1, 0.3, 0.2, 0.3) - field(-0.6, 0.9, -0.2, 0.35)\n"
        )
    };
    let compile = |field: &str| {
        let src = lit(
            "position (-5, -3.5, 2.8) look_at (0, 0, 0) fov 38 width 16 height 10",
            &fields(field),
        );
        nes::compile_source("blobs.nes", &src).unwrap()
    };
    let squares = compile("s / ((x - cx)^2 + (y - cy)^2 + (z - cz)^2)");
    let length = compile("s / length((x, y, z) - (cx, cy, cz))^2");
    for scene in [&squares, &length] {
        let f = &scene.objects[0].function;
        assert!(
            (f.proxy == Proxy::Numerator) && f.degree == Some(6),
            "{:?}",
            f.degree
        );
        assert_eq!(
            Route::for_object(&scene.objects[0], scene.settings.method, true),
            Route::Polynomial
        );
    }
    assert_eq!(
        squares.objects[0].function.value_tape.len(),
        length.objects[0].function.value_tape.len(),
        "the two forms are one graph"
    );
    let root = compile("s / (sqrt(x - cx)^2 + y^2 + z^2)");
    let f = &root.objects[0].function;
    assert!(f.degree.is_none() && f.proxy == Proxy::None);
    let v = f.value(DVec3::new(-1.0, 0.0, 0.5), &mut Vec::new());
    assert!(v.is_nan(), "sqrt(x)^2 at x = -1 gave {v}");
}

/// A distance minus a radius, `sqrt(a) - c` with `a` a sum of squares, is
/// solved through `a - c^2`, which has its sign and its zeros (and, of
/// degree 2, is a quadric): a ball written with `length` is hit where the
/// closed form says, as is a
/// cylinder from inside out (`c - sqrt(a)`); a negative `c` (never 0) and
/// an `a` that may be negative keep the interval route.
#[test]
fn a_distance_minus_a_radius_is_solved_as_its_square() {
    let ball = scene("length((x, y, z) - (1, 0.5, 0)) - 2", "auto");
    let f = &ball.objects[0].function;
    assert_eq!((f.proxy, f.degree), (Proxy::Square, Some(2)));
    // A square of degree 2 is a quadric, with the ball's zeros and
    // signs: met in closed form.
    assert!(f.quadric.is_some());
    assert_eq!(
        Route::for_object(&ball.objects[0], ball.settings.method, true),
        Route::Closed
    );
    let tracer = Tracer::new(&ball);
    let mut scratch = Scratch::default();
    let origin = DVec3::new(-9.0, 0.0, 0.0);
    for dir in [
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(1.0, 0.2, 0.1),
        DVec3::new(1.0, -0.15, 0.2),
        DVec3::new(1.0, 0.3, 0.0),
    ] {
        let want = sphere_hit(origin, dir, DVec3::new(1.0, 0.5, 0.0), 2.0);
        let got = hit(&tracer, origin, dir, &mut scratch);
        match (want, got) {
            (Some(w), Some(g)) => assert!((w - g).abs() < 1e-6, "{dir}: {g} vs {w}"),
            (None, None) => {}
            _ => panic!("{dir}: {got:?} vs {want:?}"),
        }
    }
    // Inside out: the camera inside a tube of radius 3 about the x axis
    // sees its wall where y^2 + z^2 = 9.
    let tube = scene("3 - sqrt(y^2 + z^2)", "auto");
    assert_eq!(tube.objects[0].function.proxy, Proxy::Square);
    let tracer = Tracer::new(&tube);
    let got = hit(&tracer, origin, DVec3::new(0.0, 0.6, 0.8), &mut scratch);
    assert!(got.is_some_and(|t| (t - 3.0).abs() < 1e-6), "{got:?}");
    for shape in ["sqrt(x^2 + y^2) + 1", "sqrt(x^3 + y^2) - 1"] {
        let s = scene(shape, "auto");
        assert_eq!(s.objects[0].function.proxy, Proxy::None, "{shape}");
    }
}

/// Where the denominator vanishes the numerator may too, with no surface
/// there: `x^2 / x^2 - 0.5` is 0.5 wherever it is defined, but its
/// numerator `0.5 x^2` has a double root on the plane x = 0; `x / x^2`
/// has a pole there, where it changes sign through infinity. Nothing is
/// drawn, as interval isolation draws nothing; and a function that is not
/// rational, or whose denominator may be negative, keeps its route.
#[test]
fn a_numerator_root_where_the_function_is_undefined_is_no_hit() {
    // Also poles, where f jumps through infinity and changes sign: on
    // the plane x = 0, and on the unit sphere.
    for shape in [
        "x^2 / x^2 - 0.5",
        "x / x^2",
        "(x^2 + y^2 + z^2 - 1) / (x^2 + y^2 + z^2 - 1)^2",
    ] {
        let s = scene(shape, "auto");
        assert!(s.objects[0].function.proxy == Proxy::Numerator, "{shape}");
        let tracer = Tracer::new(&s);
        let mut scratch = Scratch::default();
        for dir in [DVec3::new(1.0, 0.1, 0.0), DVec3::new(1.0, -0.2, 0.3)] {
            let t = hit(&tracer, DVec3::new(-9.0, 0.0, 0.0), dir, &mut scratch);
            assert_eq!(t, None, "{shape}");
        }
    }
    // Up to 8 distinct quadratic denominators (a numerator of degree
    // 16); past that the fold stops as soon as the degree is too high.
    let balls = |n: usize| {
        let terms: Vec<String> = (0..n)
            .map(|i| format!("0.1 / ((x - {i})^2 + y^2 + z^2)"))
            .collect();
        format!("1 - {}", terms.join(" - "))
    };
    assert!(scene(&balls(8), "auto").objects[0].function.proxy == Proxy::Numerator);
    assert!(scene(&balls(9), "auto").objects[0].function.proxy != Proxy::Numerator);
    for shape in [
        "x / y - 1",
        "sin(x) / (x^2 + 1) - 0.1",
        "x^3 + y^3 + z^3 - 1",
    ] {
        assert!(
            scene(shape, "auto").objects[0].function.proxy != Proxy::Numerator,
            "{shape}"
        );
    }
}

/// Objects' formulas run as native code on first use, and the polynomial
/// route samples them at its interpolation nodes through the same
/// evaluation: an algebraic scene (a sextic, metaballs through their
/// numerator, a degree-10 product solved by Taylor arithmetic) draws the
/// same image byte for byte with `NES_JIT=off`.
#[test]
fn native_and_interpreted_formulas_draw_the_same_image() {
    let dir = common::Scratch::new("poly-jit");
    let scene = dir.join("algebraic.nes");
    std::fs::write(
        &scene,
        lit(
            "position (-4.6, -3.2, 2.6) look_at (0, 0, 0) fov 40 width 64 height 40",
            "object (x^2 + 9/4*y^2 + z^2 - 1)^3 - x^2*z^3 - 9/80*y^2*z^3 { translate (-1, 0, 0) }\n\
             object 1 - 0.3/((x-1)^2 + y^2 + z^2) - 0.3/((x-1.6)^2 + y^2 + z^2)\n\
             object ((x^2 + y^2 + (z-1.8)^2 - 0.25) * (x^2 + (y-0.5)^2 + (z-1.8)^2 - 0.2))^2 * (x^2 + y^2 + z^2 - 9) * 0.01 + 0.001\n",
        ),
    )
    .unwrap();
    let render = |jit: &str, name: &str| {
        let out = dir.join(name);
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_nes"))
            .env("NES_JIT", jit)
            .args(["render", "-q", "-o"])
            .arg(&out)
            .arg(&scene)
            .status()
            .expect("nes runs");
        assert!(status.success());
        image::open(&out).expect("the image").to_rgb8()
    };
    let native = render("on", "native.png");
    let interpreted = render("off", "interpreted.png");
    assert!(native == interpreted, "the two images differ");
    // Not an empty picture: the heart and the metaballs are drawn.
    let background = *native.get_pixel(0, 0);
    let drawn = native.pixels().filter(|p| **p != background).count();
    assert!(drawn > 64 * 40 / 10, "{drawn} pixels drawn");
}

/// A polynomial whose mixed terms keep interval arithmetic from proving
/// far boxes empty gets a bound as large as the region rays reach: under
/// `max_distance 1e6`, a million units. Over such a range the
/// coefficients' terms (1e24) hide every value near the surface, and each
/// ray once fell back to interval isolation (about 200 evaluations a
/// ray, 27 times the time of `max_distance 100`). The range is now cut
/// to a bound on the polynomial's roots from its coefficients about the
/// range's start: the same hits, in a few evaluations a ray.
#[test]
fn a_huge_max_distance_costs_a_polynomial_no_search() {
    let shape = "x^4 + y^4 + z^4 - 0.9*(x^2*y^2 + y^2*z^2 + z^2*x^2) - 1";
    let scene = |far: f64| {
        let src = format!(
            "camera {{ position (-6, -2, 3) }}\nrender {{ max_distance {far} }}\nobject {shape}"
        );
        nes::compile_source("far.nes", &src).unwrap()
    };
    let (near, far) = (scene(100.0), scene(1e6));
    let (near_tracer, far_tracer) = (Tracer::new(&near), Tracer::new(&far));
    assert_eq!(far_tracer.routes()[0], Route::Polynomial);
    let far_bound = far.objects[0].bound.expect("bounded");
    assert!(
        far_bound.max.x > 1e5,
        "the bound is the region rays reach, or this test tests nothing: {far_bound:?}"
    );
    let origin = DVec3::new(-6.0, -2.0, 3.0);
    let (mut s_near, mut s_far) = (Scratch::default(), Scratch::default());
    let mut rays = 0;
    let mut hits = 0;
    for k in 0..400 {
        let (i, j) = ((k % 20) as f64 / 19.0, (k / 20) as f64 / 19.0);
        let aim = DVec3::new(0.7 * i - 0.35, 3.0 * i - 1.5, 3.0 * j - 1.5);
        let d = (aim - origin).normalize();
        let want = near_tracer
            .nearest_hit(origin, d, 100.0, &mut s_near)
            .map(|h| h.t);
        let got = far_tracer
            .nearest_hit(origin, d, 1e6, &mut s_far)
            .map(|h| h.t);
        rays += 1;
        match (want, got) {
            (Some(a), Some(b)) => {
                hits += 1;
                assert!((a - b).abs() < 1e-6, "along {d}: {b} against {a}");
            }
            (None, None) => {}
            _ => panic!("along {d}: {got:?} against {want:?}"),
        }
    }
    assert!(hits > 50 && hits < rays, "{hits} hits in {rays} rays");
    let per_ray = s_far.evaluations as f64 / rays as f64;
    assert!(per_ray < 10.0, "{per_ray} evaluations a ray");
}

/// A union written with `min` of a few parts, each a quadric or a
/// polynomial (shifted or scaled, or not), is searched part by part (each on its own route, within
/// its own box) and the first root taken, from outside every part; from
/// inside one it is isolated as written. Every ray hits what interval
/// isolation hits, nearest hits and shadow rays alike.
#[test]
fn a_union_of_solvable_parts_is_searched_part_by_part() {
    let torus = "((x^2 + y^2 + z^2 + 1.44 - 0.1225)^2 - 5.76*(x^2 + y^2))";
    let shapes = [
        format!("min({torus}, length((x - 0.9, y, z - 0.4)) - 0.6)"),
        // Three parts, one a ball written as a quadric, one a cubic.
        format!("min(min({torus}, (x + 1)^2 + y^2 + (z - 1)^2 - 0.25), x^3 - 3*x*y^2 - z - 2.5)"),
        // Shifted, and scaled: the union of the parts shifted or scaled.
        format!("min({torus}, length((x - 0.9, y, z - 0.4)) - 0.6) - 0.05"),
        format!("0.5 * (min({torus}, (x - 0.9)^2 + y^2 + (z - 0.4)^2 - 0.36) + 0.01)"),
    ];
    for shape in &shapes {
        let parts = scene(shape, "auto");
        let interval = scene(shape, "interval");
        let (tp, ti) = (Tracer::new(&parts), Tracer::new(&interval));
        assert_eq!(tp.routes()[0], Route::Union, "{shape}");
        assert_eq!(ti.routes()[0], Route::Interval, "{shape}");
        let f = &parts.objects[0].function;
        let mut s = Scratch::default();
        let mut hits = 0;
        let mut blocked = 0;
        for k in 0..400 {
            let a = k as f64 * 0.6180339887;
            // Every fifth ray starts inside the ball at (0.9, 0, 0.4).
            let origin = if k % 5 == 0 {
                DVec3::new(0.9, 0.1 * a.sin(), 0.4)
            } else {
                DVec3::new(-6.0 * (a * 3.0).cos(), 6.0 * a.sin(), 4.0 * (a * 1.7).cos())
            };
            let target = DVec3::new(
                1.5 * (a * 5.0).sin(),
                1.5 * (a * 2.3).cos(),
                0.6 * (a * 7.1).sin(),
            );
            let d = (target - origin).normalize();
            let got = hit(&tp, origin, d, &mut s);
            let want = hit(&ti, origin, d, &mut s);
            match (got, want) {
                (Some(g), Some(w)) => {
                    hits += 1;
                    assert!((g - w).abs() < 2e-6, "{shape}, ray {k}: {g} vs {w}");
                    let (v, grad) = f.value_and_gradient(origin + g * d, &mut Vec::new());
                    assert!(v.abs() <= 1e-5 * grad.length(), "{shape}, ray {k}: f = {v}");
                }
                (None, None) => {}
                _ => panic!("{shape}, ray {k}: {got:?} vs {want:?}"),
            }
            // A shadow ray along the same path up to 8 units.
            let (bp, bi) = (
                tp.blocked(origin, d, 8.0, &mut s),
                ti.blocked(origin, d, 8.0, &mut s),
            );
            assert_eq!(bp, bi, "{shape}, ray {k}: blocked {bp} vs {bi}");
            blocked += bp as usize;
        }
        assert!(
            hits > 100 && blocked > 100,
            "{shape}: {hits} hits, {blocked} blocked"
        );
    }
}

/// A union of up to 64 parts is met part by part; of more, by its cells
/// (a union of nine balls took ten times as long by its cells as the
/// balls as objects, when eight was the most).
#[test]
fn a_union_of_up_to_64_parts_is_met_part_by_part() {
    let balls = |n: usize| {
        let parts: Vec<String> = (0..n)
            .map(|k| format!("length((x - {}, y, z)) - 0.3", k as f64 * 0.5))
            .collect();
        format!("min({})", parts.join(", "))
    };
    for (n, route) in [(9, Route::Union), (64, Route::Union), (65, Route::Interval)] {
        let s = scene(&balls(n), "auto");
        assert_eq!(Tracer::new(&s).routes()[0], route, "{n} balls");
    }
}
