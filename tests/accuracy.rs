//! `nes accuracy`: the table's rows measure what they say.

use nes::scene::Method;

#[test]
fn the_report_compares_every_method_with_the_reference() {
    let src = std::fs::read_to_string("examples/seed.nes").unwrap();
    let mut scene = nes::compile_source("seed.nes", &src).unwrap();
    scene.camera.width = 96;
    scene.camera.height = 64;
    let report = nes::tools::accuracy::measure(&scene);
    assert!(
        report.reference.starts_with("closed form"),
        "{}",
        report.reference
    );
    let exact = report
        .rows
        .iter()
        .find(|r| r.method == Method::Exact)
        .unwrap();
    // The closed form against itself: nothing differs.
    assert_eq!(exact.errors.max_distance_error, 0.0);
    assert_eq!(exact.errors.differing, 0);
    assert!(exact.default);
    assert!(exact.errors.compared > 96 * 64 / 4, "{:?}", exact.errors);
    // Interval isolation within its epsilon, and no pixel lost.
    for r in report.rows.iter().filter(|r| r.method == Method::Interval) {
        let eps: f64 = r.setting.trim_start_matches("epsilon ").parse().unwrap();
        assert!(
            r.errors.max_distance_error <= eps,
            "{}: {:?}",
            r.setting,
            r.errors
        );
        assert_eq!(r.errors.differing, 0, "{}", r.setting);
    }
    // Every row timed; no ode rows outside the sphere space.
    assert!(report
        .rows
        .iter()
        .all(|r| r.seconds > 0.0 && r.rays_per_second > 0.0));
    assert!(report.rows.iter().all(|r| r.method != Method::Ode));
    let text = report.to_string();
    assert_eq!(text.lines().count(), 2 + report.rows.len(), "{text}");
}
