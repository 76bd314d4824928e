//! Compile-time object bounds: every surface point found independently
//! lies inside the bound, and the bound is as tight as the surface where
//! the surface's extent is known in closed form.

use common::compile;
use glam::DVec3;
use nes::compile::compute_bound;
use nes::expr::Implicit;
use nes::space::Aabb;

mod common;

fn region() -> Aabb {
    cube(20.0)
}

/// The box from `-reach` to `reach` on every axis.
fn cube(reach: f64) -> Aabb {
    Aabb {
        min: DVec3::splat(-reach),
        max: DVec3::splat(reach),
    }
}

/// Roots of `f` along lines through the region, by sign changes on a fine
/// grid refined by bisection: surface points found without intervals.
fn surface_points(f: &Implicit) -> Vec<DVec3> {
    let mut slots = Vec::new();
    let mut points = Vec::new();
    let mut seed = 11u64;
    let mut rand = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    for _ in 0..300 {
        let o = DVec3::new(rand(), rand(), rand()) * 10.0;
        let d = DVec3::new(rand(), rand(), rand()).normalize();
        let at = |t: f64, slots: &mut Vec<f64>| f.value(o + t * d, slots);
        let n = 4000;
        let (lo, hi) = (-20.0, 20.0);
        let mut a = lo;
        let mut fa = at(a, &mut slots);
        for i in 1..=n {
            let b = lo + (hi - lo) * i as f64 / n as f64;
            let fb = at(b, &mut slots);
            if fa.is_finite() && fb.is_finite() && (fa < 0.0) != (fb < 0.0) {
                let (mut l, mut r, fl) = (a, b, fa);
                for _ in 0..60 {
                    let m = 0.5 * (l + r);
                    if (at(m, &mut slots) < 0.0) == (fl < 0.0) {
                        l = m;
                    } else {
                        r = m;
                    }
                }
                let p = o + 0.5 * (l + r) * d;
                // The bound covers the region only.
                if p.abs().max_element() <= 20.0 {
                    points.push(p);
                }
            }
            a = b;
            fa = fb;
        }
    }
    points
}

#[test]
fn every_surface_point_lies_in_the_bound() {
    for expr in [
        "sphere(2)",
        "plane(normalize((1, 2, -0.5)), 1.5)",
        "torus(3, 0.5)",
        "x^8 + y^8 + z^8 - 1",
        "(x^2 + 9/4*y^2 + z^2 - 1)^3 - x^2*z^3 - 9/80*y^2*z^3",
        "sin(x) + sin(y) + sin(z) - 0.5",
        // Sums with a polynomial part per coordinate, bounded again with
        // each part's exact range: Chmutov's octic, a moved tanglecube,
        // a sextic with a mixed term, and Goursat's kind of quartic.
        "128*x^8 - 256*x^6 + 160*x^4 - 32*x^2 + 1 + 128*y^8 - 256*y^6 + 160*y^4 - 32*y^2 + 1 + 128*z^8 - 256*z^6 + 160*z^4 - 32*z^2 + 1",
        "(x - 3)^4 - 5*(x - 3)^2 + (y + 2)^4 - 5*(y + 2)^2 + (z - 1)^4 - 5*(z - 1)^2 + 11.8",
        "x^6 + y^6 + z^6 - 2*(x^2 + y^2 + z^2) + x*y*z + 0.5",
        "x^4 + y^4 + z^4 - 0.3*(x^2 + y^2 + z^2)^2 - 1",
    ] {
        let f = compile(expr);
        let bound = compute_bound(&f, region()).expect("the surface is in the region");
        let points = surface_points(&f);
        assert!(!points.is_empty(), "{expr}: no surface points found");
        for p in points {
            assert!(
                p.cmpge(bound.min - 1e-9).all() && p.cmple(bound.max + 1e-9).all(),
                "{expr}: surface point {p} outside the bound {bound:?}"
            );
        }
    }
}

#[test]
fn bounds_are_as_tight_as_the_surface() {
    let close = |a: DVec3, b: DVec3| (a - b).abs().max_element() < 1e-6;
    // A sphere of radius 2 about (7, 0, 0), and the plane z = -3.
    let src = "camera { position (-5, 0, 0) }\nobject sphere(2) { translate (7, 0, 0) }\n\
               object plane((0, 0, 1), -3)";
    let scene = nes::compile_source("tight.nes", src).unwrap();
    let sphere = compute_bound(&scene.objects[0].function, region()).unwrap();
    assert!(
        close(sphere.min, DVec3::new(5.0, -2.0, -2.0))
            && close(sphere.max, DVec3::new(9.0, 2.0, 2.0)),
        "{sphere:?}"
    );
    // The plane z = -3 across the region: a slab as thin as the plane.
    let plane = compute_bound(&scene.objects[1].function, region()).unwrap();
    assert!(plane.max.z - plane.min.z < 1e-6, "{plane:?}");
    assert!(plane.min.z <= -3.0 && plane.max.z >= -3.0, "{plane:?}");
    assert!(close(
        plane.min.truncate().extend(0.0),
        DVec3::new(-20.0, -20.0, 0.0)
    ));
    assert!(
        close(
            plane.max.truncate().extend(0.0),
            DVec3::new(20.0, 20.0, 0.0)
        ),
        "{plane:?}"
    );
}

#[test]
fn a_surface_outside_the_region_has_no_bound() {
    let f = compile("sphere(1) + 0 * x");
    let far = Aabb {
        min: DVec3::splat(5.0),
        max: DVec3::splat(9.0),
    };
    assert!(compute_bound(&f, far).is_none());
    // The same function over a region that holds it has its bound: the
    // None above is about the region, not the function.
    let b = compute_bound(&f, region()).expect("the unit sphere is in the region");
    assert!(
        (b.min + 1.0).abs().max_element() < 1e-6 && (b.max - 1.0).abs().max_element() < 1e-6,
        "{b:?}"
    );
}

/// An object's bound does not depend on how far rays reach: a torus in a
/// region of 1e60 or 1e300 (what `max_distance` makes it) gets the box it
/// gets in a small one, as the descent halves its way down (200 and more
/// levels).
#[test]
fn a_huge_region_gives_the_bound_a_small_one_does() {
    let f = compile("torus(2, 0.5) + 0.01 * sin(9 * x)");
    let small = compute_bound(&f, region()).expect("the torus is in the region");
    for reach in [1e20, 1e60, 1e300] {
        let b = compute_bound(&f, cube(reach)).expect("the torus is in the region");
        assert!(
            (b.min - small.min).abs().max_element() < 0.05
                && (b.max - small.max).abs().max_element() < 0.05,
            "region {reach}: {b:?}, against {small:?}"
        );
    }
    // An open surface keeps its thin axis thin however wide the others.
    let wave = compile("z - 0.1 * sin(x)");
    for reach in [1e6, 1e60, 1e300] {
        let b = compute_bound(&wave, cube(reach)).expect("the wave is in the region");
        assert!(
            b.min.z > -0.11 && b.max.z < 0.11 && b.max.x > 0.9 * reach,
            "region {reach}: {b:?}"
        );
    }
}

/// A bound far from its surface is reported with the operation whose
/// interval is too wide; a tight one is not. Chmutov's octic, expanded,
/// suffers the dependency problem in `128 x^8 - 256 x^6` on wide cells;
/// a ball written with a square root does not.
#[test]
fn a_loose_bound_is_reported_with_its_culprit() {
    use nes::compile::loose_bound;
    let octic = compile(
        "128*x^8 - 256*x^6 + 160*x^4 - 32*x^2 + 1 + 128*y^8 - 256*y^6 + 160*y^4 - 32*y^2 + 1 + 128*z^8 - 256*z^6 + 160*z^4 - 32*z^2 + 1",
    );
    let wide = Aabb {
        min: DVec3::splat(-2.0),
        max: DVec3::splat(2.0),
    };
    let loose = loose_bound(&octic, wide).expect("a bound twice the surface is loose");
    // The surface lies within |x|, |y|, |z| <= 1.014, plus a sampling cell.
    for a in 0..3 {
        assert!(
            loose.surface.max[a] < 1.3 && loose.surface.min[a] > -1.3,
            "{loose:?}"
        );
    }
    let culprit = loose.culprit.clone().expect("a culprit");
    let expr = &culprit.expr;
    assert!(expr.contains("128*") && expr.contains("256*"), "{expr}");
    assert!(culprit.ratio > 1.5, "{}", culprit.ratio);
    assert!(!culprit.internal);
    let said = loose.describe(false, &[]);
    assert!(said.contains("Horner") && said.contains("clip"), "{said}");
    assert!(!loose
        .describe(true, &[])
        .contains("give the object a `clip`"));
    let ball = compile("sqrt(x^2 + y^2 + z^2) - 1");
    let tight = Aabb {
        min: DVec3::splat(-1.05),
        max: DVec3::splat(1.05),
    };
    assert_eq!(loose_bound(&ball, tight), None);
}

/// A twist, a rotation whose angle varies with the point, keeps the
/// coordinate along its axis: the bound of a twisted box is as tall as
/// the box (once its angle showed twice in the along-axis part, and the
/// bound was the whole region), and as wide as the box's circumscribed
/// circle would allow, within the intervals' looseness, written either
/// way.
#[test]
fn a_twist_keeps_its_axis() {
    for twisted in [
        "(box(0.5, 0.5, 1.5) rotate 60 * z about z)",
        "(box(0.5, 1.5, 0.5) rotate 60 * y about y)",
        "box(0.5, 0.5, 1.5) at (x*cos(pi/3*z) + y*sin(pi/3*z), -x*sin(pi/3*z) + y*cos(pi/3*z), z)",
    ] {
        let b = compute_bound(&compile(twisted), region()).expect("a bound");
        let (tall, wide) = if twisted.contains("about y") {
            (1, 0)
        } else {
            (2, 0)
        };
        assert!(
            b.max[tall] < 1.51 && b.min[tall] > -1.51,
            "{twisted}: {b:?}"
        );
        for axis in [wide, 3 - tall - wide] {
            assert!(b.max[axis] < 1.6 && b.min[axis] > -1.6, "{twisted}: {b:?}");
            assert!(b.max[axis] > 0.7 && b.min[axis] < -0.7, "{twisted}: {b:?}");
        }
    }
}

/// An ellipsoid's bound is its closed-form box, unless its expanded
/// coefficients cannot tell its size: a ball of radius 1e-3 at 1e7 (its
/// constant term 1e14 rounds by more than the radius squared) is bounded
/// by the search, and its box still holds it and stays about its size.
#[test]
fn an_ellipsoid_is_bounded_in_closed_form_only_where_its_coefficients_tell_its_size() {
    let region = |c: f64| Aabb {
        min: DVec3::splat(c - 20.0),
        max: DVec3::splat(c + 20.0),
    };
    for (centre, radius, axes) in [
        (0.0, 1.0, DVec3::new(3.0, 1.0, 0.5)),
        (1e7, 1e-3, DVec3::ONE),
        (1e6, 1e-2, DVec3::ONE),
    ] {
        let f = compile(&format!(
            "(((x - {centre}) / {})^2 + ((y - {centre}) / {})^2 + ((z - {centre}) / {})^2 - 1) * {radius}^2",
            axes.x * radius,
            axes.y * radius,
            axes.z * radius
        ));
        let b = compute_bound(&f, region(centre)).expect("the ellipsoid is in the region");
        let half = axes * radius;
        let want_min = DVec3::splat(centre) - half;
        let want_max = DVec3::splat(centre) + half;
        // Holds the ellipsoid, and is at most 20% larger per side.
        assert!(
            b.min.cmple(want_min).all() && b.max.cmpge(want_max).all(),
            "{b:?}"
        );
        assert!(
            (want_min - b.min).max_element() <= 0.2 * half.min_element() + 1e-9 * centre
                && (b.max - want_max).max_element() <= 0.2 * half.min_element() + 1e-9 * centre,
            "{centre} {radius}: {b:?}"
        );
    }
}

/// A wave whose crests fall between the sampling grid's points (6 units
/// apart across a bound 200 wide) looks flatter than it is: its bound,
/// as tall as the crests, is not called loose, and so no `clip` that
/// would cut the crests is suggested.
#[test]
fn crests_between_samples_do_not_make_a_bound_loose() {
    use nes::compile::loose_bound;
    let wave = compile("z - 0.2 * sin(x) * cos(y)");
    let bound = compute_bound(&wave, cube(100.0)).expect("the wave is in the region");
    assert!(bound.max.z > 0.19 && bound.min.z < -0.19, "{bound:?}");
    assert!(loose_bound(&wave, bound).is_none());
}

/// A union whose one member overflows to +inf beside another keeps the
/// other: `min(inf, v)` is `v`. Interval sums once turned a lower bound of
/// +inf into NaN, read as empty, and the union's bound ended where `x^1000`
/// overflows, leaving out the ball at x = -3; a whole power too large for
/// `powi` once lost its half where x < 0.
#[test]
fn an_overflowing_member_does_not_hide_the_rest() {
    let union = compile("min(x^1000 - 1, sphere(0.6) translate (-3, 0, 0))");
    let b = compute_bound(&union, region()).expect("bounded");
    assert!(b.min.x <= -3.6 + 1e-6 && b.max.x >= 1.0 - 1e-6, "{b:?}");
    let exp = compile("min(exp(x^2) - 10, sphere(0.6) translate (-30, 0, 0))");
    let b = compute_bound(&exp, cube(40.0)).expect("bounded");
    assert!(b.min.x <= -30.6 + 1e-6, "{b:?}");
    let power = compile("x^1000000000 + y^2 + z^2 - 1");
    let b = compute_bound(&power, region()).expect("bounded");
    assert!(b.min.x <= -1.0 + 1e-6 && b.max.x >= 1.0 - 1e-6, "{b:?}");
}
