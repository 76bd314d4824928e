//! Every example scene parses, compiles and renders at a small size; the
//! prelude compiles on its own without a diagnostic.

use std::path::Path;

#[test]
fn every_example_renders_at_a_small_size() {
    let mut count = 0;
    for entry in std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples")).unwrap()
    {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "nes") {
            continue;
        }
        let src = std::fs::read_to_string(&path).unwrap();
        let mut scene = nes::compile_source(&path.display().to_string(), &src)
            .unwrap_or_else(|e| panic!("{}", e.render_plain()));
        assert!(
            !scene.objects.is_empty(),
            "{} draws nothing",
            path.display()
        );
        scene.camera.width = 48;
        scene.camera.height = 32;
        let (img, stats) = nes::render(&scene);
        assert_eq!(stats.nonfinite_pixels, 0, "{}", path.display());
        // Something other than the background is visible.
        let bg = scene.background;
        assert!(
            img.pixels
                .iter()
                .filter(|p| (**p - bg).abs().max_element() > 1e-3)
                .count()
                > 48,
            "{} shows almost nothing",
            path.display()
        );
        count += 1;
    }
    assert!(count >= 4, "only {count} examples found");
}

#[test]
fn the_prelude_compiles_cleanly_and_every_shape_is_usable() {
    let uses = [
        "sphere(1)",
        "plane((0, 0, 1), 0)",
        "ellipsoid(1, 2, 3)",
        "box(1, 2, 3)",
        "cube(1)",
        "torus(2, 0.5)",
        "cylinder(1)",
        "capped_cylinder(1, 2)",
        "cone(30)",
        "superellipsoid(4)",
    ];
    let prelude = nes::compile::PRELUDE;
    let defined = prelude.lines().filter(|l| l.starts_with("shape ")).count();
    assert_eq!(defined, uses.len(), "a prelude shape has no test use");
    for u in uses {
        let src = format!("camera {{ position (-9, 1, 2) look_at (0, 0, 0) }}\nobject {u}");
        nes::compile_source("p.nes", &src).unwrap_or_else(|e| panic!("{u}: {}", e.render_plain()));
    }
    assert!(nes::syntax::parse(prelude).is_ok());
}
