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
    // square, translations fold into constants).
    assert!(ring.simplified <= ring.written, "{ring:?}");
    assert!(ring.value_ops > 0 && ring.gradient_ops > ring.value_ops);
    // 500 units away, beyond max_distance 100: dropped.
    assert!(far.bound.is_none());
    assert_eq!(far.reached, 0.0);
    // Roughly a 2 x 2 box seen from 6 units away through a 60 degree
    // diagonal field of view: a few percent of the rays, never all or none.
    assert!(
        sphere.reached > 0.01 && sphere.reached < 0.5,
        "{}",
        sphere.reached
    );

    let text = plan.to_string();
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
    assert_eq!(text.matches("interval root isolation").count(), 3, "{text}");
    assert_eq!(text.matches("closed form").count(), 2, "{text}");
}
