//! Warnings: what in a scene that compiles is likely not what its writer
//! meant, or will cost far more than it shows.
//!
//! Input: the checked [`Scene`] and the file it came from (for spans).
//! Output: diagnostics whose [`Code`] is a warning (`W....`), in source
//! order. They never stop a render unless `--deny-warnings` is given.

use std::collections::HashMap;

use glam::DVec3;

use crate::ast::{self, Item, SolidKind, TransformOp};
use crate::diagnostic::{Code, Diagnostic, Span};
use crate::expr::Dual;
use crate::scene::{Object, Route, Scene};
use crate::space::Image;

use super::bound::{
    clip_cuts_within, compute_bound, local_region, reachable_region, sample_bound, undefined_share,
    Sampled, SAMPLED_POINTS, UNDEFINED_POINTS,
};
use super::{Compiler, Constant};

/// An angle within this many radians of a multiple of 15 degrees written
/// in radians (pi/12) looks like radians: two decimals' rounding, such as
/// 1.05 for pi/3 (off by 0.0028) or 2.1 for 2 pi/3 (0.0056).
const RADIAN_TOLERANCE: f64 = 0.006;

/// How many pixels across the ball holding `object`'s bound is, seen from
/// the camera, when under one: a geodesic ball of radius `r` at distance
/// `d` is seen under the angle `a` with `sin a = spread(r) / spread(d)`
/// (`r / d` flat, `sin(r/R) / sin(d/R)` in S3, `sinh(r/R) / sinh(d/R)` in
/// H3). `None` when it is larger, when the camera is within the ball,
/// and in spaces whose paths do not make that formula hold (the torus's
/// copies, the sphere space's bent rays, metrics).
fn pixels_across(scene: &Scene, object: &Object, placed: Option<&Image>) -> Option<f64> {
    let bound = object.bound.as_ref()?;
    let camera = scene.camera.position;
    let (r, d) = if scene.space.places_objects() {
        // Placed objects are written in normal coordinates about their
        // centre, where the distance from it is the geodesic distance.
        (
            bound.min.abs().max(bound.max.abs()).length(),
            placed
                .map_or(camera, |image| image.to_local(camera))
                .length(),
        )
    } else {
        let centre = (bound.min + bound.max) * 0.5;
        (
            0.5 * (bound.max - bound.min).length(),
            (camera - centre).length(),
        )
    };
    if !(r.is_finite() && d.is_finite()) || d <= r {
        return None;
    }
    let sine = scene.space.sine_of_ball(r, d)?;
    if sine.is_nan() || sine >= 1.0 {
        return None;
    }
    let across = 2.0 * sine.asin() / finest_pixel_angle(&scene.camera);
    // Under a pixel as printed (0.996 would read 1.00).
    (across < 0.995).then_some(across)
}

/// The smallest angle between neighbouring pixels' rays anywhere in the
/// image, sampled on a 9 x 9 grid of places with the corners: where a
/// wide rectilinear view stretches the image (by 1 / cos^2 of the angle
/// off its axis) a pixel subtends least, and "at most a pixel across"
/// must hold there too.
fn finest_pixel_angle(camera: &crate::camera::Camera) -> f64 {
    let rays = camera.rays();
    let (w, h) = (camera.width as f64, camera.height as f64);
    let angle = |a: DVec3, b: DVec3| a.cross(b).length().atan2(a.dot(b));
    let mut finest = f64::INFINITY;
    for i in 0..=8 {
        for j in 0..=8 {
            let (x, y) = ((w - 1.0) * i as f64 / 8.0, (h - 1.0) * j as f64 / 8.0);
            let d = rays.direction(x, y);
            for (dx, dy) in [(1.0, 0.0), (0.0, 1.0)] {
                finest = finest.min(angle(d, rays.direction(x + dx, y + dy)));
            }
        }
    }
    finest
}

/// A size in pixels to two significant digits.
fn pixels(v: f64) -> String {
    if v >= 0.01 {
        format!("{v:.2}")
    } else {
        format!("{v:.1e}")
    }
}

/// Noise whose lattice cells are narrower than this fraction of a pixel
/// is finer than the image can show.
const FEATURES_PER_PIXEL: f64 = 0.25;

/// The six directions along the axes, where W0002 and W0003 look for an
/// outside far off or in the whole of S3.
/// Directions to the cube's faces, edges and corners: where a formula is
/// looked at far away to tell an open surface from a closed one.
const FAR_DIRECTIONS: [DVec3; 26] = {
    let mut d = [DVec3::ZERO; 26];
    let mut n = 0;
    let mut i = 0;
    while i < 27 {
        let (x, y, z) = (
            (i % 3) as f64 - 1.0,
            ((i / 3) % 3) as f64 - 1.0,
            (i / 9) as f64 - 1.0,
        );
        if i != 13 {
            d[n] = DVec3::new(x, y, z);
            n += 1;
        }
        i += 1;
    }
    d
};

const AXES: [DVec3; 6] = [
    DVec3::X,
    DVec3::NEG_X,
    DVec3::Y,
    DVec3::NEG_Y,
    DVec3::Z,
    DVec3::NEG_Z,
];

impl Compiler {
    /// Every warning for `scene`, compiled from `file`.
    pub(super) fn lint(&mut self, file: &ast::File, scene: &Scene) -> Vec<Diagnostic> {
        let mut out = Vec::new();
        self.file_warnings(file, &mut out);
        let objects = file.items.iter().filter_map(|i| match i {
            Item::Object(o) => Some(o),
            _ => None,
        });
        let lights = file
            .items
            .iter()
            .filter_map(|i| match i {
                Item::Directive(d) if d.name.name == "light" => Some(d.span),
                _ => None,
            })
            .collect::<Vec<_>>();
        let space = scene.build_space();
        let reach = (scene.objects.len() <= MOST_OBJECTS_CHECKED).then(|| reachable_region(scene));
        for (item, object) in objects.zip(&scene.objects) {
            // Placed objects (S3, H3) are written in their own coordinates:
            // a point is taken there by the object's isometry.
            let placed = match &object.bound {
                Some(b) if !object.placement.0.is_empty() => {
                    space.images(b, &object.placement).first().copied()
                }
                _ => None,
            };
            // A clipped surface is open: a camera within it still sees out.
            // But a clip that cuts none of the surface (its whole bound,
            // unclipped, searched for a place the clip is positive where
            // the surface may be) leaves it closed.
            let closed = match (&object.clip, reach) {
                (None, _) => true,
                (Some(clip), Some(reach)) => {
                    let local = local_region(scene, reach, &object.placement);
                    compute_bound(&object.function, local)
                        .is_some_and(|whole| !clip_cuts_within(&object.function, clip, whole))
                }
                (Some(_), None) => false,
            };
            let judged = closed && (object.placement.0.is_empty() || placed.is_some());
            // The formula's value at a point of the scene, where it tells a
            // side: an infinite value (`(x - 1) / 0`) says nothing of one.
            let side = |p: DVec3| {
                let p = space.within_chart(p);
                let p = placed.map_or(p, |image| image.to_local(p));
                let v = object.function.value(p, &mut Vec::new());
                (judged && v.is_finite()).then_some(v)
            };
            let inside = |p: DVec3| side(p).is_some_and(|v| v < 0.0);
            let outside = |p: DVec3| side(p).is_some_and(|v| v > 0.0);
            // A formula negative far from its surface (Apery's sextic for
            // Boy's surface) has its inside outside: the fix is to negate it.
            // Evaluated only for an object something is inside of.
            let negative_far = || {
                object.bound.is_some_and(|b| {
                    let centre = (b.min + b.max) * 0.5;
                    let size = (b.max - b.min).max_element().max(1.0);
                    AXES.iter().all(|&d| inside(centre + d * (100.0 * size)))
                })
            };
            let negate = |who: &str| {
                if negative_far() {
                    format!("; the formula is negative far from its surface too, so what it calls inside is the outside: negate it (`-(...)`) if {who} is meant to be outside")
                } else {
                    String::new()
                }
            };
            // In S3 a ball of radius pi R or more is the whole space, with
            // no outside to move the camera or a light to.
            let fills_space = || {
                space.chart_radius().is_some_and(|rc| {
                    inside(DVec3::ZERO)
                        && inside(DVec3::X * rc)
                        && AXES.iter().all(|&d| inside(d * (0.5 * rc)))
                })
            };
            let whole_space = |who: &str| {
                let rc = space.chart_radius().unwrap_or(0.0);
                format!("; here {who} cannot be outside it: it holds all of the space as far as sampling shows (a ball of radius pi R = {} or more is the whole of S3), so make it smaller", crate::space::human(rc))
            };
            // Within epsilon of the surface (to first order), where the
            // clip keeps it: every ray's search finds a root where it starts.
            let on_surface = |p: DVec3| {
                if !(object.placement.0.is_empty() || placed.is_some()) {
                    return false;
                }
                let p = space.within_chart(p);
                let p = placed.map_or(p, |image| image.to_local(p));
                let (v, g) = object.function.value_and_gradient(p, &mut Vec::new());
                let kept = object
                    .clip
                    .as_ref()
                    .is_none_or(|c| c.value(p, &mut Vec::new()) <= 0.0);
                let epsilon = scene.settings.epsilon;
                // A zero gradient too (a formula 0 everywhere, W0012) is
                // no surface to be on. Scaled, so that a gradient of 1e160
                // does not square to infinity (`1e160 * (x + 3)` was said
                // to pass through every camera).
                let largest = g.abs().max_element();
                let slope = largest * (g / largest).length();
                // An object not much larger than epsilon is W0015's: the
                // camera near it is within epsilon of every point of it.
                let tiny = finer_than_epsilon(object, epsilon).is_some();
                kept && !tiny
                    && v.is_finite()
                    && slope.is_finite()
                    && slope > 0.0
                    && v.abs() / slope <= 4.0 * epsilon
            };
            let camera_on_surface = on_surface(scene.camera.position);
            if camera_on_surface {
                out.push(
                    Diagnostic::new(Code::CameraOnSurface, format!("the camera is on the surface of `{}`", object.label))
                        .label(item.solid.span, "the camera's position is on this object's surface, within epsilon")
                        .help(format!("every ray starts on the surface and finds its hit there at once, so the view shows no shape (one flat shade, or one for each side of the surface); move the camera off the surface by more than epsilon ({:e})", scene.settings.epsilon)),
                );
            }
            // A surface whose formula is negative far away in some
            // directions and positive in others (a cubic, a saddle, a
            // catenoid) is open: it has two sides, neither of them an
            // inside, and the camera sees the side it is on.
            let open = std::cell::LazyCell::new(|| {
                object.bound.is_some_and(|b| {
                    let centre = (b.min + b.max) * 0.5;
                    let size = (b.max - b.min).max_element().max(1.0);
                    let (mut negative, mut positive) = (false, false);
                    for d in FAR_DIRECTIONS {
                        let p = centre + d * (100.0 * size);
                        if inside(p) {
                            negative = true;
                        } else if outside(p) {
                            positive = true;
                        }
                    }
                    negative && positive
                })
            });
            let camera_inside = inside(scene.camera.position);
            // An inside colour says the inside is meant to be seen.
            if camera_inside && object.inside.is_none() && !camera_on_surface && !*open {
                out.push(
                    Diagnostic::new(Code::CameraInside, format!("the camera is inside `{}`", object.label))
                        .label(item.solid.span, "the camera's position is inside this object")
                        .help(if fills_space() {
                            format!("the view is the object's inside (or nothing at all){}", whole_space("the camera"))
                        } else {
                            format!("the view is the object's inside (or nothing at all); move the camera out, or give the object an `inside` colour if its inside is what you mean to show{}", negate("the camera"))
                        }),
                );
            }
            // The camera sees the side of the surface it is on; a light
            // lights the side it is on. A light on the other side lights
            // nothing the camera sees of this object.
            let camera_outside = outside(scene.camera.position);
            for (light, span) in scene.lights.iter().zip(&lights) {
                let light_inside = inside(light.position);
                let light_outside = outside(light.position);
                // A camera inside a closed surface with no inside colour
                // is W0002's already.
                let apart = (camera_inside && light_outside && (object.inside.is_some() || *open))
                    || (camera_outside && light_inside);
                if camera_on_surface || !(apart || (light_inside && fills_space())) {
                    continue;
                }
                let diagnostic = if light_inside && !*open {
                    Diagnostic::new(Code::LightInside, format!("a light is inside `{}`", object.label))
                        .label(*span, "this light's position is inside the object")
                        .label(item.solid.span, "this object")
                        .help(if fills_space() {
                            format!("its surface hides the light from everything outside it{}", whole_space("the light"))
                        } else {
                            format!("its surface hides the light from everything outside it; move the light out{}", negate("the light"))
                        })
                } else {
                    let (light_side, camera_side) = if light_inside {
                        ("negative", "positive")
                    } else {
                        ("positive", "negative")
                    };
                    Diagnostic::new(Code::LightInside, format!("a light is on the other side of `{}` from the camera", object.label))
                        .label(*span, format!("this light is where the formula is {light_side}, the camera where it is {camera_side}"))
                        .label(item.solid.span, "this object")
                        .help(if *open {
                            "the surface is open (its formula takes both signs far away), and the camera sees only the side it is on, which this light cannot reach without crossing the surface: move the light to the camera's side".to_string()
                        } else {
                            "the camera is inside the object and sees its inside, which this light, outside, cannot reach: move the light in, or the camera out".to_string()
                        })
                };
                out.push(diagnostic);
            }
            // A polynomial is a number everywhere, and a quotient of them
            // is not only where a denominator vanishes: neither is sampled.
            let may_be_undefined =
                object.function.quadric.is_none() && object.function.degree.is_none();
            let affordable = may_be_undefined
                && (object.function.value_tape.len()
                    + object.clip.as_ref().map_or(0, |c| c.value_tape.len()))
                    * UNDEFINED_POINTS
                    <= MOST_OPERATIONS_SAMPLED;
            if let Some(undefined) = object
                .bound
                .filter(|_| affordable && scene.objects.len() <= MOST_OBJECTS_CHECKED)
                .and_then(|b| undefined_share(&object.function, object.clip.as_ref(), b))
            {
                out.push(
                    Diagnostic::new(
                        Code::PartlyUndefined,
                        format!("`{}` is not a number over part of its bound", object.label),
                    )
                    .label(item.solid.span, if undefined.both_signs {
                        format!("not a number at {:.0}% of the points sampled where its surface would be", 100.0 * undefined.share)
                    } else {
                        format!("not a number at {:.0}% of the points sampled, and never changes sign where it is a number: its only zeros are at the edge of where it is defined, which no search can pin down (hits there are lost or land on the far side)", 100.0 * undefined.share)
                    })
                    .help("no surface is drawn where a formula is not a number: `sqrt`, `ln` and fractional powers of negative values, `asin` and `acos` beyond -1 and 1, `acosh` below 1, `atanh` beyond -1 and 1, `0 / 0`; keep their arguments in range (`sqrt(abs(x))`, `max(x, 0)`), or `clip` the object to where it is defined; a surface written as `sqrt(g)` is the surface `g`"),
                );
            }
            // `0 * x`, `x - x` or `1e-300 * 1e-300 * (...)` simplify to the
            // constant 0: the whole space (or clip) is the surface.
            if object.function.constant() == Some(0.0) {
                out.push(
                    Diagnostic::new(
                        Code::ZeroEverywhere,
                        format!("`{}` is 0 everywhere: every point is on its surface", object.label),
                    )
                    .label(item.solid.span, "this formula simplifies to the constant 0")
                    .help("an object is where its formula is 0, so it must change sign across the surface; look for a product with 0, or constants whose product underflows (1e-300 * 1e-300 is 0 in floating point: scale by a number nearer 1)"),
                );
            }
            let subnormal = |c: f64| c != 0.0 && c.abs() < f64::MIN_POSITIVE;
            let constants = object.function.value_tape.constants();
            if let Some(&c) = constants.iter().find(|c| !c.is_finite() || subnormal(**c)) {
                let what = if c.is_finite() {
                    "is below 2.2e-308, where numbers lose their digits: values round to 0 and its surface shows as noise"
                } else {
                    "is not finite: numbers past 1.8e308 overflow, and the formula's values are infinities or NaN"
                };
                out.push(
                    Diagnostic::new(
                        Code::BadConstant,
                        format!("`{}` computes with the number {c:e}, which {what}", object.label),
                    )
                    .label(item.solid.span, format!("its numbers, multiplied out, give {c:e}"))
                    .help("write the numbers so that they stay between about 1e-300 and 1e300 once multiplied out: a constant factor on the whole formula can be dropped (it does not move the surface), and a size like sphere(1e308) squares past 1e308, so choose units where it is nearer 1; 0 / 0 is no number at all"),
                );
            }
            if let Some(c) = object.function.constant_over() {
                out.push(
                    Diagnostic::new(
                        Code::NeverZero,
                        format!("`{}` is never 0: it is {c} over a formula", object.label),
                    )
                    .label(item.solid.span, "a number divided by something is never 0")
                    .help("an object is where its formula is 0; this one changes sign only where its denominator is 0, through infinity, which is no surface: to draw where the denominator is 0, write the denominator itself"),
                );
            }
            if object.bound.is_none() {
                let camera = scene.camera.position;
                let at_camera = object.function.value(camera, &mut Vec::new());
                let why = |v: f64| {
                    if v.is_nan() {
                        "a square root, logarithm or fractional power of a negative number, an `asin` or `acos` beyond -1 and 1, an `acosh` below 1 or an `atanh` beyond -1 and 1, or 0 / 0; keep arguments in range (`sqrt(abs(...))`, `max(..., 0)`)"
                    } else {
                        "a division by zero, or an overflow past 1.8e308; keep denominators away from zero and powers within range"
                    }
                };
                let not_finite = match object
                    .function
                    .value_tape
                    .first_not_finite(&[camera.x, camera.y, camera.z], 60)
                {
                    Some((culprit, v)) => format!(
                        "its formula is not a finite number: at the camera `{culprit}` is {v}: {}",
                        why(v)
                    ),
                    None => format!(
                        "its formula is not a finite number: at the camera it is {at_camera}: {}",
                        why(at_camera)
                    ),
                };
                out.push(
                    Diagnostic::new(Code::Unreachable, format!("no ray can reach `{}`", object.label))
                        .label(item.solid.span, "this object is not drawn")
                        .help(if !at_camera.is_finite() && object.placement.0.is_empty() {
                            not_finite.clone()
                        } else {
                            format!(
                                "{}, or lies farther than `max_distance` ({}) from every point rays reach; raise `max_distance` in `render {{ }}` if it is far",
                                if object.clip.is_some() {
                                    "its `clip` keeps none of its surface, or the surface is empty (its formula is never 0: check the signs)"
                                } else {
                                    "its surface is empty (its formula is never 0: check the signs)"
                                },
                                scene.settings.max_distance
                            )
                        }),
                );
            }
        }
        out.extend(settings_warnings(scene));
        out.sort_by_key(|d| d.span().map_or(usize::MAX, |s| s.start));
        out
    }

    /// `clip sphere(2) translate (0, 0, 1)` in a block: the `translate` is
    /// the object's (a clip takes no transforms after it without
    /// brackets), so the whole object moves, not the clip alone.
    fn transforms_after_clips(&mut self, file: &ast::File, out: &mut Vec<Diagnostic>) {
        let Some(source) = self.source.as_deref() else {
            return;
        };
        for item in &file.items {
            let Item::Object(o) = item else { continue };
            for pair in o.properties.windows(2) {
                let (clip, next) = (&pair[0], &pair[1]);
                let moves = ["translate", "rotate", "scale"].contains(&next.name.name.as_str());
                let same_line = source
                    .get(clip.span.end..next.span.start)
                    .is_some_and(|between| !between.contains('\n'));
                let clip_text = source
                    .get(clip.value.span.start..clip.value.span.end)
                    .unwrap_or("...");
                // `clip (box(1, 1, 1)) translate (0, 6, 0)`: the brackets
                // already say where the clip ends.
                let bracketed =
                    crate::expr::without_outer_parentheses(clip_text).len() < clip_text.len();
                if clip.name.name == "clip" && moves && same_line && !bracketed {
                    let next_text = source.get(next.span.start..next.span.end).unwrap_or("...");
                    out.push(
                        Diagnostic::new(
                            Code::TransformAfterClip,
                            format!("this `{}` moves the whole object, not the clip", next.name.name),
                        )
                        .label(next.span, "a property of the object")
                        .label(clip.value.span, "the clip")
                        .help(format!("to move the clip alone, put the transform inside brackets: `clip ({clip_text} {next_text})`; to move the object, write the transform on a line of its own")),
                    );
                }
            }
        }
    }

    /// `let c = (-8)^(1/3)`: a constant that is NaN or infinite, which
    /// would otherwise show only where it is used, as an empty object or a
    /// range error far from its cause.
    fn constants_not_numbers(&mut self, file: &ast::File, out: &mut Vec<Diagnostic>) {
        for item in &file.items {
            let Item::Let(l) = item else { continue };
            let components = match self.globals.lets.get(&l.name.name) {
                Some(Constant::Num(v)) => vec![*v],
                Some(Constant::Vector(v)) => v.to_array().to_vec(),
                _ => continue,
            };
            let (what, hint) = if components.iter().any(|c| c.is_nan()) {
                ("not a number (NaN)", "a fractional power of a negative number is not real: `(-8)^(1/3)` and `pow(-8, 1/3)` are NaN, `cbrt(-8)` is -2; `sqrt` and `ln` of a negative number and `0/0` are NaN too")
            } else if components.iter().any(|c| c.is_infinite()) {
                ("infinite", "a division by zero, or a number past 1.8e308 (a large power or `exp`), gives infinity")
            } else {
                continue;
            };
            out.push(
                Diagnostic::new(Code::NotANumber, format!("`{}` is {what}", l.name.name))
                    .label(l.value.span, format!("this is {what}"))
                    .help(hint),
            );
        }
    }

    /// The warnings that need only the file and its constants, not a
    /// checked scene: they are shown with errors too, which they may
    /// explain (`let r = pow(-8, 1/3)` is NaN, and `sphere(r)` an error).
    pub(super) fn file_warnings(&mut self, file: &ast::File, out: &mut Vec<Diagnostic>) {
        self.radian_angles(file, out);
        self.bytes_like_fractions(file, out);
        self.constants_not_numbers(file, out);
        self.transforms_after_clips(file, out);
    }

    /// `rotate 1.5708 about z`, `fov 1.05`, `yaw 0.7854`: a multiple of 15
    /// degrees written in radians.
    fn radian_angles(&mut self, file: &ast::File, out: &mut Vec<Diagnostic>) {
        // The prelude's shapes whose parameters are angles (`cone`'s
        // `half_angle`): each shape's name and the angles' positions.
        let angle_params: HashMap<String, Vec<(usize, String)>> = self
            .globals
            .shapes
            .values()
            .filter(|s| s.prelude)
            .map(|s| {
                let angles = s.params.iter().enumerate();
                let angles = angles.filter(|(_, (p, _))| p.name.ends_with("angle"));
                let angles = angles.map(|(i, (p, _))| (i, p.name.clone())).collect();
                (s.name.name.clone(), angles)
            })
            .filter(|(_, angles): &(String, Vec<_>)| !angles.is_empty())
            .collect();
        let mut angles: Vec<(&ast::Expr, Angle)> = Vec::new();
        let mut found = Finder {
            angle_params: &angle_params,
            angles: &mut angles,
        };
        for item in &file.items {
            match item {
                Item::Shape(s) => found.formula(&s.body),
                Item::Object(o) => {
                    found.solid(&o.solid);
                    for p in &o.properties {
                        if p.name.name == "rotate" {
                            found.angles.push((&p.value, Angle::Property("rotate")));
                        }
                    }
                }
                Item::Directive(d) if d.name.name == "camera" => {
                    for p in d.block.iter().flat_map(|b| &b.properties) {
                        for angle in ["fov", "yaw", "pitch"] {
                            if p.name.name == angle {
                                found.angles.push((&p.value, Angle::Property(angle)));
                            }
                        }
                    }
                }
                _ => {}
            }
        }
        for (e, what) in angles {
            // A rotation may be a vector of three angles.
            let values = match self.quiet_constant(e) {
                Some(Constant::Num(a)) => vec![a],
                Some(Constant::Vector(v)) => v.to_array().to_vec(),
                _ => continue,
            };
            if let Some(&a) = values.iter().find(|&&a| looks_like_radians(a)) {
                let degrees = a.to_degrees();
                // `pi / 2` is shown as 1.5708, not 1.5707963267948966.
                let a = format!("{a:.4}");
                let a = a.trim_end_matches('0').trim_end_matches('.');
                let (taker, fix) = match &what {
                    Angle::Property(p) => (format!("`{p}`"), format!("`{p} {degrees:.0}`")),
                    Angle::Parameter { shape, name } => (
                        format!("`{shape}`'s `{name}`"),
                        format!("{degrees:.0} there"),
                    ),
                };
                out.push(
                    Diagnostic::new(
                        Code::AngleInRadians,
                        format!("{taker} takes degrees, and {a} looks like radians"),
                    )
                    .label(e.span, format!("{a} radians would be {degrees:.0} degrees"))
                    .help(format!("nes measures every angle in degrees: write {fix}")),
                );
            }
        }
    }

    /// The value of a constant expression, or `None` (with no diagnostic)
    /// if it is not one.
    fn quiet_constant(&mut self, e: &ast::Expr) -> Option<Constant> {
        let before = self.diags.len();
        let c = self.constant(e).ok();
        self.diags.truncate(before);
        c
    }
}

/// What an angle is given to.
enum Angle {
    /// A property or a transform: `rotate`, `fov`, `yaw`, `pitch`.
    Property(&'static str),
    /// A prelude shape's parameter: `cone`'s `half_angle`.
    Parameter { shape: String, name: String },
}

/// Collects the angles written in formulas and solids: rotations, and
/// the arguments of prelude shapes' angle parameters.
impl Compiler {
    /// `rgb(1, 1, 0)`: bytes of 0 and 1 are all but black, and nearly
    /// always meant as fractions (yellow). `rgb(0, 0, 0)` is black as
    /// meant; a fraction such as `rgb(1, 0.5, 0)` is already an error.
    fn bytes_like_fractions(&mut self, file: &ast::File, out: &mut Vec<Diagnostic>) {
        let mut roots: Vec<&ast::Expr> = Vec::new();
        fn solid<'f>(s: &'f ast::Solid, roots: &mut Vec<&'f ast::Expr>) {
            roots.extend(s.transforms.iter().map(|t| &t.value));
            match &s.kind {
                SolidKind::Csg { children, .. } => children.iter().for_each(|c| solid(c, roots)),
                SolidKind::Formula(e) => roots.push(e),
                SolidKind::Shape { args, .. } => roots.extend(args.iter().flatten()),
            }
        }
        for item in &file.items {
            match item {
                Item::Let(l) => roots.push(&l.value),
                Item::Shape(s) => roots.push(&s.body),
                Item::Object(o) => {
                    solid(&o.solid, &mut roots);
                    roots.extend(o.properties.iter().map(|p| &p.value));
                }
                Item::Directive(d) => {
                    roots.extend(&d.value);
                    roots.extend(d.block.iter().flat_map(|b| &b.properties).map(|p| &p.value));
                }
                Item::Import(_) => {}
            }
        }
        let mut calls = Vec::new();
        for root in roots {
            root.visit(&mut |e| {
                if let ast::ExprKind::Call { name, args } = &e.kind {
                    if name.name == "rgb" && args.len() == 3 {
                        calls.push((e, args));
                    }
                }
            });
        }
        for (call, args) in calls {
            let bytes: Option<Vec<f64>> = args
                .iter()
                .map(|a| match self.quiet_constant(a) {
                    Some(Constant::Num(c)) if c == 0.0 || c == 1.0 => Some(c),
                    _ => None,
                })
                .collect();
            let Some(bytes) = bytes else { continue };
            if !bytes.contains(&1.0) {
                continue;
            }
            let written = bytes
                .iter()
                .map(|c| format!("{c}"))
                .collect::<Vec<_>>()
                .join(", ");
            let full = bytes
                .iter()
                .map(|&c| if c == 1.0 { "255" } else { "0" })
                .collect::<Vec<_>>()
                .join(", ");
            out.push(
                Diagnostic::new(
                    Code::BytesLikeFractions,
                    format!("`rgb({written})` is nearly black: rgb() takes bytes from 0 to 255"),
                )
                .label(call.span, "bytes of 0 and 1, at most 1/255 of full brightness")
                .help(format!(
                    "for fractions from 0 to 1 write the vector `({written})`; in bytes, full brightness is `rgb({full})`"
                )),
            );
        }
    }
}

struct Finder<'f, 'a> {
    angle_params: &'a HashMap<String, Vec<(usize, String)>>,
    angles: &'a mut Vec<(&'f ast::Expr, Angle)>,
}

impl<'f> Finder<'f, '_> {
    fn arguments(&mut self, name: &str, args: &'f [ast::Expr]) {
        for (i, param) in self.angle_params.get(name).into_iter().flatten() {
            if let Some(a) = args.get(*i) {
                let angle = Angle::Parameter {
                    shape: name.to_string(),
                    name: param.clone(),
                };
                self.angles.push((a, angle));
            }
        }
    }

    /// Rotations and angle arguments inside a formula:
    /// `cube(1) rotate 1.57 about z`, `cone(0.5236)`.
    fn formula(&mut self, e: &'f ast::Expr) {
        let mut found = Vec::new();
        e.visit(&mut |e| found.push(e));
        for e in found {
            match &e.kind {
                ast::ExprKind::Moved(_, transforms) => {
                    let rotations = transforms.iter().filter(|t| t.op == TransformOp::Rotate);
                    let rotations = rotations.map(|t| (&t.value, Angle::Property("rotate")));
                    self.angles.extend(rotations);
                }
                ast::ExprKind::Call { name, args } => self.arguments(&name.name, args),
                _ => {}
            }
        }
    }

    fn solid(&mut self, s: &'f ast::Solid) {
        for t in &s.transforms {
            if t.op == TransformOp::Rotate {
                self.angles.push((&t.value, Angle::Property("rotate")));
            }
        }
        match &s.kind {
            SolidKind::Csg { children, .. } => children.iter().for_each(|c| self.solid(c)),
            SolidKind::Formula(e) => self.formula(e),
            SolidKind::Shape { name, args } => {
                if let Some(args) = args {
                    self.arguments(&name.name, args);
                    args.iter().for_each(|a| self.formula(a));
                }
            }
        }
    }
}

/// Whether `a` is, to two decimals, a non-whole multiple of pi/12 up to
/// one turn.
fn looks_like_radians(a: f64) -> bool {
    let a = a.abs();
    let step = std::f64::consts::PI / 12.0;
    let nearest = (a / step).round() * step;
    a > 0.1
        && a <= std::f64::consts::TAU + RADIAN_TOLERANCE
        && a.fract() != 0.0
        && (a - nearest).abs() < RADIAN_TOLERANCE
}

/// The warnings whose verdict depends on what the command line may change
/// (the image's width, the method): noise finer than a pixel, an object
/// smaller than one, and a loose bound where the route searches it.
const SETTINGS_CODES: [Code; 5] = [
    Code::FinerThanAPixel,
    Code::LooseBound,
    Code::SmallerThanAPixel,
    Code::FinerThanEpsilon,
    Code::LongRender,
];

/// The most objects whose bounds are checked for looseness: each check
/// samples [`SAMPLED_POINTS`] points.
const MOST_OBJECTS_CHECKED: usize = 16;

/// The most tape operations a looseness check may evaluate, over all its
/// [`SAMPLED_POINTS`]: about a tenth of a second. An object with a longer value
/// tape (a sum of over 1000 terms, say) is not checked, so that `check`
/// and each save in `watch` stay quick.
const MOST_OPERATIONS_SAMPLED: usize = 40_000_000;

/// The size of `object`'s bound where it is less than 100 times
/// `epsilon` across (W0015): hits on it are located too coarsely for its
/// shape.
fn finer_than_epsilon(object: &crate::scene::Object, epsilon: f64) -> Option<f64> {
    let b = object.bound?;
    let size = (b.max - b.min).max_element();
    (size.is_finite() && size > 0.0 && size < 100.0 * epsilon).then_some(size)
}

/// Operations of an object's formula a render may evaluate before it is
/// said to be slow: measured at 3.9 to 5.0 ns an operation on this 2-core
/// machine, one thread (a sum of 1 000 and of 5 000 sines), about 20 s of
/// one thread, 10 s of two.
const LONG_RENDER_OPERATIONS: f64 = 5e9;

/// How many times a search evaluates a formula per ray, at least (12 for
/// a sum of 1 000 sines, 50 for one of 5 000, whose tiny terms widen its
/// intervals).
const EVALUATIONS_PER_RAY: f64 = 10.0;

/// W0017: an object whose formula, searched along every ray of the image
/// (and every shadow ray), comes to more than [`LONG_RENDER_OPERATIONS`]:
/// an estimate from the formula's length (per cell, where the object has
/// shorter formulas there), the pixels, samples and lights; closed forms
/// are not counted.
fn long_render(scene: &Scene, object: &crate::scene::Object, route: Route) -> Option<Diagnostic> {
    if route == Route::Closed {
        return None;
    }
    let operations = object
        .pruned
        .as_ref()
        .map_or(object.function.value_tape.operations() as f64, |p| {
            p.mean_operations()
        });
    let camera = &scene.camera;
    let rays = camera.width as f64
        * camera.height as f64
        * scene.settings.samples as f64
        * (1.0 + scene.lights.len() as f64);
    let work = operations * rays * EVALUATIONS_PER_RAY;
    // A width whose estimate is a tenth of the limit: about a second.
    let smaller =
        ((camera.width as f64 * (0.1 * LONG_RENDER_OPERATIONS / work).sqrt()) as u32).max(16);
    (work > LONG_RENDER_OPERATIONS).then(|| {
        Diagnostic::new(
            Code::LongRender,
            format!(
                "`{}` is long for an image this size: the render may take a minute or more",
                object.label
            ),
        )
        .label(
            object.span,
            format!(
                "{} operations, evaluated at least {EVALUATIONS_PER_RAY} times along each of up to {} rays: {work:.0e} or more in all",
                operations.round(),
                rays.round()
            ),
        )
        .help(format!(
            "render it smaller first to see it (--width {smaller}); a sum of many terms whose later ones add detail finer than a pixel renders in proportion to the terms kept"
        ))
    })
}

/// Warnings on `scene` as its settings now stand: see [`SETTINGS_CODES`].
fn settings_warnings(scene: &Scene) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    let straight = scene.build_space().straight_paths();
    let region = (scene.objects.len() <= MOST_OBJECTS_CHECKED).then(|| reachable_region(scene));
    let space = scene.build_space();
    for object in &scene.objects {
        if let Some(finest) = finest_noise(scene, object) {
            out.push(finest.diagnostic(object.span));
        }
        let placed = match &object.bound {
            Some(b) if !object.placement.0.is_empty() => {
                space.images(b, &object.placement).first().copied()
            }
            _ => None,
        };
        let tiny = pixels_across(scene, object, placed.as_ref());
        // Hits are located to within epsilon (in the scene's units): an
        // object not a hundred times larger loses its shape (a trial's
        // Chebyshev surface scaled by 1e-9 showed as a blob).
        let epsilon = scene.settings.epsilon;
        // (Under a pixel across, W0010 says enough.)
        if let (Some(size), None) = (finer_than_epsilon(object, epsilon), tiny) {
            out.push(
                    Diagnostic::new(
                        Code::FinerThanEpsilon,
                        format!("`{}` is at most {size:.1e} across, too small for `epsilon` ({epsilon:e})", object.label),
                    )
                    .label(object.span, format!("hits on it are located only to within {epsilon:e}"))
                    .help(format!(
                        "its shape is lost at that precision: set `epsilon` in `render {{ }}` to a thousandth of its size or less (`epsilon 1e{}`), or make the scene larger",
                        // A power of ten, rounded down.
                        (size * 1e-3).log10().floor()
                    )),
                );
        }
        if let Some(across) = tiny {
            out.push(
                Diagnostic::new(
                    Code::SmallerThanAPixel,
                    format!("`{}` is smaller than a pixel", object.label),
                )
                .label(object.span, format!("at most {} of a pixel across, seen from the camera", pixels(across)))
                .help(format!(
                    "it shows in one pixel or none{}; move it or the camera closer, make it larger, or narrow the camera's `fov`",
                    if scene.space.name() == "h3" {
                        " (in H3 things shrink exponentially with distance)"
                    } else {
                        ""
                    }
                )),
            );
        }
        let route = Route::for_object(object, scene.settings.method, straight);
        if let Some(long) = long_render(scene, object, route) {
            out.push(long);
        }
        // The polynomial route too, when very loose (below): its
        // coefficients' error grows with its terms' sizes over the stretch
        // searched (a Chmutov surface of degree 12, rotated: 9 evaluations
        // per ray against 1 clipped).
        let searched = route.searches() || route == Route::Polynomial;
        let affordable =
            object.function.value_tape.len() * SAMPLED_POINTS <= MOST_OPERATIONS_SAMPLED;
        // A bound under a pixel across costs rays nothing to search,
        // however much of it is empty (W0006 once suggested `clip box(0,
        // 0, 0)` for one a millionth of a pixel across).
        let (Some(region), Some(bound), true) = (
            region,
            object.bound,
            searched && affordable && tiny.is_none(),
        ) else {
            continue;
        };
        let region = local_region(scene, region, &object.placement);
        // Within a thousandth of the region's size of its every face.
        let slack = 1e-3 * (region.max - region.min).max_element();
        let whole = (bound.min - region.min).max_element() <= slack
            && (region.max - bound.max).max_element() <= slack;
        // The polynomial route pays for looseness only through its
        // coefficients' error, far less than a search does: warned where
        // the bound is over 16 times the surface's box (the gallery's
        // Chmutov octic, 4 times, solves in 1 evaluation per ray).
        let worth_volume = if route == Route::Polynomial {
            16.0
        } else {
            0.0
        };
        let loose = match sample_bound(&object.function, bound, worth_volume) {
            Sampled::Loose(loose) => loose,
            // A bound that never shrank, over which sampling finds no
            // sign change: a formula that is never 0 where intervals
            // cannot show it, or a surface finer than the grid.
            Sampled::NoSurface if whole => {
                out.push(
                    Diagnostic::new(
                        Code::LooseBound,
                        format!(
                            "the bound of `{}` is the whole region rays reach, and sampling finds no surface in it",
                            object.label
                        ),
                    )
                    .label(
                        object.span,
                        format!(
                            "rays search all of {} .. {}",
                            short(bound.min),
                            short(bound.max)
                        ),
                    )
                    .help("either the formula is never 0 but interval arithmetic cannot show it (an identity like sin(x)^2 + cos(x)^2 - 1 written out, say), or its surface is finer than a 32^3 grid over that region; every ray searches its whole length for nothing: simplify the formula, or give the object a `clip` around where its surface is"),
                );
                continue;
            }
            _ => continue,
        };
        let message = if whole {
            format!(
                "the bound of `{}` is the whole region rays reach, though its surface is smaller",
                object.label
            )
        } else {
            format!(
                "the bound of `{}` is loose, so rays search empty space",
                object.label
            )
        };
        let advice = loose.advice(object.clip.is_some(), &object.curved_uses);
        out.push(
            Diagnostic::new(Code::LooseBound, message)
                .label(
                    object.span,
                    format!(
                        "rays search its bound {} .. {}; its surface lies within {} .. {}",
                        short(bound.min),
                        short(bound.max),
                        short(loose.surface.min),
                        short(loose.surface.max)
                    ),
                )
                .help(if advice.is_empty() {
                    "the image is right but slower than it needs to be; a tighter `clip` leaves less to search".to_string()
                } else {
                    format!("the image is right but slower than it needs to be: {advice}")
                }),
        );
    }
    out
}

/// A point to two decimals, for a label.
fn short(p: DVec3) -> String {
    format!("({:.2}, {:.2}, {:.2})", p.x, p.y, p.z)
}

/// Computes again the warnings that depend on settings (noise finer than
/// a pixel depends on the width, a loose bound on the method), after the
/// command line changed them.
pub fn relint(scene: &mut Scene) {
    scene.warnings.retain(|d| !SETTINGS_CODES.contains(&d.code));
    let fresh = settings_warnings(scene);
    scene.warnings.extend(fresh);
    scene
        .warnings
        .sort_by_key(|d| d.span().map_or(usize::MAX, |s| s.start));
}

/// The finest noise an object uses, measured where the camera looks.
struct FinestNoise {
    cell: f64,
    pixel: f64,
}

impl FinestNoise {
    fn diagnostic(&self, span: Span) -> Diagnostic {
        Diagnostic::new(
            Code::FinerThanAPixel,
            format!(
                "this object's noise has features about {:.1e} units wide, {:.0} times finer than a pixel",
                self.cell,
                self.pixel / self.cell
            ),
        )
        .label(span, format!("a pixel here is about {:.1e} units wide", self.pixel))
        .help("the image cannot show them (it will look like static), and finding the surface means resolving each one, which is slow: lower the noise's frequency, or the octaves of fbm")
    }
}

/// The narrowest lattice cell of any `noise` in `object`, where the
/// camera looks (its target, else the bound's centre), if it is finer than
/// [`FEATURES_PER_PIXEL`] of a pixel there.
fn finest_noise(scene: &Scene, object: &crate::scene::Object) -> Option<FinestNoise> {
    let tape = &object.function.value_tape;
    let arguments = tape.noise_arguments();
    if arguments.is_empty() || !object.placement.0.is_empty() {
        return None;
    }
    let camera = &scene.camera;
    // Where the camera looks is where the pixel size matters; the bound's
    // centre only when no target is given (it may hold the camera).
    let at = match (camera.target, &object.bound) {
        (Some(t), _) => t,
        (None, Some(b)) => (b.min + b.max) / 2.0,
        (None, None) => camera.position + camera.forward,
    };
    // The argument's rate of change along each axis, by forward mode.
    let mut rate = vec![0.0; tape.len()];
    let mut slots = Vec::new();
    for axis in 0..3 {
        let inputs: [Dual<f64>; 3] = std::array::from_fn(|i| Dual {
            v: at[i],
            d: if i == axis { 1.0 } else { 0.0 },
        });
        tape.eval(&inputs, &mut slots);
        for (r, s) in rate.iter_mut().zip(&slots) {
            *r += s.d * s.d;
        }
    }
    let frequency = arguments
        .iter()
        .flat_map(|args| args.map(|a| rate[a].sqrt()))
        .filter(|f| f.is_finite())
        .fold(0.0, f64::max);
    let distance = (at - camera.position).length().max(1e-9);
    let pixel = 2.0 * distance * (camera.fov_degrees.to_radians() / 2.0).tan()
        / f64::from(camera.width.max(1));
    let cell = 1.0 / frequency;
    (cell < FEATURES_PER_PIXEL * pixel).then_some(FinestNoise { cell, pixel })
}
