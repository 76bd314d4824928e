//! The trace stage: geometric queries on a compiled scene.
//!
//! Input: a [`Scene`] and rays (a start, a unit direction, a length).
//! Output: [`Hit`]s: the nearest hit along a path, whether any hit blocks
//! a path, the path from a point to a light, the surface normal at a hit.
//! Rays travel only through the [`Space`] interface and [`Segment`]'s
//! methods; hits are found per object by its [`Route`] (see
//! [`intersect`]). This stage knows nothing of pixels or colours: the
//! per-pixel loop that calls shading sits above it, in
//! [`crate::render`](mod@crate::render), as pbrt's integrator sits above
//! its aggregate.

pub mod intersect;

use std::ops::ControlFlow;

use glam::DVec3;

use crate::expr::Implicit;
use crate::scene::{Object, OverBox, PrunedCells, Scene, ShadowPaths};
use crate::space::{
    Aabb, Approach, ClipFor, Euclidean, Image, QuadricAhead, QuadricMeeting, Segment, Space,
};
use intersect::{Limits, Query, Scratch, Search};

pub use crate::scene::Route;

impl Route {
    /// What a range clipped for this route is searched by.
    fn clip_for(self) -> ClipFor {
        match self {
            Route::Closed => ClipFor::ClosedForm,
            _ => ClipFor::Search,
        }
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
    /// The path's direction at the hit, a unit vector of the space's
    /// frame there (see [`Segment::heading`]).
    pub direction: DVec3,
    /// Which object was hit (an index into the scene's objects).
    pub object: usize,
    /// Which of its copies (an index into [`Tracer::images_of`]).
    pub image: usize,
}

/// One path light takes to a point (see [`Tracer::light_paths`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightPath {
    /// Its unit direction at the point, in the space's frame there.
    pub direction: DVec3,
    /// Its direction as the shadow query walks it.
    pub walk: DVec3,
    /// How far along it the light is.
    pub length: f64,
}

/// Where the copies of each object stand, for one kind of path.
type Images = Vec<Vec<Image>>;

/// Everything fixed for one render's queries: the scene, its space, the
/// route of each object and the images of each object in the space,
/// decided once when the tracer is made.
pub struct Tracer<'s> {
    /// The scene traced.
    pub scene: &'s Scene,
    space: Box<dyn Space>,
    routes: Vec<Route>,
    limits: Limits,
    /// Per object, the offsets of its copies in the space.
    images: Images,
    /// One image per object, at no offset: objects as written, for
    /// straight (Euclidean) shadow rays.
    plain: Images,
    /// The objects that can be hit (those with a bound), closed-form ones
    /// first: they cheaply shorten the range that searched objects must
    /// cover.
    order: Vec<usize>,
}

impl<'s> Tracer<'s> {
    /// Decide the space, the routes and the images for `scene`.
    pub fn new(scene: &'s Scene) -> Tracer<'s> {
        let mut space = scene.build_space();
        // Bounds are in the scene's coordinates unless a motion of S3 or
        // H3 places the object.
        if scene.objects.iter().all(|o| o.placement.is_empty()) {
            let bounds = scene.objects.iter().filter_map(|o| o.bound);
            if let Some(region) = bounds.reduce(|a, b| Aabb {
                min: a.min.min(b.min),
                max: a.max.max(b.max),
            }) {
                space.focus(region);
            }
        }
        let known: Vec<DVec3> = std::iter::once(scene.camera.position)
            .chain(scene.lights.iter().map(|l| l.position))
            .collect();
        space.remember(&known);
        let routes: Vec<Route> = scene
            .objects
            .iter()
            .map(|o| Route::for_object(o, scene.settings.method, space.straight_paths()))
            .collect();
        let images = scene
            .objects
            .iter()
            .map(|o| match &o.bound {
                Some(b) => distinct_images(
                    o,
                    space
                        .images(b, &o.placement)
                        .into_iter()
                        .map(|image| image.with_shape(o.function.quadric.as_ref()))
                        .collect(),
                ),
                None => Vec::new(),
            })
            .collect();
        let plain = scene.objects.iter().map(|_| vec![Image::HERE]).collect();
        let mut order: Vec<usize> = (0..scene.objects.len())
            .filter(|&i| scene.objects[i].bound.is_some())
            .collect();
        order.sort_by_key(|&i| routes[i] != Route::Closed);
        let settings = &scene.settings;
        Tracer {
            scene,
            space,
            routes,
            limits: Limits {
                epsilon: settings.epsilon,
                max_steps: settings.max_steps,
                step: settings.step,
            },
            images,
            plain,
            order,
        }
    }

    /// The space paths are walked in (for reports and diagrams).
    pub fn space(&self) -> &dyn Space {
        self.space.as_ref()
    }

    /// The space shadow paths are walked in: the scene's own, or straight
    /// lines (`shadows euclidean`).
    pub fn shadow_space(&self) -> &dyn Space {
        if self.straight_shadows() {
            &Euclidean
        } else {
            self.space()
        }
    }

    /// Whether shadow paths are straight lines among the objects as
    /// written (`shadows euclidean`). Where the space places objects by
    /// its isometries (S3, H3) they are not written in straight-line
    /// coordinates, so shadows there always follow geodesics.
    fn straight_shadows(&self) -> bool {
        self.scene.settings.shadow_paths == ShadowPaths::Euclidean
            && !self.scene.space.places_objects()
    }

    /// Each object's route, in the scene's order.
    pub fn routes(&self) -> &[Route] {
        &self.routes
    }

    /// How many copies of each object the space holds (1 in Euclidean
    /// space; lattice images in the torus; 0 for a dropped object).
    pub fn image_counts(&self) -> Vec<usize> {
        self.images.iter().map(Vec::len).collect()
    }

    /// Where object `i`'s copies stand in the space.
    pub fn images_of(&self, i: usize) -> &[Image] {
        &self.images[i]
    }

    /// Whether the path from `origin` in `direction` meets any image of
    /// object `i`'s bound within `limit`: whether the object costs that
    /// ray any search at all.
    pub fn path_meets_bound(&self, origin: DVec3, direction: DVec3, limit: f64, i: usize) -> bool {
        let Some(bound) = &self.scene.objects[i].bound else {
            return false;
        };
        let mut meets = false;
        self.space.walk(origin, direction, limit, &mut |seg| {
            let (t0, t1) = seg.range();
            for image in &self.images[i] {
                let local = seg.seen_by(image);
                if local.clip(bound, t0, t1, ClipFor::Search).is_some() {
                    meets = true;
                    return ControlFlow::Break(());
                }
            }
            ControlFlow::Continue(())
        });
        meets
    }

    /// The nearest hit along the path from `origin` in `direction` through
    /// the scene's space, within `limit`.
    pub fn nearest_hit(
        &self,
        origin: DVec3,
        direction: DVec3,
        limit: f64,
        s: &mut Scratch,
    ) -> Option<Hit> {
        let ray = Ray {
            origin,
            direction,
            limit,
        };
        let hit = self.first_hit(self.space(), &self.images, ray, Query::Nearest, s)?;
        // Where the floats are spaced wider than epsilon, no search can
        // locate the hit that closely.
        let magnitude = hit
            .point
            .abs()
            .max_element()
            .max(hit.local.abs().max_element());
        s.trouble.imprecise |= f64::EPSILON * magnitude > self.limits.epsilon;
        Some(hit)
    }

    /// A hit that blocks the shadow path from `from` along `direction`
    /// within `length` (not necessarily the nearest): a straight path
    /// among the objects as written, or the space's path among their
    /// images, as the scene's `shadows` setting says.
    pub fn shadow_hit(
        &self,
        from: DVec3,
        direction: DVec3,
        length: f64,
        s: &mut Scratch,
    ) -> Option<Hit> {
        let ray = Ray {
            origin: from,
            direction,
            limit: length,
        };
        if self.straight_shadows() {
            self.first_hit(&Euclidean, &self.plain, ray, Query::Any, s)
        } else {
            self.first_hit(self.space(), &self.images, ray, Query::Any, s)
        }
    }

    /// Whether the shadow path from `from` along `direction` is blocked
    /// within `length`.
    pub fn blocked(&self, from: DVec3, direction: DVec3, length: f64, s: &mut Scratch) -> bool {
        self.shadow_hit(from, direction, length, s).is_some()
    }

    /// The direction towards a light at `light` from `from`, and how far
    /// along that path the light is: straight, or along the space's
    /// geodesic (`shadows geodesic`). `None` when no path reaches it.
    pub fn light_path(&self, from: DVec3, light: DVec3) -> Option<(DVec3, f64)> {
        self.shadow_space().connect(from, light)
    }

    /// How many paths [`Tracer::light_paths`] gives at most: 2 in S3, else 1.
    pub fn paths_to_a_light(&self) -> usize {
        self.shadow_space().paths_to_a_light()
    }

    /// Every path light takes from a light at `light` to `from`, shortest
    /// first: one, or in S3 both arcs of the great circle, each of which
    /// can be blocked on its own. Each is its direction at `from` in the
    /// space's frame there (what shading compares with the normal), its
    /// direction as [`Tracer::blocked`] walks it, and its length.
    pub fn light_paths(&self, from: DVec3, light: DVec3) -> [Option<LightPath>; 2] {
        let space = self.shadow_space();
        let shortest = space.connect(from, light);
        let other = shortest.and_then(|p| space.other_way(p));
        let straight = self.straight_shadows();
        [shortest, other].map(|p| {
            p.map(|(walk, length)| LightPath {
                // A straight shadow path in a chart whose coordinates are
                // not orthonormal leaves in another frame direction.
                direction: if straight {
                    self.space.to_frame(from, walk).normalize_or_zero()
                } else {
                    walk
                },
                walk,
                length,
            })
        })
    }

    /// The area radius of the geodesic sphere of radius `d` about a
    /// light, along the paths shadows take: light's physical falloff is
    /// its inverse square.
    pub fn spread(&self, d: f64) -> f64 {
        self.shadow_space().spread(d)
    }

    /// Whether the path from `point` to `light` is blocked (or missing).
    pub fn in_shadow(&self, point: DVec3, light: DVec3, s: &mut Scratch) -> bool {
        match self.light_path(point, light) {
            Some((dir, len)) => self.blocked(point, dir, len, s),
            None => true,
        }
    }

    /// The unit normal at a hit, facing back along the ray. Where the
    /// gradient is zero or not finite, the normal falls back to facing
    /// the ray.
    pub fn normal(&self, hit: &Hit, s: &mut Scratch) -> DVec3 {
        self.normal_and_side(hit, s).0
    }

    /// [`Tracer::normal`], and whether the ray sees the surface's inside
    /// (it arrives from where `f < 0`, so the outward normal had to be
    /// turned towards it).
    pub fn normal_and_side(&self, hit: &Hit, s: &mut Scratch) -> (DVec3, bool) {
        let obj = &self.scene.objects[hit.object];
        let (v, g) = obj
            .function_at(hit.local)
            .value_and_gradient(hit.local, &mut s.gradient_points);
        let g = match self.images[hit.object].get(hit.image) {
            Some(image) => self.space.frame_normal(image, hit.local, g),
            None => g,
        };
        // Safe for a formula scaled by 1e160 or 1e-200, whose gradient's
        // square over- or underflows.
        let n = crate::camera::unit_vector(g);
        s.trouble.nonfinite |= !v.is_finite() || n.is_none();
        let n = n.unwrap_or(-hit.direction);
        if n.dot(hit.direction) > 0.0 {
            (-n, true)
        } else {
            (n, false)
        }
    }

    /// Where shadow rays from `hit` start: off the surface along `normal`,
    /// above the hit's location error (epsilon) and above rounding at the
    /// hit's magnitude.
    pub fn shadow_start(&self, hit: &Hit, normal: DVec3) -> DVec3 {
        let p = hit.point;
        let bias = (16.0 * self.limits.epsilon).max(1e-9 * (1.0 + p.abs().max_element()));
        self.space.step_off(p, normal, bias)
    }

    /// The first hit along `ray` in `space` among objects at `images`.
    /// With [`Query::Any`], the search stops at the first hit found.
    fn first_hit(
        &self,
        space: &dyn Space,
        images: &Images,
        ray: Ray,
        query: Query,
        s: &mut Scratch,
    ) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        // One budget of steps per object for the whole path, however many
        // pieces (torus wraps) and images it meets.
        s.budgets.clear();
        s.budgets
            .resize(self.scene.objects.len(), self.limits.max_steps);
        s.gone.clear();
        s.gone.resize(self.scene.objects.len(), false);
        let mut ahead = self.order.len();
        space.walk(ray.origin, ray.direction, ray.limit, &mut |seg| {
            let (t0, t1) = seg.range();
            let mut nearest = t1;
            let mut found = None;
            for &i in &self.order {
                if s.gone[i] {
                    continue;
                }
                let obj = &self.scene.objects[i];
                let route = self.routes[i];
                let Some(bound) = &obj.bound else { continue };
                let single = images[i].len() == 1;
                for (k, image) in images[i].iter().enumerate() {
                    let hit_at = |t: f64| {
                        let (point, direction, local) = seg.point_heading_and_local(image, t);
                        Hit {
                            t,
                            point,
                            local,
                            direction,
                            object: i,
                            image: k,
                        }
                    };
                    match seg.approach(image, bound, t0, nearest) {
                        Approach::Maybe => {}
                        Approach::NotHere => continue,
                        Approach::Never => {
                            if single {
                                s.gone[i] = true;
                                ahead -= 1;
                            }
                            continue;
                        }
                    }
                    // Borrow the segment unless it must be moved: an
                    // integrated step is large to copy.
                    let shifted;
                    let local = if image.is_here() {
                        seg
                    } else {
                        // A ball or plane along a path that solves it
                        // whole (a copy placed by a motion, in S3 or H3):
                        // one quadratic answers the bound test, the clip
                        // and the meeting, and whether the rest of the
                        // path meets it at all.
                        let whole = match (&obj.function.quadric, obj.cutting_clip(), route) {
                            (Some(q), None, Route::Closed) => {
                                seg.quadric_ahead(image, q, t0, nearest)
                            }
                            _ => None,
                        };
                        if let Some(meeting) = whole {
                            s.evaluations += 1;
                            match meeting {
                                QuadricAhead::Never => {
                                    if single && !s.gone[i] {
                                        s.gone[i] = true;
                                        ahead -= 1;
                                    }
                                }
                                QuadricAhead::NotHere => {}
                                QuadricAhead::At(t) if t <= nearest => {
                                    nearest = t;
                                    found = Some(hit_at(t));
                                    if query == Query::Any {
                                        best = found;
                                        return ControlFlow::Break(());
                                    }
                                }
                                QuadricAhead::At(_) => {}
                            }
                            continue;
                        }
                        shifted = seg.seen_by(image);
                        // A clipped ball or plane the rest of the path
                        // never meets is dropped as well.
                        if single
                            && route == Route::Closed
                            && obj.function.quadric.as_ref().is_some_and(|q| {
                                seg.quadric_ahead(image, q, t0, nearest)
                                    == Some(QuadricAhead::Never)
                            })
                        {
                            if !s.gone[i] {
                                s.gone[i] = true;
                                ahead -= 1;
                            }
                            continue;
                        }
                        &shifted
                    };
                    // A path that has left an object behind for good skips
                    // it on every later segment, and ends once it has
                    // left them all.
                    if single && local.gone_past(bound) {
                        s.gone[i] = true;
                        ahead -= 1;
                    }
                    let Some((a, b)) = local.clip(bound, t0, nearest, route.clip_for()) else {
                        continue;
                    };
                    let Some((a, b)) = narrow_to_cells(local, route, obj, a, b) else {
                        continue;
                    };
                    s.object = i;
                    if s.budgets[i] == 0 {
                        s.trouble.out_of_steps = true;
                        continue;
                    }
                    let search = Search {
                        f: &obj.function,
                        seg: local,
                        limits: Limits {
                            max_steps: s.budgets[i],
                            ..self.limits
                        },
                        // A clipped surface's roots outside the clip are
                        // passed over, which needs each one located (but
                        // see `first_kept_root`).
                        query: if obj.cutting_clip().is_some() {
                            Query::Nearest
                        } else {
                            query
                        },
                        value_errors: obj.value_errors.as_ref(),
                        parts: &obj.parts,
                    };
                    let before = s.steps;
                    let mut search_range = |search: &Search, route: Route, a: f64, b: f64| match (
                        obj.cutting_clip(),
                        &obj.clip,
                    ) {
                        (Some(clip), _) => {
                            first_kept_root(search, query, clip, route, bound, a, b, s)
                        }
                        // A clip proven to cut the surface only within
                        // epsilon of the bound's faces still cuts a
                        // surface lying along a face (`cos(x)` in its own
                        // box, cut by a ball): a hit that near a face is
                        // checked, and one the clip removes is searched
                        // again with it.
                        (None, Some(clip)) => {
                            let t = search_object(search, route, bound, a, b, s)?;
                            let p = search.seg.point(t);
                            if bound.shrunk(self.limits.epsilon).contains(p) {
                                return Some(t);
                            }
                            s.evaluations += 1;
                            if clip.value(p, &mut s.points) <= 0.0 {
                                return Some(t);
                            }
                            let nearest = Search {
                                query: Query::Nearest,
                                ..*search
                            };
                            first_kept_root(&nearest, query, clip, route, bound, a, b, s)
                        }
                        (None, None) => search_object(search, route, bound, a, b, s),
                    };
                    let found_t = match (&obj.pruned, local.as_line()) {
                        // Cell by cell, each with its shorter formula, which
                        // may be a quadric or a polynomial there.
                        (Some(pruned), Some(line)) if route == Route::Interval => pruned
                            .first_in_runs(
                                line.start,
                                line.direction,
                                line.inverse_direction,
                                a - line.t0,
                                b - line.t0,
                                |from, to, f| {
                                    let route = Route::for_cell(f);
                                    let search = search.with_formula(f);
                                    search_range(&search, route, from + line.t0, to + line.t0)
                                },
                            ),
                        // Along a curve, piece by piece: each piece whose
                        // box lies in cells of one formula is searched with
                        // it.
                        (Some(pruned), None) if route == Route::Interval => first_in_cells_along(
                            local,
                            pruned,
                            &obj.function,
                            a,
                            b,
                            |from, to, f| {
                                let route = Route::for_cell(f);
                                let search = search.with_formula(f);
                                search_range(&search, route, from, to)
                            },
                        ),
                        _ => search_range(&search, route, a, b),
                    };
                    s.budgets[i] = s.budgets[i].saturating_sub(s.steps - before);
                    let Some(t) = found_t else {
                        continue;
                    };
                    if t <= nearest {
                        nearest = t;
                        found = Some(hit_at(t));
                        if query == Query::Any {
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
                None if ahead == 0 => ControlFlow::Break(()),
                None => ControlFlow::Continue(()),
            }
        });
        best
    }
}

/// A path to follow: from `origin` along the unit `direction` for `limit`.
#[derive(Debug, Clone, Copy)]
struct Ray {
    origin: DVec3,
    direction: DVec3,
    limit: f64,
}

/// The first hit of the search's object on its segment within `[a, b]`,
/// by `route`. Segments without boxes are sampled whatever the route; a
/// closed form the segment cannot solve falls back to isolation.
fn search_object(
    search: &Search,
    route: Route,
    bound: &Aabb,
    a: f64,
    b: f64,
    s: &mut Scratch,
) -> Option<f64> {
    if search.seg.sample_pieces(a, b).is_some() {
        return search.along_samples(bound, a, b, s);
    }
    match route {
        Route::Closed => {
            s.evaluations += 1;
            let q = search.f.quadric.as_ref()?;
            match search.seg.meet_quadric(q, a, b) {
                QuadricMeeting::Solved(t) => {
                    let t = t?;
                    // Polish where the expanded form loses digits near the
                    // line's anchor.
                    let cancels = search
                        .seg
                        .as_line()
                        .is_some_and(|line| q.cancels_at(line.start));
                    Some(if cancels { search.polish(t, s) } else { t })
                }
                QuadricMeeting::Unsolvable => search.isolate(a, b, s),
            }
        }
        Route::Polynomial => search.polynomial(a, b, s),
        Route::Union => first_of_parts(search, bound, a, b, s),
        Route::Interval => search.isolate(a, b, s),
        Route::March => search.march(a, b, search.limits.step, s),
        Route::Adaptive => search.adaptive(a, b, s),
    }
}

/// The union route (see [`Route::Union`]): from a point outside every
/// part (`f`, their minimum, positive there), the first root of `f` is the
/// first of the parts' first roots, each part searched only up to the
/// first root found so far. From inside a part, or where a path curves,
/// `f` is isolated as written.
fn first_of_parts(search: &Search, bound: &Aabb, a: f64, b: f64, s: &mut Scratch) -> Option<f64> {
    let parts = match search.f.union.as_deref() {
        Some(parts) if search.seg.as_line().is_some() => parts,
        _ => return search.isolate(a, b, s),
    };
    s.evaluations += 1;
    let start = search.f.value(search.seg.point(a), &mut s.points);
    // NaN (undefined there) and inside alike.
    if start.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return search.isolate(a, b, s);
    }
    let mut first = None;
    let mut end = b;
    for (k, part) in parts.iter().enumerate() {
        let route = Route::for_cell(part);
        // Only where the path meets the part's own box, when it has one.
        let aids = search.parts.get(k);
        let (own, from, to) = match aids.map(|p| &p.bound) {
            Some(None) => continue,
            Some(Some(own)) => match search.seg.clip(own, a, end, route.clip_for()) {
                Some((from, to)) => (own, from, to),
                None => continue,
            },
            None => (bound, a, end),
        };
        let part_search = Search {
            value_errors: aids.and_then(|p| p.value_errors.as_ref()),
            ..search.with_formula(part)
        };
        if let Some(t) = search_object(&part_search, route, own, from, to, s) {
            if search.query == Query::Any {
                return Some(t);
            }
            if t <= end {
                (first, end) = (Some(t), t);
            }
        }
    }
    first
}

/// The first root in `[a, b]` where `clip` is negative or zero: roots
/// outside the clip are stepped over and the search goes on past them.
/// Each retry is charged a step, so the ray's budget bounds them. Where a
/// quadric clip narrows a line to the one range it keeps, every root
/// there is kept, so a shadow ray (`query` [`Query::Any`]) takes any
/// root found there; should that one still fall outside the clip (by
/// rounding at the range's ends), the range is searched again root by
/// root, so no root inside is passed over.
#[allow(clippy::too_many_arguments)]
fn first_kept_root(
    search: &Search,
    query: Query,
    clip: &Implicit,
    route: Route,
    bound: &Aabb,
    a: f64,
    b: f64,
    s: &mut Scratch,
) -> Option<f64> {
    // A quadric clip (a ball, a half-space) along a line, or a ball along
    // a geodesic of S3 or H3, keeps one range of the path, known in
    // closed form: only that is searched.
    let (mut from, mut b) = (a, b);
    if let Some(q) = &clip.quadric {
        if let Some(kept) = search.seg.quadric_keeps(q, a, b) {
            (from, b) = kept?;
            if query == Query::Any {
                let any = Search {
                    query: Query::Any,
                    ..*search
                };
                let t = search_object(&any, route, bound, from, b, s)?;
                s.evaluations += 1;
                if clip.value(search.seg.point(t), &mut s.points) <= 0.0 {
                    return Some(t);
                }
            }
        }
    }
    let start = s.steps;
    loop {
        let t = search_object(search, route, bound, from, b, s)?;
        s.evaluations += 1;
        if clip.value(search.seg.point(t), &mut s.points) <= 0.0 {
            return Some(t);
        }
        s.steps += 1;
        if s.steps - start >= search.limits.max_steps {
            s.trouble.out_of_steps = true;
            return None;
        }
        // Past the root found, by more than its location error.
        from = t + 4.0 * search.limits.epsilon + 4.0 * f64::EPSILON * t.abs();
        if from >= b {
            return None;
        }
    }
}

/// The first of `visit(from, to, f)` over the pieces of `[a, b]` of a
/// curved `seg`, in order, each with the formula that serves its box
/// (see [`PrunedCells::formula_over`]); pieces in empty cells are passed
/// over, a piece whose cells need different formulas is halved until it
/// is about an eighth of a cell long, then searched with `full`, and
/// neighbours with one formula are searched as one.
fn first_in_cells_along<'f, T>(
    seg: &Segment,
    pruned: &'f PrunedCells,
    full: &'f Implicit,
    a: f64,
    b: f64,
    mut visit: impl FnMut(f64, f64, &Implicit) -> Option<T>,
) -> Option<T> {
    let cell = pruned.cell_size().min_element();
    let halvings = ((b - a) / (cell / 8.0)).log2().ceil().clamp(0.0, 16.0) as u32;
    let mut run: Option<(f64, f64, &'f Implicit)> = None;
    let mut piece = |from: f64, to: f64, f: Option<&'f Implicit>| -> Option<T> {
        if let (Some((start, end, g)), Some(f)) = (run, f) {
            if std::ptr::eq(f, g) && end == from {
                run = Some((start, to, g));
                return None;
            }
        }
        let found = run.and_then(|(start, end, g)| visit(start, end, g));
        run = f.map(|f| (from, to, f));
        found
    };
    let found = pieces_in_cells(seg, pruned, full, a, b, halvings, &mut piece);
    found.or_else(|| piece(b, b, None))
}

/// [`first_in_cells_along`]'s pieces in order, to `piece(from, to, f)`,
/// with `None` for a piece in empty cells.
fn pieces_in_cells<'f, T>(
    seg: &Segment,
    pruned: &'f PrunedCells,
    full: &'f Implicit,
    a: f64,
    b: f64,
    halvings: u32,
    piece: &mut impl FnMut(f64, f64, Option<&'f Implicit>) -> Option<T>,
) -> Option<T> {
    let Some(bounds) = seg.point_bounds(a, b) else {
        return piece(a, b, Some(full));
    };
    match pruned.formula_over(bounds.min, bounds.max) {
        OverBox::Empty => piece(a, b, None),
        OverBox::One(f) => piece(a, b, Some(f)),
        OverBox::Mixed if halvings == 0 => piece(a, b, Some(full)),
        OverBox::Mixed => {
            let m = 0.5 * (a + b);
            pieces_in_cells(seg, pruned, full, a, m, halvings - 1, piece)
                .or_else(|| pieces_in_cells(seg, pruned, full, m, b, halvings - 1, piece))
        }
    }
}

/// For interval isolation along a line: the part of `[a, b]` between the
/// first and last cell of the object's grid that may hold surface. The
/// seed's marching methods keep their whole range, as the report has them.
/// The polynomial route keeps it too: it solves a range at once, whatever
/// its length, and the two walks through the grid cost more than the
/// searches they saved (the gallery's renders, one thread, best of three:
/// Cayley's cubic 0.47 -> 0.31 s, Kummer's quartic 0.62 -> 0.43
/// s, Chmutov's octic 0.72 -> 0.66 s; no polynomial scene slower).
#[inline]
fn narrow_to_cells(
    seg: &Segment,
    route: Route,
    obj: &Object,
    a: f64,
    b: f64,
) -> Option<(f64, f64)> {
    match (seg.as_line(), route, &obj.cells) {
        (Some(line), Route::Interval, Some(cells)) => cells
            .narrow(
                line.start,
                line.direction,
                line.inverse_direction,
                a - line.t0,
                b - line.t0,
            )
            .map(|(a, b)| (a + line.t0, b + line.t0)),
        _ => Some((a, b)),
    }
}

/// Drop images that coincide with another: a plane or cylinder moved
/// along itself is the same surface, and would be tested twice.
/// Of equal images the one nearest the cell is kept, since bounds are
/// tested against the shifted path.
fn distinct_images(obj: &Object, images: Vec<Image>) -> Vec<Image> {
    let Some(q) = &obj.function.quadric else {
        return images;
    };
    let Some(mut images) = images
        .iter()
        .map(|i| i.as_offset())
        .collect::<Option<Vec<DVec3>>>()
    else {
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
    kept.into_iter().map(Image::offset).collect()
}
