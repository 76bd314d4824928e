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

use crate::scene::{Method, Object, Scene};
use crate::shade;
use crate::space::{self, Segment, Space};
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
            Method::Auto | Method::Exact | Method::Interval => Route::Interval,
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

/// A ray's first hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance travelled along the path.
    pub t: f64,
    pub point: DVec3,
    /// The path's direction at the hit.
    pub direction: DVec3,
    pub object: usize,
}

/// Rows per unit of parallel work (and per cancellation check).
const BAND: u32 = 8;

/// Everything fixed for one render: the scene, its space and the route of
/// each object, decided once.
pub struct Tracer<'s> {
    pub scene: &'s Scene,
    space: Box<dyn Space>,
    routes: Vec<Route>,
}

impl<'s> Tracer<'s> {
    pub fn new(scene: &'s Scene) -> Tracer<'s> {
        let routes = scene
            .objects
            .iter()
            .map(|o| Route::for_object(o, scene.settings.method))
            .collect();
        Tracer {
            scene,
            space: space::for_scene(scene.space),
            routes,
        }
    }

    pub fn routes(&self) -> &[Route] {
        &self.routes
    }

    /// The first hit along the path from `origin` in `direction`, within
    /// `limit`. With `any`, the search stops at the first hit found, not
    /// necessarily the nearest (for shadow rays).
    pub fn first_hit(
        &self,
        origin: DVec3,
        direction: DVec3,
        limit: f64,
        any: bool,
        s: &mut Scratch,
    ) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        self.space.walk(origin, direction, limit, &mut |seg| {
            let Segment::Line {
                origin: o,
                direction: d,
                t0,
                t1,
            } = *seg;
            let inv_d = d.recip();
            let mut nearest = t1;
            let mut found = None;
            // Closed-form objects first: they cheaply shorten the range
            // that the searched objects must cover.
            for pass in [true, false] {
                for (i, obj) in self.scene.objects.iter().enumerate() {
                    let route = self.routes[i];
                    if (route == Route::Closed) != pass {
                        continue;
                    }
                    let Some(bound) = &obj.bound else { continue };
                    let Some((a, b)) = bound.clip(o, inv_d, t0, nearest) else {
                        continue;
                    };
                    if let Some(t) = self.intersect(obj, route, o, d, a, b, s) {
                        if t <= nearest {
                            nearest = t;
                            found = Some(Hit {
                                t,
                                point: o + t * d,
                                direction: d,
                                object: i,
                            });
                            if any {
                                best = found;
                                return ControlFlow::Break(());
                            }
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

    #[allow(clippy::too_many_arguments)]
    fn intersect(
        &self,
        obj: &Object,
        route: Route,
        o: DVec3,
        d: DVec3,
        a: f64,
        b: f64,
        s: &mut Scratch,
    ) -> Option<f64> {
        let st = &self.scene.settings;
        match route {
            Route::Closed => {
                s.evaluations += 1;
                intersect::quadric(obj.function.quadric.as_ref()?, o, d, a, b)
            }
            Route::Interval => {
                intersect::isolate(&obj.function, o, d, a, b, st.epsilon, st.max_steps, s)
            }
            Route::March => intersect::march(
                &obj.function,
                o,
                d,
                a,
                b,
                st.step,
                st.epsilon,
                st.max_steps,
                s,
            ),
            Route::Adaptive => intersect::adaptive(
                &obj.function,
                o,
                d,
                a,
                b,
                st.step,
                st.epsilon,
                st.max_steps,
                s,
            ),
        }
    }

    /// Whether the straight segment from `point` to `light` is blocked.
    pub fn in_shadow(&self, point: DVec3, light: DVec3, s: &mut Scratch) -> bool {
        let to_light = light - point;
        let dist = to_light.length();
        if dist == 0.0 {
            return false;
        }
        self.first_hit(point, to_light / dist, dist, true, s)
            .is_some()
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
            let st = st.ok_or(Cancelled)?;
            stats.primary_rays += st.primary_rays;
            stats.shadow_rays += st.shadow_rays;
            stats.evaluations += st.evaluations;
            stats.nonfinite_pixels += st.nonfinite_pixels;
        }
        Ok((image, stats))
    }
}

/// Render a scene with default options.
pub fn render(scene: &Scene) -> (Image, RenderStats) {
    Tracer::new(scene)
        .render(&TraceOptions::default())
        .expect("no cancel token, so no cancellation")
}
