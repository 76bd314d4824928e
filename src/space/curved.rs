//! The spaces of constant curvature: the 3-sphere S3 (curvature 1/R^2)
//! and hyperbolic space H3 (curvature -1/R^2).
//!
//! Input: a ray's start in the scene's coordinates, its direction in the
//! orthonormal frame there, and its length; an object's placement (the
//! rigid motions written after it). Output: geodesic segments in the
//! scene's coordinates, the object's placement as an isometry of the
//! model, shortest paths to lights (both arcs of the great circle in S3)
//! and the area of geodesic spheres for light's falloff.
//!
//! **Coordinates.** The scene's coordinates are geodesic normal
//! coordinates about the origin: the point `p` is where the geodesic
//! leaving the origin along `p / |p|` is after `|p|`. An object's formula
//! is read in normal coordinates about its own centre, where the rigid
//! motions written after it (its placement) take the origin: `sphere(1)
//! translate (7, 0, 0)` is the geodesic ball of radius 1 whose centre is
//! 7 away. Directions are given in the orthonormal frame at a point that
//! the frame at the origin is carried to along the geodesic from the
//! origin (so yaw and pitch mean what they mean in Euclidean space).
//!
//! **The model.** Points are held on the model in R^4: S3 is
//! `X0^2 + |Xs|^2 = R^2`, H3 is the hyperboloid `X0^2 - |Xs|^2 = R^2`,
//! `X0 > 0`, with the form `<A, B> = sigma A0 B0 + As . Bs` (sigma = 1 in
//! S3, -1 in H3). A geodesic is `X(s) = C(s) X + R S(s) D`, `s = t / R`,
//! with C, S = cos, sin (S3) or cosh, sinh (H3): exact, and each segment
//! is anchored at its own start, renormalised onto the model, so nothing
//! drifts however many times a path loops round S3.

use std::f64::consts::PI;
use std::ops::ControlFlow;

use glam::{DMat3, DMat4, DVec3, DVec4};

use super::{Aabb, NearLine, QuadricAhead, QuadricMeeting, Segment, Space};
use crate::expr::Quadric;

/// The curvature's sign and radius: which model points live on, and how
/// far a radian of the model is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Curvature {
    /// 1 for S3, -1 for H3.
    sigma: f64,
    /// The curvature radius R, positive.
    radius: f64,
}

impl Curvature {
    /// The 3-sphere of radius `radius`.
    pub fn spherical(radius: f64) -> Curvature {
        Curvature { sigma: 1.0, radius }
    }

    /// Hyperbolic space of curvature `-1 / radius^2`.
    pub fn hyperbolic(radius: f64) -> Curvature {
        Curvature {
            sigma: -1.0,
            radius,
        }
    }

    fn spherical_space(&self) -> bool {
        self.sigma > 0.0
    }

    /// The curvature's sign: 1 in S3, -1 in H3.
    pub fn sign(&self) -> f64 {
        self.sigma
    }

    /// The curvature radius R.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// The model's isometry that moves the origin along the geodesic
    /// through `v` by `|v|`, as a matrix on R^4 (first coordinate `X0`):
    /// for a compiler that maps points through it in expressions.
    pub fn translation_matrix(&self, v: DVec3) -> DMat4 {
        self.translation(v)
    }

    /// S(s): sin or sinh.
    #[inline]
    fn s(&self, s: f64) -> f64 {
        if self.spherical_space() {
            s.sin()
        } else {
            s.sinh()
        }
    }

    /// (C(s), S(s)) in one go: one sincos, or one exponential: expm1
    /// where it keeps sinh's digits (small s), exp beyond, where the
    /// difference `e^s - e^-s` loses under two ulps and exp costs a
    /// fraction of expm1.
    #[inline]
    fn cs(&self, s: f64) -> (f64, f64) {
        if self.spherical_space() {
            let (sn, c) = s.sin_cos();
            (c, sn)
        } else if s.abs() < 0.5 {
            let m = s.exp_m1();
            let e = m + 1.0;
            (1.0 + 0.5 * m * m / e, 0.5 * m * (m + 2.0) / e)
        } else {
            let e = s.exp();
            let inverse = 1.0 / e;
            (0.5 * (e + inverse), 0.5 * (e - inverse))
        }
    }

    /// `<a, b>`, the model's form.
    #[inline]
    fn dot(&self, a: DVec4, b: DVec4) -> f64 {
        self.sigma * a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w
    }

    /// The point at normal coordinates `p`.
    pub fn exp(&self, p: DVec3) -> DVec4 {
        let r = p.length();
        let (c, s) = self.cs(r / self.radius);
        let along = if r > 0.0 { self.radius * s / r } else { 1.0 };
        let xs = p * along;
        DVec4::new(self.radius * c, xs.x, xs.y, xs.z)
    }

    /// The normal coordinates of the model point `x` (in S3, of length at
    /// most pi R: the antipode of the origin is the sphere of that radius,
    /// and is given as a point on it).
    pub fn log(&self, x: DVec4) -> DVec3 {
        let xs = spatial(x);
        let n = xs.length();
        if n == 0.0 {
            return if x.x >= 0.0 {
                DVec3::ZERO
            } else {
                DVec3::new(PI * self.radius, 0.0, 0.0)
            };
        }
        let theta = if self.spherical_space() {
            n.atan2(x.x)
        } else {
            asinh(n / self.radius)
        };
        xs * (self.radius * theta / n)
    }

    /// The model tangent at `x` of the unit vector `v` of the frame there.
    fn frame_to_model(&self, x: DVec4, v: DVec3) -> DVec4 {
        let xs = spatial(x);
        let n = xs.length();
        if n == 0.0 {
            return DVec4::new(0.0, v.x, v.y, v.z);
        }
        let radial = xs / n;
        let along = v.dot(radial);
        let across = v - along * radial;
        let r = self.radius;
        // The radial unit vector is (-sigma S, C radial) with S = n / R and
        // C = X0 / R: no trigonometry.
        let head = along * (x.x / r) * radial + across;
        DVec4::new(-self.sigma * along * n / r, head.x, head.y, head.z)
    }

    /// The frame components at `x` of the model tangent `v`.
    fn model_to_frame(&self, x: DVec4, v: DVec4) -> DVec3 {
        let xs = spatial(x);
        let n = xs.length();
        let vs = spatial(v);
        if n == 0.0 {
            return vs;
        }
        let radial = xs / n;
        let r = self.radius;
        let along = -(n / r) * v.x + (x.x / r) * radial.dot(vs);
        let across = vs - radial.dot(vs) * radial;
        along * radial + across
    }

    /// A frame vector at `x` as a velocity in normal coordinates: the
    /// part across the radius is stretched by `|p| / |Xs|`.
    fn frame_to_chart(&self, x: DVec4, p: DVec3, v: DVec3) -> DVec3 {
        let n = spatial(x).length();
        let r = p.length();
        if n == 0.0 || r == 0.0 {
            return v;
        }
        let radial = p / r;
        let along = v.dot(radial);
        along * radial + (v - along * radial) * (r / n)
    }

    /// A gradient of a function of normal coordinates at `p`, as a vector
    /// of the orthonormal frame there (the normal's direction).
    /// `x` is the model point at `p`.
    fn gradient_to_frame(&self, p: DVec3, x: DVec4, g: DVec3) -> DVec3 {
        let r = p.length();
        if r == 0.0 {
            return g;
        }
        let n = spatial(x).length();
        let radial = p / r;
        let along = g.dot(radial);
        along * radial + (g - along * radial) * (r / n)
    }

    /// The isometry that moves the origin to `exp(v)` along the geodesic
    /// between them, turning nothing about it.
    fn translation(&self, v: DVec3) -> DMat4 {
        let d = v.length();
        if d == 0.0 {
            return DMat4::IDENTITY;
        }
        let u = v / d;
        let theta = d / self.radius;
        let (c, s) = self.cs(theta);
        let e0 = DVec4::X;
        let w = DVec4::new(0.0, u.x, u.y, u.z);
        // e0 -> C e0 + S w, w -> -sigma S e0 + C w, the rest fixed.
        let outer = |a: DVec4, b: DVec4| DMat4::from_cols(a * b.x, a * b.y, a * b.z, a * b.w);
        DMat4::IDENTITY + (outer(e0, e0) + outer(w, w)) * (c - 1.0) + outer(w, e0) * s
            - outer(e0, w) * (self.sigma * s)
    }

    /// A rotation about the origin.
    fn rotation(m: DMat3) -> DMat4 {
        DMat4::from_cols(
            DVec4::X,
            DVec4::new(0.0, m.x_axis.x, m.x_axis.y, m.x_axis.z),
            DVec4::new(0.0, m.y_axis.x, m.y_axis.y, m.y_axis.z),
            DVec4::new(0.0, m.z_axis.x, m.z_axis.y, m.z_axis.z),
        )
    }

    /// Move `x` back onto the model and `d` back to a unit tangent there.
    fn renormalise(&self, x: DVec4, d: DVec4) -> (DVec4, DVec4) {
        let x = x * (self.radius / (self.sigma * self.dot(x, x)).sqrt());
        let d = d - x * (self.dot(d, x) / self.dot(x, x));
        (x, d / self.dot(d, d).sqrt())
    }

    /// The geodesic from `x` with unit tangent `d` after the angle whose
    /// half has C and S `half`, back on the model.
    fn renormalise_along(&self, x: DVec4, d: DVec4, (ch, sh): (f64, f64)) -> (DVec4, DVec4) {
        let (c, sn) = (ch * ch - self.sigma * sh * sh, 2.0 * sh * ch);
        self.renormalise(
            x * c + d * (self.radius * sn),
            x * (-self.sigma * sn / self.radius) + d * c,
        )
    }

    /// The geodesic from `x` with unit tangent `d`, after `s` radians.
    #[inline]
    fn along(&self, x: DVec4, d: DVec4, s: f64) -> (DVec4, DVec4) {
        let (c, sn) = self.cs(s);
        (
            x * c + d * (self.radius * sn),
            x * (-self.sigma * sn / self.radius) + d * c,
        )
    }

    /// The range of `a C(s) + b S(s)` over the piece whose ends have the
    /// (C, S) pairs `ea` and `eb` (under half a turn apart in S3):
    /// the ends, and the one turning point if the slope changes sign,
    /// where the value is `+-hypot(a, b)` in S3 and `+-sqrt(a^2 - b^2)`
    /// in H3. Widened by its rounding.
    fn trig_range(&self, a: f64, b: f64, ea: (f64, f64), eb: (f64, f64)) -> (f64, f64) {
        let va = a * ea.0 + b * ea.1;
        let vb = a * eb.0 + b * eb.1;
        let da = -self.sigma * a * ea.1 + b * ea.0;
        let db = -self.sigma * a * eb.1 + b * eb.0;
        let (mut lo, mut hi) = (va.min(vb), va.max(vb));
        if da * db < 0.0 {
            let turn = (a * a + self.sigma * b * b).max(0.0).sqrt();
            // A maximum where the slope goes from rising to falling.
            let rising = da > 0.0;
            match (self.spherical_space(), rising) {
                (true, true) => hi = hi.max(turn),
                (true, false) => lo = lo.min(-turn),
                (false, true) => hi = hi.max(-turn),
                (false, false) => lo = lo.min(turn),
            }
        }
        let slack = 4.0
            * f64::EPSILON
            * (a.abs() + b.abs())
            * (ea.0.abs() + ea.1.abs() + eb.0.abs() + eb.1.abs());
        (lo - slack, hi + slack)
    }

    /// How far the model's points at distance `rho` from the origin lie
    /// from its tangent plane there: `2 R S(rho / 2R)^2` (`R - X0` in S3,
    /// `X0 - R` in H3), computed without cancellation.
    fn rim(&self, rho: f64) -> f64 {
        let h = self.s(rho / (2.0 * self.radius));
        2.0 * self.radius * h * h
    }

    /// [`Curvature::rim`] for a ball that does not hold the whole space
    /// (in S3, `rho < pi R`) and whose rim is finite; `None` otherwise
    /// (every test against the ball then passes).
    fn rim_height(&self, rho: f64) -> Option<f64> {
        if self.spherical_space() && rho >= PI * self.radius {
            return None;
        }
        Some(self.rim(rho)).filter(|h| h.is_finite())
    }

    /// The area radius of geodesic spheres of radius `d`: `d` flat,
    /// `R |sin(d / R)|` in S3, `R sinh(d / R)` in H3.
    pub fn spread(&self, d: f64) -> f64 {
        (self.radius * self.s(d / self.radius)).abs()
    }
}

fn spatial(x: DVec4) -> DVec3 {
    DVec3::new(x.y, x.z, x.w)
}

/// A rigid motion an object's placement is built of, in the scene's
/// terms: what `translate` and `rotate` mean in every space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Rigid {
    /// Along the geodesic from the origin through `v`, by `|v|`.
    Translate(DVec3),
    /// About the origin.
    Rotate(DMat3),
}

/// An object's placement: the rigid motions written after it, in the
/// order they apply. Empty where the compiler folds transforms into the
/// formula (the flat spaces).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Placement(pub Vec<Rigid>);

impl Placement {
    /// How far the placement can move the origin: a bound on the distance
    /// of the object's centre from the scene's origin.
    pub fn reach(&self) -> f64 {
        self.0
            .iter()
            .map(|m| match m {
                Rigid::Translate(v) => v.length(),
                Rigid::Rotate(_) => 0.0,
            })
            .sum()
    }

    /// Whether the placement moves nothing.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// A placement as an isometry of the model, both ways.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    pub(super) curvature: Curvature,
    /// From the object's model coordinates to the scene's.
    to_world: DMat4,
    /// Its inverse, built from the inverses of the parts (not inverted
    /// numerically).
    to_local: DMat4,
    /// The ball about the object's centre that holds its bound.
    ball: Ball,
    /// The first row of `to_local`: a moved point's first model
    /// coordinate, which every test against the object's centre needs.
    first_row: DVec4,
    /// The object's closed form, when [`Motion::with_shape`] was told it.
    shape: Shape,
}

/// What [`Motion::quadric_ahead`] needs of an object that is a ball about
/// its centre or a plane through it, computed once per image.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Shape {
    /// Not known, or neither.
    Other,
    /// A geodesic ball, with its rim height ([`Ball::rim`]).
    Ball(Ball),
    /// A totally geodesic plane with unit normal `n`: the combination of
    /// the motion's rows that gives `n . Xs` in the object's coordinates
    /// from a model point in the scene's.
    Plane { n: DVec3, row: DVec4 },
}

impl Motion {
    pub(super) fn new(curvature: Curvature, placement: &Placement, bound: &Aabb) -> Motion {
        let mut to_world = DMat4::IDENTITY;
        let mut to_local = DMat4::IDENTITY;
        for m in &placement.0 {
            let (forward, back) = match *m {
                Rigid::Translate(v) => (curvature.translation(v), curvature.translation(-v)),
                Rigid::Rotate(r) => (Curvature::rotation(r), Curvature::rotation(r.transpose())),
            };
            to_world = forward * to_world;
            to_local *= back;
        }
        Motion {
            curvature,
            to_world,
            to_local,
            ball: Ball::new(&curvature, bound_ball_radius(bound)),
            first_row: to_local.row(0),
            shape: Shape::Other,
        }
    }

    /// The motion of an object whose formula is `q` (see [`Shape`]).
    pub(super) fn with_shape(self, q: &Quadric) -> Motion {
        let k = &self.curvature;
        let shape = if let Some(rho) = ball_radius(q) {
            Shape::Ball(Ball::new(k, rho))
        } else if let Some(n) = plane_normal(q) {
            let m = self.to_local;
            Shape::Plane {
                n,
                row: m.row(1) * n.x + m.row(2) * n.y + m.row(3) * n.z,
            }
        } else {
            Shape::Other
        };
        Motion { shape, ..self }
    }

    /// [`Geodesic::quadric_ahead`] for `g` moved into the object's
    /// coordinates, from the one or two coordinates of the moved path the
    /// quadratic needs, where [`Motion::with_shape`] prepared them: `q`
    /// must be the quadric it was given (the object's formula).
    #[inline]
    pub(super) fn quadric_ahead(
        &self,
        g: &Geodesic,
        q: &Quadric,
        a: f64,
        b: f64,
    ) -> Option<QuadricAhead> {
        debug_assert!(match self.shape {
            Shape::Ball(ball) => ball_radius(q) == Some(ball.rho),
            Shape::Plane { n, .. } => plane_normal(q) == Some(n),
            Shape::Other => true,
        });
        let k = &self.curvature;
        let r = k.radius;
        let quadratic = match self.shape {
            Shape::Ball(ball) => match ball.rim {
                // No real root: a ball of S3 holding the whole space has no
                // surface.
                None if k.spherical_space() => (1.0, 0.0, 1.0),
                // A rim height past the floats: the general route says so.
                None => return self.move_in(g).quadric_ahead(q, a, b),
                Some(rim) => {
                    let (x0, d0) = (self.first_row.dot(g.x), self.first_row.dot(g.d));
                    // The start's height over the tangent plane at the
                    // centre, `R - X0` in S3 and `X0 - R` in H3: directly
                    // where it is at least half a radius, whose rounding
                    // is then that of X0; else from the start's spatial
                    // part, as `|Xs|^2 / (R + X0)`, which does not cancel.
                    let direct = k.sigma * (r - x0);
                    let height = if direct >= 0.5 * r {
                        direct
                    } else {
                        let m = self.to_local;
                        let xs =
                            DVec3::new(m.row(1).dot(g.x), m.row(2).dot(g.x), m.row(3).dot(g.x));
                        xs.length_squared() / (r + x0)
                    };
                    ball_quadratic_from(k, x0, d0, height - rim)
                }
            },
            Shape::Plane { row, .. } => plane_quadratic_from(k, row.dot(g.x), row.dot(g.d)),
            Shape::Other => return self.move_in(g).quadric_ahead(q, a, b),
        };
        g.quadratic_ahead(quadratic, a, b)
    }

    /// The geodesic as the object sees it.
    pub(super) fn move_in(&self, g: &Geodesic) -> Geodesic {
        Geodesic {
            x: self.to_local * g.x,
            d: self.to_local * g.d,
            ball: Some(self.ball),
            ..*g
        }
    }

    /// The point of `g` at `t` and its heading, in the scene's
    /// coordinates, and the point in the object's: one model point, moved.
    pub(super) fn point_heading_and_local(&self, g: &Geodesic, t: f64) -> (DVec3, DVec3, DVec3) {
        let k = &self.curvature;
        let (x, v) = g.model_at(t);
        (k.log(x), k.model_to_frame(x, v), k.log(self.to_local * x))
    }

    /// The point `p` (scene coordinates) in the object's coordinates.
    pub(super) fn point_to_local(&self, p: DVec3) -> DVec3 {
        let k = &self.curvature;
        k.log(self.to_local * k.exp(p))
    }

    /// Whether the piece `[a, b]` of `g` (in the scene's coordinates) may
    /// come within `rho` of the object's centre: [`Geodesic::may_come_within`]
    /// for the moved geodesic, from the two model coordinates it needs
    /// (the first row of the motion), before the whole geodesic is moved.
    /// The height `R - X0` is taken directly: its rounding, an ulp of R,
    /// is far below any bound's ball.
    #[inline]
    pub(super) fn approach(&self, g: &Geodesic, rho: f64, a: f64, b: f64) -> Approach {
        let row = self.first_row;
        let (x0, d0) = (row.dot(g.x), row.dot(g.d));
        let ball = if self.ball.rho == rho {
            self.ball
        } else {
            Ball::new(&self.curvature, rho)
        };
        // An object that is a ball is its own bound, tighter than the
        // ball about its box.
        let ball = match self.shape {
            Shape::Ball(own) if own.rho < ball.rho => own,
            _ => ball,
        };
        // Whether the whole geodesic passes by is the cheaper question,
        // and most paths pass most objects by: it is asked first.
        let k = &g.curvature;
        let r = k.radius;
        let xs2 = (k.sigma * (r * r - x0 * x0)).max(0.0);
        if ball
            .rim
            .is_some_and(|threshold| g.never_within(x0, d0, xs2, threshold))
        {
            Approach::Never
        } else if g.may_come_within_from(x0, d0, Some(xs2), &ball, a, b) {
            Approach::Maybe
        } else {
            Approach::NotHere
        }
    }

    /// The normal at `local` (object coordinates) of a surface with
    /// gradient `gradient` there, in the frame at the same point in the
    /// scene's coordinates.
    pub(super) fn normal_to_world(&self, local: DVec3, gradient: DVec3) -> DVec3 {
        let k = &self.curvature;
        let x = k.exp(local);
        let n_local = k.gradient_to_frame(local, x, gradient);
        let v = self.to_world * k.frame_to_model(x, n_local);
        k.model_to_frame(self.to_world * x, v)
    }
}

/// How a piece of a path stands to an object's bound.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Approach {
    /// It may meet the bound here.
    Maybe,
    /// Not on this piece.
    NotHere,
    /// Not on this piece nor anywhere further along the path.
    Never,
}

/// The ball about an object's centre that holds its bound, with the
/// heights the tests against it need. Each costs a sine or sinh, and
/// the tests run on every piece of every path: so they are computed once
/// per object, when its image is made, and carried by the paths moved
/// into its coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Ball {
    rho: f64,
    /// [`Curvature::rim_height`] of `rho`.
    rim: Option<f64>,
    /// The height a path's point must come below to be within `rho`, or
    /// a little above it (in S3, `rho^2 / 2R`, from `sin x <= x`);
    /// infinite where every test passes.
    threshold: f64,
}

impl Ball {
    fn new(k: &Curvature, rho: f64) -> Ball {
        let threshold = if k.spherical_space() {
            if rho >= PI * k.radius {
                f64::INFINITY
            } else {
                0.5 * rho * rho / k.radius
            }
        } else {
            k.rim(rho)
        };
        Ball {
            rho,
            rim: k.rim_height(rho),
            threshold: if threshold.is_finite() {
                threshold
            } else {
                f64::INFINITY
            },
        }
    }
}

/// The radius of the ball about the origin that holds `bound`.
#[inline]
pub(super) fn bound_ball_radius(bound: &Aabb) -> f64 {
    bound.min.abs().max(bound.max.abs()).length()
}

/// A piece of a geodesic: `X(s) = C(s) x + R S(s) d`, `s = (t - t0) / R`,
/// for `t` in `[t0, t1]`, seen in normal coordinates about the origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geodesic {
    pub(super) curvature: Curvature,
    x: DVec4,
    d: DVec4,
    pub(super) t0: f64,
    pub(super) t1: f64,
    /// (C, S) of half the piece's angle, `(t1 - t0) / 2R`: bound tests
    /// at the piece's end need it for every object.
    half_end: (f64, f64),
    /// The ball of the object whose coordinates the piece was moved
    /// into, if it was.
    ball: Option<Ball>,
}

impl Geodesic {
    /// The ball of radius `rho` about the origin, from the piece's own
    /// object when it is that one.
    #[inline]
    fn ball(&self, rho: f64) -> Ball {
        match self.ball {
            Some(b) if b.rho == rho => b,
            _ => Ball::new(&self.curvature, rho),
        }
    }

    fn model_at(&self, t: f64) -> (DVec4, DVec4) {
        self.curvature
            .along(self.x, self.d, (t - self.t0) / self.curvature.radius)
    }

    /// The point at distance `t`, in normal coordinates.
    pub(super) fn point(&self, t: f64) -> DVec3 {
        self.curvature.log(self.model_at(t).0)
    }

    /// The velocity in normal coordinates at `t`.
    pub(super) fn velocity(&self, t: f64) -> DVec3 {
        let k = &self.curvature;
        let (x, v) = self.model_at(t);
        let p = k.log(x);
        k.frame_to_chart(x, p, k.model_to_frame(x, v))
    }

    /// [`Geodesic::point`] and [`Geodesic::velocity`] from one model
    /// point (one sine-cosine pair and one arctangent, not two each).
    fn point_and_velocity(&self, t: f64) -> (DVec3, DVec3) {
        let k = &self.curvature;
        let (x, v) = self.model_at(t);
        let p = k.log(x);
        (p, k.frame_to_chart(x, p, k.model_to_frame(x, v)))
    }

    /// [`Geodesic::point`] and [`Geodesic::heading`] from one model point.
    pub(super) fn point_and_heading(&self, t: f64) -> (DVec3, DVec3) {
        let k = &self.curvature;
        let (x, v) = self.model_at(t);
        (k.log(x), k.model_to_frame(x, v))
    }

    /// The unit direction of travel at `t`, in the frame there.
    pub(super) fn heading(&self, t: f64) -> DVec3 {
        let (x, v) = self.model_at(t);
        self.curvature.model_to_frame(x, v)
    }

    /// (C, S) of the angle from the piece's start to `t`.
    #[inline]
    fn angle_at(&self, t: f64) -> (f64, f64) {
        if t == self.t0 {
            (1.0, 0.0)
        } else if t == self.t1 {
            let (ch, sh) = self.half_end;
            (ch * ch - self.curvature.sigma * sh * sh, 2.0 * sh * ch)
        } else {
            self.curvature.cs((t - self.t0) / self.curvature.radius)
        }
    }

    /// A box holding every point of `[a, b]` in normal coordinates, and
    /// one holding every velocity there. Each model coordinate along the
    /// piece is `A C(s) + B S(s)`, whose range is exact (its ends and its
    /// one turning point); normal coordinates are `F(theta) Xs` with
    /// `F = theta / S(theta)` monotone in the angle `theta` from the
    /// origin, so an interval of `theta` bounds them, and their velocity
    /// `F Vs + Xs F'(theta) dtheta/dt` likewise. Tight for short pieces:
    /// the searches' slopes along the path depend on it. A piece of S3
    /// that may reach the cut locus (the antipode, at `pi R`) gets the
    /// whole ball of that radius.
    pub(super) fn bounds(&self, a: f64, b: f64) -> (Aabb, Aabb) {
        let k = &self.curvature;
        let r = k.radius;
        let spherical = k.spherical_space();
        let (ea, eb) = (self.angle_at(a), self.angle_at(b));
        let x = self.x.to_array();
        let d = self.d.to_array();
        let point = |i: usize| k.trig_range(x[i], r * d[i], ea, eb);
        let speed = |i: usize| k.trig_range(d[i], -k.sigma * x[i] / r, ea, eb);
        let x0 = point(0);
        let xs = [point(1), point(2), point(3)];
        let vs = [speed(1), speed(2), speed(3)];
        let (mut near, mut far) = (0.0, 0.0);
        for (lo, hi) in xs {
            let gap = if lo > 0.0 {
                lo
            } else if hi < 0.0 {
                -hi
            } else {
                0.0
            };
            near += gap * gap;
            far += lo.abs().max(hi.abs()).powi(2);
        }
        let (near, far) = (near.sqrt(), far.sqrt());
        // theta = atan2(|Xs|, X0) (S3) falls as X0 grows; it grows with
        // |Xs| where X0 > 0 and falls with it beyond a quarter turn. Each
        // extreme angle comes with its (|Xs|, X0) pair, which gives its
        // sine and cosine without more trigonometry.
        let (lo_pair, hi_pair) = if spherical {
            (
                (if x0.1 > 0.0 { near } else { far }, x0.1),
                (if x0.0 >= 0.0 { far } else { near }, x0.0),
            )
        } else {
            ((near, 0.0), (far, 0.0))
        };
        let (theta_lo, theta_hi) = if spherical {
            (lo_pair.0.atan2(lo_pair.1), hi_pair.0.atan2(hi_pair.1))
        } else {
            (asinh(near / r), asinh(far / r))
        };
        if spherical && theta_hi >= PI * (1.0 - 1e-6) {
            let rr = PI * r * (1.0 + 1e-9);
            let ball = Aabb {
                min: DVec3::splat(-rr),
                max: DVec3::splat(rr),
            };
            return (ball, speed_box(f64::INFINITY));
        }
        // F = theta / S(theta), R theta / |Xs| on the model, and the range
        // of F' over the angles.
        let (f_lo, f_hi, f_slope) = if spherical {
            let over_sin = |theta: f64, (n, c): (f64, f64)| {
                if theta < 1e-4 || n == 0.0 {
                    theta_over_sin(theta)
                } else {
                    theta * n.hypot(c) / n * (1.0 + 4.0 * f64::EPSILON)
                }
            };
            (
                over_sin(theta_lo, lo_pair) * (1.0 - 8.0 * f64::EPSILON),
                over_sin(theta_hi, hi_pair),
                (
                    theta_over_sin_slope_below(theta_lo, lo_pair),
                    theta_over_sin_slope(theta_hi, hi_pair),
                ),
            )
        } else {
            (
                theta_over_sinh(theta_hi, far / r),
                theta_over_sinh(theta_lo, near / r),
                theta_over_sinh_slope(theta_lo, theta_hi, near / r, far / r),
            )
        };
        // The angle's rate: X0 = R C(theta), so theta' = -sigma X0' / |Xs|,
        // at most 1 / R at unit speed. From the ranges over the piece, it
        // shrinks with the piece; a bound of its size alone would leave
        // the velocity box a constant width `|Xs| F' / R` however short
        // the piece, and a search along it could not prove a path that
        // leaves a surface near a singular point free of roots (the
        // cushion's shadow rays in S3 took 57 000 evaluations).
        let rate_bound = (-1.0 / r, 1.0 / r);
        let rate = if near > 0.0 {
            let x0_rate = speed(0);
            let (lo, hi) = (
                (x0_rate.0 / near).min(x0_rate.0 / far),
                (x0_rate.1 / near).max(x0_rate.1 / far),
            );
            let (lo, hi) = if spherical { (-hi, -lo) } else { (lo, hi) };
            let slack = 1e-12 / r;
            (
                (lo - slack).max(rate_bound.0),
                (hi + slack).min(rate_bound.1),
            )
        } else {
            rate_bound
        };
        let rate = if rate.0 <= rate.1 { rate } else { rate_bound };
        let df = times(f_slope, rate);
        let scale = far + 0.5 * (b - a) + r;
        let slack = 64.0 * f64::EPSILON * scale;
        let mut min = DVec3::ZERO;
        let mut max = DVec3::ZERO;
        let mut vmin = DVec3::ZERO;
        let mut vmax = DVec3::ZERO;
        for i in 0..3 {
            let (lo, hi) = times(xs[i], (f_lo, f_hi));
            min[i] = lo - slack;
            max[i] = hi + slack;
            let (vlo, vhi) = times(vs[i], (f_lo, f_hi));
            let (mlo, mhi) = times(xs[i], df);
            vmin[i] = vlo + mlo - 1e-12 * (1.0 + vlo.abs());
            vmax[i] = vhi + mhi + 1e-12 * (1.0 + vhi.abs());
        }
        (
            Aabb { min, max },
            Aabb {
                min: vmin,
                max: vmax,
            },
        )
    }

    /// The piece `[a, b]` as its tangent line at the middle with error
    /// bars: by the mean value theorem the velocity box bounds how far
    /// the velocity, and so the path, strays from the tangent. Both
    /// shrink with the piece (the path by its square), so a search that
    /// halves pieces converges as on a straight line.
    pub(super) fn near_line(&self, a: f64, b: f64) -> Option<NearLine> {
        let (points, velocities) = self.bounds(a, b);
        let at = 0.5 * (a + b);
        let reach = 0.5 * (b - a);
        let (start, direction) = self.point_and_velocity(at);
        let stray = (velocities.min - direction)
            .abs()
            .max((velocities.max - direction).abs());
        if !stray.is_finite() || !start.is_finite() || !direction.is_finite() {
            return None;
        }
        // On a long piece the error bars (growing with its square) can be
        // wider than the piece's box: then the box serves better.
        if (stray * reach).max_element() > 0.25 * (points.max - points.min).max_element() {
            return None;
        }
        // The rounding of the points searches evaluate, at the model's
        // scale.
        let rounding = 64.0 * f64::EPSILON * (start.length() + reach + self.curvature.radius);
        Some(NearLine {
            at,
            start,
            direction,
            reach,
            deviation: stray * reach * (1.0 + 1e-12) + DVec3::splat(rounding),
            slope_deviation: stray * (1.0 + 1e-12) + DVec3::splat(1e-12),
        })
    }

    /// Whether the whole geodesic through the point with first
    /// coordinate `x0` and spatial part of squared norm `xs2`, tangent's
    /// first coordinate `d0`, stays outside the ball about the model
    /// origin whose rim is `threshold` above the origin's tangent plane
    /// ([`Curvature::rim_height`]): its closest approach (a great circle's
    /// in S3; in H3 where it has one) is `(|Xs|^2 - R^2 d0^2) / (R +
    /// sqrt(x0^2 + sigma R^2 d0^2))` above that plane.
    fn never_within(&self, x0: f64, d0: f64, xs2: f64, threshold: f64) -> bool {
        let k = &self.curvature;
        let r = k.radius;
        let rd = r * d0;
        let turn = x0 * x0 + k.sigma * rd * rd;
        if !(k.spherical_space() || x0 * x0 > rd * rd) || turn < 0.0 {
            return false;
        }
        let least = (xs2 - rd * rd) / (r + turn.sqrt());
        let slack = 1e-9 * threshold + 64.0 * f64::EPSILON * (r + x0.abs() + xs2.sqrt());
        least > threshold + slack
    }

    /// Whether, from the piece's end on, the geodesic stays farther than
    /// `rho` from the object's centre: when its closest approach over the
    /// whole geodesic is farther, or (in H3, where the distance is convex
    /// along it) once it is beyond `rho` and growing.
    pub(super) fn gone_past(&self, rho: f64) -> bool {
        let k = &self.curvature;
        let r = k.radius;
        let spherical = k.spherical_space();
        let Some(threshold) = self.ball(rho).rim else {
            return false;
        };
        let (x0, d0) = (self.x.x, self.d.x);
        let xs2 = spatial(self.x).length_squared();
        if self.never_within(x0, d0, xs2, threshold) {
            return true;
        }
        if spherical {
            return false;
        }
        let rd = r * d0;
        let slack = 1e-9 * threshold + 16.0 * f64::EPSILON * (r + x0.abs() + xs2.sqrt());
        let e = xs2 / (r + x0);
        let (ch, sh) = self.half_end;
        let (sn, cs) = (2.0 * sh * ch, ch * ch + sh * sh);
        // g = X0 - R along the piece, and its slope, at the end.
        let g = e + 2.0 * sh * sh * x0 + rd * sn;
        let slope = sn * x0 + rd * cs;
        slope > 0.0 && g > threshold + slack
    }

    /// Whether the piece `[a, b]` may come within `rho` of the object's
    /// centre (the model origin): how a bound is tested without leaving
    /// the model. The height `g(s)` over the origin's tangent plane
    /// (`R - X0` in S3, `X0 - R` in H3) is `e + 2 S(s/2)^2 x0 - sigma R
    /// d0 S(s)`, whose least value on the piece is at an end or at the
    /// one turning point, all in closed form and without cancellation.
    pub(super) fn may_come_within(&self, rho: f64, a: f64, b: f64) -> bool {
        let xs2 = spatial(self.x).length_squared();
        let ball = self.ball(rho);
        self.may_come_within_from(self.x.x, self.d.x, Some(xs2), &ball, a, b)
    }

    /// [`Geodesic::may_come_within`] for the geodesic whose start and
    /// tangent have first coordinates `x0` and `d0` (and the start's
    /// spatial part squared norm `xs2`, if known: without it the height
    /// is `R - X0` directly, good to an ulp of R).
    #[inline]
    fn may_come_within_from(
        &self,
        x0: f64,
        d0: f64,
        xs2: Option<f64>,
        ball: &Ball,
        a: f64,
        b: f64,
    ) -> bool {
        let k = &self.curvature;
        let r = k.radius;
        let spherical = k.spherical_space();
        let threshold = ball.threshold;
        if threshold == f64::INFINITY {
            return true;
        }
        let xs2 = xs2.unwrap_or_else(|| (k.sigma * (r * r - x0 * x0)).max(0.0));
        let e = match xs2 {
            _ if spherical && x0 <= 0.0 => r - x0,
            n2 if n2 > 0.0 && x0.abs() < 1e8 * r => n2 / (r + x0),
            _ => k.sigma * (r - x0),
        };
        let sigma = k.sigma;
        // g and g' at s, from the half angle's S and C.
        let at = |t: f64| {
            let (ch, sh) = if t == self.t0 {
                (1.0, 0.0)
            } else if t == self.t1 {
                self.half_end
            } else {
                k.cs(0.5 * (t - self.t0) / r)
            };
            let (sn, cs) = (2.0 * sh * ch, ch * ch - sigma * sh * sh);
            (
                e + 2.0 * sh * sh * x0 - sigma * r * d0 * sn,
                sn * x0 - sigma * r * d0 * cs,
            )
        };
        let (ga, da) = at(a);
        let (gb, db) = at(b);
        let mut least = ga.min(gb);
        if da < 0.0 && db > 0.0 {
            let rd = r * d0;
            let hyp = (x0 * x0 + sigma * rd * rd).max(0.0).sqrt();
            least = least.min((xs2 - rd * rd) / (r + hyp));
        }
        let slack = 1e-9 * threshold + 16.0 * f64::EPSILON * (r + x0.abs() + xs2.sqrt());
        least <= threshold + slack
    }

    /// The first meeting in `[a, b]` with a geodesic ball about the
    /// object's centre or a totally geodesic plane through it, in closed
    /// form: along the geodesic both are `A C(s) + B S(s) = c`, a
    /// quadratic in `u = tan(s / 2)` (or `tanh(s / 2)`) whose
    /// coefficients are computed without cancellation.
    pub(super) fn meet_quadric(&self, q: &Quadric, a: f64, b: f64) -> QuadricMeeting {
        let Some((qa, qb, qc)) = self.quadric_quadratic(q) else {
            return QuadricMeeting::Unsolvable;
        };
        let (ua, ub) = (self.half_tangent(a), self.half_tangent(b));
        let root = first_quadratic_root(qa, qb, qc, ua, ub)
            .map(|u| self.distance_at_half_tangent(u).clamp(a, b));
        QuadricMeeting::Solved(root)
    }

    /// The quadratic in the half tangent whose roots are where the piece
    /// meets `q`, when `q` is a ball about the origin or a plane through
    /// it (see [`Geodesic::meet_quadric`]).
    #[inline]
    fn quadric_quadratic(&self, q: &Quadric) -> Option<(f64, f64, f64)> {
        let k = &self.curvature;
        if let Some(rho) = ball_radius(q) {
            // A ball of S3 of radius pi R or more is the whole space, with
            // no surface: the quadratic of its rim height would wrap round
            // to a false one at 2 pi R - rho. One with no real root.
            if k.spherical_space() && rho >= PI * k.radius {
                return Some((1.0, 0.0, 1.0));
            }
            Some(self.ball_quadratic(rho))
        } else if let Some(n) = plane_normal(q) {
            let (xa, db) = (n.dot(spatial(self.x)), n.dot(spatial(self.d)));
            Some(plane_quadratic_from(k, xa, db))
        } else {
            None
        }
    }

    /// [`Segment::quadric_ahead`] for this piece, already moved into the
    /// object's coordinates; `a` is the piece's start.
    pub(super) fn quadric_ahead(&self, q: &Quadric, a: f64, b: f64) -> Option<QuadricAhead> {
        self.quadratic_ahead(self.quadric_quadratic(q)?, a, b)
    }

    /// [`Geodesic::quadric_ahead`] from the quadric's quadratic in the
    /// half tangent; `None` where it is not finite.
    #[inline]
    fn quadratic_ahead(
        &self,
        (qa, qb, qc): (f64, f64, f64),
        a: f64,
        b: f64,
    ) -> Option<QuadricAhead> {
        if !(qa.is_finite() && qb.is_finite() && qc.is_finite()) {
            return None;
        }
        // The first root from the piece's start to its end (whose half
        // tangent comes without trigonometry), then its distance: an
        // arctangent for a root, none for a miss.
        let (ua, u_end) = (self.half_tangent(a), self.half_tangent(self.t1));
        let roots = quadratic_roots(qa, qb, qc);
        if let Some(u) = first_in(roots, ua, u_end) {
            let t = self.distance_at_half_tangent(u).clamp(a, self.t1);
            return Some(if t <= b {
                QuadricAhead::At(t)
            } else {
                QuadricAhead::NotHere
            });
        }
        // The whole path ahead: in H3 the half tangent runs over [0, 1)
        // (roots within rounding of the start count as met); in S3 the
        // great circle comes round again, and only a quadratic with no
        // real root (a circle that passes a ball by) is never met.
        let never = if self.curvature.spherical_space() {
            let scale = qa.abs().max(qb.abs()).max(qc.abs());
            qa.abs() > 1e-9 * scale && first_in(roots, f64::MIN, f64::MAX).is_none()
        } else {
            first_in(roots, -1e-9, 1.0).is_none()
        };
        Some(if never {
            QuadricAhead::Never
        } else {
            QuadricAhead::NotHere
        })
    }

    /// `u = tan(s / 2)` (S3) or `tanh(s / 2)` (H3) at distance `t`.
    fn half_tangent(&self, t: f64) -> f64 {
        if t == self.t0 {
            return 0.0;
        }
        if t == self.t1 {
            return self.half_end.1 / self.half_end.0;
        }
        let s = 0.5 * (t - self.t0) / self.curvature.radius;
        if self.curvature.spherical_space() {
            s.tan()
        } else {
            s.tanh()
        }
    }

    /// The distance at which the half tangent is `u`.
    fn distance_at_half_tangent(&self, u: f64) -> f64 {
        let s = if self.curvature.spherical_space() {
            2.0 * u.atan()
        } else {
            2.0 * u.atanh()
        };
        self.t0 + self.curvature.radius * s
    }

    /// The quadratic in the half tangent `u` whose sign is the sign of
    /// the distance from the centre minus `rho` along the piece: the
    /// model's height above the ball's rim, `R - X0 - e` in S3 and
    /// `X0 - R - e` in H3 (`e = 2 R S(rho / 2R)^2`), times `1 + u^2` or
    /// `1 - u^2`, with `R - X0 = |Xs|^2 / (R + X0)` so that nothing cancels.
    fn ball_quadratic(&self, rho: f64) -> (f64, f64, f64) {
        let k = &self.curvature;
        let r = k.radius;
        let (x0, d0) = (self.x.x, self.d.x);
        let xs2 = spatial(self.x).length_squared();
        let e_a = if k.spherical_space() && x0 <= 0.0 {
            r - x0
        } else {
            xs2 / (r + x0)
        };
        ball_quadratic_from(k, x0, d0, e_a - k.rim(rho))
    }

    /// The part of `[a, b]` where the quadric `q` may be negative or zero,
    /// when `q` is a ball about the origin (see [`Geodesic::within`]):
    /// `Some(None)` when the piece stays outside; `None` for other
    /// quadrics, which the piece cannot tell in closed form.
    pub(super) fn quadric_keeps(&self, q: &Quadric, a: f64, b: f64) -> Option<Option<(f64, f64)>> {
        ball_radius(q).map(|rho| self.within(rho, a, b))
    }

    /// The part of `[a, b]` within `rho` of the object's centre (the hull
    /// of it, widened by rounding), from [`Geodesic::ball_quadratic`]'s
    /// roots; `None` if the piece stays farther.
    pub(super) fn within(&self, rho: f64, a: f64, b: f64) -> Option<(f64, f64)> {
        if self.ball(rho).rim.is_none() {
            return Some((a, b));
        }
        if !self.may_come_within(rho, a, b) {
            return None;
        }
        let (qa, qb, qc) = self.ball_quadratic(rho);
        let (ua, ub) = (self.half_tangent(a), self.half_tangent(b));
        let h = |u: f64| (qa * u + qb) * u + qc;
        let scale = qa.abs() + qb.abs() + qc.abs();
        let inside = |u: f64| h(u) <= 1e-9 * scale;
        // The roots inside the range split it where the sign changes; the
        // inside set is their hull with the ends that are inside.
        let mut marks = vec![];
        let disc = qb * qb - 4.0 * qa * qc;
        if qa != 0.0 && disc >= 0.0 {
            let q = -0.5 * (qb + qb.signum() * disc.sqrt());
            marks.push(q / qa);
            if q != 0.0 {
                marks.push(qc / q);
            }
        } else if qa == 0.0 && qb != 0.0 {
            marks.push(-qc / qb);
        }
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for u in marks
            .into_iter()
            .filter(|u| *u > ua && *u < ub)
            .chain([ua, ub])
        {
            let keep = u != ua && u != ub || inside(u);
            if keep {
                lo = lo.min(u);
                hi = hi.max(u);
            }
        }
        if lo > hi {
            // Neither end inside and no crossing: only a graze the
            // rounding hides, which the model test let through.
            return Some((a, b));
        }
        let margin = 1e-9 * (b - a) + 4.0 * f64::EPSILON * (a.abs() + b.abs());
        let t_lo = if lo == ua {
            a
        } else {
            self.distance_at_half_tangent(lo) - margin
        };
        let t_hi = if hi == ub {
            b
        } else {
            self.distance_at_half_tangent(hi) + margin
        };
        Some((t_lo.max(a), t_hi.min(b)))
    }
}

/// [`Geodesic::ball_quadratic`] from the start's and the tangent's first
/// model coordinates and the start's height `e` over the ball's rim.
#[inline]
fn ball_quadratic_from(k: &Curvature, x0: f64, d0: f64, e: f64) -> (f64, f64, f64) {
    let r = k.radius;
    if k.spherical_space() {
        (e + 2.0 * x0, -2.0 * r * d0, e)
    } else {
        (2.0 * x0 - e, 2.0 * r * d0, e)
    }
}

/// The quadratic in the half tangent of a totally geodesic plane, from
/// `n . Xs` of the start and of the tangent.
#[inline]
fn plane_quadratic_from(k: &Curvature, xa: f64, db: f64) -> (f64, f64, f64) {
    let r = k.radius;
    if k.spherical_space() {
        (-xa, 2.0 * r * db, xa)
    } else {
        (xa, 2.0 * r * db, xa)
    }
}

/// `asinh(u)` as `ln(1 + u + u^2 / (1 + sqrt(1 + u^2)))`, to a few ulps:
/// the standard library's goes through `hypot`, which costs as much as
/// the logarithm, and every point of an H3 path is found through it.
#[inline]
fn asinh(u: f64) -> f64 {
    let a = u.abs();
    let r = if a > 1e150 {
        a.ln() + std::f64::consts::LN_2
    } else {
        (a + a * a / (1.0 + (1.0 + a * a).sqrt())).ln_1p()
    };
    r.copysign(u)
}

/// The range of the product of two intervals.
fn times((a, b): (f64, f64), (c, d): (f64, f64)) -> (f64, f64) {
    let p = [a * c, a * d, b * c, b * d];
    (
        p.iter().copied().fold(f64::INFINITY, f64::min),
        p.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    )
}

/// `theta / sin(theta)`, increasing on [0, pi).
fn theta_over_sin(theta: f64) -> f64 {
    if theta < 1e-4 {
        1.0 + theta * theta / 6.0 * (1.0 + 1e-3)
    } else {
        theta / theta.sin()
    }
}

/// An upper bound of the derivative of `theta / sin(theta)` on [0, theta]
/// (it increases): `(sin - theta cos) / sin^2`.
/// `(n, c)` is the angle's `(|Xs|, X0)`, proportional to its sine and
/// cosine.
fn theta_over_sin_slope(theta: f64, (n, c): (f64, f64)) -> f64 {
    if theta < 1e-3 {
        theta / 3.0 * (1.0 + theta)
    } else {
        let h = n.hypot(c);
        let (s, co) = (n / h, c / h);
        (s - theta * co) / (s * s) * (1.0 + 1e-12)
    }
}

/// A lower bound of the derivative of `theta / sin(theta)` at `theta`
/// (at least `theta / 3`; see [`theta_over_sin_slope`]), with the
/// rounding of the difference in its numerator.
fn theta_over_sin_slope_below(theta: f64, (n, c): (f64, f64)) -> f64 {
    if theta < 1e-3 {
        theta / 3.0 * (1.0 - 1e-12)
    } else {
        let h = n.hypot(c);
        let (s, co) = (n / h, c / h);
        let error = 8.0 * f64::EPSILON * (s + theta * co.abs()) / (s * s);
        ((s - theta * co) / (s * s) * (1.0 - 1e-12) - error).max(0.0)
    }
}

/// The range of the derivative of `theta / sinh(theta)` over `[lo, hi]`,
/// given the sines of the ends: `(sinh - theta cosh) / sinh^2`, which
/// falls from 0 to its least at theta = 1.6061 and rises towards 0
/// after.
fn theta_over_sinh_slope(lo: f64, hi: f64, sinh_lo: f64, sinh_hi: f64) -> (f64, f64) {
    let slope = |theta: f64, sinh: f64| -> (f64, f64) {
        if theta < 1e-3 {
            // -theta / 3 + 7 theta^3 / 90 - ...
            (-theta / 3.0, -theta / 3.0 * (1.0 - theta))
        } else if !sinh.is_finite() {
            (-0.3098168352, 0.0)
        } else {
            let cosh = (1.0 + sinh * sinh).sqrt();
            let v = (sinh - theta * cosh) / (sinh * sinh);
            let error =
                8.0 * f64::EPSILON * (sinh + theta * cosh) / (sinh * sinh) + 1e-12 * v.abs();
            (v - error, v + error)
        }
    };
    let (a, b) = (slope(lo, sinh_lo), slope(hi, sinh_hi));
    // The least, -0.30981683518595..., at 1.60611529880276...
    let least = if lo <= 1.6061153 && hi >= 1.6061152 {
        a.0.min(b.0).min(-0.3098168352)
    } else {
        a.0.min(b.0)
    };
    (least.max(-0.3098168352), a.1.max(b.1).min(0.0))
}

/// `theta / sinh(theta)`, decreasing on [0, inf), given `sinh(theta)`.
fn theta_over_sinh(theta: f64, sinh: f64) -> f64 {
    if theta < 1e-4 {
        1.0 - theta * theta / 6.0 * (1.0 - 1e-3)
    } else if !sinh.is_finite() {
        0.0
    } else {
        theta / sinh
    }
}

/// The smallest root of `a u^2 + b u + c` in `[lo, hi]`.
fn first_quadratic_root(a: f64, b: f64, c: f64, lo: f64, hi: f64) -> Option<f64> {
    first_in(quadratic_roots(a, b, c), lo, hi)
}

/// The real roots of `a u^2 + b u + c` (NaN for none), a graze within
/// rounding counted as its double root.
#[inline]
fn quadratic_roots(a: f64, b: f64, c: f64) -> [f64; 2] {
    let mut roots = [f64::NAN; 2];
    let scale = a.abs().max(b.abs()).max(c.abs());
    if scale == 0.0 || !scale.is_finite() {
        return roots;
    }
    let inverse = 1.0 / scale;
    let (a, b, c) = (a * inverse, b * inverse, c * inverse);
    if a.abs() <= 1e-300 {
        if b != 0.0 {
            roots[0] = -c / b;
        }
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            // A graze within rounding: the double root.
            if disc > -1e-14 * (b * b + (4.0 * a * c).abs()) {
                roots[0] = -b / (2.0 * a);
            }
        } else {
            let q = -0.5 * (b + b.signum() * disc.sqrt());
            roots[0] = q / a;
            if q != 0.0 {
                roots[1] = c / q;
            }
        }
    }
    roots
}

/// The smallest of `roots` in `[lo, hi]`, to a rounding's tolerance.
#[inline]
fn first_in(roots: [f64; 2], lo: f64, hi: f64) -> Option<f64> {
    let tol = 1e-15 * (1.0 + lo.abs().max(hi.abs()));
    roots
        .into_iter()
        .filter(|u| *u >= lo - tol && *u <= hi + tol)
        .min_by(f64::total_cmp)
        .map(|u| u.clamp(lo, hi))
}

/// A box of velocities of speed at most `k`.
fn speed_box(k: f64) -> Aabb {
    Aabb {
        min: DVec3::splat(-k),
        max: DVec3::splat(k),
    }
}

/// The radius of a quadric that is a ball about the origin: `m` a
/// positive multiple of the identity, no linear part.
fn ball_radius(q: &Quadric) -> Option<f64> {
    let k = q.m.x_axis.x;
    let m = q.m.to_cols_array();
    let tol = 1e-12 * k.abs();
    let isotropic = k > 0.0
        && (0..3).all(|i| (m[4 * i] - k).abs() <= tol)
        && [1, 2, 3, 5, 6, 7].iter().all(|&i| m[i].abs() <= tol)
        && q.b.abs().max_element() <= 1e-12 * k.sqrt() * (-q.c / k).abs().sqrt().max(1.0);
    (isotropic && q.c < 0.0).then(|| (-q.c / k).sqrt())
}

/// The normal of a quadric that is a plane through the origin.
fn plane_normal(q: &Quadric) -> Option<DVec3> {
    let linear = q.m.to_cols_array().iter().all(|v| *v == 0.0);
    let n = q.b.length();
    (linear && n > 0.0 && q.c.abs() <= 1e-14 * n).then(|| q.b / n)
}

/// How far from the scene's origin, in curvature radii, paths of H3 go.
/// The hyperboloid's coordinates grow as `e^(d/R)`, and a point's
/// position in normal coordinates is a difference of coordinates that
/// size: its rounding, about `R e^(2d/R) 1e-16`, reaches the default
/// epsilon near `d = 11 R`. Nothing of radius `R` or less is visible
/// beyond: it subtends under `2 sinh(1) e^-12`, about 1.4e-5 radians.
pub const H3_REACH: f64 = 12.0;

/// How far the H3 geodesic from the model point `x` (of the hyperboloid
/// of radius `radius`) with unit tangent `d` goes before it leaves the
/// ball of [`H3_REACH`] radii about the origin for good. Its distance
/// from the origin obeys `cosh(r(t)/R) = A cosh(t/R) + B sinh(t/R)` with
/// `A = x_0 / R` and `B = d_0` (the hyperboloid's time coordinates), so
/// the exit is a root of a quadratic in `e^(t/R)`: a path heading towards
/// the origin goes `12 R + r` before it leaves, not `12 R - r`.
fn h3_exit(x: DVec4, d: DVec4, radius: f64) -> f64 {
    let (a, b) = (x.x / radius, d.x);
    let c = H3_REACH.cosh();
    // `A^2 - B^2 >= 1` on the model; rounding must not make the root
    // complex.
    let disc = (c * c - (a * a - b * b)).max(0.0);
    let sum = (a + b).max(f64::MIN_POSITIVE);
    (radius * ((c + disc.sqrt()) / sum).ln()).max(0.0)
}

/// S3 or H3, ready to walk rays.
#[derive(Debug, Clone, Copy)]
pub struct CurvedSpace {
    curvature: Curvature,
    /// In S3, how many times a path may go round.
    loops: f64,
    /// (C, S) of half a full piece's angle: every piece but a path's last
    /// is full, and its end is needed on every one.
    full_half: (f64, f64),
    /// Points many paths start or end at (the camera, the lights), with
    /// their model points: [`Space::remember`].
    known: [(DVec3, DVec4); KNOWN_POINTS],
    /// How many of `known` are set.
    known_count: usize,
}

/// How many points [`CurvedSpace`] keeps the model points of.
const KNOWN_POINTS: usize = 4;

impl CurvedSpace {
    /// The space of `curvature`; in S3 paths end after `loops` turns.
    pub fn new(curvature: Curvature, loops: f64) -> CurvedSpace {
        let mut space = CurvedSpace {
            curvature,
            loops,
            full_half: (1.0, 0.0),
            known: [(DVec3::ZERO, DVec4::ZERO); KNOWN_POINTS],
            known_count: 0,
        };
        space.full_half = curvature.cs(0.5 * space.piece() / curvature.radius);
        space
    }

    /// A segment's longest length: 0.9 of a half circle in S3 (a piece
    /// under half a turn has at most one turning point in each model
    /// coordinate, and its half-angle tangent stays finite, below 6.4),
    /// four radii in H3. Longer pieces mean fewer tests per object: from
    /// a quarter circle and two radii, 9% fewer instructions for the seed
    /// scene in S3 and 19% in H3.
    fn piece(&self) -> f64 {
        if self.curvature.spherical_space() {
            0.9 * PI * self.curvature.radius
        } else {
            4.0 * self.curvature.radius
        }
    }

    /// The model point of `p`: one remembered, or computed.
    #[inline]
    fn model_point(&self, p: DVec3) -> DVec4 {
        self.known[..self.known_count]
            .iter()
            .find(|(q, _)| *q == p)
            .map_or_else(|| self.curvature.exp(p), |&(_, x)| x)
    }

    /// The ball about the origin that holds everything a path of `limit`
    /// from `origin` reaches, as a radius (everything, in S3).
    fn reach_radius(&self, origin: DVec3, limit: f64) -> f64 {
        if self.curvature.spherical_space() {
            PI * self.curvature.radius
        } else {
            (origin.length() + limit).min(H3_REACH * self.curvature.radius)
        }
    }
}

impl Space for CurvedSpace {
    fn walk(
        &self,
        origin: DVec3,
        direction: DVec3,
        limit: f64,
        visit: &mut dyn FnMut(&Segment) -> ControlFlow<()>,
    ) {
        let k = self.curvature;
        let x = self.model_point(origin);
        let d = k.frame_to_model(x, direction);
        let (mut x, mut d) = k.renormalise(x, d);
        let limit = match self.loop_length() {
            Some(l) => limit.min(self.loops * l),
            None => limit.min(h3_exit(x, d, k.radius)),
        };
        let piece = self.piece();
        let mut t0 = 0.0;
        while t0 < limit {
            let full = t0 + piece <= limit;
            let t1 = if full { t0 + piece } else { limit };
            // A full piece's length may differ from `piece` by the
            // rounding of `t0 + piece`, far below any test's slack.
            let half_end = if full {
                self.full_half
            } else {
                k.cs(0.5 * (t1 - t0) / k.radius)
            };
            let g = Geodesic {
                curvature: k,
                x,
                d,
                t0,
                t1,
                half_end,
                ball: None,
            };
            if visit(&Segment::geodesic(g)).is_break() {
                return;
            }
            (x, d) = k.renormalise_along(x, d, half_end);
            t0 = t1;
        }
    }

    fn remember(&mut self, points: &[DVec3]) {
        for &p in points {
            if self.known_count < KNOWN_POINTS && p.is_finite() {
                self.known[self.known_count] = (p, self.curvature.exp(p));
                self.known_count += 1;
            }
        }
    }

    fn images(&self, bound: &Aabb, placement: &Placement) -> Vec<super::Image> {
        vec![super::Image::motion(Motion::new(
            self.curvature,
            placement,
            bound,
        ))]
    }

    fn connect(&self, from: DVec3, to: DVec3) -> Option<(DVec3, f64)> {
        let k = &self.curvature;
        let (a, b) = (self.model_point(from), self.model_point(to));
        // The part of b across a: R S(d/R) times the unit direction.
        let across = b - a * (k.dot(a, b) / k.dot(a, a));
        let size = k.dot(across, across).max(0.0).sqrt();
        if size == 0.0 || !size.is_finite() {
            return None;
        }
        let r = k.radius;
        let angle = if k.spherical_space() {
            size.atan2(k.dot(a, b) / r)
        } else {
            asinh(size / r)
        };
        let v = k.model_to_frame(a, across / size);
        Some((v / v.length(), r * angle))
    }

    fn other_way(&self, (direction, length): (DVec3, f64)) -> Option<(DVec3, f64)> {
        let l = self.loop_length()?;
        Some((-direction, l - length))
    }

    fn spread(&self, d: f64) -> f64 {
        self.curvature.spread(d)
    }

    fn step_off(&self, point: DVec3, direction: DVec3, distance: f64) -> DVec3 {
        let k = &self.curvature;
        let x = k.exp(point);
        point + k.frame_to_chart(x, point, direction) * distance
    }

    fn light_reach(&self, region: Aabb, light: DVec3) -> Aabb {
        // Geodesic balls about the origin are convex in H3, so the path
        // between two points stays within the farther one's distance.
        let r = region
            .min
            .abs()
            .max(region.max.abs())
            .length()
            .max(light.length());
        let r = if self.curvature.spherical_space() {
            PI * self.curvature.radius
        } else {
            r
        };
        cube(r)
    }

    fn reach(&self, origin: DVec3, limit: f64) -> Aabb {
        cube(self.reach_radius(origin, limit))
    }

    fn local_region(&self, region: Aabb, placement: &Placement) -> Aabb {
        if self.curvature.spherical_space() {
            return cube(PI * self.curvature.radius * (1.0 + 1e-9));
        }
        let r = region.min.abs().max(region.max.abs()).length();
        cube(r + placement.reach())
    }

    fn straight_paths(&self) -> bool {
        false
    }

    fn loop_length(&self) -> Option<f64> {
        self.curvature
            .spherical_space()
            .then_some(2.0 * PI * self.curvature.radius)
    }

    fn chart_radius(&self) -> Option<f64> {
        self.curvature
            .spherical_space()
            .then_some(PI * self.curvature.radius)
    }

    fn within_chart(&self, p: DVec3) -> DVec3 {
        // Along the geodesic through the origin and `p`, which closes
        // after 2 pi R: the same point at a distance in [-pi R, pi R].
        let Some(whole) = self.loop_length() else {
            return p;
        };
        let r = p.length();
        if !(r > 0.5 * whole && r.is_finite()) {
            return p;
        }
        let mut along = r % whole;
        if along > 0.5 * whole {
            along -= whole;
        }
        p * (along / r)
    }
}

fn cube(r: f64) -> Aabb {
    Aabb {
        min: DVec3::splat(-r),
        max: DVec3::splat(r),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spaces() -> [Curvature; 4] {
        [
            Curvature::spherical(1.0),
            Curvature::spherical(7.5),
            Curvature::hyperbolic(1.0),
            Curvature::hyperbolic(3.0),
        ]
    }

    /// Normal coordinates go to the model and back.
    #[test]
    fn asinh_agrees_with_the_standard_library() {
        for k in -400..=400 {
            let u = 1.1f64.powi(k) * if k % 2 == 0 { 1.0 } else { -1.0 };
            let (ours, std) = (asinh(u), u.asinh());
            assert!(
                (ours - std).abs() <= 4.0 * f64::EPSILON * std.abs(),
                "asinh({u}) = {ours}, std {std}"
            );
        }
        for u in [1e149, 1e151, 1e300, -1e300] {
            assert!((asinh(u) - u.asinh()).abs() <= 4.0 * f64::EPSILON * u.asinh().abs());
        }
        assert_eq!(asinh(0.0), 0.0);
        assert!(asinh(f64::NAN).is_nan());
        assert_eq!(asinh(f64::INFINITY), f64::INFINITY);
    }

    #[test]
    fn exp_and_log_are_inverse() {
        for k in spaces() {
            for p in [
                DVec3::new(0.3, -0.2, 0.1),
                DVec3::new(1.0, 2.0, -0.5) * k.radius * 0.9,
                DVec3::new(0.0, 0.0, 1e-9),
            ] {
                let x = k.exp(p);
                assert!((k.sigma * k.dot(x, x) / (k.radius * k.radius) - 1.0).abs() < 1e-14);
                let back = k.log(x);
                assert!(
                    (back - p).length() <= 1e-12 * (1.0 + p.length()),
                    "{p} {back}"
                );
            }
        }
    }

    /// A path stays on the model to 1e-12 relative after many loops, and
    /// in S3 comes back to its start after each whole turn.
    #[test]
    fn geodesics_stay_on_the_model_after_many_loops() {
        for k in spaces() {
            let space = CurvedSpace::new(k, 1000.0);
            let origin = DVec3::new(0.2, -0.4, 0.3) * k.radius;
            let dir = DVec3::new(0.3, 0.9, -0.2).normalize();
            let limit = if k.spherical_space() {
                200.0 * 2.0 * PI * k.radius
            } else {
                30.0 * k.radius
            };
            let mut worst: f64 = 0.0;
            let mut last = None;
            space.walk(origin, dir, limit, &mut |seg| {
                let g = seg.as_geodesic().expect("curved spaces walk geodesics");
                // Relative to the coordinates' own size (in H3 they grow as
                // e^(t/R), and the form's terms with them).
                let (x, v) = g.model_at(g.t1);
                let (xe, ve) = (x.length_squared(), v.length_squared());
                let r2 = k.radius * k.radius;
                worst = worst.max((k.sigma * k.dot(x, x) - r2).abs() / xe);
                worst = worst.max(k.dot(x, v).abs() / (xe * ve).sqrt());
                worst = worst.max((k.dot(v, v) - 1.0).abs() / ve);
                last = Some((g.t1, g.point(g.t1)));
                ControlFlow::Continue(())
            });
            assert!(worst < 1e-12, "{k:?}: {worst:e}");
            if k.spherical_space() {
                let (t, p) = last.unwrap();
                assert!((t - limit).abs() < 1e-9 * limit);
                assert!((p - origin).length() < 1e-9 * k.radius, "{p} vs {origin}");
            }
        }
    }

    /// A ball or plane said never to be met from a path's start on (in H3
    /// over the rest of the path, in S3 on the whole great circle) has no
    /// sign change along the whole path (sampled densely to where
    /// paths end), and one that is met has: the test drops a floor a
    /// path rises away from, so it must never drop one it would reach.
    #[test]
    fn a_quadric_never_met_has_no_sign_change_ahead() {
        for k in [Curvature::hyperbolic(3.0), Curvature::spherical(3.0)] {
            never_met_quadrics_are_not_crossed(k);
        }
    }

    /// A ball of S3 whose radius reaches the antipode holds the whole
    /// space and has no surface: no path meets it (its rim height's
    /// quadratic would wrap round to a false sphere at 2 pi R - rho).
    #[test]
    fn a_ball_holding_all_of_s3_is_never_met() {
        let k = Curvature::spherical(3.0);
        let ball = Quadric::new(DMat3::IDENTITY, DVec3::ZERO, -100.0);
        CurvedSpace::new(k, 1.0).walk(DVec3::new(0.5, 0.2, 0.0), DVec3::X, 1e9, &mut |seg| {
            let g = seg.as_geodesic().expect("geodesics");
            let (t0, t1) = seg.range();
            assert_eq!(g.quadric_ahead(&ball, t0, t1), Some(QuadricAhead::Never));
            assert_eq!(g.meet_quadric(&ball, t0, t1), QuadricMeeting::Solved(None));
            ControlFlow::Continue(())
        });
    }

    /// See [`a_quadric_never_met_has_no_sign_change_ahead`]:
    /// `quadric_ahead`'s `Never` against the path sampled to its end (a
    /// whole turn in S3).
    fn never_met_quadrics_are_not_crossed(k: Curvature) {
        let space = CurvedSpace::new(k, 1.0);
        let quadrics = [
            ("ball", Quadric::new(DMat3::IDENTITY, DVec3::ZERO, -4.0)),
            (
                "plane",
                Quadric::new(DMat3::ZERO, DVec3::new(0.2, -0.3, 0.9).normalize(), 0.0),
            ),
        ];
        let (mut never, mut met) = (0, 0);
        for i in 0..400 {
            let f = i as f64;
            let origin = DVec3::new((f * 0.37).sin(), (f * 0.61).cos(), (f * 0.23).sin()) * 6.0;
            // Half the paths head roughly towards the quadrics.
            let wander = DVec3::new((f * 1.3).cos(), (f * 0.7).sin(), (f * 2.1).sin() - 0.1);
            let towards = if i % 2 == 0 {
                -origin.normalize()
            } else {
                DVec3::ZERO
            };
            let dir = (wander + 1.5 * towards).normalize();
            for (name, q) in &quadrics {
                let mut first = None;
                let mut sign_change = false;
                space.walk(origin, dir, 1e9, &mut |seg| {
                    let g = seg.as_geodesic().expect("geodesics");
                    let (t0, t1) = seg.range();
                    first.get_or_insert(g.quadric_ahead(q, t0, t1) == Some(QuadricAhead::Never));
                    let mut last = q.value(g.point(t0));
                    for j in 1..=4000 {
                        let v = q.value(g.point(t0 + (t1 - t0) * j as f64 / 4000.0));
                        sign_change |= v.signum() != last.signum();
                        last = v;
                    }
                    ControlFlow::Continue(())
                });
                if first == Some(true) {
                    never += 1;
                    assert!(
                        !sign_change,
                        "{k:?} {name} {i}: said never met, but crossed"
                    );
                } else if sign_change {
                    met += 1;
                }
            }
        }
        // Both answers occur, so the test tests something.
        assert!(never > 50 && met > 50, "{k:?}: never {never}, met {met}");
    }

    /// A copy made ready for its ball or plane gives the meeting the path
    /// moved whole into its coordinates gives: the same answer, at the
    /// same distance to rounding, from paths that start far from the
    /// centre, near it (where the height over the rim comes from the
    /// spatial part) and at it; and the hit's point in the copy's
    /// coordinates is the moved path's.
    #[test]
    fn a_prepared_copy_meets_a_path_where_the_moved_path_does() {
        let quadrics = [
            Quadric::new(DMat3::IDENTITY, DVec3::ZERO, -0.36),
            Quadric::new(DMat3::IDENTITY, DVec3::ZERO, -4.0),
            Quadric::new(DMat3::ZERO, DVec3::new(0.2, -0.3, 0.9).normalize(), 0.0),
        ];
        let placement = Placement(vec![
            Rigid::Rotate(DMat3::from_rotation_z(0.7) * DMat3::from_rotation_x(-0.4)),
            Rigid::Translate(DVec3::new(2.5, -0.8, 0.6)),
        ]);
        let centre = DVec3::new(2.5, -0.8, 0.6);
        let bound = cube(2.0);
        let (mut met, mut compared) = (0, 0);
        for k in spaces() {
            let space = CurvedSpace::new(k, 1.0);
            let plain = Motion::new(k, &placement, &bound);
            for q in &quadrics {
                let prepared = plain.with_shape(q);
                for i in 0..300 {
                    let f = i as f64;
                    let wander = DVec3::new((f * 0.37).sin(), (f * 0.61).cos(), (f * 0.23).sin());
                    // From far away, from within a tenth of a radius of the
                    // centre, and from the centre itself.
                    let origin = match i % 3 {
                        0 => wander * 4.0,
                        1 => centre + wander * 0.1 * k.radius.min(1.0),
                        _ => centre,
                    };
                    let dir = (DVec3::new((f * 1.3).cos(), (f * 0.7).sin(), (f * 2.1).sin())
                        + 0.8 * (centre - origin).normalize_or_zero())
                    .normalize();
                    space.walk(origin, dir, 40.0, &mut |seg| {
                        let g = seg.as_geodesic().expect("geodesics");
                        let (t0, t1) = seg.range();
                        let b = 0.5 * (t0 + t1);
                        let fast = prepared.quadric_ahead(g, q, t0, b);
                        let moved = plain.move_in(g).quadric_ahead(q, t0, b);
                        compared += 1;
                        match (fast, moved) {
                            (Some(QuadricAhead::At(s)), Some(QuadricAhead::At(t))) => {
                                met += 1;
                                assert!(
                                    (s - t).abs() <= 1e-9 * (1.0 + t.abs()),
                                    "{k:?} {i}: at {s}, moved {t}"
                                );
                                // On the model: normal coordinates of
                                // S3 jump at the antipode.
                                let (_, _, local) = prepared.point_heading_and_local(g, t);
                                let moved_point = plain.move_in(g).point(t);
                                let gap = (k.exp(local) - k.exp(moved_point)).length();
                                assert!(
                                    gap <= 1e-9 * (k.radius + t.abs()),
                                    "{k:?} {i}: local {local}, moved {moved_point}"
                                );
                            }
                            (fast, moved) => {
                                assert_eq!(fast, moved, "{k:?} {i} on [{t0}, {b}]")
                            }
                        }
                        ControlFlow::Continue(())
                    });
                }
            }
        }
        assert!(met > 200 && compared > 2000, "met {met} of {compared}");
    }

    /// The frame's direction and the chart velocity agree with finite
    /// differences of the path's points.
    #[test]
    fn velocities_match_finite_differences() {
        for k in spaces() {
            let space = CurvedSpace::new(k, 1.0);
            let origin = DVec3::new(0.5, 0.1, -0.3) * k.radius;
            let dir = DVec3::new(-0.2, 0.7, 0.4).normalize();
            space.walk(origin, dir, 2.0 * k.radius, &mut |seg| {
                let (t0, t1) = seg.range();
                let t = 0.5 * (t0 + t1);
                let h = 1e-6 * k.radius;
                let fd = (seg.point(t + h) - seg.point(t - h)) / (2.0 * h);
                let v = seg.direction(t);
                assert!((fd - v).length() < 1e-6, "{k:?}: {fd} vs {v}");
                ControlFlow::Continue(())
            });
            // At the start the frame direction is the one given.
            space.walk(origin, dir, k.radius, &mut |seg| {
                let h = seg.heading(0.0);
                assert!((h - dir).length() < 1e-12, "{h} vs {dir}");
                ControlFlow::Break(())
            });
        }
    }

    /// Boxes hold every point of their piece.
    #[test]
    fn boxes_hold_the_path() {
        for k in spaces() {
            let space = CurvedSpace::new(k, 2.0);
            let origin = DVec3::new(0.5, 0.1, -0.3) * k.radius;
            let dir = DVec3::new(-0.2, 0.7, 0.4).normalize();
            space.walk(origin, dir, 10.0 * k.radius, &mut |seg| {
                let (t0, t1) = seg.range();
                for j in 0..8 {
                    let a = t0 + (t1 - t0) * j as f64 / 8.0;
                    let b = a + (t1 - t0) / 8.0;
                    let (bx, vb) = seg.bounds(a, b).unwrap();
                    for i in 0..=50 {
                        let t = a + (b - a) * i as f64 / 50.0;
                        let p = seg.point(t);
                        assert!(
                            p.cmpge(bx.min).all() && p.cmple(bx.max).all(),
                            "{k:?} {a} {b} {t} {p} {bx:?}"
                        );
                        let v = seg.direction(t);
                        assert!(v.cmpge(vb.min).all() && v.cmple(vb.max).all(), "{v} {vb:?}");
                    }
                }
                ControlFlow::Continue(())
            });
        }
    }

    /// Short pieces get small velocity boxes, holding the velocity: a
    /// search along a curved path proves a piece free of roots from its
    /// slope there, which needs the box to shrink with the piece. Paths
    /// far from the origin and near it, pieces down to a millionth of R.
    #[test]
    fn velocity_boxes_shrink_with_the_piece() {
        for k in spaces() {
            let space = CurvedSpace::new(k, 2.0);
            let r = k.radius;
            for (origin, dir) in [
                (DVec3::new(0.14, 0.003, 0.1), DVec3::new(-0.39, -0.64, 0.66)),
                (DVec3::new(0.5, 0.1, -0.3), DVec3::new(-0.2, 0.7, 0.4)),
                (DVec3::new(-1.2, 0.4, 0.2), DVec3::new(0.3, 0.1, -0.9)),
                (DVec3::new(0.02, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0)),
            ] {
                let dir = dir.normalize();
                space.walk(origin * r, dir, 3.0 * r, &mut |seg| {
                    let (t0, t1) = seg.range();
                    for fraction in [1e-2, 1e-4, 1e-6] {
                        let length = fraction * r;
                        for j in 0..16 {
                            let a = t0 + (t1 - t0 - length) * j as f64 / 15.0;
                            let b = a + length;
                            let (_, vb) = seg.bounds(a, b).unwrap();
                            let width = (vb.max - vb.min).max_element();
                            // Near S3's antipode, where normal coordinates
                            // stretch without bound, velocities change fast.
                            let far_out = seg.point(a).length() > 0.75 * PI * r;
                            assert!(
                                far_out || width < 40.0 * fraction + 1e-10,
                                "{k:?}: a piece of {length} at {a} has velocities {vb:?}"
                            );
                            for i in 0..=8 {
                                let v = seg.direction(a + (b - a) * i as f64 / 8.0);
                                assert!(
                                    v.cmpge(vb.min).all() && v.cmple(vb.max).all(),
                                    "{k:?}: {v} outside {vb:?} on [{a}, {b}]"
                                );
                            }
                        }
                    }
                    ControlFlow::Continue(())
                });
            }
        }
    }

    /// Translating by v then by -v is the identity; a translation takes
    /// the origin to exp(v).
    #[test]
    fn translations_are_isometries() {
        for k in spaces() {
            let v = DVec3::new(0.4, -0.3, 0.2) * k.radius;
            let t = k.translation(v);
            let back = k.translation(-v);
            let o = DVec4::new(k.radius, 0.0, 0.0, 0.0);
            assert!((t * o - k.exp(v)).length() < 1e-12 * k.radius);
            let id = back * t;
            assert!(id.abs_diff_eq(DMat4::IDENTITY, 1e-12));
            let (a, b) = (
                k.exp(DVec3::new(0.1, 0.2, 0.3)),
                k.exp(DVec3::new(-0.5, 0.0, 0.4)),
            );
            assert!((k.dot(t * a, t * b) - k.dot(a, b)).abs() < 1e-12 * k.radius * k.radius);
        }
    }

    /// The shortest path to a point has the geodesic distance, and
    /// following it arrives there.
    #[test]
    fn connect_arrives() {
        for k in spaces() {
            let space = CurvedSpace::new(k, 1.0);
            let (p, q) = (
                DVec3::new(0.3, -0.2, 0.5) * k.radius,
                DVec3::new(-0.6, 0.4, 0.1) * k.radius,
            );
            let (dir, len) = space.connect(p, q).unwrap();
            let end = super::super::points_along(&space, p, dir, &[len])[0].unwrap();
            assert!((end - q).length() < 1e-9 * k.radius, "{end} vs {q}");
            if k.spherical_space() {
                let (dir2, len2) = space.other_way((dir, len)).unwrap();
                let end2 = super::super::points_along(&space, p, dir2, &[len2])[0].unwrap();
                assert!((end2 - q).length() < 1e-9 * k.radius, "{end2} vs {q}");
            }
        }
    }

    /// The closed form meets a ball and a plane where the path's points
    /// cross them.
    #[test]
    fn closed_forms_find_the_crossing() {
        for k in spaces() {
            let ball = Quadric::new(DMat3::IDENTITY, DVec3::ZERO, -(0.4 * k.radius).powi(2));
            let plane = Quadric::new(DMat3::ZERO, DVec3::new(0.0, 0.0, 1.0), 0.0);
            let space = CurvedSpace::new(k, 1.0);
            let origin = DVec3::new(-0.9, 0.1, 0.35) * k.radius;
            let dir = DVec3::new(1.0, -0.05, -0.3).normalize();
            for (q, f) in [
                (
                    ball,
                    Box::new(|p: DVec3| p.length() - 0.4 * k.radius) as Box<dyn Fn(DVec3) -> f64>,
                ),
                (plane, Box::new(|p: DVec3| p.z)),
            ] {
                let mut found = None;
                let mut sampled = None;
                space.walk(origin, dir, 3.0 * k.radius, &mut |seg| {
                    let (t0, t1) = seg.range();
                    if sampled.is_none() {
                        let n = 4000;
                        for i in 0..n {
                            let (a, b) = (
                                t0 + (t1 - t0) * i as f64 / n as f64,
                                t0 + (t1 - t0) * (i + 1) as f64 / n as f64,
                            );
                            if f(seg.point(a)) * f(seg.point(b)) <= 0.0 {
                                sampled = Some(0.5 * (a + b));
                                break;
                            }
                        }
                    }
                    if let QuadricMeeting::Solved(Some(t)) = seg.meet_quadric(&q, t0, t1) {
                        found = Some(t);
                        return ControlFlow::Break(());
                    }
                    ControlFlow::Continue(())
                });
                let (t, s) = (
                    found.expect("closed form finds it"),
                    sampled.expect("sampled"),
                );
                assert!((t - s).abs() < 1e-3 * k.radius, "{k:?}: {t} vs {s}");
            }
        }
    }
}
