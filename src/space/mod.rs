//! Spaces: how a ray travels.
//!
//! Input: a ray's start, unit direction and length limit.
//! Output: the pieces of its path, in order, as [`Segment`]s, which the
//! intersector can search by their points, tangents and bounding boxes.
//! The tracer sees only segments, object images and connecting geodesics,
//! and never looks inside a space; adding a space means implementing
//! [`Space`] and, if its paths are neither lines nor circles, a segment
//! kind.

mod sphere;
mod torus;

use std::ops::ControlFlow;

use glam::DVec3;

use crate::scene::{Aabb, Method, Scene, SpaceKind};
pub use sphere::{DenseStep, IntegratedLoop, IntegratorStats, PathMode, SphereSpace, GRID};
pub use torus::TorusSpace;

/// A piece of a ray's path, parametrised by `t`, the distance travelled
/// along the whole path, for `t` in `[t0, t1]`.
// Segments live on the stack, one at a time per object test; boxing the
// integrated step would allocate for every step of every ray.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Segment<'a> {
    /// The points `start + (t - t0) * direction`. Anchored at its own
    /// start, not at the path's origin, so that a piece far along the path
    /// (after many torus wraps) keeps full precision.
    Line {
        start: DVec3,
        direction: DVec3,
        t0: f64,
        t1: f64,
    },
    /// The circle `centre + radius (cos(t/radius) start + sin(t/radius)
    /// tangent)`, with `start` and `tangent` orthonormal.
    Arc {
        centre: DVec3,
        radius: f64,
        start: DVec3,
        tangent: DVec3,
        t0: f64,
        t1: f64,
    },
    /// One step of a numerically integrated path: a quintic-accurate
    /// interpolant between two accepted integrator steps (see
    /// [`sphere::DenseStep`]). Searched by sign changes at its ends and
    /// refined on the interpolant.
    Dense(sphere::DenseStep<'a>),
}

impl<'a> Segment<'a> {
    pub fn range(&self) -> (f64, f64) {
        match *self {
            Segment::Line { t0, t1, .. } | Segment::Arc { t0, t1, .. } => (t0, t1),
            Segment::Dense(ref s) => (s.t0, s.t1),
        }
    }

    /// The point at distance `t`.
    #[inline]
    pub fn point(&self, t: f64) -> DVec3 {
        match *self {
            Segment::Line {
                start,
                direction,
                t0,
                ..
            } => start + (t - t0) * direction,
            Segment::Arc {
                centre,
                radius,
                start,
                tangent,
                ..
            } => {
                let (s, c) = (t / radius).sin_cos();
                centre + radius * (c * start + s * tangent)
            }
            Segment::Dense(ref s) => s.point(t),
        }
    }

    /// For a straight segment, its start, direction and the distance at
    /// its start: the segment is `start + (t - t0) direction`, which lets
    /// a search evaluate along the line in its parameter alone.
    #[inline]
    pub fn as_line(&self) -> Option<(DVec3, DVec3, f64)> {
        match *self {
            Segment::Line {
                start,
                direction,
                t0,
                ..
            } => Some((start, direction, t0)),
            _ => None,
        }
    }

    /// The unit direction of travel at distance `t`.
    #[inline]
    pub fn direction(&self, t: f64) -> DVec3 {
        match *self {
            Segment::Line { direction, .. } => direction,
            Segment::Arc {
                radius,
                start,
                tangent,
                ..
            } => {
                let (s, c) = (t / radius).sin_cos();
                c * tangent - s * start
            }
            Segment::Dense(ref s) => s.direction(t),
        }
    }

    /// A box holding every point of the piece `[a, b]`, and one holding
    /// every direction of travel there. Conservative for lines and arcs;
    /// `None` for integrated steps, which are searched by sampling.
    pub fn bounds(&self, a: f64, b: f64) -> Option<(Aabb, Aabb)> {
        match *self {
            Segment::Line {
                start,
                direction,
                t0,
                ..
            } => {
                let (p, q) = (start + (a - t0) * direction, start + (b - t0) * direction);
                Some((
                    Aabb {
                        min: p.min(q),
                        max: p.max(q),
                    },
                    Aabb {
                        min: direction,
                        max: direction,
                    },
                ))
            }
            Segment::Arc {
                radius,
                start,
                tangent,
                ..
            } => {
                // The points' box as `point_bounds` makes it; the
                // directions turn with them, a quarter turn ahead.
                let points = self.point_bounds(a, b)?;
                Some((points, arc_box(a / radius, b / radius, tangent, -start)))
            }
            Segment::Dense(_) => None,
        }
    }

    /// A box holding every point of the piece `[a, b]` (see [`bounds`];
    /// for integrated steps, the chord's box widened by the most a circle
    /// of the step's radius can bulge from it).
    ///
    /// [`bounds`]: Segment::bounds
    pub fn point_bounds(&self, a: f64, b: f64) -> Option<Aabb> {
        match *self {
            Segment::Arc {
                centre,
                radius,
                start,
                tangent,
                ..
            } => {
                let points = arc_box(a / radius, b / radius, start, tangent);
                Some(Aabb {
                    min: centre + radius * points.min,
                    max: centre + radius * points.max,
                })
            }
            Segment::Dense(ref s) => Some(s.chord_box(a, b)),
            Segment::Line { .. } => self.bounds(a, b).map(|(p, _)| p),
        }
    }

    /// The same path moved by `-offset` (the path as seen by an object's
    /// image at `offset`).
    pub fn shifted(&self, offset: DVec3) -> Segment<'a> {
        match *self {
            Segment::Line {
                start,
                direction,
                t0,
                t1,
            } => Segment::Line {
                start: start - offset,
                direction,
                t0,
                t1,
            },
            Segment::Arc {
                centre,
                radius,
                start,
                tangent,
                t0,
                t1,
            } => Segment::Arc {
                centre: centre - offset,
                radius,
                start,
                tangent,
                t0,
                t1,
            },
            Segment::Dense(mut s) => {
                s.offset += offset;
                Segment::Dense(s)
            }
        }
    }
}

/// The box of `cos(s) u + sin(s) v` for `s` in `[s0, s1]`: the ends, plus
/// every axis extreme the angle range passes.
fn arc_box(s0: f64, s1: f64, u: DVec3, v: DVec3) -> Aabb {
    let at = |s: f64| s.cos() * u + s.sin() * v;
    let (p, q) = (at(s0), at(s1));
    let mut min = p.min(q);
    let mut max = p.max(q);
    for axis in 0..3 {
        // Component: u_i cos s + v_i sin s = A cos(s - phi).
        let amplitude = (u[axis] * u[axis] + v[axis] * v[axis]).sqrt();
        let phi = v[axis].atan2(u[axis]);
        // Maximum at s = phi + 2k pi, minimum at s = phi + pi + 2k pi.
        let passes = |angle: f64| {
            let k = ((s0 - angle) / std::f64::consts::TAU).ceil();
            angle + k * std::f64::consts::TAU <= s1
        };
        if passes(phi) {
            max[axis] = amplitude;
        }
        if passes(phi + std::f64::consts::PI) {
            min[axis] = -amplitude;
        }
    }
    // Rounding in the trigonometry: widen by a few ulps of the unit scale.
    Aabb {
        min: min - DVec3::splat(1e-15),
        max: max + DVec3::splat(1e-15),
    }
}

pub trait Space: Sync + Send {
    /// Visit the path from `origin` along the unit vector `direction` for
    /// length `limit`, piece by piece in order, until `visit` breaks.
    fn walk(
        &self,
        origin: DVec3,
        direction: DVec3,
        limit: f64,
        visit: &mut dyn FnMut(&Segment) -> ControlFlow<()>,
    );

    /// The offsets at which copies of an object with this bound appear in
    /// the space's fundamental domain (quotient spaces repeat objects).
    fn images(&self, _bound: &Aabb) -> Vec<DVec3> {
        vec![DVec3::ZERO]
    }

    /// The shortest path from `from` to `to` that [`Space::walk`] would
    /// follow: its starting direction and length, if there is one.
    fn connect(&self, from: DVec3, to: DVec3) -> Option<(DVec3, f64)> {
        let d = to - from;
        let len = d.length();
        (len > 0.0).then(|| (d / len, len))
    }

    /// For paths integrated numerically: how the integrator fared (for
    /// `nes explain` and the stress tests). `None` where paths are exact.
    fn integrator_stats(&self) -> Option<IntegratorStats> {
        None
    }

    /// A box holding every point a path of length `limit` from `origin` can
    /// reach, in the coordinates objects are written in.
    fn reach(&self, origin: DVec3, limit: f64) -> Aabb {
        Aabb {
            min: origin - DVec3::splat(limit),
            max: origin + DVec3::splat(limit),
        }
    }
}

/// Flat space: every path is one straight segment.
#[derive(Debug, Clone, Copy, Default)]
pub struct Euclidean;

impl Space for Euclidean {
    fn walk(
        &self,
        origin: DVec3,
        direction: DVec3,
        limit: f64,
        visit: &mut dyn FnMut(&Segment) -> ControlFlow<()>,
    ) {
        let _ = visit(&Segment::Line {
            start: origin,
            direction,
            t0: 0.0,
            t1: limit,
        });
    }
}

/// The space a scene asks for. The method `ode` makes the sphere space
/// integrate its paths; the camera's view direction settles the sphere
/// space's vertical rays.
/// The points at distances `ts` (ascending) along the path from `origin`
/// in `direction`, in the space's coordinates; `None` past the path's end
/// (the sphere space's paths end after one loop).
pub fn points_along(
    space: &dyn Space,
    origin: DVec3,
    direction: DVec3,
    ts: &[f64],
) -> Vec<Option<DVec3>> {
    let mut out = vec![None; ts.len()];
    let Some(&last) = ts.last() else {
        return out;
    };
    let mut next = 0;
    space.walk(origin, direction, last, &mut |seg| {
        let (t0, t1) = seg.range();
        while next < ts.len() && ts[next] <= t1 {
            if ts[next] >= t0 {
                out[next] = Some(seg.point(ts[next]));
            }
            next += 1;
        }
        if next == ts.len() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    out
}

/// How the sphere space's paths are followed for `scene`: `method ode`
/// integrates them whatever the space block says. `None` outside the
/// sphere space.
pub fn sphere_path(scene: &Scene) -> Option<PathMode> {
    match scene.space {
        SpaceKind::Sphere { .. } if scene.settings.method == Method::Ode => {
            Some(PathMode::Integrated {
                tolerance: scene.settings.tolerance,
            })
        }
        SpaceKind::Sphere { path, .. } => Some(path),
        _ => None,
    }
}

pub fn for_scene(scene: &Scene) -> Box<dyn Space> {
    match scene.space {
        SpaceKind::Euclidean => Box::new(Euclidean),
        SpaceKind::Torus {
            min,
            max,
            wraps,
            periodic,
        } => Box::new(TorusSpace::new(min, max, wraps, periodic)),
        SpaceKind::Sphere { radius, path } => Box::new(SphereSpace::new(
            radius,
            sphere_path(scene).unwrap_or(path),
            scene.camera.forward,
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arc_boxes_hold_every_point_of_the_arc() {
        let u = DVec3::new(0.6, 0.0, 0.8);
        let v = DVec3::new(0.0, 1.0, 0.0);
        for (s0, s1) in [
            (0.0, 0.3),
            (-1.0, 2.0),
            (2.5, 6.0),
            (0.0, 6.3),
            (-4.0, -3.0),
        ] {
            let b = arc_box(s0, s1, u, v);
            for i in 0..=100 {
                let s = s0 + (s1 - s0) * i as f64 / 100.0;
                let p = s.cos() * u + s.sin() * v;
                assert!(
                    p.cmpge(b.min).all() && p.cmple(b.max).all(),
                    "{s}: {p} not in {b:?}"
                );
            }
        }
    }
}
