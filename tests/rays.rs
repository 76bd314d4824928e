//! `nes rays`: the drawing's geometry, checked against each space's paths
//! computed independently, not just that a file appears.

use glam::DVec3;

mod common;
use common::Scratch;
use nes::tools::rays::{diagram, Selection, View};

fn scene(src: &str) -> nes::Scene {
    nes::compile_source("rays.nes", src).unwrap_or_else(|e| panic!("{e:?}"))
}

fn column(s: &nes::Scene, every: u32) -> Vec<(u32, u32)> {
    Selection::Column {
        x: s.camera.width / 2,
        every,
    }
    .pixels(s.camera.width, s.camera.height)
    .unwrap()
}

/// In the sphere space every drawn point of a ray, path and steps alike,
/// lies on the circle of radius R through the camera that bends down
/// from the ray's direction: centre = origin + R down(d), in the plane of
/// d and down(d).
#[test]
fn sphere_space_paths_are_drawn_on_their_circles() {
    for method in ["exact", "march", "ode"] {
        let s = scene(&format!(
            "space sphere {{ radius 8 }}\n\
             camera {{ position (-4, 0, 0) pitch 20 width 40 height 30 }}\n\
             render {{ method {method} step 0.05 }}\n\
             light {{ position (6, 1, 2) }}\n\
             object sphere(1) {{ translate (2, 0, -1) }}\n\
             object plane((0, 0, 1), -3)"
        ));
        let space =
            nes::space::SphereSpace::new(8.0, nes::space::PathMode::Exact, s.camera.forward);
        let d = diagram(
            &s,
            &column(&s, 3),
            View::parse("side", s.camera.position).unwrap(),
        );
        let mut points = 0;
        let mut hits = 0;
        for r in &d.rays {
            let down = space.down(r.direction);
            let centre = r.origin + 8.0 * down;
            let normal = r.direction.cross(down);
            let on_circle = |p: DVec3| {
                ((p - centre).length() - 8.0).abs() < 1e-6 && (p - centre).dot(normal).abs() < 1e-6
            };
            for &p in r.path.iter().flatten().chain(&r.samples).chain(&r.circle) {
                assert!(
                    on_circle(p),
                    "{method} pixel {:?}: {p} is off the circle",
                    r.pixel
                );
                points += 1;
            }
            if let Some((p, _)) = r.hit {
                assert!(on_circle(p), "{method}: hit {p} off the circle");
                hits += 1;
            }
        }
        assert!(points > 500, "{method}: only {points} points");
        assert!(hits >= 3, "{method}: only {hits} drawn hits");
        if method == "march" {
            assert!(
                d.rays.iter().any(|r| !r.samples.is_empty()),
                "march steps drawn"
            );
        }
    }
}

/// In the torus every stretch of a drawn path is straight along the ray's
/// direction, stays in the cell, and a stretch ends on a face where the
/// path wraps.
#[test]
fn torus_paths_are_straight_in_the_cell_and_wrap_at_faces() {
    let s = scene(
        "space torus { min -5 max 5 wraps 30 }\n\
         camera { position (-2, 0, 0) yaw 20 pitch 5 width 40 height 30 }\n\
         render { max_distance 60 }\n\
         object sphere(1) { translate (3, 2, 0.5) }",
    );
    let d = diagram(
        &s,
        &Selection::Row { y: 15, every: 4 }.pixels(40, 30).unwrap(),
        View::parse("top", s.camera.position).unwrap(),
    );
    let inside = |p: DVec3| p.abs().max_element() <= 5.0 + 1e-9;
    let on_face = |p: DVec3| (p.abs().max_element() - 5.0).abs() < 1e-9;
    let mut wraps = 0;
    for r in &d.rays {
        for line in &r.path {
            for &p in line {
                assert!(inside(p), "{p} outside the cell");
                assert!(
                    (p - line[0]).cross(r.direction).length()
                        < 1e-9 * (1.0 + (p - line[0]).length()),
                    "{p} is off the straight stretch from {}",
                    line[0]
                );
            }
        }
        for &w in &r.wraps {
            assert!(on_face(w), "wrap at {w}, not on a face");
            wraps += 1;
        }
        // The drawn length is the hit's distance (or the whole ray).
        let drawn: f64 = r
            .path
            .iter()
            .map(|l| l.windows(2).map(|w| (w[1] - w[0]).length()).sum::<f64>())
            .sum();
        let want = match r.hit {
            Some(_) => {
                let tracer = nes::trace::Tracer::new(&s);
                let mut sc = nes::trace::intersect::Scratch::default();
                tracer
                    .nearest_hit(r.origin, r.direction, 60.0, &mut sc)
                    .unwrap()
                    .t
            }
            None => 60.0,
        };
        assert!((drawn - want).abs() < 1e-6, "drawn {drawn}, path {want}");
    }
    assert!(wraps > 10, "only {wraps} wraps");
}

/// The march's steps lie on the straight ray in Euclidean space, hits lie
/// on the surface, and shadow rays are drawn blocked exactly when the
/// renderer finds the point in shadow.
#[test]
fn steps_hits_and_shadows_are_where_the_renderer_has_them() {
    let s = scene(
        "camera { position (-4, 0, 1) pitch -15 width 30 height 20 }\n\
         render { method march step 0.1 }\n\
         light { position (0, -4, 5) }\n\
         object sphere(0.8) { translate (1, 0, 0.3) }\n\
         object plane((0, 0, 1), -1)",
    );
    let d = diagram(
        &s,
        &column(&s, 1),
        View::parse("side", s.camera.position).unwrap(),
    );
    let tracer = nes::trace::Tracer::new(&s);
    let mut blocked = 0;
    let (mut samples, mut hits, mut shadows) = (0, 0, 0);
    for r in &d.rays {
        for &p in &r.samples {
            assert!((p - r.origin).cross(r.direction).length() < 1e-9, "{p}");
            samples += 1;
        }
        let mut sc = nes::trace::intersect::Scratch::default();
        let found = tracer.nearest_hit(r.origin, r.direction, 100.0, &mut sc);
        // A hit is drawn exactly where the renderer finds one, on the
        // object it finds, at its point.
        assert_eq!(r.hit.is_some(), found.is_some(), "pixel {:?}", r.pixel);
        let Some((p, object)) = r.hit else { continue };
        let hit = found.unwrap();
        assert_eq!(object, hit.object, "pixel {:?}", r.pixel);
        assert!((p - hit.point).length() < 1e-9, "pixel {:?}: {p}", r.pixel);
        hits += 1;
        let mut slots = Vec::new();
        assert!(s.objects[object].function.value(p, &mut slots).abs() < 1e-5);
        // One shadow ray per light the surface faces (none towards a light
        // behind it, as the renderer skips those).
        let n = tracer.normal(&hit, &mut sc);
        let facing = s
            .lights
            .iter()
            .filter(|l| (l.position - hit.point).dot(n) > 0.0)
            .count();
        assert_eq!(r.shadows.len(), facing, "pixel {:?}", r.pixel);
        for sh in &r.shadows {
            shadows += 1;
            let start = tracer.shadow_start(&hit, n);
            let shadowed = tracer.in_shadow(start, s.lights[sh.light].position, &mut sc);
            assert_eq!(sh.blocked_at.is_some(), shadowed, "pixel {:?}", r.pixel);
            blocked += usize::from(shadowed);
        }
    }
    assert!(blocked > 0, "some shadow ray in the column is blocked");
    assert!(
        shadows > blocked,
        "some shadow ray in the column is not blocked"
    );
    assert!(
        samples > 0 && hits > 0,
        "{samples} steps, {hits} hits drawn"
    );
}

/// The cross section of a sphere in a plane through its centre is drawn as
/// a circle of its radius.
#[test]
fn cross_sections_are_the_zero_contours() {
    let s = scene(
        "camera { position (-4, 0, 0) width 20 height 20 }\n\
         object sphere(1.5) { translate (2, 0.5, 0) }",
    );
    let d = diagram(
        &s,
        &column(&s, 5),
        View::parse("y=0.5", s.camera.position).unwrap(),
    );
    let segs = &d.contours[0];
    assert!(segs.len() > 50);
    for seg in segs {
        for &(x, z) in seg {
            let r = ((x - 2.0).powi(2) + z * z).sqrt();
            assert!((r - 1.5).abs() < 0.02, "({x}, {z}) at radius {r}");
        }
    }
    // A plane that misses the sphere shows no section of it.
    let d = diagram(
        &s,
        &column(&s, 5),
        View::parse("y=2.5", s.camera.position).unwrap(),
    );
    assert!(d.contours[0].is_empty());
}

#[test]
fn the_command_writes_svg_and_png_and_rejects_bad_views() {
    let dir = Scratch::new("rays");
    for name in ["r.svg", "r.png"] {
        let out = dir.join(name);
        let run = std::process::Command::new(env!("CARGO_BIN_EXE_nes"))
            .args([
                "rays",
                "examples/sphere-space.nes",
                "--width",
                "70",
                "--row",
                "20",
                "-o",
            ])
            .arg(&out)
            .output()
            .unwrap();
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        let bytes = std::fs::read(&out).unwrap();
        if name.ends_with("svg") {
            assert!(String::from_utf8_lossy(&bytes).contains("<svg"));
        } else {
            assert!(image::load_from_memory(&bytes).is_ok());
        }
    }
    for args in [
        vec!["--view", "diagonal"],
        vec!["--view", "w=1"],
        vec!["--row", "5000"],
        vec!["--every", "0"],
        vec!["--every", "1"],
        vec!["--pixel", "1;2"],
    ] {
        let run = std::process::Command::new(env!("CARGO_BIN_EXE_nes"))
            .args(["rays", "examples/seed.nes"])
            .args(&args)
            .arg("-o")
            .arg(dir.join("bad.svg"))
            .env("NO_COLOR", "1")
            .output()
            .unwrap();
        assert_eq!(run.status.code(), Some(1), "{args:?}");
        assert!(
            String::from_utf8_lossy(&run.stderr).contains("E0501"),
            "{args:?}"
        );
        assert!(!dir.join("bad.svg").exists(), "{args:?} wrote a drawing");
    }
}

/// The 3D view draws the same traced rays as a plane view (only the
/// projection differs), and takes no cross sections.
#[test]
fn the_perspective_view_draws_the_same_rays() {
    let s = scene(
        "space torus { min -5 max 5 wraps 10 }\n\
         camera { position (-2, 0, 0) width 30 height 20 }\n\
         object sphere(1) { translate (3, 0.5, 0) }",
    );
    let pixels = column(&s, 4);
    let flat = diagram(&s, &pixels, View::parse("side", s.camera.position).unwrap());
    let solid = diagram(&s, &pixels, View::parse("3d", s.camera.position).unwrap());
    assert_eq!(flat.rays, solid.rays);
    assert!(!flat.contours[0].is_empty());
    assert!(solid.contours.iter().all(Vec::is_empty));
    let dir = Scratch::new("rays-3d");
    let _ = std::fs::remove_file(dir.join("r.png"));
    nes::tools::rays::draw(&solid, &dir.join("r.png")).unwrap();
    assert!(image::open(dir.join("r.png")).is_ok());
}

/// `--mark` writes the render with exactly the drawn pixels red; every
/// other pixel is the plain render's.
#[test]
fn marked_pixels_are_red_and_the_rest_is_the_render() {
    let dir = Scratch::new("rays-mark");
    let (marked, plain) = (dir.join("marked.png"), dir.join("plain.png"));
    let run = |args: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_nes"))
            .args(args)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    run(&[
        "rays",
        "examples/sphere-space.nes",
        "--width",
        "56",
        "--row",
        "10",
        "--every",
        "7",
        "-o",
        dir.join("r.svg").to_str().unwrap(),
        "--mark",
        marked.to_str().unwrap(),
    ]);
    run(&[
        "render",
        "examples/sphere-space.nes",
        "--width",
        "56",
        "-q",
        "-o",
        plain.to_str().unwrap(),
    ]);
    let (m, p) = (
        image::open(&marked).unwrap().to_rgb8(),
        image::open(&plain).unwrap().to_rgb8(),
    );
    let chosen: Vec<u32> = (0..56).filter(|x| x % 7 == 28 % 7).collect();
    for (x, y, px) in m.enumerate_pixels() {
        if y == 10 && chosen.contains(&x) {
            assert_eq!(px.0, [255, 0, 0], "({x}, {y})");
        } else {
            assert_eq!(px, p.get_pixel(x, y), "({x}, {y})");
        }
    }
}

/// In S3 the drawing's coordinates (normal coordinates about the origin)
/// name every point within pi R, and the same points again beyond: a
/// ball is drawn once, inside that radius, not a second time past the
/// antipode. The 3D view marks the placed objects, whose bounds it cannot
/// draw as boxes.
#[test]
fn s3_objects_are_drawn_once_within_the_antipode() {
    let s = scene(
        "space s3 { radius 4 }\n\
         camera { position (0, 0, 0) width 40 height 30 }\n\
         object sphere(0.6) { translate (10.8, 1.6, 0) }\n\
         object sphere(0.6) { translate (4.5, -1, 0) }",
    );
    let rows = Selection::Row { y: 15, every: 4 }.pixels(40, 30).unwrap();
    let d = diagram(&s, &rows, View::parse("top", s.camera.position).unwrap());
    let r = 4.0 * std::f64::consts::PI;
    for (i, segs) in d.contours.iter().enumerate() {
        assert!(segs.len() > 20, "object {i} has a cross section");
        for seg in segs {
            for &(x, y) in seg {
                let length = (x * x + y * y).sqrt();
                assert!(length <= r * (1.0 + 1e-9), "object {i}: ({x}, {y})");
            }
        }
    }
    // The far ball's section lies on its side of the camera (stretched
    // across the view, as normal coordinates stretch far things), with
    // no second section past the antipode, on the other side.
    for seg in &d.contours[0] {
        for &(x, y) in seg {
            assert!(x > 5.0, "({x}, {y})");
        }
    }
    assert!(d.rays.iter().all(|ray| ray.circle.len() > 1));
    assert_eq!(d.placed, [true, true]);
    assert!(d.bounds.iter().all(Option::is_none));
    let flat = scene("camera { position (-4, 0, 0) width 20 height 20 }\nobject sphere(1)");
    let d = diagram(
        &flat,
        &column(&flat, 5),
        View::parse("3d", DVec3::ZERO).unwrap(),
    );
    assert_eq!(d.placed, [false]);
    assert!(d.bounds[0].is_some());
}
