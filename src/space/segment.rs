//! Segments: the pieces of a ray's path, and every question the tracer,
//! the tools and the diagrams may ask of one.
//!
//! Input: what a space's `walk` builds (a line, a circular arc, one
//! integrator step). Output: answers in the scene's coordinates: points,
//! directions, conservative boxes, the range that can reach a bound, a
//! closed-form meeting with a quadric where the path's shape allows one,
//! sample pieces where it has no boxes, and the line form of a straight
//! piece. The kinds themselves are private: **no code outside
//! `src/space/` can tell an arc from an integrated step**, so a new kind
//! of path is added here and nowhere else.

use glam::DVec3;

use super::curved::{bound_ball_radius, Approach, Geodesic};
use super::metric::{ChartStep, Metric};
use super::sphere::DenseStep;
use super::{Aabb, Image, ImageKind};
use crate::expr::Quadric;

/// A piece of a ray's path, parametrised by `t`, the distance travelled
/// along the whole path, for `t` in [`Segment::range`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment<'a>(Kind<'a>);

// Segments live on the stack, one at a time per object test; boxing the
// integrated step would allocate for every step of every ray.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind<'a> {
    /// The points `line.start + (t - line.t0) * line.direction` for `t`
    /// up to `t1`. Anchored at its own start, not at the path's origin, so
    /// that a piece far along the path (after many torus wraps) keeps
    /// full precision.
    Line { line: Line, t1: f64 },
    /// The circle through `origin` (at `t = 0`) of radius `radius` about
    /// `origin - radius start`: the points `origin + radius (sin(s)
    /// tangent - 2 sin^2(s/2) start)`, `s = t / radius`, with `start` and
    /// `tangent` orthonormal. Anchored at its own start, not its centre, so that a
    /// huge radius (1e15) costs no precision near the start: the offsets
    /// from it are computed to full relative precision.
    Arc {
        origin: DVec3,
        radius: f64,
        start: DVec3,
        tangent: DVec3,
        t0: f64,
        t1: f64,
    },
    /// One step of a numerically integrated path: a quintic-accurate
    /// interpolant between two accepted integrator steps. It has no
    /// conservative boxes; it is searched through its sample pieces.
    Dense(DenseStep<'a>),
    /// A piece of a geodesic of S3 or H3, seen in normal coordinates.
    Geodesic(Geodesic),
    /// One integrator step of a geodesic of a metric the scene wrote, in
    /// its chart, with the metric (for the frame its headings are in).
    /// Searched through its sample pieces, like `Dense`.
    Chart(&'a ChartStep, &'a Metric),
}

/// A straight segment's line form: the segment is
/// `start + (t - t0) direction`, which lets a search evaluate along the
/// line in its parameter alone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line {
    /// The point at distance `t0`.
    pub start: DVec3,
    /// The unit direction of travel.
    pub direction: DVec3,
    /// `1 / direction`, per component, computed once per segment for box
    /// clipping and grid walks.
    pub inverse_direction: DVec3,
    /// The distance along the whole path at `start`.
    pub t0: f64,
}

/// A curved piece as a line with error bars: for `t` in its range the
/// path is within `deviation` (per coordinate) of `start + (t - at)
/// direction`, and its velocity within `slope_deviation` of `direction`.
/// Searches evaluate along it as along a straight segment, with the
/// error added, which is far tighter than a box around the piece.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NearLine {
    /// The distance the line is anchored at (the piece's middle).
    pub at: f64,
    /// The path's point at `at`.
    pub start: DVec3,
    /// The path's velocity at `at`.
    pub direction: DVec3,
    /// Half the piece's length: `|t - at|` is at most this.
    pub reach: f64,
    /// How far the path may be from the line, per coordinate.
    pub deviation: DVec3,
    /// How far its velocity may be from `direction`, per coordinate.
    pub slope_deviation: DVec3,
}

/// What a range clipped to a bound will be searched by: a closed-form
/// solve on a circle is cheaper than narrowing the arc piece by piece.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClipFor {
    /// A closed-form meeting with a quadric follows.
    ClosedForm,
    /// A search (isolation, marching, sampling) follows.
    Search,
}

/// Where a path meets a ball or plane object from a segment's start on,
/// in closed form over the whole path ahead (see
/// [`Segment::quadric_ahead`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum QuadricAhead {
    /// First met at this distance, within the range asked about.
    At(f64),
    /// Not within the range asked about.
    NotHere,
    /// Not on this segment nor anywhere further along the path.
    Never,
}

/// A closed-form meeting of a segment with a quadric.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum QuadricMeeting {
    /// The first root in the range, if any.
    Solved(Option<f64>),
    /// The segment's shape has no closed form with this quadric: search.
    Unsolvable,
}

/// A stretch between two sample points of a segment that has no
/// conservative boxes, with a box that holds the path between them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SamplePiece {
    /// Distance along the whole path at the start, `a < b`.
    pub a: f64,
    /// Distance along the whole path at the end.
    pub b: f64,
    /// The path's point at distance `a`.
    pub start: DVec3,
    /// The path's point at distance `b`.
    pub end: DVec3,
    /// Holds every point of the path for `t` in `[a, b]`.
    pub bounds: Aabb,
}

impl<'a> Segment<'a> {
    /// The straight segment `start + (t - t0) direction`, `t` in
    /// `[t0, t1]`.
    #[inline]
    pub fn line(start: DVec3, direction: DVec3, t0: f64, t1: f64) -> Segment<'static> {
        Segment(Kind::Line {
            line: Line {
                start,
                direction,
                inverse_direction: direction.recip(),
                t0,
            },
            t1,
        })
    }

    /// The arc through `origin` (at `t = 0`, direction `tangent`) on the
    /// circle of radius `radius` about `origin - radius start`, `t` in
    /// `[t0, t1]`; `start` and `tangent` orthonormal.
    pub(super) fn arc(
        origin: DVec3,
        radius: f64,
        start: DVec3,
        tangent: DVec3,
        (t0, t1): (f64, f64),
    ) -> Segment<'static> {
        Segment(Kind::Arc {
            origin,
            radius,
            start,
            tangent,
            t0,
            t1,
        })
    }

    /// One integrator step with its dense output.
    pub(super) fn integrated(step: DenseStep<'a>) -> Segment<'a> {
        Segment(Kind::Dense(step))
    }

    /// A piece of a geodesic of a space of constant curvature.
    pub(super) fn geodesic(g: Geodesic) -> Segment<'static> {
        Segment(Kind::Geodesic(g))
    }

    /// One integrator step of a metric space's geodesic.
    pub(super) fn chart(step: &'a ChartStep, metric: &'a Metric) -> Segment<'a> {
        Segment(Kind::Chart(step, metric))
    }

    /// The geodesic piece, for the curved spaces' own tests.
    #[cfg(test)]
    pub(super) fn as_geodesic(&self) -> Option<&Geodesic> {
        match &self.0 {
            Kind::Geodesic(g) => Some(g),
            _ => None,
        }
    }

    /// The distances `[t0, t1]` the segment covers.
    #[inline]
    pub fn range(&self) -> (f64, f64) {
        match self.0 {
            Kind::Line { line, t1 } => (line.t0, t1),
            Kind::Arc { t0, t1, .. } => (t0, t1),
            Kind::Dense(ref s) => (s.t0, s.t1),
            Kind::Geodesic(ref g) => (g.t0, g.t1),
            Kind::Chart(c, _) => (c.t0, c.t1),
        }
    }

    /// The point at distance `t`.
    #[inline]
    pub fn point(&self, t: f64) -> DVec3 {
        match self.0 {
            Kind::Line { line, .. } => line.start + (t - line.t0) * line.direction,
            Kind::Arc {
                origin,
                radius,
                start,
                tangent,
                ..
            } => origin + radius * arc_offset(t / radius, start, tangent),
            Kind::Dense(ref s) => s.point(t),
            Kind::Geodesic(ref g) => g.point(t),
            Kind::Chart(c, _) => c.point(t),
        }
    }

    /// The line form of a straight segment; `None` for a curved one.
    #[inline]
    pub fn as_line(&self) -> Option<Line> {
        match self.0 {
            Kind::Line { line, .. } => Some(line),
            _ => None,
        }
    }

    /// The path's velocity at distance `t`, `d point / dt`, in the
    /// coordinates points are given in: the unit direction of travel
    /// where those coordinates are Euclidean (see [`Segment::heading`]).
    #[inline]
    pub fn direction(&self, t: f64) -> DVec3 {
        match self.0 {
            Kind::Line { line, .. } => line.direction,
            Kind::Arc {
                radius,
                start,
                tangent,
                ..
            } => {
                let (s, c) = (t / radius).sin_cos();
                c * tangent - s * start
            }
            Kind::Dense(ref s) => s.direction(t),
            Kind::Geodesic(ref g) => g.velocity(t),
            Kind::Chart(c, _) => c.velocity(t),
        }
    }

    /// The unit direction of travel at distance `t` in the space's
    /// orthonormal frame at that point: what shading compares normals and
    /// light directions with. The same as [`Segment::direction`] except
    /// in the curved spaces, whose coordinates stretch lengths.
    #[inline]
    pub fn heading(&self, t: f64) -> DVec3 {
        match self.0 {
            Kind::Geodesic(ref g) => g.heading(t),
            Kind::Chart(c, metric) => {
                let v = c.velocity(t);
                match metric.frame_at(c.point(t)) {
                    Some(f) => f.to_frame(v).normalize_or_zero(),
                    None => v.normalize_or_zero(),
                }
            }
            _ => self.direction(t),
        }
    }

    /// The part of `[a, b]` where the quadric `q` may be negative or zero
    /// (a superset, widened by rounding), where the segment can tell in
    /// closed form: on a line when it is one interval, on a piece of a
    /// geodesic of S3 or H3 when `q` is a ball about the origin.
    /// `Some(None)` when none of `[a, b]` is; `None` when it cannot tell.
    pub fn quadric_keeps(&self, q: &Quadric, a: f64, b: f64) -> Option<Option<(f64, f64)>> {
        match self.0 {
            Kind::Line { line, .. } => {
                let (lo, hi) = q.nonpositive_range_on_line(line.start, line.direction)?;
                let (from, to) = (a.max(line.t0 + lo), b.min(line.t0 + hi));
                Some((from <= to).then_some((from, to)))
            }
            Kind::Geodesic(ref g) => g.quadric_keeps(q, a, b),
            _ => None,
        }
    }

    /// [`Segment::point`] and [`Segment::heading`] at `t` together, for
    /// a hit: a geodesic finds its model point once for both.
    pub fn point_and_heading(&self, t: f64) -> (DVec3, DVec3) {
        match self.0 {
            Kind::Geodesic(ref g) => g.point_and_heading(t),
            _ => (self.point(t), self.heading(t)),
        }
    }

    /// [`Segment::point_and_heading`] at `t`, and the point in the
    /// coordinates of the copy at `image` (what [`Segment::seen_by`]'s
    /// point gives): where a motion places the copy, from one model point
    /// of the path, moved.
    #[inline]
    pub fn point_heading_and_local(&self, image: &Image, t: f64) -> (DVec3, DVec3, DVec3) {
        match (&self.0, &image.0) {
            (Kind::Geodesic(g), ImageKind::Motion(m)) => m.point_heading_and_local(g, t),
            _ => {
                let (point, heading) = self.point_and_heading(t);
                let local = if image.is_here() {
                    point
                } else {
                    self.seen_by(image).point(t)
                };
                (point, heading, local)
            }
        }
    }

    /// A box holding every point of the piece `[a, b]`, and one holding
    /// every direction of travel there. Conservative for lines and arcs;
    /// `None` for segments searched by sampling (see
    /// [`Segment::sample_pieces`]).
    pub fn bounds(&self, a: f64, b: f64) -> Option<(Aabb, Aabb)> {
        match self.0 {
            Kind::Line { line, .. } => {
                let p = line.start + (a - line.t0) * line.direction;
                let q = line.start + (b - line.t0) * line.direction;
                Some((
                    Aabb {
                        min: p.min(q),
                        max: p.max(q),
                    },
                    Aabb {
                        min: line.direction,
                        max: line.direction,
                    },
                ))
            }
            Kind::Arc {
                radius,
                start,
                tangent,
                ..
            } => {
                // The directions turn with the points, a quarter turn
                // ahead.
                let points = self.point_bounds(a, b)?;
                Some((points, arc_box(a / radius, b / radius, tangent, -start)))
            }
            Kind::Dense(_) | Kind::Chart(..) => None,
            Kind::Geodesic(ref g) => Some(g.bounds(a, b)),
        }
    }

    /// Whether the path, from this segment's end on, never comes (back)
    /// within `bound` (so later segments need not test it): in S3 and H3
    /// when the whole geodesic passes the bound's ball by, and in H3 also
    /// once it is beyond the ball and moving away (the distance to a point
    /// is convex along a geodesic there). False where that is not known.
    #[inline]
    pub fn gone_past(&self, bound: &Aabb) -> bool {
        match self.0 {
            Kind::Geodesic(ref g) => g.gone_past(bound_ball_radius(bound)),
            _ => false,
        }
    }

    /// The piece `[a, b]` of a curved segment as a line with error bars
    /// (see [`NearLine`]); `None` for lines (use [`Segment::as_line`]) and
    /// for kinds that offer none.
    pub fn near_line(&self, a: f64, b: f64) -> Option<NearLine> {
        match self.0 {
            Kind::Geodesic(ref g) => g.near_line(a, b),
            _ => None,
        }
    }

    /// A box holding every point of the piece `[a, b]` (see
    /// [`Segment::bounds`]; for integrated steps, the chord's box widened
    /// by the most a circle of the step's radius can bulge from it).
    pub fn point_bounds(&self, a: f64, b: f64) -> Option<Aabb> {
        match self.0 {
            Kind::Arc {
                origin,
                radius,
                start,
                tangent,
                ..
            } => {
                let offsets = arc_offset_box(a / radius, b / radius, start, tangent);
                // The sum's rounding, at the scale of the coordinates.
                let slack = DVec3::splat(2.0 * f64::EPSILON) * origin.abs();
                Some(Aabb {
                    min: origin + radius * offsets.min - slack,
                    max: origin + radius * offsets.max + slack,
                })
            }
            Kind::Dense(ref s) => Some(s.chord_box(a, b)),
            Kind::Chart(c, _) => Some(c.chord_box(a, b)),
            Kind::Line { .. } | Kind::Geodesic(_) => self.bounds(a, b).map(|(p, _)| p),
        }
    }

    /// The part of `[t0, t1]` that can reach `bound`: exact for lines; for
    /// arcs, the run of pieces whose boxes meet it (or the whole range
    /// when a closed form follows); for integrated steps, the whole range
    /// when the step's box meets it. The line case runs on every ray and
    /// object, so it is inlined; the others are not.
    #[inline(always)]
    pub fn clip(&self, bound: &Aabb, t0: f64, t1: f64, then: ClipFor) -> Option<(f64, f64)> {
        match self.0 {
            Kind::Line { line, .. } => bound
                .clip(
                    line.start,
                    line.inverse_direction,
                    t0 - line.t0,
                    t1 - line.t0,
                )
                .map(|(a, b)| (a + line.t0, b + line.t0)),
            _ => self.clip_curve(bound, t0, t1, then),
        }
    }

    #[inline(never)]
    fn clip_curve(&self, bound: &Aabb, t0: f64, t1: f64, then: ClipFor) -> Option<(f64, f64)> {
        match self.0 {
            Kind::Line { .. } => self.clip(bound, t0, t1, then),
            // A closed form finds no root where the path does not meet
            // the surface, and a geodesic's ball was already tested by
            // [`Segment::approach`].
            Kind::Arc { .. } | Kind::Geodesic(_) if then == ClipFor::ClosedForm => Some((t0, t1)),
            Kind::Arc { .. } => self.narrow_curve(bound, t0, t1),
            Kind::Geodesic(ref g) => {
                // The ball about the object's centre that holds the bound,
                // tested in the model first: cheap, and it rejects most
                // objects a piece passes far from.
                let rho = bound_ball_radius(bound);
                // The part within the ball, in closed form.
                let (a, b) = g.within(rho, t0, t1)?;
                // Then the box itself, which the ball holds with room to
                // spare: the piece lies within its error bars of its
                // tangent line, so the line against the box grown by them
                // keeps every point of the piece in the box.
                let Some(near) = g.near_line(a, b) else {
                    return Some((a, b));
                };
                let grown = Aabb {
                    min: bound.min - near.deviation,
                    max: bound.max + near.deviation,
                };
                let (lo, hi) =
                    grown.clip(near.start, near.direction.recip(), a - near.at, b - near.at)?;
                let margin = 1e-9 * (b - a);
                Some((
                    (lo + near.at - margin).max(a),
                    (hi + near.at + margin).min(b),
                ))
            }
            Kind::Dense(_) | Kind::Chart(..) => {
                let bx = self.point_bounds(t0, t1)?;
                bx.overlaps(bound).then_some((t0, t1))
            }
        }
    }

    /// The part of a curved segment that can meet `bound`: the range is
    /// cut into pieces, and runs from the first piece whose box meets the
    /// bound to the last. Keeps searches (and marching) off the rest of
    /// a loop.
    fn narrow_curve(&self, bound: &Aabb, t0: f64, t1: f64) -> Option<(f64, f64)> {
        const PIECES: usize = 32;
        let meets = |a: f64, b: f64| self.point_bounds(a, b).is_some_and(|bx| bx.overlaps(bound));
        if !meets(t0, t1) {
            return None;
        }
        let h = (t1 - t0) / PIECES as f64;
        let piece = |i: usize| {
            (
                t0 + i as f64 * h,
                if i + 1 == PIECES {
                    t1
                } else {
                    t0 + (i + 1) as f64 * h
                },
            )
        };
        let first = (0..PIECES).find(|&i| meets(piece(i).0, piece(i).1))?;
        let last = (first..PIECES)
            .rev()
            .find(|&i| meets(piece(i).0, piece(i).1))?;
        Some((piece(first).0, piece(last).1))
    }

    /// The first meeting with the quadric `q` in `[a, b]` in closed form:
    /// a quadratic along a line, a quadratic in `tan(s/2)` along an arc
    /// when `q`'s quadratic part is isotropic (a sphere or a plane).
    pub fn meet_quadric(&self, q: &Quadric, a: f64, b: f64) -> QuadricMeeting {
        match self.0 {
            Kind::Line { line, .. } => QuadricMeeting::Solved(
                q.first_root_on_line(line.start, line.direction, a - line.t0, b - line.t0)
                    .map(|t| t + line.t0),
            ),
            Kind::Arc {
                origin,
                radius,
                start,
                tangent,
                ..
            } => match q.first_root_on_circle(origin, radius, start, tangent, a, b) {
                Some(root) => QuadricMeeting::Solved(root),
                None => QuadricMeeting::Unsolvable,
            },
            Kind::Dense(_) | Kind::Chart(..) => QuadricMeeting::Unsolvable,
            Kind::Geodesic(ref g) => g.meet_quadric(q, a, b),
        }
    }

    /// For a segment without conservative boxes (an integrated step), the
    /// stretches between its fixed sample points that overlap `[a, b]`,
    /// each with a box holding the path there; `None` for segments that
    /// have boxes (search those with [`Segment::bounds`]). The samples are
    /// the step's own grid, whose points the space placed at no cost.
    pub fn sample_pieces(
        &self,
        a: f64,
        b: f64,
    ) -> Option<impl Iterator<Item = SamplePiece> + use<'_, 'a>> {
        let (pieces, step) = match self.0 {
            Kind::Dense(ref s) => (s.grid_pieces(a, b), Sampled::Dense(s)),
            Kind::Chart(c, _) => (c.grid_pieces(a, b), Sampled::Chart(c)),
            _ => return None,
        };
        Some(pieces.filter_map(move |k| {
            let (ta, tb) = match step {
                Sampled::Dense(s) => (s.grid_time(k).max(a), s.grid_time(k + 1).min(b)),
                Sampled::Chart(c) => (c.grid_time(k).max(a), c.grid_time(k + 1).min(b)),
            };
            if ta >= tb {
                return None;
            }
            let (start, end, bounds) = match step {
                Sampled::Dense(s) => {
                    let (p, q) = (s.point_near_grid(k, ta), s.point_near_grid(k + 1, tb));
                    (p, q, s.chord_box_of(p, q, ta, tb))
                }
                Sampled::Chart(c) => {
                    let (p, q) = (c.point(ta), c.point(tb));
                    (p, q, c.chord_box_of(p, q))
                }
            };
            Some(SamplePiece {
                a: ta,
                b: tb,
                start,
                end,
                bounds,
            })
        }))
    }

    /// How many straight pieces draw the segment faithfully: one for a
    /// line, more for a curve.
    pub fn drawing_pieces(&self) -> usize {
        match self.0 {
            Kind::Line { .. } => 1,
            _ => 48,
        }
    }

    /// The same path as the copy of an object at `image` sees it: in the
    /// coordinates its formula is written in.
    pub fn seen_by(&self, image: &Image) -> Segment<'a> {
        match image.0 {
            ImageKind::Offset(offset) => self.shifted(offset),
            ImageKind::Motion(ref m) => match self.0 {
                Kind::Geodesic(ref g) => Segment(Kind::Geodesic(m.move_in(g))),
                // Motions belong to the curved spaces, whose paths are
                // geodesics.
                _ => *self,
            },
        }
    }

    /// The first meeting in `[a, b]` (`a` the segment's start) with the
    /// copy at `image` of an object that is the quadric `q`, in one
    /// closed form that also tells whether the rest of the path meets it
    /// at all: for a geodesic of S3 or H3 and a geodesic ball or totally
    /// geodesic plane (one quadratic in the half tangent, which covers the
    /// whole path ahead in H3 and the whole great circle in S3). It
    /// stands for [`Segment::approach`], [`Segment::clip`] and
    /// [`Segment::meet_quadric`] together, which each solve a form of
    /// the same quadratic. `None` where it does not apply. `q` is the
    /// object's formula, which the image was made ready for
    /// ([`Image::with_shape`]) if it was.
    #[inline]
    pub fn quadric_ahead(
        &self,
        image: &Image,
        q: &Quadric,
        a: f64,
        b: f64,
    ) -> Option<QuadricAhead> {
        match (&self.0, &image.0) {
            (Kind::Geodesic(g), ImageKind::Motion(m)) => m.quadric_ahead(g, q, a, b),
            _ => None,
        }
    }

    /// A cheap first test, before the path is moved for `image`: whether
    /// the piece `[a, b]` may meet `bound` (in the image's coordinates),
    /// surely does not, or surely does not and neither does the rest of
    /// the path. Curved spaces test the ball about the object's centre
    /// from two coordinates of the moved path; other paths say
    /// [`Approach::Maybe`] and leave it to [`Segment::clip`].
    #[inline]
    pub fn approach(&self, image: &Image, bound: &Aabb, a: f64, b: f64) -> Approach {
        match (&self.0, &image.0) {
            (Kind::Geodesic(g), ImageKind::Motion(m)) => {
                m.approach(g, bound_ball_radius(bound), a, b)
            }
            _ => Approach::Maybe,
        }
    }

    /// The same path moved by `-offset` (the path as seen by an object's
    /// image at `offset`).
    fn shifted(&self, offset: DVec3) -> Segment<'a> {
        Segment(match self.0 {
            Kind::Line { mut line, t1 } => {
                line.start -= offset;
                Kind::Line { line, t1 }
            }
            Kind::Arc {
                origin,
                radius,
                start,
                tangent,
                t0,
                t1,
            } => Kind::Arc {
                origin: origin - offset,
                radius,
                start,
                tangent,
                t0,
                t1,
            },
            Kind::Dense(mut s) => {
                s.offset += offset;
                Kind::Dense(s)
            }
            // Curved spaces place objects by motions, not offsets, and a
            // metric space holds each object once, where it is written.
            Kind::Geodesic(g) => Kind::Geodesic(g),
            Kind::Chart(c, m) => Kind::Chart(c, m),
        })
    }
}

/// A segment searched through its sample points.
#[derive(Clone, Copy)]
enum Sampled<'s, 'a> {
    Dense(&'s DenseStep<'a>),
    Chart(&'s ChartStep),
}

/// Where the unit circle through the origin, leaving along `v` and
/// turning about `-u`, is at angle `s`: `sin(s) v - 2 sin^2(s/2) u`
/// (`= (cos(s) - 1) u + sin(s) v` without the cancellation of `cos(s) - 1`
/// at small angles).
#[inline]
fn arc_offset(s: f64, u: DVec3, v: DVec3) -> DVec3 {
    // Both from the half angle: one sine-cosine pair per point.
    let (sh, ch) = (0.5 * s).sin_cos();
    (2.0 * sh * ch) * v - (2.0 * sh * sh) * u
}

/// The box of [`arc_offset`] for `s` in `[s0, s1]`: the ends, plus every
/// axis extreme the angle range passes, each computed to full relative
/// precision and widened by its rounding (so the box of a short piece at a
/// huge radius is as tight as the piece).
fn arc_offset_box(s0: f64, s1: f64, u: DVec3, v: DVec3) -> Aabb {
    let mut min = DVec3::splat(f64::INFINITY);
    let mut max = DVec3::splat(f64::NEG_INFINITY);
    let mut include = |p: DVec3, s: f64, axis: Option<usize>| {
        // The offset's size is at most |sin s| + 2 sin^2(s/2), itself at
        // most |s| + s^2 / 2 and 3: its rounding is a few ulps of that.
        let slack = 8.0 * f64::EPSILON * (s.abs() + 0.5 * s * s).min(3.0) + 1e-300;
        for i in 0..3 {
            if axis.is_none_or(|a| a == i) {
                min[i] = min[i].min(p[i] - slack);
                max[i] = max[i].max(p[i] + slack);
            }
        }
    };
    // Both ends from their half angles, with the sine and cosine of s
    // their slopes need.
    let end = |s: f64| {
        let (sh, ch) = (0.5 * s).sin_cos();
        let (sn, cs) = (2.0 * sh * ch, 1.0 - 2.0 * sh * sh);
        ((sn * v - (2.0 * sh * sh) * u), sn, cs)
    };
    let ((p0, sn0, cs0), (p1, sn1, cs1)) = (end(s0), end(s1));
    include(p0, s0, None);
    include(p1, s1, None);
    if s1 - s0 < std::f64::consts::PI {
        // Under half a turn each component has at most one turning point,
        // passed where its slope `-u_i sin s + v_i cos s` changes sign;
        // its value there, `+-A - u_i` with `A = hypot(u_i, v_i)`, is
        // written without cancellation. No arctangent: a search takes
        // boxes of ever shorter pieces.
        for i in 0..3 {
            let slope = |sn: f64, cs: f64| -u[i] * sn + v[i] * cs;
            let (d0, d1) = (slope(sn0, cs0), slope(sn1, cs1));
            let (rises, falls) = (d0 > 0.0 && d1 < 0.0, d0 < 0.0 && d1 > 0.0);
            if !(rises || falls) {
                continue;
            }
            let v2 = v[i] * v[i];
            let a = (u[i] * u[i] + v2).sqrt();
            let s = if s0.abs() > s1.abs() { s0 } else { s1 };
            let extreme = match (rises, u[i] > 0.0, u[i] < 0.0) {
                (true, true, _) => v2 / (a + u[i]),
                (true, false, _) => a - u[i],
                (false, _, true) => -v2 / (a - u[i]),
                (false, _, false) => -(a + u[i]),
            };
            include(DVec3::splat(extreme), s, Some(i));
        }
        return Aabb { min, max };
    }
    for axis in 0..3 {
        // Component: u_i (cos s - 1) + v_i sin s = A cos(s - phi) - u_i.
        let phi = v[axis].atan2(u[axis]);
        for extreme in [phi, phi + std::f64::consts::PI] {
            let k = ((s0 - extreme) / std::f64::consts::TAU).ceil();
            let at = extreme + k * std::f64::consts::TAU;
            if at <= s1 {
                include(arc_offset(at, u, v), at, Some(axis));
            }
        }
    }
    Aabb { min, max }
}

/// The box of `cos(s) u + sin(s) v` for `s` in `[s0, s1]`: the ends, plus
/// every axis extreme the angle range passes.
fn arc_box(s0: f64, s1: f64, u: DVec3, v: DVec3) -> Aabb {
    let (sn0, cs0) = s0.sin_cos();
    let (sn1, cs1) = s1.sin_cos();
    let (p, q) = (cs0 * u + sn0 * v, cs1 * u + sn1 * v);
    let mut min = p.min(q);
    let mut max = p.max(q);
    if s1 - s0 < std::f64::consts::PI {
        // At most one turning point per component under half a turn,
        // where its slope changes sign (see `arc_offset_box`).
        for axis in 0..3 {
            let slope = |sn: f64, cs: f64| -u[axis] * sn + v[axis] * cs;
            let (d0, d1) = (slope(sn0, cs0), slope(sn1, cs1));
            let amplitude = || (u[axis] * u[axis] + v[axis] * v[axis]).sqrt();
            if d0 > 0.0 && d1 < 0.0 {
                max[axis] = amplitude();
            } else if d0 < 0.0 && d1 > 0.0 {
                min[axis] = -amplitude();
            }
        }
        return Aabb {
            min: min - DVec3::splat(1e-15),
            max: max + DVec3::splat(1e-15),
        };
    }
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

    /// The offsets' boxes hold the offsets, at every scale of angle: whole
    /// turns and the 1e-15 radians a piece of a ray spans at a radius of
    /// 1e15, where they are as tight as the piece is long.
    #[test]
    fn arc_offset_boxes_hold_the_arc_and_stay_tight_at_small_angles() {
        let u = DVec3::new(0.6, 0.0, 0.8);
        let v = DVec3::new(0.0, 1.0, 0.0);
        for (s0, s1) in [
            (0.0, 0.3),
            (-1.0, 2.0),
            (2.5, 6.0),
            (0.0, 6.3),
            (1e-15, 3e-15),
            (0.0, 1e-13),
        ] {
            let b = arc_offset_box(s0, s1, u, v);
            for i in 0..=100 {
                let s = s0 + (s1 - s0) * i as f64 / 100.0;
                let p = arc_offset(s, u, v);
                assert!(
                    p.cmpge(b.min).all() && p.cmple(b.max).all(),
                    "{s}: {p} not in {b:?}"
                );
            }
            let longest = (b.max - b.min).max_element();
            assert!(
                longest <= 1.01 * (s1 - s0) + 1e-14 * s1.abs(),
                "{s0}..{s1}: {b:?}"
            );
        }
        // A ray piece a micron long, at 1e6 along a path of radius 1e15,
        // keeps its boxes a micron wide.
        let seg = Segment::arc(
            DVec3::new(1.0, 2.0, 3.0),
            1e15,
            DVec3::Z,
            DVec3::X,
            (0.0, 1e7),
        );
        let b = seg.point_bounds(1e6, 1e6 + 1e-6).unwrap();
        assert!((b.max - b.min).max_element() < 2e-6, "{b:?}");
        let p = seg.point(1e6 + 5e-7);
        assert!(p.cmpge(b.min).all() && p.cmple(b.max).all());
    }

    /// Clipping keeps every point of the path that lies in the bound, for
    /// lines and arcs alike, and drops ranges that miss it.
    #[test]
    fn clipping_keeps_every_point_inside_the_bound() {
        let bound = Aabb {
            min: DVec3::new(-1.0, -0.5, -0.25),
            max: DVec3::new(1.0, 0.5, 0.75),
        };
        let segments = [
            Segment::line(
                DVec3::new(-3.0, 0.1, 0.2),
                DVec3::new(1.0, 0.05, -0.02).normalize(),
                2.0,
                12.0,
            ),
            Segment::arc(
                DVec3::new(0.0, 0.0, 0.2),
                3.2,
                DVec3::Z,
                DVec3::X,
                (0.0, 20.0),
            ),
        ];
        for seg in segments {
            let (t0, t1) = seg.range();
            let inside: Vec<f64> = (0..=4000)
                .map(|i| t0 + (t1 - t0) * i as f64 / 4000.0)
                .filter(|&t| {
                    let p = seg.point(t);
                    p.cmpge(bound.min).all() && p.cmple(bound.max).all()
                })
                .collect();
            assert!(!inside.is_empty(), "the test's path must cross the bound");
            let (a, b) = seg
                .clip(&bound, t0, t1, ClipFor::Search)
                .expect("the path crosses the bound");
            for t in inside {
                assert!(t >= a - 1e-9 && t <= b + 1e-9, "{t} outside [{a}, {b}]");
            }
        }
        let away = Segment::line(DVec3::new(5.0, 5.0, 5.0), DVec3::X, 0.0, 10.0);
        assert_eq!(away.clip(&bound, 0.0, 10.0, ClipFor::Search), None);
    }
}
