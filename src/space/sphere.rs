//! The seed report's "two-dimensional sphere" space (DIGEST section 8).
//!
//! A ray from `T0` with direction `v` follows a great circle of radius `R`
//! whose centre lies below the ray, in the vertical plane that holds it:
//! `centre = T0 + R * down`, where `down` is the unit vector perpendicular
//! to `v` in that plane with negative z. Only one loop (length 2 pi R) is
//! searched.
//!
//! Vertical rays have no vertical plane of their own. They take the plane
//! of the camera's horizontal view direction `h` (x if the camera looks
//! straight up or down): `down = h` for a ray straight up and `-h` for one
//! straight down, the limits of rays tilted towards `h`.
//!
//! Two ways to move along the circle: exactly (an arc), or the report's
//! route, integrating the geodesic equations in spherical coordinates with
//! an adaptive Dormand-Prince 5(4) method with dense output. The report's
//! coordinates put every horizontal ray on the coordinate pole, where the
//! equations are singular; here the polar axis is tilted 45 degrees out of
//! each ray's plane, so the path keeps 45 degrees from both poles and the
//! integration is regular everywhere.

use std::f64::consts::TAU;
use std::ops::ControlFlow;

use glam::DVec3;

use super::dopri;
use super::{Aabb, PathMode, Segment, Space};

/// The sphere space, ready to walk rays: every path is one loop of a circle
/// of radius `radius` bending downward (see the module docs), walked as an
/// exact arc or as the steps of one integrated reference loop.
#[derive(Debug, Clone)]
pub struct SphereSpace {
    radius: f64,
    path: PathMode,
    /// The camera's horizontal view direction, for vertical rays.
    horizontal: DVec3,
    /// With `PathMode::Integrated`: one loop integrated once. In each ray's
    /// own frame (built from its start and direction) every ray has the
    /// same initial state, so the same solution serves every ray.
    reference: Vec<ReferenceStep>,
    integrator: IntegratorStats,
}

/// How the integrator fared over one loop: steps accepted and rejected
/// (a rejected step is retried with a smaller size).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct IntegratorStats {
    /// Steps the integrator kept.
    pub accepted: usize,
    /// Steps it rejected and retried with a smaller size (not counted in
    /// `accepted`).
    pub rejected: usize,
}

/// One accepted integrator step of the reference path.
#[derive(Debug, Clone, Copy)]
struct ReferenceStep {
    t0: f64,
    h: f64,
    coefficients: [[f64; 4]; 5],
    /// The unit-sphere points at `t0 + h k / GRID`, in frame coordinates:
    /// the same for every ray, so computed once; a ray places them with
    /// one 3x3 product each instead of two sine-cosine pairs.
    grid: [DVec3; GRID + 1],
    /// A ball holding the whole step, in frame coordinates: its centre and
    /// radius (the path's radius times `reach`).
    ball_centre: DVec3,
    reach: f64,
}

/// The sample points per integrator step at which a dense step is searched
/// for sign changes (then refined on the interpolant).
pub const GRID: usize = 8;

/// The unit-sphere point of spherical coordinates (u, w), in frame
/// coordinates.
fn unit_point(u: f64, w: f64) -> DVec3 {
    let (su, cu) = u.sin_cos();
    let (sw, cw) = w.sin_cos();
    DVec3::new(su * cw, su * sw, cu)
}

impl SphereSpace {
    /// The space whose circles have radius `radius` (positive), moved along as
    /// `path` says; `forward` is the camera's view direction, whose horizontal
    /// part settles vertical rays (x when it has none). With
    /// [`PathMode::Integrated`], one loop is integrated here, once, for every ray.
    pub fn new(radius: f64, path: PathMode, forward: DVec3) -> Self {
        let horizontal = DVec3::new(forward.x, forward.y, 0.0)
            .try_normalize()
            .unwrap_or(DVec3::X);
        let (reference, integrator) = match path {
            PathMode::Exact => (Vec::new(), IntegratorStats::default()),
            PathMode::Integrated { tolerance } => {
                integrate(radius, TAU * radius, tolerance, reference_start(radius))
            }
        };
        SphereSpace {
            radius,
            path,
            horizontal,
            reference,
            integrator,
        }
    }

    /// The unit vector from the ray's start towards its circle's centre.
    pub fn down(&self, v: DVec3) -> DVec3 {
        let n = DVec3::NEG_Z.cross(v);
        let c = v.cross(n);
        match c.try_normalize() {
            Some(c) if n.length() > 1e-12 => c,
            _ => {
                if v.z > 0.0 {
                    self.horizontal
                } else {
                    -self.horizontal
                }
            }
        }
    }
}

impl Space for SphereSpace {
    fn walk(
        &self,
        origin: DVec3,
        direction: DVec3,
        limit: f64,
        visit: &mut dyn FnMut(&Segment) -> ControlFlow<()>,
    ) {
        let r = self.radius;
        let down = self.down(direction);
        let centre = origin + r * down;
        let limit = limit.min(TAU * r);
        match self.path {
            PathMode::Exact => {
                let _ = visit(&Segment::arc(origin, r, -down, direction, (0.0, limit)));
            }
            PathMode::Integrated { .. } => {
                let frame = integration_frame(-down, direction);
                for step in &self.reference {
                    if step.t0 >= limit {
                        break;
                    }
                    let mut dense = DenseStep {
                        path: step,
                        t0: step.t0,
                        t1: (step.t0 + step.h).min(limit),
                        centre,
                        radius: r,
                        frame,
                        whole: Aabb {
                            min: DVec3::ZERO,
                            max: DVec3::ZERO,
                        },
                        offset: DVec3::ZERO,
                    };
                    let c = dense.place(step.ball_centre);
                    let reach = DVec3::splat(r * step.reach);
                    dense.whole = Aabb {
                        min: c - reach,
                        max: c + reach,
                    };
                    if visit(&Segment::integrated(dense)).is_break() {
                        return;
                    }
                }
            }
        }
    }

    fn connect(&self, from: DVec3, to: DVec3) -> Option<(DVec3, f64)> {
        let r = self.radius;
        let delta = to - from;
        let horizontal = DVec3::new(delta.x, delta.y, 0.0);
        let h = horizontal.try_normalize().unwrap_or(self.horizontal);
        // The vertical plane through both, with coordinates (along h, z).
        let (dx, dz) = (horizontal.length(), delta.z);
        let chord = (dx * dx + dz * dz).sqrt();
        if chord == 0.0 || chord > 2.0 * r {
            return None;
        }
        let mid = (0.5 * dx, 0.5 * dz);
        let normal = (-dz / chord, dx / chord);
        let offset = (r * r - 0.25 * chord * chord).max(0.0).sqrt();
        let mut best: Option<(DVec3, f64)> = None;
        for side in [-1.0, 1.0] {
            let c = (
                mid.0 + side * offset * normal.0,
                mid.1 + side * offset * normal.1,
            );
            // The start, seen from the centre; the space puts the centre
            // below every ray, so it must lie below `from`.
            let s = (-c.0 / r, -c.1 / r);
            if s.1 <= 0.0 {
                continue;
            }
            for dir in [1.0, -1.0] {
                let v = (dir * s.1, -dir * s.0);
                let q = ((dx - c.0) / r, (dz - c.1) / r);
                let along_s = q.0 * s.0 + q.1 * s.1;
                let along_v = q.0 * v.0 + q.1 * v.1;
                let angle = along_v.atan2(along_s).rem_euclid(TAU);
                let length = angle * r;
                let v3 = (v.0 * h + v.1 * DVec3::Z).normalize();
                // Only a direction the space maps to this very circle.
                let centre3 = from + c.0 * h + c.1 * DVec3::Z;
                if (from + r * self.down(v3) - centre3).length() > 1e-6 * r.max(1.0) {
                    continue;
                }
                if best.is_none_or(|(_, l)| length < l) {
                    best = Some((v3, length));
                }
            }
        }
        best
    }

    /// With the integrated path: how the integrator fared on the one loop
    /// every ray shares.
    fn integrator_stats(&self) -> Option<IntegratorStats> {
        match self.path {
            PathMode::Exact => None,
            PathMode::Integrated { .. } => Some(self.integrator),
        }
    }

    fn straight_paths(&self) -> bool {
        false
    }

    fn loop_length(&self) -> Option<f64> {
        Some(TAU * self.radius)
    }

    fn reach(&self, origin: DVec3, limit: f64) -> Aabb {
        // Every path stays on a circle of radius R through the start.
        let extent = limit.min(2.0 * self.radius);
        Aabb {
            min: origin - DVec3::splat(extent),
            max: origin + DVec3::splat(extent),
        }
    }
}

/// One accepted integrator step with its dense output, for one ray: the
/// position on a circle of radius `radius` about `centre + offset`, from
/// spherical coordinates (u, w) in the ray's frame (e1, e2, e3). The
/// interpolant is shared by every ray (see [`SphereSpace`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DenseStep<'a> {
    path: &'a ReferenceStep,
    /// The range searched.
    pub t0: f64,
    pub t1: f64,
    centre: DVec3,
    radius: f64,
    frame: [DVec3; 3],
    /// A box holding the whole step (before `offset`), from the step's
    /// ball: one placed point per step, so that a path's steps far from
    /// every object cost almost nothing.
    whole: Aabb,
    /// Subtracted from every point (object images).
    pub offset: DVec3,
}

impl PartialEq for ReferenceStep {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self, other)
    }
}

impl DenseStep<'_> {
    fn state(&self, t: f64) -> [f64; 4] {
        let (t0, h) = (self.path.t0, self.path.h);
        let theta = if h > 0.0 { (t - t0) / h } else { 0.0 };
        dopri::dense_state(&self.path.coefficients, theta)
    }

    /// A frame-coordinate unit-sphere point placed on this ray's circle
    /// (before `offset`).
    #[inline]
    fn place(&self, unit: DVec3) -> DVec3 {
        let [e1, e2, e3] = self.frame;
        self.centre + self.radius * (unit.x * e1 + unit.y * e2 + unit.z * e3)
    }

    pub fn point(&self, t: f64) -> DVec3 {
        let y = self.state(t);
        self.place(unit_point(y[0], y[2])) - self.offset
    }

    /// The distance along the path of grid point `k`.
    #[inline]
    pub fn grid_time(&self, k: usize) -> f64 {
        if k == GRID {
            self.path.t0 + self.path.h
        } else {
            self.path.t0 + self.path.h * (k as f64 / GRID as f64)
        }
    }

    /// The point at grid point `k`, or at `t` if `t` is not that grid
    /// point (a range cut short by a nearer hit or the length limit).
    #[inline]
    pub fn point_near_grid(&self, k: usize, t: f64) -> DVec3 {
        if t == self.grid_time(k) {
            self.place(self.path.grid[k]) - self.offset
        } else {
            self.point(t)
        }
    }

    /// The grid pieces `[k, k + 1]` that overlap `[a, b]`.
    pub fn grid_pieces(&self, a: f64, b: f64) -> std::ops::Range<usize> {
        let (t0, h) = (self.path.t0, self.path.h);
        if h <= 0.0 {
            return 0..1;
        }
        let first = (((a - t0) / h) * GRID as f64)
            .floor()
            .clamp(0.0, GRID as f64 - 1.0) as usize;
        let last = (((b - t0) / h) * GRID as f64)
            .ceil()
            .clamp(1.0, GRID as f64) as usize;
        first..last.max(first + 1)
    }

    /// A box holding the path for `t` in `[a, b]`, given its end points:
    /// their box widened by the sagitta `h^2 / 8R` of a circle of the
    /// path's radius, plus a margin for the interpolant's error.
    pub fn chord_box_of(&self, p: DVec3, q: DVec3, a: f64, b: f64) -> Aabb {
        let h = b - a;
        let pad = h * h / (8.0 * self.radius) + 1e-9 * (1.0 + self.radius);
        Aabb {
            min: p.min(q) - DVec3::splat(pad),
            max: p.max(q) + DVec3::splat(pad),
        }
    }

    /// A box holding the path for `t` in `[a, b]`.
    pub fn chord_box(&self, a: f64, b: f64) -> Aabb {
        if a == self.t0 && b == self.grid_time(GRID) {
            return Aabb {
                min: self.whole.min - self.offset,
                max: self.whole.max - self.offset,
            };
        }
        let p = self.point_near_grid(0, a);
        let q = self.point_near_grid(GRID, b);
        self.chord_box_of(p, q, a, b)
    }

    pub fn direction(&self, t: f64) -> DVec3 {
        let y = self.state(t);
        let [e1, e2, e3] = self.frame;
        let (su, cu) = y[0].sin_cos();
        let (sw, cw) = y[2].sin_cos();
        let e_u = cu * cw * e1 + cu * sw * e2 - su * e3;
        let e_w = -sw * e1 + cw * e2;
        (y[1] * e_u + y[3] * su * e_w).normalize_or_zero()
    }
}

/// The geodesic equations on the unit sphere in (u, u', w, w'):
/// u'' = sin u cos u w'^2, w'' = -2 cot u u' w'.
fn geodesic(y: &[f64; 4]) -> [f64; 4] {
    let (s, c) = y[0].sin_cos();
    [
        y[1],
        s * c * y[3] * y[3],
        y[3],
        -2.0 * (c / s) * y[1] * y[3],
    ]
}

/// The frame of a ray's integration: polar axis 45 degrees between the
/// normal of the ray's plane and the start, first axis towards the start.
fn integration_frame(start: DVec3, tangent: DVec3) -> [DVec3; 3] {
    let normal = start.cross(tangent).normalize();
    let e3 = (normal + start).normalize();
    let e1 = (start - start.dot(e3) * e3).normalize();
    [e1, e3.cross(e1), e3]
}

/// The initial state (u, u', w, w') every ray has in the frame of
/// [`integration_frame`]: u = 45 degrees, w = 0 and the same velocity, so
/// the path stays 45 degrees from both poles of the coordinates, where the
/// equations' `cot u` term is singular.
fn reference_start(radius: f64) -> [f64; 4] {
    // Any start and tangent give the same state in their own frame.
    let (start, tangent) = (DVec3::X, DVec3::Y);
    let [e1, e2, e3] = integration_frame(start, tangent);
    let u0 = start.dot(e3).clamp(-1.0, 1.0).acos();
    let (su, cu) = u0.sin_cos();
    // w0 = 0 by the choice of e1.
    let e_u = cu * e1 - su * e3;
    let speed = 1.0 / radius;
    [
        u0,
        tangent.dot(e_u) * speed,
        0.0,
        tangent.dot(e2) * speed / su,
    ]
}

/// One loop of a great circle of the unit sphere integrated exactly as the
/// `ode` path integrates, but from any polar angle: the circle starts at
/// `(u, w) = (closest, 0)` heading along the parallel, so `closest` is how
/// near it comes to the coordinates' pole. The ode path itself always
/// starts at 45 degrees ([`SphereSpace`]); this exists to check the
/// integrator where the equations are hardest.
#[derive(Debug, Clone)]
pub struct IntegratedLoop {
    steps: Vec<ReferenceStep>,
    /// How the integrator fared over the loop.
    pub stats: IntegratorStats,
}

impl IntegratedLoop {
    /// `closest` is clamped to `[1e-12, pi / 2]`: a circle through the pole
    /// itself has no finite `w'`.
    pub fn new(closest: f64, tolerance: f64) -> Self {
        let closest = closest.clamp(1e-12, std::f64::consts::FRAC_PI_2);
        let start = [closest, 0.0, 0.0, 1.0 / closest.sin()];
        let (steps, stats) = integrate(1.0, TAU, tolerance, start);
        IntegratedLoop { steps, stats }
    }

    /// The integrated point at arc length `t` in `[0, 2 pi]`.
    pub fn point(&self, t: f64) -> DVec3 {
        let i = self.steps.partition_point(|s| s.t0 + s.h < t);
        let step = &self.steps[i.min(self.steps.len() - 1)];
        let y = unit_frame_view(step).state(t);
        unit_point(y[0], y[2])
    }

    /// The exact great circle's point at arc length `t`.
    pub fn exact_point(&self, t: f64) -> DVec3 {
        let start = unit_point(self.steps[0].coefficients[0][0], 0.0);
        start * t.cos() + DVec3::Y * t.sin()
    }
}

/// A step viewed on the unit sphere in frame coordinates.
fn unit_frame_view(step: &ReferenceStep) -> DenseStep<'_> {
    DenseStep {
        path: step,
        t0: step.t0,
        t1: step.t0 + step.h,
        centre: DVec3::ZERO,
        radius: 1.0,
        frame: [DVec3::X, DVec3::Y, DVec3::Z],
        whole: Aabb {
            min: DVec3::ZERO,
            max: DVec3::ZERO,
        },
        offset: DVec3::ZERO,
    }
}

/// Integrate the geodesic equations for arc length `limit` on a sphere of
/// radius `radius` from the state `start` (u, u', w, w'; the velocity in
/// angle per unit of arc length), with adaptive Dormand-Prince 5(4) steps
/// and their dense output. The state is integrated on the unit sphere.
fn integrate(
    radius: f64,
    limit: f64,
    tolerance: f64,
    start: [f64; 4],
) -> (Vec<ReferenceStep>, IntegratorStats) {
    let mut y = start;
    let mut stats = IntegratorStats::default();
    let mut out = Vec::new();
    let mut t = 0.0;
    let mut h = (0.1 * radius).min(limit);
    let mut k1 = geodesic(&y);
    let mut steps = 0;
    while t < limit && steps < 1_000_000 {
        steps += 1;
        h = h.min(limit - t);
        let (y_new, k) = dopri::trial(&y, k1, h, geodesic);
        let err = dopri::error_norm(&y, &y_new, &k, h, tolerance);
        if err <= 1.0 || h < 1e-12 * radius {
            let coefficients = dopri::dense_coefficients(&y, &y_new, &k, h);
            out.push(ReferenceStep {
                t0: t,
                h,
                coefficients,
                grid: [DVec3::ZERO; GRID + 1],
                ball_centre: DVec3::ZERO,
                reach: 0.0,
            });
            stats.accepted += 1;
            let step = out.last_mut().expect("just pushed");
            let view = unit_frame_view(step);
            let mut grid = [DVec3::ZERO; GRID + 1];
            for (k, g) in grid.iter_mut().enumerate() {
                let y = view.state(view.grid_time(k));
                *g = unit_point(y[0], y[2]);
            }
            step.grid = grid;
            // The ball about the grid's box centre through the farthest
            // grid point, widened by the most a piece of a unit circle
            // bulges from its chord, and a margin for the interpolant.
            let (lo, hi) = grid
                .iter()
                .fold((grid[0], grid[0]), |(lo, hi), &p| (lo.min(p), hi.max(p)));
            let centre = 0.5 * (lo + hi);
            let farthest = grid
                .iter()
                .map(|&p| (p - centre).length())
                .fold(0.0, f64::max);
            let piece = h / radius / GRID as f64;
            step.ball_centre = centre;
            step.reach = farthest + piece * piece / 8.0 + 1e-9 * (1.0 + 1.0 / radius);
            t += h;
            y = y_new;
            k1 = k[6];
        } else {
            stats.rejected += 1;
        }
        h *= dopri::step_factor(err, 5.0);
    }
    (out, stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn space(path: PathMode) -> SphereSpace {
        SphereSpace::new(5.0, path, DVec3::X)
    }

    /// The exact path's one segment, an arc (which borrows nothing).
    fn first_arc(s: &SphereSpace, origin: DVec3, v: DVec3) -> Segment<'static> {
        let mut seen = None;
        s.walk(origin, v, 1e9, &mut |seg| {
            // An exact arc: it has boxes, so no sample pieces.
            assert!(seg.sample_pieces(0.0, 1.0).is_none() && seg.as_line().is_none());
            let (t0, t1) = seg.range();
            let (start, tangent) = (seg.point(t0), seg.direction(t0));
            let centre = origin + 5.0 * s.down(v);
            seen = Some(Segment::arc(
                start,
                5.0,
                (start - centre) / 5.0,
                tangent,
                (t0, t1),
            ));
            ControlFlow::Break(())
        });
        seen.expect("an arc")
    }

    #[test]
    fn a_horizontal_ray_bends_down_around_a_centre_below() {
        let s = space(PathMode::Exact);
        let seg = first_arc(&s, DVec3::ZERO, DVec3::X);
        // A quarter loop later the ray is at (5, 0, -5), heading down.
        let quarter = 0.25 * TAU * 5.0;
        assert!((seg.point(quarter) - DVec3::new(5.0, 0.0, -5.0)).length() < 1e-12);
        assert!((seg.direction(quarter) - DVec3::NEG_Z).length() < 1e-12);
        // One loop only.
        assert!((seg.range().1 - TAU * 5.0).abs() < 1e-12);
    }

    #[test]
    fn vertical_rays_have_a_finite_circle() {
        let s = space(PathMode::Exact);
        for v in [DVec3::Z, DVec3::NEG_Z] {
            let down = s.down(v);
            assert!(down.is_finite() && (down.length() - 1.0).abs() < 1e-12);
            assert!(down.dot(v).abs() < 1e-12);
        }
    }

    /// The integrated path stays within its tolerance of the exact circle
    /// over a whole loop, for rays in every direction, horizontal ones
    /// included.
    #[test]
    fn the_integrator_follows_the_exact_circle() {
        let exact = space(PathMode::Exact);
        let ode = space(PathMode::Integrated { tolerance: 1e-10 });
        for v in [
            DVec3::X,
            DVec3::new(0.6, 0.8, 0.0),
            DVec3::new(1.0, 0.3, 0.5).normalize(),
            DVec3::new(0.2, -0.1, -0.9).normalize(),
        ] {
            let arc = first_arc(&exact, DVec3::ONE, v);
            let mut worst: f64 = 0.0;
            let mut end = 0.0;
            ode.walk(DVec3::ONE, v, 1e9, &mut |s| {
                let (a, b) = s.range();
                for t in [a, 0.5 * (a + b), b] {
                    worst = worst.max((s.point(t) - arc.point(t)).length());
                    worst = worst.max((s.direction(t) - arc.direction(t)).length());
                }
                end = b;
                ControlFlow::Continue(())
            });
            assert!(worst < 1e-7, "{v}: {worst}");
            assert!((end - TAU * 5.0).abs() < 1e-9);
        }
    }

    /// The geodesic that `connect` finds reaches the light.
    #[test]
    fn connect_finds_a_path_that_walk_follows() {
        let s = space(PathMode::Exact);
        let from = DVec3::new(1.0, 2.0, 0.0);
        for to in [
            DVec3::new(4.0, 2.0, 1.0),
            DVec3::new(1.0, -1.0, 3.0),
            DVec3::new(-2.0, 5.0, -4.0),
        ] {
            let (dir, len) = s.connect(from, to).expect("within reach");
            let mut end = None;
            s.walk(from, dir, len, &mut |seg| {
                end = Some(seg.point(len));
                ControlFlow::Break(())
            });
            assert!((end.unwrap() - to).length() < 1e-9, "{to}");
        }
        assert!(s.connect(from, from + DVec3::new(11.0, 0.0, 0.0)).is_none());
    }
}
