//! Spaces: how a ray travels.
//!
//! Input: a ray's start, unit direction and length limit, and the scene's
//! [`SpaceKind`] (which space, with its checked parameters). Output: the
//! pieces of its path, in order, as [`Segment`]s, which the tracer
//! searches by their points, tangents, bounding boxes and line forms;
//! the offsets of an object's copies; the path to a light; what the ray
//! diagrams draw of the space.
//!
//! **Everything that knows a concrete space or a kind of segment lives in
//! this folder.** The tracer, shading, the tools and the diagrams see only
//! the [`Space`] trait, [`Segment`]'s methods and [`SpaceKind`]'s names
//! and descriptions; a new space implements [`Space`], adds its
//! parameters to [`SpaceKind`], and (if its paths are neither lines nor
//! circles nor integrated steps) a segment kind in `segment.rs`.

mod curved;
mod dop853;
mod dopri;
mod metric;
mod segment;
mod sphere;
mod torus;

use std::ops::ControlFlow;
use std::sync::Arc;

use glam::DVec3;

pub use curved::{Approach, Curvature, CurvedSpace, Placement, Rigid, H3_REACH};
pub use metric::{
    symmetric_index, Frame, Metric, MetricSizes, MetricSpace, PathReport, CHART_REACH,
    DEFAULT_METRIC_SAMPLE, DEFAULT_METRIC_STEPS, MAX_CHART_GRID,
};
pub use segment::{ClipFor, Line, NearLine, QuadricAhead, QuadricMeeting, SamplePiece, Segment};
pub use sphere::{IntegratedLoop, IntegratorStats, SphereSpace};
pub use torus::TorusSpace;

/// An axis-aligned box in the space's coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// The corner with the smallest coordinates.
    pub min: DVec3,
    /// The corner with the largest coordinates.
    pub max: DVec3,
}

impl Aabb {
    /// Whether the two boxes share a point.
    #[inline]
    pub fn overlaps(&self, other: &Aabb) -> bool {
        self.min.cmple(other.max).all() && self.max.cmpge(other.min).all()
    }

    /// The box with each face moved inward by `by` (empty, its min above
    /// its max somewhere, when `by` is more than half its size).
    pub fn shrunk(&self, by: f64) -> Aabb {
        Aabb {
            min: self.min + by,
            max: self.max - by,
        }
    }

    /// Whether the box holds no point.
    pub fn is_empty(&self) -> bool {
        !self.min.cmple(self.max).all()
    }

    /// Whether `p` lies in the box (its faces included).
    #[inline]
    pub fn contains(&self, p: DVec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// The parameter range within `[t0, t1]` in which the ray `o + t d` is
    /// inside the box, if any. `inv` is `1 / d`, computed once per ray.
    #[inline]
    pub fn clip(&self, o: DVec3, inv: DVec3, t0: f64, t1: f64) -> Option<(f64, f64)> {
        let a = (self.min - o) * inv;
        let b = (self.max - o) * inv;
        // NaN (0 * inf, a ray in the box's plane) falls back to the full
        // range on that axis through max/min's NaN handling.
        let near = a.min(b);
        let far = a.max(b);
        let lo = t0.max(near.max_element());
        let hi = t1.min(far.min_element());
        (lo <= hi).then_some((lo, hi))
    }
}

/// Where one copy of an object stands in the space: moved by an offset
/// (the torus's lattice; none in Euclidean space) or, in the curved
/// spaces, by the isometry its placement is. Opaque outside this folder:
/// the tracer hands it to [`Segment::seen_by`] and [`Image::normal`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Image(ImageKind);

// An image is made once per object and render, and borrowed after.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
enum ImageKind {
    Offset(DVec3),
    Motion(curved::Motion),
}

impl Image {
    /// The object as written.
    pub const HERE: Image = Image(ImageKind::Offset(DVec3::ZERO));

    /// A copy moved by `offset`: its point `p` appears at `p + offset`.
    pub fn offset(offset: DVec3) -> Image {
        Image(ImageKind::Offset(offset))
    }

    fn motion(m: curved::Motion) -> Image {
        Image(ImageKind::Motion(m))
    }

    /// The copy of an object whose formula is the quadric `shape`, made
    /// ready for [`Segment::quadric_ahead`]: a copy placed by an isometry
    /// of S3 or H3 keeps what that closed form needs per path (the rim
    /// height of a ball, the row of the motion a plane's normal picks), so
    /// no path is moved whole for it.
    pub fn with_shape(self, shape: Option<&crate::expr::Quadric>) -> Image {
        match (self.0, shape) {
            (ImageKind::Motion(m), Some(q)) => Image(ImageKind::Motion(m.with_shape(q))),
            _ => self,
        }
    }

    /// Whether this is the object as written, so a path needs no moving.
    #[inline]
    pub fn is_here(&self) -> bool {
        matches!(self.0, ImageKind::Offset(o) if o == DVec3::ZERO)
    }

    /// The offset of a copy moved by one; `None` for a copy placed by an
    /// isometry of a curved space.
    pub fn as_offset(&self) -> Option<DVec3> {
        match self.0 {
            ImageKind::Offset(o) => Some(o),
            ImageKind::Motion(_) => None,
        }
    }

    /// The point `p` of the space in the copy's coordinates (where its
    /// formula is evaluated).
    pub fn to_local(&self, p: DVec3) -> DVec3 {
        match self.0 {
            ImageKind::Offset(o) => p - o,
            ImageKind::Motion(ref m) => m.point_to_local(p),
        }
    }

    /// The direction of the normal of a surface whose formula has
    /// `gradient` at `local` (in the copy's coordinates), in the
    /// orthonormal frame of the space at that point (not normalised).
    #[inline]
    pub fn normal(&self, local: DVec3, gradient: DVec3) -> DVec3 {
        match self.0 {
            ImageKind::Offset(_) => gradient,
            ImageKind::Motion(ref m) => m.normal_to_world(local, gradient),
        }
    }
}

/// Which space rays travel in, with its parameters.
#[derive(Debug, Clone, PartialEq)]
pub enum SpaceKind {
    /// Flat space: rays are straight lines (the default).
    Euclidean,
    /// The flat 3-torus: the box `[min, max]` with opposite faces glued.
    Torus {
        /// The cell's corner with the smallest coordinates.
        min: DVec3,
        /// The cell's corner with the largest coordinates (above `min` on every
        /// axis).
        max: DVec3,
        /// Face crossings allowed per ray.
        wraps: u32,
        /// Objects repeat across faces (otherwise the cell clips them).
        periodic: bool,
    },
    /// The seed's sphere space: each ray follows a circle of this radius.
    Sphere {
        /// The circles' radius, positive (25 by default).
        radius: f64,
        /// Whether paths follow the exact circle or are integrated.
        path: PathMode,
    },
    /// The 3-sphere of radius `radius` (curvature `1 / radius^2`).
    S3 {
        /// The curvature radius, positive.
        radius: f64,
        /// How many times a ray may go round the space.
        loops: u32,
    },
    /// Hyperbolic space of curvature `-1 / radius^2`.
    H3 {
        /// The curvature radius, positive.
        radius: f64,
    },
    /// A metric the scene writes, in a chart: its geodesics are
    /// integrated.
    Metric(MetricKind),
}

/// The compiled metric of `space metric { ... }`: shared, since a scene
/// (and its space) is cloned for each panel and frame.
#[derive(Debug, Clone)]
pub struct MetricKind(pub Arc<Metric>);

impl PartialEq for MetricKind {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// The largest curvature radius of S3 and H3: points are held on a model
/// in R^4 with coordinates of the radius's size, which round to about
/// `radius * 1e-16`; at 1e6 that is still below the default epsilon.
pub const MAX_CURVATURE_RADIUS: f64 = 1e6;

/// How rays move in the sphere space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PathMode {
    /// Along the exact circle.
    Exact,
    /// By integrating the geodesic equations (DOPRI5) to this tolerance.
    Integrated {
        /// The integrator's relative tolerance, 1e-14 to 1e-2 (`tolerance`
        /// of the `render` block, 1e-8 by default).
        tolerance: f64,
    },
}

/// The largest sphere-space radius whose paths `method ode` integrates:
/// its points are placed about the circle's centre, and the rounding of a
/// coordinate that far away (1e9 * 2^-52, about 2e-7) must stay below the
/// default epsilon (1e-6).
pub const MAX_INTEGRATED_RADIUS: f64 = 1e9;

/// The largest sphere-space radius: the closed form on circles squares it
/// (1e100 squared is still finite), and at it paths are as straight as
/// floating point can tell.
pub const MAX_SPHERE_RADIUS: f64 = 1e100;

/// Every space a scene can name, in the order the docs list them.
pub const SPACE_NAMES: [&str; 6] = ["euclidean", "torus", "sphere", "s3", "h3", "metric"];

impl SpaceKind {
    /// The space's name as a scene file writes it.
    pub fn name(&self) -> &'static str {
        match self {
            SpaceKind::Euclidean => "euclidean",
            SpaceKind::Torus { .. } => "torus",
            SpaceKind::Sphere { .. } => "sphere",
            SpaceKind::S3 { .. } => "s3",
            SpaceKind::H3 { .. } => "h3",
            SpaceKind::Metric(_) => "metric",
        }
    }

    /// The curvature of a space of constant curvature (S3, H3); `None`
    /// for the others.
    pub fn curvature(&self) -> Option<Curvature> {
        match *self {
            SpaceKind::S3 { radius, .. } => Some(Curvature::spherical(radius)),
            SpaceKind::H3 { radius } => Some(Curvature::hyperbolic(radius)),
            _ => None,
        }
    }

    /// Whether the space is curved in the sense of a geometry (S3, H3):
    /// objects are placed by its isometries, their formulas read in
    /// normal coordinates about their own centre, rather than moved by
    /// transforms folded into the formula.
    pub fn places_objects(&self) -> bool {
        matches!(self, SpaceKind::S3 { .. } | SpaceKind::H3 { .. })
    }

    /// The sine of the angle under which a geodesic ball of radius `r` is
    /// seen from distance `d` (its centre's), where rays from a point make
    /// that one formula hold: `r / d` flat, `sin(r/R) / sin(d/R)` in S3,
    /// `sinh(r/R) / sinh(d/R)` in H3. `None` in the torus (copies), the
    /// sphere space (bent rays) and metric spaces.
    pub fn sine_of_ball(&self, r: f64, d: f64) -> Option<f64> {
        match self {
            SpaceKind::Euclidean => Some(r / d),
            SpaceKind::S3 { .. } | SpaceKind::H3 { .. } => {
                let k = self.curvature()?;
                Some(k.spread(r) / k.spread(d))
            }
            _ => None,
        }
    }

    /// Whether the space aims the camera in a frame of its own (a metric's
    /// orthonormal frame at the camera), so that a scene written for
    /// another space is compiled again for it.
    pub fn aims_camera(&self) -> bool {
        matches!(self, SpaceKind::Metric(_))
    }

    /// For a metric space: the operations of one evaluation of its
    /// geodesic equation (12 per integrator step).
    pub fn operations_per_step(&self) -> Option<usize> {
        match self {
            SpaceKind::Metric(m) => Some(m.0.sizes.evaluated),
            _ => None,
        }
    }

    /// For a metric space: what was derived from the metric, in words, for
    /// `nes explain`.
    pub fn derivation(&self) -> Option<String> {
        let SpaceKind::Metric(m) = self else {
            return None;
        };
        let z = m.0.sizes;
        Some(format!(
            "metric derived symbolically: its 6 entries {} operations; Christoffel symbols {} of 18 not zero, {} operations (the whole geodesic equation {}); evaluated as the entries with the lowered equation (D_v g) v - 1/2 d(v^T g v), {} operations ({}), solved numerically, 12 times per integrator step",
            z.metric, z.christoffel_nonzero, z.christoffel, z.acceleration, z.evaluated, if m.0.is_compiled() { "compiled to machine code" } else { "interpreted" }
        ))
    }

    /// The listed name ([`SPACE_NAMES`]) that `name` is, in any case
    /// (`S3` is `s3`, as panel labels write it); `None` for no space.
    pub fn canonical_name(name: &str) -> Option<&'static str> {
        SPACE_NAMES
            .iter()
            .copied()
            .find(|n| n.eq_ignore_ascii_case(name.trim()))
    }

    /// The seed report's parameters, for a space named without any.
    pub fn default_named(name: &str) -> Option<SpaceKind> {
        Some(match name {
            "euclidean" => SpaceKind::Euclidean,
            "torus" => SpaceKind::Torus {
                min: DVec3::splat(-10.0),
                max: DVec3::splat(10.0),
                wraps: 500,
                periodic: true,
            },
            "sphere" => SpaceKind::Sphere {
                radius: 25.0,
                path: PathMode::Exact,
            },
            "s3" => SpaceKind::S3 {
                radius: 10.0,
                loops: 1,
            },
            "h3" => SpaceKind::H3 { radius: 10.0 },
            "metric" => SpaceKind::Metric(MetricKind(Arc::new(Metric::flat()))),
            _ => return None,
        })
    }

    /// Whether the space's paths can be integrated numerically (`method
    /// ode`); elsewhere that method has nothing to integrate, or cannot do
    /// it accurately (see [`SpaceKind::why_not_integrate`]).
    pub fn can_integrate(&self) -> bool {
        self.why_not_integrate().is_none()
    }

    /// Why `method ode` cannot follow this space's paths, as a sentence;
    /// `None` when it can.
    pub fn why_not_integrate(&self) -> Option<String> {
        match *self {
            SpaceKind::Sphere { radius, .. } if radius > MAX_INTEGRATED_RADIUS => Some(format!(
                "its paths are placed about their circle's centre, here {radius:e} away, and \
                 beyond a radius of {MAX_INTEGRATED_RADIUS:e} that rounds more coarsely than a \
                 hit's tolerance (method auto's exact circles hold at any radius)"
            )),
            SpaceKind::Sphere { .. } => None,
            SpaceKind::S3 { .. } | SpaceKind::H3 { .. } => Some(format!(
                "the {} space's paths are its exact geodesics ({}), computed in closed form, \
                 so there is nothing to integrate",
                self.name(),
                if matches!(self, SpaceKind::S3 { .. }) {
                    "great circles"
                } else {
                    "geodesics of the hyperboloid"
                }
            )),
            SpaceKind::Euclidean | SpaceKind::Torus { .. } => Some(format!(
                "it integrates curved paths, and the {} space's are straight",
                self.name()
            )),
            SpaceKind::Metric(_) => None,
        }
    }

    /// What to do instead of `method ode` where
    /// [`SpaceKind::why_not_integrate`] refuses it, as a help line.
    pub fn instead_of_integrating(&self) -> &'static str {
        match self {
            SpaceKind::S3 { .. } | SpaceKind::H3 { .. } => {
                "use the default method, auto, which follows these paths exactly"
            }
            SpaceKind::Sphere { .. } => "use method auto, whose exact circles hold at any radius",
            SpaceKind::Euclidean | SpaceKind::Torus { .. } => {
                "use exact, interval, march or adaptive here, or add `space sphere { radius R }`"
            }
            SpaceKind::Metric(_) => "metric spaces integrate their geodesics whatever the method",
        }
    }

    /// How paths are followed: `integrate` (the tolerance of `method ode`)
    /// integrates them whatever the space block says.
    fn path_mode(path: PathMode, integrate: Option<f64>) -> PathMode {
        match integrate {
            Some(tolerance) => PathMode::Integrated { tolerance },
            None => path,
        }
    }

    /// The space ready to walk rays in. `forward` is the camera's view
    /// direction (it settles the sphere space's vertical rays);
    /// `integrate`, the tolerance to integrate paths to, where the space
    /// can ([`SpaceKind::can_integrate`]).
    /// `tolerance` is the render's integrator tolerance, which a metric
    /// space always integrates to.
    pub fn build(&self, forward: DVec3, integrate: Option<f64>, tolerance: f64) -> Box<dyn Space> {
        match *self {
            SpaceKind::Euclidean => Box::new(Euclidean),
            SpaceKind::Torus {
                min,
                max,
                wraps,
                periodic,
            } => Box::new(TorusSpace::new(min, max, wraps, periodic)),
            SpaceKind::Sphere { radius, path } => Box::new(SphereSpace::new(
                radius,
                Self::path_mode(path, integrate),
                forward,
            )),
            SpaceKind::S3 { radius, loops } => {
                Box::new(CurvedSpace::new(Curvature::spherical(radius), loops as f64))
            }
            SpaceKind::H3 { radius } => {
                Box::new(CurvedSpace::new(Curvature::hyperbolic(radius), 1.0))
            }
            SpaceKind::Metric(ref m) => Box::new(MetricSpace::new(m.0.clone(), tolerance)),
        }
    }

    /// A short label, for panels rendered side by side.
    pub fn label(&self) -> String {
        match *self {
            SpaceKind::Euclidean => "euclidean".into(),
            SpaceKind::Torus {
                min, max, wraps, ..
            } => {
                if min == DVec3::splat(min.x) && max == DVec3::splat(max.x) {
                    format!("torus [{}, {}]^3, {} wraps", min.x, max.x, wraps)
                } else {
                    format!("torus, {wraps} wraps")
                }
            }
            SpaceKind::Sphere { radius, .. } => format!("sphere R = {radius}"),
            SpaceKind::S3 { radius, .. } => format!("S3 R = {radius}"),
            SpaceKind::H3 { radius } => format!("H3 R = {radius}"),
            SpaceKind::Metric(ref m) => format!("metric {}", m.0.label),
        }
    }

    /// The space and its parameters in words, for `nes explain`;
    /// `integrate` as for [`SpaceKind::build`].
    pub fn description(&self, integrate: Option<f64>, tolerance: f64) -> String {
        let v = |p: DVec3| format!("({}, {}, {})", p.x, p.y, p.z);
        match *self {
            SpaceKind::Euclidean => "euclidean".to_string(),
            SpaceKind::Torus {
                min,
                max,
                wraps,
                periodic,
            } => format!(
                "torus (cell {} .. {}, {} wraps, objects {})",
                v(min),
                v(max),
                wraps,
                if periodic { "periodic" } else { "clipped" }
            ),
            SpaceKind::Sphere { radius, path } => format!(
                "sphere (R {}, {})",
                radius,
                match Self::path_mode(path, integrate) {
                    PathMode::Exact => "exact circles".to_string(),
                    PathMode::Integrated { tolerance } =>
                        format!("paths integrated by DOPRI5, tolerance {tolerance:e}"),
                }
            ),
            SpaceKind::S3 { radius, loops } => format!(
                "s3 (the 3-sphere of radius {}: curvature {}; exact great circles, at most {loops} loop{})",
                human(radius),
                human(1.0 / (radius * radius)),
                if loops == 1 { "" } else { "s" }
            ),
            SpaceKind::H3 { radius } => format!(
                "h3 (hyperbolic space of radius {}: curvature {}; exact geodesics on the hyperboloid)",
                human(radius),
                human(-1.0 / (radius * radius))
            ),
            SpaceKind::Metric(ref m) => format!(
                "metric {} (geodesics integrated by DOP853, tolerance {tolerance:e}, at most {} steps per path, samples {} apart)",
                m.0.label,
                m.0.max_steps,
                human(m.0.sample)
            ),
        }
    }

    /// What ends a ray from `origin` (the camera) in this space, in words,
    /// for `nes explain`: `max_distance`, or the space's own end of a
    /// path where that comes first (one loop of the sphere space's
    /// circles, `loops` turns round S3, [`H3_REACH`] radii from the origin
    /// in H3), or a torus's face crossings.
    pub fn ray_end(&self, max_distance: f64, origin: DVec3) -> String {
        let by_distance = format!("rays end after {} (max_distance)", human(max_distance));
        match *self {
            SpaceKind::Euclidean => by_distance,
            SpaceKind::Metric(ref m) => format!(
                "{by_distance} of arc length, or after {} integrator steps, on leaving the chart's domain, where the metric is singular, or {} from the origin in the chart",
                m.0.max_steps,
                human(CHART_REACH)
            ),
            SpaceKind::Torus { wraps, .. } => {
                format!("{by_distance} or {wraps} face crossings, whichever comes first")
            }
            SpaceKind::Sphere { radius, .. } => {
                let turn = std::f64::consts::TAU * radius;
                if max_distance < turn {
                    format!(
                        "{by_distance}, within one loop of their circle ({})",
                        human(turn)
                    )
                } else {
                    format!(
                        "rays end after one loop of their circle, 2 pi R = {} (before max_distance {})",
                        human(turn),
                        human(max_distance)
                    )
                }
            }
            SpaceKind::S3 { radius, loops } => {
                let turn = std::f64::consts::TAU * radius;
                let end = loops as f64 * turn;
                if max_distance < end {
                    format!(
                        "{by_distance}, within {loops} loop{} round the space (2 pi R = {} each)",
                        if loops == 1 { "" } else { "s" },
                        human(turn)
                    )
                } else if loops == 1 {
                    format!(
                        "rays end after one loop round the space, 2 pi R = {} (before max_distance {})",
                        human(turn),
                        human(max_distance)
                    )
                } else {
                    format!(
                        "rays end after {loops} loops round the space, {} (2 pi R = {} each, before max_distance {})",
                        human(end),
                        human(turn),
                        human(max_distance)
                    )
                }
            }
            SpaceKind::H3 { radius } => {
                let reach = H3_REACH * radius;
                let from_camera = reach - origin.length();
                if max_distance < from_camera {
                    format!(
                        "{by_distance}, within {} R = {} of the origin",
                        H3_REACH,
                        human(reach)
                    )
                } else {
                    format!(
                        "rays end {} R = {} from the origin, where positions lose their digits (primary rays after {}, before max_distance {})",
                        H3_REACH,
                        human(reach),
                        human(from_camera.max(0.0)),
                        human(max_distance)
                    )
                }
            }
        }
    }
}

/// `x` for a person to read: four significant digits, without trailing
/// zeros (`-0.1111`, `25.13`, `100`), and in exponent form outside
/// 0.001 .. 1e6 (`1e-12`).
pub(crate) fn human(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || !a.is_finite() {
        return format!("{x}");
    }
    let trim = |t: String| {
        if t.contains('.') {
            t.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            t
        }
    };
    if (1e-3..1e6).contains(&a) {
        let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
        trim(format!("{x:.decimals$}"))
    } else {
        let t = format!("{x:.3e}");
        let (mantissa, exponent) = t.split_once('e').expect("exponent form");
        format!("{}e{exponent}", trim(mantissa.to_string()))
    }
}

/// How rays travel in one space: its paths, the copies of objects it holds
/// and the shortest paths to lights. Built by [`SpaceKind::build`]; the
/// tracer, shading and the tools see a space only through this trait.
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

    /// Where copies of an object with this bound and placement appear
    /// (quotient spaces repeat objects; curved spaces place them by an
    /// isometry).
    fn images(&self, _bound: &Aabb, _placement: &Placement) -> Vec<Image> {
        vec![Image::HERE]
    }

    /// The region objects' bounds are searched in, in the coordinates of
    /// an object with `placement`, given `region` in the scene's.
    fn local_region(&self, region: Aabb, _placement: &Placement) -> Aabb {
        region
    }

    /// The shortest path from `from` to `to` that [`Space::walk`] would
    /// follow: its starting direction and length, if there is one.
    fn connect(&self, from: DVec3, to: DVec3) -> Option<(DVec3, f64)> {
        let d = to - from;
        let len = d.length();
        (len > 0.0).then(|| (d / len, len))
    }

    /// A second path between the ends of the path [`Space::connect`]
    /// gave, as its starting direction and length (the other arc of a
    /// great circle of S3), if the space has one.
    fn other_way(&self, _shortest: (DVec3, f64)) -> Option<(DVec3, f64)> {
        None
    }

    /// How many paths light takes from a light to a point: the shortest,
    /// and the other way round where [`Space::other_way`] gives one (2 in
    /// S3). Each gets its own shadow ray.
    fn paths_to_a_light(&self) -> usize {
        1 + self.other_way((DVec3::X, 1.0)).is_some() as usize
    }

    /// The area radius of a geodesic sphere of radius `d`: its area over
    /// 4 pi, squared root. Light's physical falloff is `1 / spread(d)^2`.
    fn spread(&self, d: f64) -> f64 {
        d
    }

    /// The point `distance` from `point` along `direction` (a unit vector
    /// of the frame there), for small distances: how shadow rays step off
    /// a surface.
    fn step_off(&self, point: DVec3, direction: DVec3, distance: f64) -> DVec3 {
        point + direction * distance
    }

    /// The frame components at `at` of the chart vector `chart`: the same
    /// vector where the scene's coordinates are orthonormal, as everywhere
    /// but a metric space.
    fn to_frame(&self, _at: DVec3, chart: DVec3) -> DVec3 {
        chart
    }

    /// The normal of a surface whose formula has `gradient` at `local` in
    /// the copy `image`, in the orthonormal frame there (not normalised).
    fn frame_normal(&self, image: &Image, local: DVec3, gradient: DVec3) -> DVec3 {
        image.normal(local, gradient)
    }

    /// Whether paths are integrated numerically (once for every ray, or per
    /// ray), so that surfaces are found by sampling the steps.
    fn integrates(&self) -> bool {
        self.integrator_stats().is_some() || self.path_report().is_some()
    }

    /// Where paths are integrated per ray (a metric space): how the walks
    /// so far ended and how far the unit-speed constraint drifted.
    fn path_report(&self) -> Option<PathReport> {
        None
    }

    /// For paths integrated numerically: how the integrator fared (for
    /// `nes explain` and the stress tests). `None` where paths are exact.
    fn integrator_stats(&self) -> Option<IntegratorStats> {
        None
    }

    /// A box holding every point of the paths [`Space::connect`] gives from
    /// points of `region` to a light at `light`, in the coordinates objects
    /// are written in: where a shadow's blockers can be. By default the
    /// straight segments' hull.
    fn light_reach(&self, region: Aabb, light: DVec3) -> Aabb {
        Aabb {
            min: region.min.min(light),
            max: region.max.max(light),
        }
    }

    /// A box holding every point a path of length `limit` from `origin` can
    /// reach, in the coordinates objects are written in.
    fn reach(&self, origin: DVec3, limit: f64) -> Aabb {
        Aabb {
            min: origin - DVec3::splat(limit),
            max: origin + DVec3::splat(limit),
        }
    }

    /// Whether every segment [`Space::walk`] gives is straight (has a line
    /// form), so that routes solving along lines apply.
    fn straight_paths(&self) -> bool {
        true
    }

    /// Told the box that holds every object's bound (in the scene's
    /// coordinates): no hit lies outside it, so a space whose steps are
    /// kept short for the search's sake may take long ones out there.
    fn focus(&mut self, _region: Aabb) {}

    /// Told the points many paths start or end at (the camera, the
    /// lights): a space whose paths start from a point computed from
    /// them may keep it. Paths are the same either way.
    fn remember(&mut self, _points: &[DVec3]) {}

    /// Where every path closes on itself: the length of one whole loop
    /// (drawn by `nes rays`), if paths are closed.
    fn loop_length(&self) -> Option<f64> {
        None
    }

    /// How far from the origin the scene's coordinates go before they
    /// name points again: in S3 normal coordinates about the origin reach
    /// every point within `pi R` (the origin's antipode), and beyond
    /// repeat them. `None` where coordinates name each point once (or
    /// repeat by a cell, [`Space::cell`]). Drawings stop there.
    fn chart_radius(&self) -> Option<f64> {
        None
    }

    /// The coordinates within [`Space::chart_radius`] of the point `p`
    /// names: a formula of the scene's coordinates means its point there
    /// (a ball of radius 1 at the origin of S3 holds `(-5, 0, 0)` when
    /// `R = 1`, which is `(2 pi - 5, 0, 0)`). `p` itself where coordinates
    /// name each point once.
    fn within_chart(&self, p: DVec3) -> DVec3 {
        p
    }

    /// The space's fundamental cell, if it has one, as a box with a line
    /// saying what its faces do (drawn by `nes rays`).
    fn cell(&self) -> Option<Cell> {
        None
    }
}

/// A fundamental cell: the box `[min, max]` and what happens at its faces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    /// The corner with the smallest coordinates.
    pub min: DVec3,
    /// The corner with the largest coordinates.
    pub max: DVec3,
    /// What a path does at a face, for a legend.
    pub legend: &'static str,
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
        let _ = visit(&Segment::line(origin, direction, 0.0, limit));
    }
}

/// The points at distances `ts` (ascending) along the path from `origin`
/// in `direction`, in the space's coordinates; `None` past the path's end
/// (a closed path ends after one loop).
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Numbers for people: four significant digits, no trailing zeros.
    #[test]
    fn human_numbers() {
        for (x, text) in [
            (-1.0 / 9.0, "-0.1111"),
            (0.0625, "0.0625"),
            (25.132741228718345, "25.13"),
            (100.0, "100"),
            (36.0, "36"),
            (1e-12, "1e-12"),
            (1.5e7, "1.5e7"),
            (0.0, "0"),
        ] {
            assert_eq!(human(x), text, "{x}");
        }
    }

    /// Every listed name builds its space, and the name comes back.
    #[test]
    fn every_named_space_has_defaults() {
        for name in SPACE_NAMES {
            let kind = SpaceKind::default_named(name).expect("listed spaces have defaults");
            assert_eq!(kind.name(), name);
        }
        assert_eq!(SpaceKind::default_named("flat"), None);
        assert_eq!(SpaceKind::canonical_name("S3"), Some("s3"));
        assert_eq!(SpaceKind::canonical_name(" Euclidean "), Some("euclidean"));
        assert_eq!(SpaceKind::canonical_name("flat"), None);
    }
}
