//! Every example scene parses, compiles and renders at a small size; the
//! prelude compiles on its own without a diagnostic.

use std::path::Path;

#[test]
fn every_example_renders_at_a_small_size() {
    let rendered = render_all_in("examples");
    // The examples the documentation names are among them (others may be
    // added).
    for name in [
        "approach.nes",
        "csg.nes",
        "heart-and-cube.nes",
        "hello.nes",
        "implicit.nes",
        "h3.nes",
        "s3.nes",
        "seed.nes",
        "sphere-r25.nes",
        "sphere-space.nes",
        "torus.nes",
    ] {
        assert!(
            rendered.iter().any(|r| r == name),
            "{name} not rendered: {rendered:?}"
        );
    }
}

/// The README's gallery: at least twenty surfaces, each trusted in every
/// pixel.
#[test]
fn every_gallery_scene_renders_at_a_small_size() {
    let rendered = render_all_in("examples/gallery");
    assert!(rendered.len() >= 20, "{rendered:?}");
}

/// The metric spaces' examples: Nil, Sol, S2 x R, H2 x R and a lens,
/// each trusted in every pixel, with no path ending early.
#[test]
fn every_metric_space_example_renders_at_a_small_size() {
    let rendered = render_all_in("examples/metric");
    for name in ["nil.nes", "sol.nes", "s2xr.nes", "h2xr.nes", "lens.nes"] {
        assert!(
            rendered.iter().any(|r| r == name),
            "{name} not rendered: {rendered:?}"
        );
    }
}

/// Renders every scene in `folder` at 48 x 32; their file names.
fn render_all_in(folder: &str) -> Vec<String> {
    let mut rendered = Vec::new();
    for entry in std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(folder)).unwrap() {
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
        // No example is warned about (`--deny-warnings` passes on each).
        assert!(
            scene.warnings.is_empty(),
            "{}: {:?}",
            path.display(),
            scene
                .warnings
                .iter()
                .map(|w| &w.message)
                .collect::<Vec<_>>()
        );
        scene.camera.width = 48;
        scene.camera.height = 32;
        let (img, stats) = nes::render(&scene);
        assert_eq!(stats.nonfinite_pixels, 0, "{}", path.display());
        // Every pixel can be trusted.
        assert!(
            stats.warnings(&scene.settings).is_empty(),
            "{}: {:?}",
            path.display(),
            stats.warnings(&scene.settings)
        );
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
        rendered.push(path.file_name().unwrap().to_string_lossy().into_owned());
    }
    rendered
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
        "horosphere((1, 0, 0), 1)",
        "equidistant((0, 0, 1), -1)",
    ];
    let prelude = nes::compile::PRELUDE;
    // Each shape the prelude defines has exactly one use here, by name.
    let mut defined: Vec<&str> = prelude
        .lines()
        .filter_map(|l| l.strip_prefix("shape "))
        .map(|rest| {
            rest.split(|c: char| !(c.is_alphanumeric() || c == '_'))
                .next()
                .unwrap()
        })
        .collect();
    let mut used: Vec<&str> = uses.iter().map(|u| u.split('(').next().unwrap()).collect();
    defined.sort_unstable();
    used.sort_unstable();
    assert_eq!(defined, used, "a prelude shape has no test use");
    for u in uses {
        let src = format!("camera {{ position (-9, 1, 2) look_at (0, 0, 0) }}\nobject {u}");
        let scene = nes::compile_source("p.nes", &src)
            .unwrap_or_else(|e| panic!("{u}: {}", e.render_plain()));
        // Usable: it has a surface within reach, which the camera sees.
        assert!(scene.objects[0].bound.is_some(), "{u}: no surface in reach");
        let mut small = scene.clone();
        small.camera.width = 24;
        small.camera.height = 16;
        let (img, _) = nes::render(&small);
        assert!(
            img.pixels.iter().any(|p| *p != small.background),
            "{u}: nothing visible"
        );
    }
    assert!(nes::syntax::parse(prelude).is_ok());
}
