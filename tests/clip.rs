//! `clip`: a surface drawn only where a second formula is negative or
//! zero, open where it is cut. Each test knows the hit from the geometry.

use glam::DVec3;
use nes::trace::intersect::Scratch;
use nes::trace::Tracer;

fn scene(object: &str) -> nes::Scene {
    let src = format!("camera {{ position (-9, 0, 0) }}\n{object}");
    nes::compile_source("clip.nes", &src).unwrap_or_else(|e| panic!("{}", e.render_plain()))
}

fn hit(scene: &nes::Scene, origin: DVec3, direction: DVec3) -> Option<f64> {
    let tracer = Tracer::new(scene);
    tracer
        .nearest_hit(
            origin,
            direction.normalize(),
            100.0,
            &mut Scratch::default(),
        )
        .map(|h| h.t)
}

/// A unit sphere kept below z = 0.3, in every route: a ray straight down
/// misses the cut-away cap and meets the inside of the bowl at its
/// bottom; a ray across above the cut passes through the open top; one
/// below the cut hits the side as if unclipped.
#[test]
fn a_clipped_sphere_is_an_open_bowl() {
    for (shape, method) in [
        ("sphere(1)", "auto"),
        (
            "x^4 + y^4 + z^4 + 2*x^2*y^2 + 2*x^2*z^2 + 2*y^2*z^2 - 1",
            "auto",
        ),
        ("sqrt(x^2 + y^2 + z^2) - 1", "auto"),
        ("sphere(1)", "march"),
    ] {
        let s = scene(&format!(
            "render {{ method {method} }}\nshape s = {shape}\nobject s {{ clip z - 0.3 }}"
        ));
        let down = hit(&s, DVec3::new(0.0, 0.0, 5.0), -DVec3::Z);
        assert!(
            (down.expect("the bowl's bottom") - 6.0).abs() < 1e-4,
            "{shape}: {down:?}"
        );
        let above = hit(&s, DVec3::new(-5.0, 0.0, 0.6), DVec3::X);
        assert_eq!(above, None, "{shape}: above the cut");
        let below = hit(&s, DVec3::new(-5.0, 0.0, 0.2), DVec3::X);
        let want = 5.0 - (1.0f64 - 0.04).sqrt();
        assert!(
            (below.expect("the side") - want).abs() < 1e-4,
            "{shape}: {below:?}"
        );
    }
}

/// The clip moves with the object's transforms, and shrinks its bound to
/// the kept part.
#[test]
fn the_clip_moves_with_the_object_and_bounds_it() {
    let s = scene("object sphere(1) { clip z - 0.3 translate (0, 0, 2) }");
    let bound = s.objects[0].bound.expect("a bound");
    assert!(bound.max.z < 2.31 && bound.max.z > 2.29, "{bound:?}");
    assert!(bound.min.z < 1.01, "{bound:?}");
    // Where `clip` stands among the block's transforms does not matter.
    let before = scene("object sphere(1) { translate (0, 0, 2) clip z - 0.3 }");
    assert_eq!(before.objects[0].bound, s.objects[0].bound);
    // Straight down onto the moved bowl's bottom, at z = 1.
    let down = hit(&s, DVec3::new(0.0, 0.0, 5.0), -DVec3::Z).expect("the bottom");
    assert!((down - 4.0).abs() < 1e-4, "{down}");
    // Transforms written after the solid, before the block, move it too
    // (in its own coordinates, with the block's after them): a half ball
    // of radius 0.5 about (0, 0, 2), scaled then moved.
    for written in [
        "object sphere(1) scale 0.5 translate (0, 0, 2) { clip z }",
        "object sphere(1) scale 0.5 { translate (0, 0, 2) clip z }",
        "object (sphere(1) scale 0.5) translate (0, 0, 2) { clip z }",
    ] {
        let s = scene(written);
        let bound = s.objects[0].bound.expect("a bound");
        assert!((bound.max.z - 2.0).abs() < 1e-6, "{written}: {bound:?}");
        assert!((bound.min.z - 1.5).abs() < 1e-6, "{written}: {bound:?}");
        let down = hit(&s, DVec3::new(0.0, 0.0, 5.0), -DVec3::Z).expect("the bowl's inside");
        assert!((down - 3.5).abs() < 1e-4, "{written}: {down}");
    }
}

/// A clip that keeps nothing of the surface drops the object, and one
/// that is not a number is an error at its span.
#[test]
fn clips_that_keep_nothing_or_are_not_numbers() {
    let s = scene("object sphere(1) { clip x - 2 }");
    assert!(s.objects[0].bound.is_some());
    let src = "camera { position (-9, 0, 0) }\nobject sphere(1) { clip sphere(2) translate (0, 0, 9) }\nobject sphere(1) { clip 5 + x^2 }";
    let s = nes::compile_source("clip.nes", src).unwrap();
    assert!(s.objects[1].bound.is_none(), "nothing kept");
    let src = "camera { position (-9, 0, 0) }\nobject sphere(1) { clip (1, 2, 3) }";
    let e = nes::compile_source("clip.nes", src)
        .unwrap_err()
        .render_plain();
    assert!(
        e.contains("`clip` takes a formula in x, y, z, not a vector"),
        "{e}"
    );
    assert!(e.contains("clip.nes:2:25"), "{e}");
}

/// Shadow rays through sheets at every half-integer x, kept inside a
/// ball of radius 2.5: a path is blocked exactly when it crosses a sheet
/// inside the ball, however many sheets it crosses outside.
#[test]
fn a_shadow_ray_is_blocked_only_by_the_kept_part() {
    let s = scene("object sin(3.141592653589793 * (x - 0.5)) { clip sphere(2.5) }");
    let tracer = Tracer::new(&s);
    let blocked =
        |from: DVec3, length: f64| tracer.blocked(from, DVec3::X, length, &mut Scratch::default());
    // Through the middle: x = -1.5 .. 1.5 lie inside.
    assert!(blocked(DVec3::new(-5.0, 0.0, 0.0), 10.0));
    // At y = 2.45 the ball keeps |x| < 0.497: no half-integer, although
    // the path crosses sheets on both sides.
    assert!(!blocked(DVec3::new(-5.0, 2.45, 0.0), 10.0));
    // At y = 2.3 it keeps |x| < 0.98: x = +-0.5 block.
    assert!(blocked(DVec3::new(-5.0, 2.3, 0.0), 10.0));
    // Ending before the ball: the sheets at -4.5 and -3.5 are cut away.
    assert!(!blocked(DVec3::new(-5.0, 0.0, 0.0), 2.4));
    // Starting inside, between two sheets, ending before the next.
    assert!(!blocked(DVec3::new(-0.2, 0.0, 0.0), 0.6));
    assert!(blocked(DVec3::new(-0.2, 0.0, 0.0), 0.8));
}

/// The same sheets clipped by a geodesic ball (radius 2.3) in S3 and H3, along the
/// geodesic through the ball's centre (the x axis of the normal
/// coordinates): blocked exactly where a sheet inside the ball is
/// crossed, and the first hit is the first kept sheet.
#[test]
fn a_ball_clip_keeps_its_part_of_a_geodesic() {
    for space in ["space s3 { radius 10 }", "space h3 { radius 3 }"] {
        let s = scene(&format!(
            "{space}\nobject sin(3.141592653589793 * (x - 0.5)) {{ clip sphere(2.3) }}"
        ));
        let tracer = Tracer::new(&s);
        let blocked = |from: DVec3, length: f64| {
            tracer.blocked(from, DVec3::X, length, &mut Scratch::default())
        };
        assert!(blocked(DVec3::new(-5.0, 0.0, 0.0), 10.0), "{space}");
        assert!(!blocked(DVec3::new(-5.0, 0.0, 0.0), 2.4), "{space}");
        assert!(!blocked(DVec3::new(-0.2, 0.0, 0.0), 0.6), "{space}");
        assert!(blocked(DVec3::new(-0.2, 0.0, 0.0), 0.8), "{space}");
        let first = hit(&s, DVec3::new(-5.0, 0.0, 0.0), DVec3::X).expect("a kept sheet");
        // x = -1.5: the sheets at -4.5 .. -2.5 lie outside the ball.
        assert!((first - 3.5).abs() < 1e-4, "{space}: {first}");
    }
}

/// A clip around a surface whose automatic bound is already tight cuts
/// nothing, and costs nothing: the same image in no more evaluations than
/// without it. (It once cost an evaluation of the clip per hit and made
/// shadow rays locate every root: 3.7 M -> 4.3 M evaluations for this
/// superquadric at 800 x 500.) A clip that does cut still cuts.
#[test]
fn a_clip_that_cuts_no_surface_costs_nothing() {
    let shape = "(abs(x)^(2/2.6) + abs(y)^(2/2.6))^(2.6/0.3) + abs(z)^(2/0.3) - 1";
    let render = |clip: &str| {
        let src = format!(
            "camera {{ position (-6.5, -4.6, 3.7) look_at (0, 0, 0) width 160 height 100 }}\nlight {{ position (-6, -7, 9) }}\nobject {shape} {{ {clip} }}\nobject plane((0, 0, 1), -1.2)"
        );
        let scene = nes::compile_source("clip.nes", &src).unwrap();
        let cuts = scene.objects[0].clip_cuts;
        let (image, stats) = nes::render(&scene);
        (image, stats.evaluations, cuts)
    };
    let (plain, plain_work, _) = render("");
    let (around, around_work, around_cuts) = render("clip cube(1.001)");
    assert!(!around_cuts, "cube(1.001) holds the whole superquadric");
    // The bound is searched within the clip's box, so the two may differ
    // by a cell's worth; the clip's own cost is gone.
    assert!(
        around_work as f64 <= 1.01 * plain_work as f64,
        "{around_work} evaluations against {plain_work}"
    );
    let differ = plain
        .pixels
        .iter()
        .zip(&around.pixels)
        .map(|(a, b)| (*a - *b).abs().max_element())
        .fold(0.0, f64::max);
    // Hits agree to the search's epsilon (1e-6), not to the bit: the
    // bound, searched within the clip's box, starts some searches
    // elsewhere.
    assert!(differ < 1e-4, "pixels differ by {differ}");
    // A box the bound equals is cut by the bound's faces: the clip adds
    // nothing to them. A ball cuts inside the bound.
    let (boxed, _, box_cuts) = render("clip cube(0.9)");
    assert!(!box_cuts, "the bound's faces are cube(0.9)'s");
    assert!(boxed.pixels != plain.pixels, "cube(0.9) changed nothing");
    let (ball, _, ball_cuts) = render("clip sphere(0.95)");
    assert!(ball_cuts, "sphere(0.95) cuts the superquadric's corners");
    assert!(ball.pixels != plain.pixels, "sphere(0.95) changed nothing");
}

/// Every hit of a clipped object lies within its clip, in every space:
/// along straight paths the bound's faces cut where the clip does, and a
/// clip that only the bound's faces would cut is passed over; a curved
/// path is searched over pieces that reach past the bound, and there the
/// clip itself must reject what lies beyond it (a plane clipped by a
/// cube, met by paths that reach the plane past the cube).
#[test]
fn every_hit_of_a_clipped_object_lies_within_its_clip() {
    for space in ["euclidean", "s3", "h3", "sphere"] {
        let src = format!(
            "space {space}\ncamera {{ position (-3, 0, 1.5) }}\nobject plane((0, 0, 1), 0) {{ clip cube(1) }}\nobject (x^2 + y^2 + z^2 - 1.2) * (x - 5) {{ clip cube(1) translate (0, 0, -2) }}"
        );
        let scene = nes::compile_source("clip.nes", &src).unwrap();
        let tracer = Tracer::new(&scene);
        let mut s = Scratch::default();
        let origin = DVec3::new(-3.0, 0.0, 1.5);
        let mut hits = 0;
        for k in 0..900 {
            let (i, j) = ((k % 30) as f64 / 29.0, (k / 30) as f64 / 29.0);
            let aim = DVec3::new(4.0 * i - 2.0, 4.0 * j - 2.0, -2.0);
            let Some(h) = tracer.nearest_hit(origin, (aim - origin).normalize(), 30.0, &mut s)
            else {
                continue;
            };
            hits += 1;
            let clip = scene.objects[h.object].clip.as_ref().unwrap();
            let kept = clip.value(h.local, &mut Vec::new());
            assert!(
                kept <= 1e-5,
                "{space}: object {} hit at {} (its own coordinates), where its clip is {kept}",
                h.object,
                h.local
            );
        }
        assert!(hits > 50, "{space}: {hits} hits");
    }
}

/// A surface lying along its own bound's faces (`cos(x)`, the planes
/// x = +-pi/2, whose box is as wide as they are) is cut by a ball there
/// all the same: a ray to a point of the plane outside the ball passes,
/// one to a point inside hits it, in every route. (The clip was once
/// judged to cut nothing the faces do not, and passed over.)
#[test]
fn a_surface_along_its_bounds_faces_is_cut_by_the_clip() {
    let half_pi = std::f64::consts::FRAC_PI_2;
    for method in ["auto", "march"] {
        let s = scene(&format!(
            "render {{ method {method} }}\nobject cos(x) {{ clip sphere(2) }}"
        ));
        let origin = DVec3::new(-9.0, 0.0, 0.0);
        for (target, kept) in [
            (DVec3::new(-half_pi, 1.9, 1.9), false),
            (DVec3::new(-half_pi, 0.5, -0.5), true),
        ] {
            let got = hit(&s, origin, target - origin);
            let want = (target - origin).length();
            match (got, kept) {
                (Some(t), true) => assert!((t - want).abs() < 1e-4, "{method}: {t} for {want}"),
                (None, false) => {}
                // Past the cut-away piece the ray may meet the far plane
                // within the ball, but not the near one.
                (Some(t), false) => assert!(t > want + 1.0, "{method}: hit at {t}, cut away"),
                (None, true) => panic!("{method}: no hit towards {target}"),
            }
        }
    }
}
