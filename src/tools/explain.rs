//! `nes explain`: the render plan, in words.
//!
//! Input: a checked [`Scene`]. Output: a [`Plan`] (printable) saying, per
//! object, how large its expression is before and after simplification,
//! how its hits are found, its bound and how many rays reach it; what the
//! renderer skips and why; and the work per ray, measured on a small
//! sample render. Everything here is decided at compile time except the
//! measured figures.

use std::fmt;

use glam::DVec3;

use crate::scene::{Method, Scene};
use crate::space::Aabb;
use crate::trace::{Route, Tracer};

/// Width of the sample render that measures the work per ray.
const SAMPLE_WIDTH: u32 = 120;
/// The most steps a search of the sample render may take (the scene's own
/// `max_steps` when lower).
const SAMPLE_MAX_STEPS: u64 = 2_000;
/// Width of the coverage grid (paths tested against every object's bound).
const COVERAGE_WIDTH: u32 = 64;
/// Width of the pilot grid that measures how many integrator steps a path
/// of an integrated space takes.
const PILOT_WIDTH: u32 = 8;
/// The integrator steps that the coverage grid and the sample render may
/// each take, about a second or two: a metric whose paths take thousands
/// of steps gets smaller grids, so `explain` stays quick beside the render
/// it explains.
const GRID_STEPS: f64 = 2e6;
/// The operations per evaluation of a geodesic equation that [`GRID_STEPS`]
/// is counted in; a longer equation's steps count for more.
const TYPICAL_STEP_OPERATIONS: f64 = 64.0;

/// The render plan of a scene, as [`plan`] decides it: its `Display` is what
/// `nes explain` prints. Every part is a list of printable lines.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The scene at a glance: counts, space, method, image size, epsilon and
    /// reach; whether it is animated; how the integrator fared, for `method ode`.
    pub header: Vec<String>,
    /// One entry per object, in the scene's order.
    pub objects: Vec<ObjectPlan>,
    /// What the renderer skips, and why, one sentence each.
    pub skips: Vec<String>,
    /// The work per ray, measured on a small sample render (at most 120 pixels
    /// wide, one sample per pixel), and the estimate for the full render.
    pub work: Vec<String>,
}

/// How one object is rendered.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectPlan {
    /// The solid as written, e.g. `sphere(1) translate (0, 0, 1)`.
    pub label: String,
    /// Nodes of its expression as written (with transforms folded in), before
    /// simplification; constants and inputs count too, and a repeated
    /// subexpression counts once.
    pub written: usize,
    /// Nodes after simplification, counted the same way.
    pub simplified: usize,
    /// Operations of its value tape (constants and inputs not counted).
    pub value_ops: usize,
    /// Operations of its gradient tape (value and gradient together).
    pub gradient_ops: usize,
    /// How its hits are found, in words.
    pub route: String,
    /// Its bound; `None` when no ray can reach its surface and it is dropped.
    pub bound: Option<Aabb>,
    /// How many copies of it the space holds (1 in Euclidean space, lattice
    /// images in the torus, 0 when dropped).
    pub images: usize,
    /// Fraction of primary rays whose path meets the bound.
    pub reached: f64,
    /// Operations of its `clip` formula, if it has one.
    pub clip_ops: Option<usize>,
    /// Whether the clip may cut the surface where rays reach it (else
    /// the searches pass it over).
    pub clip_cuts: bool,
    /// When sampling shows its bound looser than its surface: what and why.
    pub loose: Option<String>,
    /// Its shorter formulas per cell, if it has them: how many, over how
    /// many cells, and their mean operations.
    pub cells: Option<(usize, usize, usize, f64)>,
}

/// The plan for `scene` as it would render now.
pub fn plan(scene: &Scene) -> Plan {
    let tracer = Tracer::new(scene);
    let settings = &scene.settings;
    // `method ode` integrates paths whatever the space block says.
    let integrated = tracer.space().integrates();
    let header = vec![
        format!(
            "{} object{}, {} light{}, {} space, method {}",
            scene.objects.len(),
            plural(scene.objects.len()),
            scene.lights.len(),
            plural(scene.lights.len()),
            scene.space_description(),
            settings.method.name()
        ),
        format!(
            "{} x {} pixels, {} sample{} per pixel, epsilon {:e}, {}",
            scene.camera.width,
            scene.camera.height,
            settings.samples,
            plural(settings.samples as usize),
            settings.epsilon,
            scene
                .space
                .ray_end(settings.max_distance, scene.camera.position)
        ),
    ];

    let mut header = header;
    if scene.animated {
        header.push(
            "animated: the scene reads `time` or `frame`; this plan is for frame 0 \
             (`nes render --frames A..B` renders the others)"
                .to_string(),
        );
    }
    if let Some(stats) = tracer.space().integrator_stats() {
        header.push(format!(
            "geodesics integrated once for every ray: one loop in {} DOPRI5 steps ({} rejected and retried)",
            stats.accepted, stats.rejected
        ));
    }

    // A step of a long geodesic equation costs more: grids are sized by
    // steps of a typical one's length.
    let weight = scene
        .space
        .operations_per_step()
        .map_or(1.0, |ops| (ops as f64 / TYPICAL_STEP_OPERATIONS).max(1.0));
    let steps = steps_per_path(scene, &tracer, weight);
    let cost = steps.map(|s| s * weight);
    let before = tracer.space().path_report().unwrap_or_default();
    let reached = coverage(scene, &tracer, cost);
    if let Some(derivation) = scene.space.derivation() {
        header.push(derivation);
        if let Some(r) = tracer.space().path_report().map(|r| r.since(&before)) {
            header.push(format!(
                "primary rays of the coverage sample (a coarse grid, as `reached by` below): {}",
                r.summary()
            ));
            if r.ended_early() > 0 {
                header.push(format!(
                    "primary rays of the coverage sample: {}",
                    r.ended_early_warning()
                ));
            }
        }
    }
    let counts = tracer.image_counts();
    let objects = scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let f = &o.function;
            ObjectPlan {
                label: o.label.clone(),
                written: f.size_written,
                simplified: f.size_simplified,
                value_ops: f.value_tape.operations(),
                gradient_ops: f.gradient_tape.operations(),
                route: route_text(
                    tracer.routes()[i],
                    o,
                    settings.step,
                    integrated,
                    matches!(scene.space, crate::space::SpaceKind::Metric(_)),
                ),
                bound: o.bound,
                images: counts[i],
                reached: reached[i],
                clip_ops: o.clip.as_ref().map(|c| c.value_tape.operations()),
                clip_cuts: o.clip_cuts,
                loose: o
                    .bound
                    .filter(|_| tracer.routes()[i].searches())
                    .and_then(|b| crate::compile::loose_bound(&o.function, b))
                    .map(|l| l.describe(o.clip.is_some(), &o.curved_uses)),
                cells: o.pruned.as_ref().map(|p| {
                    (
                        p.functions.len(),
                        p.occupied_count(),
                        p.n(),
                        p.mean_operations(),
                    )
                }),
            }
        })
        .collect();

    let mut skips = Vec::new();
    let dropped: Vec<&str> = scene
        .objects
        .iter()
        .filter(|o| o.bound.is_none())
        .map(|o| o.label.as_str())
        .collect();
    if !dropped.is_empty() {
        skips.push(format!(
            "dropped, no surface within reach of any ray: {}",
            dropped.join(", ")
        ));
    }
    skips.push("a ray searches an object only where its path meets the object's bound".to_string());
    if scene.lights.is_empty() {
        skips.push("no lights: no shadow rays, every hit shows ambient light".to_string());
    } else if !settings.shadows {
        skips.push("shadows off: no shadow rays".to_string());
    } else {
        skips.push(match tracer.paths_to_a_light() {
            1 => "shadow rays: one per hit and light, none where the surface faces away from the light"
                .to_string(),
            n => format!(
                "shadow rays: {n} per hit and light, one along each arc of the great circle through \
                 them (light arrives both ways), none along an arc that reaches the surface from behind"
            ),
        });
    }
    skips.push(
        "gradients: evaluated once per hit, for the normal; searches use values and slopes along \
         the path (on straight paths one dual-number pass in the path's parameter)"
            .to_string(),
    );
    let (written, simplified): (usize, usize) = scene
        .objects
        .iter()
        .map(|o| (o.function.size_written, o.function.size_simplified))
        .fold((0, 0), |(a, b), (c, d)| (a + c, b + d));
    skips.push(format!(
        "simplification: {written} operation{} as written, {simplified} after folding constants, \
         applying identities and sharing common subexpressions",
        plural(written)
    ));

    Plan {
        header,
        objects,
        skips,
        work: measured_work(scene, steps, cost),
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

/// How an object's hits are found, in words.
pub(crate) fn route_text(
    route: Route,
    o: &crate::scene::Object,
    step: f64,
    integrated: bool,
    metric: bool,
) -> String {
    if integrated {
        let points = if metric {
            "at points `sample` apart (in arc length and in the chart)"
        } else {
            "at 8 points per step"
        };
        return format!("sampled along each integrator step {points}, sign changes refined on the interpolant: a surface crossed twice between two samples can be missed");
    }
    match route {
        Route::Closed => {
            let (kind, equation) = match &o.function.quadric {
                Some(q) if q.is_linear() => ("a plane", "linear"),
                _ => ("a quadric", "quadratic"),
            };
            format!("closed form ({kind}): one {equation} equation per path segment")
        }
        Route::Polynomial => format!(
            "exact polynomial roots ({}degree {}): its coefficients along each straight path segment (from values at degree + 1 points up to degree {}, else by Taylor arithmetic), the first root isolated by Bernstein subdivision; every hit found, touching ones included",
            match o.function.proxy {
                crate::expr::Proxy::Numerator => "of the numerator over its nonnegative denominator, ",
                crate::expr::Proxy::Square => "of sqrt(a) - c as a - c^2, ",
                crate::expr::Proxy::None => "",
            },
            o.function.degree.unwrap_or(0),
            crate::expr::univariate::MOST_INTERPOLATED_DEGREE
        ),
        Route::Union => {
            let parts = o.function.union.as_deref().unwrap_or_default();
            let closed = parts.iter().filter(|p| p.quadric.is_some()).count();
            format!(
                "each part's exact roots: a union (min) of {} parts, {closed} met in closed form and {} by exact polynomial roots, each searched along a straight path segment from outside them all and the first root taken (from inside a part, interval root isolation); every hit found, touching ones included",
                parts.len(),
                parts.len() - closed
            )
        }
        Route::Interval => {
            "interval root isolation: every hit found, touching ones included".to_string()
        }
        Route::March => {
            format!("fixed-step march, step {step}: misses features thinner than the step")
        }
        Route::Adaptive => format!(
            "adaptive march from step {step}: misses hits between samples where |f| keeps falling"
        ),
    }
}

fn vec_text(v: DVec3) -> String {
    format!("({}, {}, {})", num(v.x), num(v.y), num(v.z))
}

/// Short decimals: bounds are computed, and twelve digits would hide them;
/// past a trillion, the exponent form (`2.8e15`, not sixteen digits), with
/// digits enough to tell a bound's ends apart (a ball of radius 0.6 at
/// 1e6 was bounded by `999999.4 .. 1.000e6`).
fn num(x: f64) -> String {
    if x.abs() >= 1e12 && x.is_finite() {
        return format!("{x:.6e}");
    }
    let r = (x * 1000.0).round() / 1000.0;
    if r == 0.0 {
        "0".to_string()
    } else {
        format!("{r}")
    }
}

/// Per object, the fraction of primary rays (on a coarse grid) whose path
/// meets its bound; each path walked once per object, of `steps`
/// integrator steps each where the space integrates them.
fn coverage(scene: &Scene, tracer: &Tracer, steps: Option<f64>) -> Vec<f64> {
    let paths_per_pixel = scene.objects.len().max(1) as f64;
    let across = across_within(scene, COVERAGE_WIDTH, paths_per_pixel, steps);
    coverage_on(scene, tracer, across)
}

fn coverage_on(scene: &Scene, tracer: &Tracer, across: u32) -> Vec<f64> {
    coverage_until(scene, tracer, across, || false)
}

/// [`coverage_on`], stopping after any pixel where `enough` says so.
fn coverage_until(
    scene: &Scene,
    tracer: &Tracer,
    across: u32,
    mut enough: impl FnMut() -> bool,
) -> Vec<f64> {
    let cam = scene.camera;
    let (w, h) = grid(cam.width, cam.height, across);
    let rays = cam.rays();
    let mut hits = vec![0usize; scene.objects.len()];
    let mut pixels = 0;
    'grid: for y in 0..h {
        for x in 0..w {
            let px = (x as f64 + 0.5) * cam.width as f64 / w as f64;
            let py = (y as f64 + 0.5) * cam.height as f64 / h as f64;
            let d = rays.direction(px, py);
            for (i, n) in hits.iter_mut().enumerate() {
                if tracer.path_meets_bound(cam.position, d, scene.settings.max_distance, i) {
                    *n += 1;
                }
            }
            pixels += 1;
            if enough() {
                break 'grid;
            }
        }
    }
    hits.iter()
        .map(|&n| n as f64 / pixels.max(1) as f64)
        .collect()
}

/// The integrator steps a primary path takes, on average over a pilot
/// grid, where the space integrates paths. The pilot stops early once its
/// paths have cost a quarter of [`GRID_STEPS`] (steps weighted by
/// `weight`): where steps are dear, a few paths say enough.
fn steps_per_path(scene: &Scene, tracer: &Tracer, weight: f64) -> Option<f64> {
    let before = tracer.space().path_report()?;
    let spent = || {
        tracer.space().path_report().map_or(0.0, |r| {
            let r = r.since(&before);
            (r.accepted + r.rejected) as f64 * weight
        })
    };
    coverage_until(scene, tracer, PILOT_WIDTH, || spent() > 0.25 * GRID_STEPS);
    let pilot = tracer.space().path_report()?.since(&before);
    (pilot.paths > 0).then(|| (pilot.accepted + pilot.rejected) as f64 / pilot.paths as f64)
}

/// How many pixels across a grid of at most `most` may be when each pixel
/// walks `paths_per_pixel` paths of `steps` integrator steps each, within
/// [`GRID_STEPS`] (at least 1).
fn across_within(scene: &Scene, most: u32, paths_per_pixel: f64, steps: Option<f64>) -> u32 {
    let Some(steps) = steps.filter(|s| *s > 0.0) else {
        return most;
    };
    let cam = scene.camera;
    let pixels = GRID_STEPS / (steps * paths_per_pixel);
    let aspect = cam.height.max(1) as f64 / cam.width.max(1) as f64;
    let across = (pixels / aspect).sqrt().floor();
    if across >= most as f64 {
        most
    } else {
        (across as u32).clamp(1, most)
    }
}

fn grid(width: u32, height: u32, across: u32) -> (u32, u32) {
    let w = across.min(width).max(1);
    let h = ((height as u64 * w as u64) / width.max(1) as u64).max(1) as u32;
    (w, h)
}

/// The sample render's lines; `steps` integrator steps a path, `cost`
/// the same weighted by the equation's length (which sizes the sample).
fn measured_work(scene: &Scene, steps: Option<f64>, cost: Option<f64>) -> Vec<String> {
    let mut sample = scene.clone();
    // A primary path, and a shadow path to each light from where it hits.
    let paths_per_pixel = 1.0 + scene.lights.len() as f64;
    let across = across_within(scene, SAMPLE_WIDTH, paths_per_pixel, cost);
    let (w, h) = grid(scene.camera.width, scene.camera.height, across);
    sample.camera.width = w;
    sample.camera.height = h;
    sample.settings.samples = 1;
    // A scene whose rays run out of steps must not make `explain` take as
    // long as the render it explains.
    sample.settings.max_steps = sample.settings.max_steps.min(SAMPLE_MAX_STEPS);
    let (_, stats) = crate::render(&sample);
    let rays = (stats.primary_rays + stats.shadow_rays).max(1);
    let mut lines = vec![format!(
        "measured on a {w} x {h} sample render: {:.1} function evaluations per ray \
         ({} primary and {} shadow rays)",
        stats.evaluations as f64 / rays as f64,
        stats.primary_rays,
        stats.shadow_rays
    )];
    let full =
        scene.camera.width as f64 * scene.camera.height as f64 * scene.settings.samples as f64;
    let per_pixel = |n: u64| n as f64 / stats.primary_rays.max(1) as f64 * full / 1e6;
    let integrated = stats.integration.map_or(String::new(), |r| {
        format!(
            " and {:.1} M integrator steps",
            per_pixel(r.accepted + r.rejected)
        )
    });
    lines.push(format!(
        "the full render: about {:.1} M evaluations{integrated}",
        per_pixel(stats.evaluations)
    ));
    if let Some(steps) = steps.filter(|_| across < SAMPLE_WIDTH.min(scene.camera.width)) {
        lines.push(format!(
            "the sample is {w} pixels across, not {SAMPLE_WIDTH}: a path takes about {steps:.0} integrator steps, and the sample is sized to about {:.0e} steps of an equation of {TYPICAL_STEP_OPERATIONS} operations",
            GRID_STEPS
        ));
    }
    for warning in stats.warnings(&sample.settings) {
        lines.push(format!(
            "warning[{}] (sample render, at most {} steps per ray and object): {}",
            warning.code.as_str(),
            sample.settings.max_steps,
            warning.text
        ));
    }
    if scene.settings.method == Method::March || scene.settings.method == Method::Adaptive {
        lines.push(
            "the seed's marching methods can miss thin features; `method auto` cannot".to_string(),
        );
    }
    lines
}

impl fmt::Display for Plan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for line in &self.header {
            writeln!(f, "{line}")?;
        }
        for (i, o) in self.objects.iter().enumerate() {
            writeln!(f)?;
            writeln!(f, "object {}: {}", i + 1, o.label)?;
            writeln!(
                f,
                "  expression  {} operation{} as written, {} after simplification \
                 (tapes: {} for the value, {} with the gradient)",
                o.written,
                plural(o.written),
                o.simplified,
                o.value_ops,
                o.gradient_ops
            )?;
            writeln!(f, "  route       {}", o.route)?;
            if let Some(ops) = o.clip_ops {
                let cost = if o.clip_cuts {
                    "each hit found costs one evaluation of it"
                } else {
                    "it cuts nothing the bound's own faces do not (the surface lies within it, or the bound is its box), so searches pass it over, checking against it only a hit within epsilon of the bound's faces"
                };
                writeln!(
                    f,
                    "  clip        drawn only where its clip formula ({ops} operation{}) is negative or zero, open where cut; the bound is searched for within what it keeps; {cost}",
                    if ops == 1 { "" } else { "s" }
                )?;
            }
            match &o.bound {
                Some(b) => writeln!(
                    f,
                    "  bound       {} .. {}{}",
                    vec_text(b.min),
                    vec_text(b.max),
                    if o.images > 1 {
                        format!(", {} copies in the space", o.images)
                    } else {
                        String::new()
                    }
                )?,
                None => writeln!(
                    f,
                    "  bound       none: no ray can reach its surface; dropped"
                )?,
            }
            if let Some((formulas, cells, n, mean)) = o.cells {
                writeln!(
                    f,
                    "  cells       {formulas} shorter formula{} for the {cells} cells (of {n}^3) where the surface may lie, \
                     with the min/max/smin choices made there: {mean:.0} operations on average instead of {}; \
                     paths search each cell with its own (a curved piece across cells with its block's)",
                    plural(formulas),
                    o.value_ops
                )?;
            }
            if let Some(loose) = &o.loose {
                writeln!(f, "  note        {loose}")?;
            }
            writeln!(f, "  reached by  {:.0}% of primary rays", 100.0 * o.reached)?;
        }
        writeln!(f)?;
        writeln!(f, "skipped work:")?;
        for s in &self.skips {
            writeln!(f, "  - {s}")?;
        }
        writeln!(f)?;
        writeln!(f, "work per ray:")?;
        for w in &self.work {
            writeln!(f, "  - {w}")?;
        }
        Ok(())
    }
}
