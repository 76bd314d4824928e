//! `nes explain`: the plan names each object's route, bound and size, the
//! work the renderer skips, and what it measured.

use glam::DVec3;

const SCENE: &str = "
camera { position (-6, 0, 0) width 64 height 48 }
shape ring(major: positive, minor: positive) = (sqrt(x^2 + y^2) - major)^2 + z^2 - minor^2
object sphere(1) { translate (0, 2, 0) }
object ring(1, 0.25) { translate (0, -2, 0) }
object sphere(1) { translate (0, 0, 500) }
";

/// The fraction of the camera's pixel-centre rays whose straight line
/// meets the box `lo .. hi` within the scene's `max_distance`.
fn fraction_meeting_box(scene: &nes::Scene, lo: DVec3, hi: DVec3) -> f64 {
    let cam = scene.camera;
    let rays = cam.rays();
    let mut meets = 0;
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = rays.direction(x as f64 + 0.5, y as f64 + 0.5);
            let (mut t0, mut t1) = (0.0f64, scene.settings.max_distance);
            for a in 0..3 {
                let (o, v) = (cam.position[a], d[a]);
                if v == 0.0 {
                    if o < lo[a] || o > hi[a] {
                        t1 = -1.0;
                    }
                    continue;
                }
                let (ta, tb) = ((lo[a] - o) / v, (hi[a] - o) / v);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
            if t0 <= t1 {
                meets += 1;
            }
        }
    }
    meets as f64 / (cam.width * cam.height) as f64
}

#[test]
fn the_plan_names_routes_bounds_and_skipped_work() {
    let scene = nes::compile_source("explain.nes", SCENE).unwrap();
    let plan = nes::tools::explain::plan(&scene);
    let [sphere, ring, far] = &plan.objects[..] else {
        panic!("three objects expected: {plan:?}");
    };
    assert!(
        sphere.route.starts_with("closed form (a quadric)"),
        "{}",
        sphere.route
    );
    assert!(
        ring.route.starts_with("interval root isolation"),
        "{}",
        ring.route
    );
    // The sphere's bound is its own box, to within the bound's margin.
    let b = sphere.bound.expect("reachable");
    assert!(
        (b.min - DVec3::new(-1.0, 1.0, -1.0)).abs().max_element() < 1e-6,
        "{b:?}"
    );
    assert!(
        (b.max - DVec3::new(1.0, 3.0, 1.0)).abs().max_element() < 1e-6,
        "{b:?}"
    );
    // The ring is written with operations that simplify away (x^2 is a
    // square, translations fold into constants). Simplified, it is
    // (sqrt(x^2 + (y + 2)^2) - 1)^2 + z^2 - 0.0625: the inputs x, y, z,
    // the constants 2, 1 and 0.0625, and ten operations (y + 2, three
    // squares of coordinates, the sum, sqrt, the difference, its square,
    // the sum with z^2 and the final difference): 16 nodes, of which the
    // value tape evaluates the ten operations.
    assert_eq!(ring.simplified, 16, "{ring:?}");
    assert!(ring.written > ring.simplified, "{ring:?}");
    assert_eq!(ring.value_ops, 10, "{ring:?}");
    assert!(ring.gradient_ops > ring.value_ops, "{ring:?}");
    // 500 units away, beyond max_distance 100: dropped.
    assert!(far.bound.is_none());
    assert_eq!(far.reached, 0.0);
    // Roughly a 2 x 2 box seen from 6 units away through a 60 degree
    // diagonal field of view: a few percent of the rays, never all or none;
    // exactly the pixels whose ray meets the box, by the slab test.
    assert!(
        sphere.reached > 0.01 && sphere.reached < 0.5,
        "{}",
        sphere.reached
    );
    let ring_box = (
        DVec3::new(-1.25, -3.25, -0.25),
        DVec3::new(1.25, -0.75, 0.25),
    );
    let ring_bound = ring.bound.expect("reachable");
    assert!(
        (ring_bound.min - ring_box.0).abs().max_element() < 1e-6
            && (ring_bound.max - ring_box.1).abs().max_element() < 1e-6,
        "{ring_bound:?}"
    );
    for (o, (lo, hi)) in [
        (
            sphere,
            (DVec3::new(-1.0, 1.0, -1.0), DVec3::new(1.0, 3.0, 1.0)),
        ),
        (ring, ring_box),
    ] {
        let want = fraction_meeting_box(&scene, lo, hi);
        assert!(
            (o.reached - want).abs() < 1.5 / (64.0 * 48.0),
            "{}: reached {} vs {want}",
            o.label,
            o.reached
        );
    }

    let text = plan.to_string();
    // The totals are the sums over the objects.
    let written: usize = plan.objects.iter().map(|o| o.written).sum();
    let simplified: usize = plan.objects.iter().map(|o| o.simplified).sum();
    assert!(
        text.contains(&format!(
            "simplification: {written} operations as written, {simplified} after"
        )),
        "{text}"
    );
    assert!(text.contains("no lights: no shadow rays"), "{text}");
    assert!(
        text.contains("dropped, no surface within reach of any ray: sphere"),
        "{text}"
    );
    assert!(text.contains("function evaluations per ray"), "{text}");
}

#[test]
fn the_explain_command_prints_the_plan() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_nes"))
        .args(["explain", "examples/implicit.nes"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    // The heart and the rounded cube are polynomials; the ring, with its
    // square root, is not.
    assert_eq!(
        text.matches("exact polynomial roots (degree 6)").count(),
        1,
        "{text}"
    );
    assert_eq!(
        text.matches("exact polynomial roots (degree 8)").count(),
        1,
        "{text}"
    );
    assert_eq!(text.matches("interval root isolation").count(), 1, "{text}");
    assert_eq!(text.matches("closed form").count(), 2, "{text}");
}

/// The loose-bound note: shown for an object the interval route searches
/// (Chmutov's octic written with `abs`, which is not a polynomial), with
/// the culprit named; not for the same surface as a polynomial, which the
/// polynomial route solves whatever its bound.
#[test]
fn a_loose_bound_is_noted_only_where_searches_pay_for_it() {
    let scene = |wrap: &dyn Fn(&str) -> String| {
        format!(
            "shape T8(t) = 128*t^8 - 256*t^6 + 160*t^4 - 32*t^2 + 1\n\
             camera {{ position (-4, -2.5, 2) look_at (0, 0, 0) width 80 height 50 }}\n\
             shape s = T8({}) + T8({}) + T8({})\nobject s\n",
            wrap("x"),
            wrap("y"),
            wrap("z")
        )
    };
    let explain = |src: String| {
        let scene = nes::compile_source("loose.nes", &src).unwrap();
        nes::tools::explain::plan(&scene).to_string()
    };
    let searched = explain(scene(&|v| format!("abs({v})")));
    assert!(searched.contains("interval root isolation"), "{searched}");
    assert!(searched.contains("  note        its bound"), "{searched}");
    assert!(searched.contains("256*"), "{searched}");
    let solved = explain(scene(&|v| v.to_string()));
    assert!(
        solved.contains("exact polynomial roots (degree 8)"),
        "{solved}"
    );
    assert!(!solved.contains("  note"), "{solved}");
}

/// In S3 and H3 the loose-bound note names what the user wrote (a
/// builtin, the prelude shape built on one, or a translated part), never
/// the internal operations the space's model compiles to, and never an
/// infinite or NaN ratio; with advice the user can follow.
#[test]
fn a_loose_bound_in_a_curved_space_names_what_was_written() {
    let notes = |space: &str, objects: &str| -> Vec<String> {
        let src = format!(
            "space {space}\ncamera {{ position (-3, 0, 1) look_at (1, 0, 0) width 32 height 24 }}\n\
             light {{ position (1, -2, 2.5) }}\n{objects}"
        );
        let scene = nes::compile_source("curved.nes", &src).unwrap();
        let text = nes::tools::explain::plan(&scene).to_string();
        text.lines()
            .filter(|l| l.starts_with("  note"))
            .map(str::to_string)
            .collect()
    };
    let clean = |note: &str| {
        for word in ["chc", "shc", "inf", "NaN"] {
            assert!(!note.contains(word), "`{word}` in: {note}");
        }
    };
    let horosphere = notes(
        "h3 { radius 3 }",
        "object horosphere((1, 0, 0), 2)\nshape b = busemann((0, 1, 0)) + 1\nobject b\n",
    );
    assert_eq!(horosphere.len(), 2, "{horosphere:?}");
    assert!(horosphere[0].contains("`horosphere`"), "{}", horosphere[0]);
    assert!(horosphere[0].contains("unbounded"), "{}", horosphere[0]);
    assert!(horosphere[1].contains("`busemann`"), "{}", horosphere[1]);
    let balls = notes(
        "h3 { radius 3 }",
        "shape two = min(geodesic_distance((0, 3, 0)) - 1, geodesic_distance((0, -3, 0)) - 1)\nobject two\n",
    );
    assert_eq!(balls.len(), 1, "{balls:?}");
    assert!(balls[0].contains("`geodesic_distance`"), "{}", balls[0]);
    assert!(balls[0].contains("`sphere(r) translate c`"), "{}", balls[0]);
    let parts = notes(
        "s3 { radius 4 }",
        "object union(sphere(1) translate (0, 0, 3), cube(0.5) translate (0, 0, -3))\n",
    );
    assert_eq!(parts.len(), 1, "{parts:?}");
    assert!(parts[0].contains("a translated part"), "{}", parts[0]);
    assert!(parts[0].contains("its own object"), "{}", parts[0]);
    for note in horosphere.iter().chain(&balls).chain(&parts) {
        clean(note);
        assert!(note.contains("clip"), "{note}");
    }
}

/// A culprit whose interval is unbounded is said to be, not "infx wider".
#[test]
fn an_unbounded_culprit_is_said_in_words() {
    use nes::compile::{Culprit, LooseBound};
    use nes::space::Aabb;
    let loose = |ratio: f64| LooseBound {
        bound: Aabb {
            min: DVec3::splat(-2.0),
            max: DVec3::splat(2.0),
        },
        surface: Aabb {
            min: DVec3::splat(-1.0),
            max: DVec3::splat(1.0),
        },
        holds: Aabb {
            min: DVec3::splat(-1.0),
            max: DVec3::splat(1.0),
        },
        culprit: Some(Culprit {
            expr: "ln(x)".into(),
            ratio,
            internal: false,
        }),
    };
    let said = loose(f64::INFINITY).describe(false, &[]);
    assert!(said.contains("is unbounded over a cell"), "{said}");
    assert!(!said.contains("inf"), "{said}");
    let said = loose(3e9).describe(false, &[]);
    assert!(said.contains("3e9 times wider"), "{said}");
    let said = loose(12.4).describe(false, &[]);
    assert!(said.contains("12x wider"), "{said}");
}

/// The header says what really ends rays in each space, prints the
/// curvature for people, and the shadow-ray line counts both arcs to a
/// light in S3.
#[test]
fn the_header_says_what_ends_rays_in_each_space() {
    let plan = |space: &str, camera: &str| {
        let src = format!(
            "{space}\ncamera {{ position {camera} look_at (1, 0, 0) width 16 height 12 }}\n\
             light {{ position (1, -2, 2.5) }}\nobject sphere(0.5) {{ translate (2, 0, 0) }}\n"
        );
        let scene = nes::compile_source("spaces.nes", &src).unwrap();
        nes::tools::explain::plan(&scene)
    };
    let s3 = plan("space s3 { radius 4 }", "(0, 0, 0)");
    let text = s3.header.join("\n");
    assert!(text.contains("curvature 0.0625"), "{text}");
    assert!(
        text.contains("rays end after one loop round the space, 2 pi R = 25.13"),
        "{text}"
    );
    assert!(s3
        .skips
        .iter()
        .any(|l| l.starts_with("shadow rays: 2 per hit and light")));
    let loops = plan(
        "space s3 { radius 4 loops 3 }\nrender { max_distance 1000 }",
        "(0, 0, 0)",
    );
    let text = loops.header.join("\n");
    assert!(
        text.contains("after 3 loops round the space, 75.4"),
        "{text}"
    );
    let short = plan(
        "space s3 { radius 4 }\nrender { max_distance 10 }",
        "(0, 0, 0)",
    );
    let text = short.header.join("\n");
    assert!(text.contains("rays end after 10 (max_distance)"), "{text}");
    let h3 = plan("space h3 { radius 3 }", "(-1, 0, 0)");
    let text = h3.header.join("\n");
    assert!(text.contains("curvature -0.1111"), "{text}");
    assert!(!text.contains("e-1"), "{text}");
    assert!(
        text.contains("rays end 12 R = 36 from the origin") && text.contains("after 35"),
        "{text}"
    );
    assert!(h3
        .skips
        .iter()
        .any(|l| l.starts_with("shadow rays: one per hit")));
    let flat = plan("", "(-3, 0, 0)");
    let text = flat.header.join("\n");
    assert!(text.contains("rays end after 100 (max_distance)"), "{text}");
}

/// A metric whose geodesics take thousands of integrator steps (it
/// wiggles on a scale of 0.06) shrinks explain's coverage grid and sample
/// render to fit their step budgets, and says so with the full render's
/// estimate, instead of integrating for minutes.
#[test]
fn a_metric_of_costly_paths_gets_a_smaller_sample() {
    let scene = nes::compile_source(
        "wiggle.nes",
        "space metric { g diag(1 + 0.5 * sin(100 * x), 1, 1) }
         camera { position (-5, 0, 0) width 160 height 100 }
         light { position (-5, 5, 5) }
         object sphere(1)",
    )
    .unwrap();
    let plan = nes::tools::explain::plan(&scene);
    let text = plan.to_string();
    let number_after = |line: &str, key: &str| -> f64 {
        let rest = &line[line.find(key).unwrap_or_else(|| panic!("{key} in {line}")) + key.len()..];
        rest.split(|c: char| !(c.is_ascii_digit() || c == '.'))
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let coverage = text
        .lines()
        .find(|l| l.contains("coverage sample (a coarse grid"))
        .unwrap_or_else(|| panic!("{text}"));
    let paths = number_after(coverage, "geodesics: ");
    let steps = number_after(coverage, "paths, ");
    assert!(steps > 5000.0, "{coverage}");
    assert!(
        paths * steps < 3e6,
        "the coverage grid took {paths} paths of {steps} steps: {coverage}"
    );
    let sample = text
        .lines()
        .find(|l| l.contains("sample render:"))
        .unwrap_or_else(|| panic!("{text}"));
    let across = number_after(sample, "measured on a ");
    assert!((8.0..120.0).contains(&across), "{sample}");
    assert!(
        text.contains(&format!("the sample is {across} pixels across, not 120")),
        "{text}"
    );
    assert!(text.contains("M integrator steps"), "{text}");
}
