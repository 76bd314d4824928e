//! The trace stage: a compiled scene to an image in memory.
//!
//! Input: a [`Scene`] and [`TraceOptions`]. Output: an [`Image`] of linear
//! colours and [`RenderStats`]. Rays travel through the scene's space (only
//! through the [`Space`] interface); hits are found per object by its
//! route; pixels are shaded by [`crate::shade`]. Tiles are traced in
//! parallel with rayon. This stage does no I/O: progress and cancellation
//! go through the options.

pub mod intersect;

use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use crate::scene::{Aabb, Method, Object, Scene, ShadowPaths};
use crate::shade;
use crate::space::{self, Euclidean, Segment, Space};
use intersect::Scratch;

/// How one object's hits are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Route {
    /// Closed form: the object is a plane or a quadric.
    Closed,
    /// Guaranteed interval root isolation.
    Interval,
    /// The seed's fixed-step marching.
    March,
    /// The seed's adaptive marching.
    Adaptive,
}

impl Route {
    pub fn for_object(object: &Object, method: Method) -> Route {
        let closed = object.function.quadric.is_some();
        match method {
            Method::Auto | Method::Exact if closed => Route::Closed,
            Method::Auto | Method::Exact | Method::Interval | Method::Ode => Route::Interval,
            Method::March => Route::March,
            Method::Adaptive => Route::Adaptive,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Route::Closed => "closed form",
            Route::Interval => "interval root isolation",
            Route::March => "fixed-step march",
            Route::Adaptive => "adaptive march",
        }
    }
}

/// What the caller can control while a render runs.
#[derive(Default)]
pub struct TraceOptions<'a> {
    /// Checked before each band of rows; when set, the render stops and
    /// returns [`Cancelled`].
    pub cancel: Option<&'a AtomicBool>,
    /// Called after each band with (bands done, bands in all).
    pub progress: Option<&'a (dyn Fn(usize, usize) + Sync)>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cancelled;

/// Linear RGB pixels, row by row from the top.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<DVec3>,
}

impl Image {
    pub fn pixel(&self, x: u32, y: u32) -> DVec3 {
        self.pixels[(y * self.width + x) as usize]
    }
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RenderStats {
    pub primary_rays: u64,
    pub shadow_rays: u64,
    /// Evaluations of object functions (point and interval).
    pub evaluations: u64,
    /// Pixels where a sample met a non-finite value and fell back to the
    /// background colour.
    pub nonfinite_pixels: u64,
}

impl std::ops::AddAssign for RenderStats {
    fn add_assign(&mut self, o: RenderStats) {
        self.primary_rays += o.primary_rays;
        self.shadow_rays += o.shadow_rays;
        self.evaluations += o.evaluations;
        self.nonfinite_pixels += o.nonfinite_pixels;
    }
}

/// A ray's first hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance travelled along the path.
    pub t: f64,
    /// Where the hit is, in the space's coordinates (in the torus, inside
    /// the fundamental cell).
    pub point: DVec3,
    /// The same point in the coordinates of the object's image that was
    /// hit: where its function and gradient are evaluated.
    pub local: DVec3,
    /// The path's direction at the hit.
    pub direction: DVec3,
    pub object: usize,
}

/// Rows per unit of parallel work (and per cancellation check).
const BAND: u32 = 8;

/// Everything fixed for one render: the scene, its space, the route of
/// each object and the images of each object in the space, decided once.
pub struct Tracer<'s> {
    pub scene: &'s Scene,
    space: Box<dyn Space>,
    routes: Vec<Route>,
    /// Per object, the offsets of its copies in the space.
    images: Vec<Vec<DVec3>>,
    /// One image per object, at no offset: objects as written, for
    /// straight (Euclidean) shadow rays.
    plain: Vec<Vec<DVec3>>,
    /// The objects that can be hit (those with a bound), closed-form ones
    /// first: they cheaply shorten the range that searched objects must
    /// cover.
    order: Vec<usize>,
}

impl<'s> Tracer<'s> {
    pub fn new(scene: &'s Scene) -> Tracer<'s> {
        let routes: Vec<Route> = scene
            .objects
            .iter()
            .map(|o| Route::for_object(o, scene.settings.method))
            .collect();
        let space = space::for_scene(scene);
        let images = scene
            .objects
            .iter()
            .map(|o| match &o.bound {
                Some(b) => distinct_images(o, space.images(b)),
                None => Vec::new(),
            })
            .collect();
        let plain = scene.objects.iter().map(|_| vec![DVec3::ZERO]).collect();
        let mut order: Vec<usize> = (0..scene.objects.len())
            .filter(|&i| scene.objects[i].bound.is_some())
            .collect();
        order.sort_by_key(|&i| routes[i] != Route::Closed);
        Tracer {
            scene,
            space,
            routes,
            images,
            plain,
            order,
        }
    }

    /// The space paths are walked in (for reports, not for looking inside).
    pub fn space(&self) -> &dyn Space {
        self.space.as_ref()
    }

    pub fn routes(&self) -> &[Route] {
        &self.routes
    }

    /// How many copies of each object the space holds (1 in Euclidean
    /// space; lattice images in the torus; 0 for a dropped object).
    pub fn image_counts(&self) -> Vec<usize> {
        self.images.iter().map(Vec::len).collect()
    }

    /// Whether the path from `origin` in `direction` meets any image of
    /// object `i`'s bound within `limit`: whether the object costs that
    /// ray any search at all.
    pub fn path_meets_bound(&self, origin: DVec3, direction: DVec3, limit: f64, i: usize) -> bool {
        let Some(bound) = &self.scene.objects[i].bound else {
            return false;
        };
        let inv_d = direction.recip();
        let mut meets = false;
        self.space.walk(origin, direction, limit, &mut |seg| {
            let (t0, t1) = seg.range();
            for &offset in &self.images[i] {
                let local = seg.shifted(offset);
                if clip(&local, Route::Interval, bound, inv_d, t0, t1).is_some() {
                    meets = true;
                    return ControlFlow::Break(());
                }
            }
            ControlFlow::Continue(())
        });
        meets
    }

    /// The first hit along the path from `origin` in `direction` through
    /// the scene's space, within `limit`. With `any`, the search stops at
    /// the first hit found, not necessarily the nearest (for shadow rays).
    pub fn first_hit(
        &self,
        origin: DVec3,
        direction: DVec3,
        limit: f64,
        any: bool,
        s: &mut Scratch,
    ) -> Option<Hit> {
        self.first_hit_in(&*self.space, &self.images, origin, direction, limit, any, s)
    }

    #[allow(clippy::too_many_arguments)]
    fn first_hit_in(
        &self,
        space: &dyn Space,
        images: &[Vec<DVec3>],
        origin: DVec3,
        direction: DVec3,
        limit: f64,
        any: bool,
        s: &mut Scratch,
    ) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        space.walk(origin, direction, limit, &mut |seg| {
            let (t0, t1) = seg.range();
            let inv_d = direction.recip();
            let mut nearest = t1;
            let mut found = None;
            for &i in &self.order {
                let obj = &self.scene.objects[i];
                let route = self.routes[i];
                let Some(bound) = &obj.bound else { continue };
                for &offset in &images[i] {
                    // Borrow the segment unless it must be moved: an
                    // integrated step is large to copy.
                    let shifted;
                    let local = if offset == DVec3::ZERO {
                        seg
                    } else {
                        shifted = seg.shifted(offset);
                        &shifted
                    };
                    let Some((a, b)) = clip(local, route, bound, inv_d, t0, nearest) else {
                        continue;
                    };
                    let Some((a, b)) = narrow_to_cells(local, route, obj, inv_d, a, b) else {
                        continue;
                    };
                    s.object = i;
                    let Some(t) = self.intersect(obj, route, local, a, b, !any, s) else {
                        continue;
                    };
                    if t <= nearest {
                        nearest = t;
                        found = Some(Hit {
                            t,
                            point: seg.point(t),
                            local: local.point(t),
                            direction: seg.direction(t),
                            object: i,
                        });
                        if any {
                            best = found;
                            return ControlFlow::Break(());
                        }
                    }
                }
            }
            match found {
                Some(h) => {
                    best = Some(h);
                    ControlFlow::Break(())
                }
                None => ControlFlow::Continue(()),
            }
        });
        best
    }

    /// The first hit of `obj` on `seg` within `[a, b]`. Without `precise`
    /// (shadow rays, which only ask whether there is one), interval
    /// isolation returns a point of the first piece proven to hold a root
    /// instead of refining it.
    #[allow(clippy::too_many_arguments)]
    fn intersect(
        &self,
        obj: &Object,
        route: Route,
        seg: &Segment,
        a: f64,
        b: f64,
        precise: bool,
        s: &mut Scratch,
    ) -> Option<f64> {
        let st = &self.scene.settings;
        let f = &obj.function;
        match (route, seg) {
            (_, Segment::Dense(step)) => {
                let bound = obj.bound.as_ref()?;
                intersect::dense(f, step, seg, bound, a, b, st.epsilon, s)
            }
            (
                Route::Closed,
                Segment::Line {
                    start,
                    direction,
                    t0,
                    ..
                },
            ) => {
                s.evaluations += 1;
                let q = f.quadric.as_ref()?;
                let t = intersect::quadric(q, *start, *direction, a - t0, b - t0)? + t0;
                Some(if q.cancels_at(*start) {
                    intersect::polish(f, seg, t, s)
                } else {
                    t
                })
            }
            (
                Route::Closed,
                Segment::Arc {
                    centre,
                    radius,
                    start,
                    tangent,
                    ..
                },
            ) => {
                s.evaluations += 1;
                match intersect::quadric_on_circle(
                    f.quadric.as_ref()?,
                    *centre,
                    *radius,
                    *start,
                    *tangent,
                    a,
                    b,
                ) {
                    Some(hit) => hit,
                    None => intersect::isolate(f, seg, a, b, st.epsilon, st.max_steps, precise, s),
                }
            }
            (Route::Interval, _) => {
                intersect::isolate(f, seg, a, b, st.epsilon, st.max_steps, precise, s)
            }
            (Route::March, _) => {
                intersect::march(f, seg, a, b, st.step, st.epsilon, st.max_steps, s)
            }
            (Route::Adaptive, _) => {
                intersect::adaptive(f, seg, a, b, st.step, st.epsilon, st.max_steps, s)
            }
        }
    }

    /// The direction towards a light at `light` from `from`, and how far
    /// along that path the light is: straight, or along the space's
    /// geodesic (`shadows geodesic`). `None` when no path reaches it.
    pub fn light_path(&self, from: DVec3, light: DVec3) -> Option<(DVec3, f64)> {
        match self.scene.settings.shadow_paths {
            ShadowPaths::Euclidean => Euclidean.connect(from, light),
            ShadowPaths::Geodesic => self.space.connect(from, light),
        }
    }

    /// Whether the path from `from` along `direction` is blocked within
    /// `length`: a straight path among the objects as written, or the
    /// space's path among their images.
    pub fn blocked(&self, from: DVec3, direction: DVec3, length: f64, s: &mut Scratch) -> bool {
        self.shadow_hit(from, direction, length, s).is_some()
    }

    /// A hit that blocks the shadow path (not necessarily the nearest).
    pub fn shadow_hit(
        &self,
        from: DVec3,
        direction: DVec3,
        length: f64,
        s: &mut Scratch,
    ) -> Option<Hit> {
        match self.scene.settings.shadow_paths {
            ShadowPaths::Euclidean => {
                self.first_hit_in(&Euclidean, &self.plain, from, direction, length, true, s)
            }
            ShadowPaths::Geodesic => self.first_hit(from, direction, length, true, s),
        }
    }

    /// The offsets of object `i`'s copies in the space (its point `p`
    /// appears at `p + offset`).
    pub fn images_of(&self, i: usize) -> &[DVec3] {
        &self.images[i]
    }

    /// Whether the straight or geodesic path from `point` to `light` is
    /// blocked (or missing).
    pub fn in_shadow(&self, point: DVec3, light: DVec3, s: &mut Scratch) -> bool {
        match self.light_path(point, light) {
            Some((dir, len)) => self.blocked(point, dir, len, s),
            None => true,
        }
    }

    /// The linear colour seen along one primary ray, and whether a
    /// non-finite value had to be replaced.
    pub fn trace_ray(
        &self,
        direction: DVec3,
        s: &mut Scratch,
        stats: &mut RenderStats,
    ) -> (DVec3, bool) {
        stats.primary_rays += 1;
        let origin = self.scene.camera.position;
        match self.first_hit(
            origin,
            direction,
            self.scene.settings.max_distance,
            false,
            s,
        ) {
            None => (self.scene.background, false),
            Some(hit) => {
                let c = shade::shade(self, &hit, s, stats);
                if c.is_finite() {
                    (c, false)
                } else {
                    (self.scene.background, true)
                }
            }
        }
    }

    /// Render the whole image, in bands of rows traced in parallel.
    pub fn render(&self, options: &TraceOptions) -> Result<(Image, RenderStats), Cancelled> {
        let cam = &self.scene.camera;
        let rays = cam.rays();
        let (w, h) = (cam.width, cam.height);
        let mut image = Image {
            width: w,
            height: h,
            pixels: vec![DVec3::ZERO; (w * h) as usize],
        };
        let total = h.div_ceil(BAND) as usize;
        let done = AtomicU64::new(0);
        let grid = (self.scene.settings.samples as f64).sqrt().ceil() as u32;
        let band_stats: Vec<Option<RenderStats>> = image
            .pixels
            .par_chunks_mut((w * BAND) as usize)
            .enumerate()
            .map_init(Scratch::default, |s, (band, pixels)| {
                if options.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                    return None;
                }
                let mut stats = RenderStats::default();
                let y0 = band as u32 * BAND;
                for (i, out) in pixels.iter_mut().enumerate() {
                    let (x, y) = (i as u32 % w, y0 + i as u32 / w);
                    let mut sum = DVec3::ZERO;
                    let mut broken = false;
                    for sy in 0..grid {
                        for sx in 0..grid {
                            let px = x as f64 + (sx as f64 + 0.5) / grid as f64;
                            let py = y as f64 + (sy as f64 + 0.5) / grid as f64;
                            let (c, bad) = self.trace_ray(rays.direction(px, py), s, &mut stats);
                            sum += c;
                            broken |= bad;
                        }
                    }
                    stats.nonfinite_pixels += broken as u64;
                    *out = sum / (grid * grid) as f64;
                }
                stats.evaluations = std::mem::take(&mut s.evaluations);
                let n = done.fetch_add(1, Ordering::Relaxed) as usize + 1;
                if let Some(p) = options.progress {
                    p(n, total);
                }
                Some(stats)
            })
            .collect();
        let mut stats = RenderStats::default();
        for st in band_stats {
            stats += st.ok_or(Cancelled)?;
        }
        Ok((image, stats))
    }
}

/// The range of `seg` within `[t0, t1]` that can reach `bound`: exact for
/// lines, the whole range for arcs whose box meets the bound, and the
/// whole range for integrated steps. The line case is a few operations on
/// every ray and object, so it is inlined; the others are not.
#[inline(always)]
fn clip(
    seg: &Segment,
    route: Route,
    bound: &Aabb,
    inv_d: DVec3,
    t0: f64,
    t1: f64,
) -> Option<(f64, f64)> {
    match seg {
        Segment::Line { start, t0: s0, .. } => bound
            .clip(*start, inv_d, t0 - s0, t1 - s0)
            .map(|(a, b)| (a + s0, b + s0)),
        _ => clip_curve(seg, route, bound, t0, t1),
    }
}

#[inline(never)]
fn clip_curve(seg: &Segment, route: Route, bound: &Aabb, t0: f64, t1: f64) -> Option<(f64, f64)> {
    match seg {
        Segment::Line { .. } => unreachable!("lines are clipped inline"),
        // A closed-form solve on a circle is cheaper than boxing the arc.
        Segment::Arc { .. } if route == Route::Closed => Some((t0, t1)),
        Segment::Arc { .. } => narrow_arc(seg, bound, t0, t1),
        Segment::Dense(_) => {
            let bx = seg.point_bounds(t0, t1)?;
            let overlap = bx.min.cmple(bound.max).all() && bx.max.cmpge(bound.min).all();
            overlap.then_some((t0, t1))
        }
    }
}

/// For interval isolation along a line: the part of `[a, b]` between the
/// first and last cell of the object's grid that may hold surface. The
/// seed's marching methods keep their whole range, as the report has them.
#[inline]
fn narrow_to_cells(
    seg: &Segment,
    route: Route,
    obj: &Object,
    inv_d: DVec3,
    a: f64,
    b: f64,
) -> Option<(f64, f64)> {
    match (seg, route, &obj.cells) {
        (
            Segment::Line {
                start,
                direction,
                t0,
                ..
            },
            Route::Interval,
            Some(cells),
        ) => cells
            .narrow(*start, *direction, inv_d, a - t0, b - t0)
            .map(|(a, b)| (a + t0, b + t0)),
        _ => Some((a, b)),
    }
}

/// The part of an arc that can meet `bound`: the arc is cut into pieces,
/// and the range runs from the first piece whose box meets the bound to
/// the last. Keeps searches (and marching) off the rest of the loop.
fn narrow_arc(seg: &Segment, bound: &Aabb, t0: f64, t1: f64) -> Option<(f64, f64)> {
    const PIECES: usize = 32;
    let meets = |a: f64, b: f64| {
        seg.point_bounds(a, b)
            .is_some_and(|bx| bx.min.cmple(bound.max).all() && bx.max.cmpge(bound.min).all())
    };
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

/// Drop images that coincide with another: a plane or cylinder moved
/// along itself is the same surface, and would be tested twice.
/// Of equal images the one nearest the cell is kept, since bounds are
/// tested against the shifted path.
fn distinct_images(obj: &Object, mut images: Vec<DVec3>) -> Vec<DVec3> {
    let Some(q) = &obj.function.quadric else {
        return images;
    };
    images.sort_by(|a, b| a.length_squared().total_cmp(&b.length_squared()));
    let mut kept: Vec<DVec3> = Vec::new();
    for off in images {
        // q(p - a) = q(p - b) for all p iff M (a - b) = 0 and the linear
        // and constant parts agree, which for a shift reduces to
        // M delta = 0 and b . delta = 0 (relative to the scale).
        let same = kept.iter().any(|k| {
            let delta = off - *k;
            let scale =
                (q.m.abs()
                    .to_cols_array()
                    .iter()
                    .copied()
                    .fold(0.0, f64::max)
                    + q.b.abs().max_element())
                .max(1e-300)
                    * delta.length().max(1e-300);
            (q.m * delta).abs().max_element() <= 1e-12 * scale
                && q.b.dot(delta).abs() <= 1e-12 * scale
        });
        if !same {
            kept.push(off);
        }
    }
    kept
}

/// Render a scene with default options.
pub fn render(scene: &Scene) -> (Image, RenderStats) {
    Tracer::new(scene)
        .render(&TraceOptions::default())
        .expect("no cancel token, so no cancellation")
}
