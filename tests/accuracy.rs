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
    // Every pixel whose central ray meets an object, by closed form, is
    // compared.
    let hit_pixels = pixels_hitting_the_seed_objects(&scene);
    assert!(hit_pixels > 96 * 64 / 4, "{hit_pixels}");
    assert_eq!(exact.errors.compared, hit_pixels, "{:?}", exact.errors);
    assert_eq!(exact.errors.missed, 0);
    // Interval isolation within its epsilon, and no pixel lost: each of
    // the ladder's epsilons has its row.
    let interval: Vec<_> = report
        .rows
        .iter()
        .filter(|r| r.method == Method::Interval)
        .collect();
    let settings: Vec<&str> = interval.iter().map(|r| r.setting.as_str()).collect();
    assert_eq!(
        settings,
        [
            "epsilon 1e-3",
            "epsilon 1e-4",
            "epsilon 1e-6",
            "epsilon 1e-8"
        ]
    );
    for r in interval {
        let eps: f64 = r.setting.trim_start_matches("epsilon ").parse().unwrap();
        assert!(
            r.errors.max_distance_error <= eps,
            "{}: {:?}",
            r.setting,
            r.errors
        );
        assert_eq!(r.errors.differing, 0, "{}", r.setting);
        assert_eq!(r.errors.compared, hit_pixels, "{}", r.setting);
    }
    // The marching methods have a row per step, and the hits they find
    // are located to the scene's epsilon.
    for method in [Method::Adaptive, Method::March] {
        let rows: Vec<_> = report.rows.iter().filter(|r| r.method == method).collect();
        assert_eq!(rows.len(), 4, "{method:?}");
        for r in rows {
            assert!(r.errors.compared > 0, "{method:?} {}", r.setting);
            assert!(
                r.errors.max_distance_error <= scene.settings.epsilon,
                "{method:?} {}: {:?}",
                r.setting,
                r.errors
            );
        }
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

/// The pixels of the seed scene (three spheres over the floor z = -3)
/// whose central ray meets an object within `max_distance`, in closed
/// form.
fn pixels_hitting_the_seed_objects(scene: &nes::Scene) -> usize {
    use glam::DVec3;
    let spheres = [
        (DVec3::new(7.0, 0.0, 0.0), 2.0),
        (DVec3::new(4.5, -2.0, 1.6), 0.5),
        (DVec3::new(6.7, 3.0, -2.3), 0.5),
    ];
    let cam = scene.camera;
    let o = cam.position;
    let limit = scene.settings.max_distance;
    let rays = cam.rays();
    let mut count = 0;
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = rays.direction(x as f64 + 0.5, y as f64 + 0.5);
            let sphere = spheres.iter().any(|&(c, r)| {
                let oc = o - c;
                let b = oc.dot(d);
                let disc = b * b - (oc.length_squared() - r * r);
                disc >= 0.0 && -b - disc.sqrt() > 0.0 && -b - disc.sqrt() <= limit
            });
            let floor = d.z < 0.0 && (-3.0 - o.z) / d.z <= limit;
            count += usize::from(sphere || floor);
        }
    }
    count
}

/// A scene whose default route is not interval isolation (a quartic's
/// exact polynomial roots) gets an `auto` row, and that row is the one
/// marked as the default, not interval isolation's.
#[test]
fn the_default_row_is_the_route_auto_takes() {
    let src = "camera { position (-5, -3, 2) look_at (0, 0, 0) width 40 height 25 }\n\
               light { position (-3, -6, 8) }\n\
               object (x^2 + y^2 + z^2 + 0.8^2 - 0.3^2)^2 - 4 * 0.8^2 * (x^2 + y^2)\n";
    let scene = nes::compile_source("quartic.nes", src).unwrap();
    let report = nes::tools::accuracy::measure(&scene);
    let defaults: Vec<_> = report.rows.iter().filter(|r| r.default).collect();
    assert_eq!(defaults.len(), 1, "{}", report);
    assert_eq!(defaults[0].method, Method::Auto, "{}", report);
    assert_eq!(defaults[0].errors.differing, 0);
}
