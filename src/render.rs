//! The render stage: the per-pixel loop above the tracer's queries.
//!
//! Input: a [`Tracer`] (a compiled scene with its space and routes) and
//! [`RenderOptions`]. Output: an [`Image`] of linear colours and
//! [`RenderStats`]. Per pixel, a fixed stratified grid of primary rays;
//! per ray, the nearest hit from [`crate::trace`] and its colour from
//! [`crate::shade`]. Bands of rows are rendered in parallel with rayon.
//! This stage does no I/O: progress and cancellation go through the
//! options, and **a render is a pure function of the scene**.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use crate::diagnostic::Code;
use crate::scene::{Method, RenderSettings, Scene};
use crate::shade;
use crate::space::PathReport;
use crate::trace::intersect::{Scratch, Trouble};
use crate::trace::Tracer;

/// What the caller can control while a render runs.
#[derive(Default)]
pub struct RenderOptions<'a> {
    /// Checked before each band of rows; when set, the render stops and
    /// returns [`Cancelled`].
    pub cancel: Option<&'a AtomicBool>,
    /// Called after each band with (bands done, bands in all).
    pub progress: Option<&'a (dyn Fn(usize, usize) + Sync)>,
    /// Render only these rows of the image (a shard); the image returned
    /// holds just them. `None`: every row.
    pub rows: Option<std::ops::Range<u32>>,
}

/// A render stopped by its cancel token.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cancelled;

/// Linear RGB pixels, row by row from the top.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `width * height` linear colours.
    pub pixels: Vec<DVec3>,
}

impl Image {
    /// The pixel in column `x` of row `y`.
    pub fn pixel(&self, x: u32, y: u32) -> DVec3 {
        self.pixels[(y * self.width + x) as usize]
    }
}

/// What a render did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RenderStats {
    /// Rays from the camera.
    pub primary_rays: u64,
    /// Rays from hits towards lights.
    pub shadow_rays: u64,
    /// Evaluations of object functions (point and interval).
    pub evaluations: u64,
    /// Pixels where a sample's colour was not finite and fell back to the
    /// background colour.
    pub nonfinite_pixels: u64,
    /// Pixels where a search (view or shadow) used up `max_steps`: a
    /// surface there may be missing.
    pub out_of_steps_pixels: u64,
    /// Pixels whose hit could not be located to `epsilon` (the numbers at
    /// its distance are too coarse): drawn, but less exact than asked.
    pub imprecise_pixels: u64,
    /// Pixels whose hit had a non-finite value, or a gradient that is zero
    /// or not finite (other than those of `nonfinite_pixels`): the normal
    /// there is a guess.
    pub undefined_pixels: u64,
    /// Pixels where an object's colour formula was not a number (that
    /// component drawn as 0).
    pub undefined_colour_pixels: u64,
    /// Pixels whose ray met an object's values overflowing to infinities
    /// of opposite signs: a surface there may be missing.
    pub overflow_pixels: u64,
    /// In a metric space: how the render's paths were integrated, how many
    /// ended early and how far the unit-speed constraint drifted.
    pub integration: Option<PathReport>,
}

impl std::ops::AddAssign for RenderStats {
    fn add_assign(&mut self, o: RenderStats) {
        self.primary_rays += o.primary_rays;
        self.shadow_rays += o.shadow_rays;
        self.evaluations += o.evaluations;
        self.nonfinite_pixels += o.nonfinite_pixels;
        self.out_of_steps_pixels += o.out_of_steps_pixels;
        self.imprecise_pixels += o.imprecise_pixels;
        self.undefined_pixels += o.undefined_pixels;
        self.undefined_colour_pixels += o.undefined_colour_pixels;
        self.overflow_pixels += o.overflow_pixels;
        self.integration = match (self.integration, o.integration) {
            (Some(a), Some(b)) => Some(a.merged(&b)),
            (a, b) => a.or(b),
        };
    }
}

impl RenderStats {
    /// Counts one pixel's trouble (and whether its colour fell back).
    fn count(&mut self, trouble: Trouble, fell_back: bool) {
        self.nonfinite_pixels += fell_back as u64;
        self.out_of_steps_pixels += trouble.out_of_steps as u64;
        self.imprecise_pixels += trouble.imprecise as u64;
        self.undefined_pixels += (trouble.nonfinite && !fell_back) as u64;
        self.undefined_colour_pixels += (trouble.colour_undefined && !fell_back) as u64;
        self.overflow_pixels += trouble.overflow as u64;
    }

    /// One warning per kind of untrusted pixel, each saying why and what to
    /// change; empty when every pixel can be trusted.
    pub fn warnings(&self, settings: &RenderSettings) -> Vec<PixelWarning> {
        let pixels = |n: u64| format!("{n} pixel{}", if n == 1 { "" } else { "s" });
        let mut out = Vec::new();
        if self.out_of_steps_pixels > 0 {
            // A march takes about (distance / step) steps: a tiny step is
            // the likelier cause than the bound.
            let remedy = match settings.method {
                Method::March | Method::Adaptive => format!(
                    "a march takes about (distance searched) / step of them: raise `step` \
                     (now {}) or `max_steps` in `render {{ }}`, or bound the object tighter",
                    crate::compile::readable(settings.step)
                ),
                _ => "raise `max_steps` in `render { }`, or bound the object tighter \
                      (`nes explain` shows which expression is loose)"
                    .to_string(),
            };
            out.push(PixelWarning::new(
                Code::OutOfSteps,
                format!(
                    "{} ran out of steps (max_steps {}): a surface there may be missing; {remedy}",
                    pixels(self.out_of_steps_pixels),
                    settings.max_steps
                ),
            ));
        }
        if self.imprecise_pixels > 0 {
            out.push(PixelWarning::new(
                Code::Imprecise,
                format!(
                    "{} hit a surface that could not be located to epsilon {:e} (the numbers \
                 at that distance are spaced wider): raise `epsilon`, or move the scene \
                 nearer the origin",
                    pixels(self.imprecise_pixels),
                    settings.epsilon
                ),
            ));
        }
        if self.undefined_pixels > 0 {
            out.push(PixelWarning::new(
                Code::UndefinedNormal,
                format!(
                    "{} hit where the object's value is NaN or infinite or its gradient is \
                 zero, NaN or infinite: the normal there is a guess; check the expression \
                 for overflow or underflow (a huge power) or a point outside its domain",
                    pixels(self.undefined_pixels)
                ),
            ));
        }
        if self.overflow_pixels > 0 {
            out.push(PixelWarning::new(
                Code::Overflow,
                format!(
                    "{} met an object whose value overflows to infinity on both sides of a \
                 change of sign: a surface there may be missing; scale the formula down \
                 (multiplying it by a constant does not move its surface), or look for a \
                 product or power past 1e308, or a division by zero (a constant like \
                 `(3*a - 1)/(3 - a)` where `a` is 3 in some frame)",
                    pixels(self.overflow_pixels)
                ),
            ));
        }
        if self.undefined_colour_pixels > 0 {
            out.push(PixelWarning::new(
                Code::UndefinedColour,
                format!(
                    "{} hit where the object's colour formula is not a number (drawn as 0 in \
                 that component, so darker): check its domain, such as `sqrt` or `ln` of a \
                 negative value, or a division by zero",
                    pixels(self.undefined_colour_pixels)
                ),
            ));
        }
        if self.nonfinite_pixels > 0 {
            out.push(PixelWarning::new(
                Code::NotFinite,
                format!(
                    "{} met NaN or infinity and show the background",
                    pixels(self.nonfinite_pixels)
                ),
            ));
        }
        if let Some(r) = self.integration {
            // Integrated paths evaluate an object wherever they come near
            // its bound: none at all means the image is background alone,
            // which a bent space can do without a word otherwise.
            if self.evaluations == 0 && self.primary_rays > 0 {
                out.push(PixelWarning::new(
                    Code::NoPathNear,
                    "no path came near any object: the image shows only the background; `nes probe --pixel X,Y` shows where a path goes, and `nes explain` which objects rays reach"
                        .to_string(),
                ));
            }
            if r.ended_early() > 0 {
                out.push(PixelWarning::new(Code::EndedEarly, r.ended_early_warning()));
            }
            out.extend(
                r.shooting_warning()
                    .map(|w| PixelWarning::new(Code::ShootingFailed, w)),
            );
            out.extend(r.drift_warning().map(|w| PixelWarning::new(Code::Drift, w)));
        }
        out
    }
}

/// A warning a render gives about its pixels (or paths), after the
/// image is made: its code (`W01..`, listed in docs/errors.md) and text.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelWarning {
    /// What kind of trouble.
    pub code: Code,
    /// How many pixels, what it means, and the fix.
    pub text: String,
}

impl PixelWarning {
    fn new(code: Code, text: String) -> PixelWarning {
        PixelWarning { code, text }
    }
}

impl std::fmt::Display for PixelWarning {
    /// `warning[W0101]: 12 pixels ran out of steps ...`, as stderr shows it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "warning[{}]: {}", self.code.as_str(), self.text)
    }
}

/// The most pixels one render holds in memory at once (linear colours,
/// 24 bytes each, plus 3 bytes of sRGB: about 3.6 GB): a larger image is
/// rendered in shards (`--shard K/N`), each holding a band of rows.
pub const MAX_PIXELS_IN_MEMORY: u64 = 1 << 27;

/// Whether `width * rows` pixels fit in [`MAX_PIXELS_IN_MEMORY`].
pub fn fits_in_memory(width: u32, rows: u32) -> bool {
    width as u64 * rows as u64 <= MAX_PIXELS_IN_MEMORY
}

/// Rows per unit of parallel work (and per cancellation check).
const BAND: u32 = 8;

/// The linear colour seen along one primary ray, and whether a
/// non-finite value had to be replaced.
pub fn trace_ray(
    tracer: &Tracer,
    direction: DVec3,
    s: &mut Scratch,
    stats: &mut RenderStats,
) -> (DVec3, bool) {
    stats.primary_rays += 1;
    let scene = tracer.scene;
    let origin = scene.camera.position;
    match tracer.nearest_hit(origin, direction, scene.settings.max_distance, s) {
        None => (scene.background, false),
        Some(hit) => {
            let c = shade::shade(tracer, &hit, s, &mut stats.shadow_rays);
            if c.is_finite() {
                (c, false)
            } else {
                (scene.background, true)
            }
        }
    }
}

/// Render the whole image, in bands of rows traced in parallel.
pub fn render_with(
    tracer: &Tracer,
    options: &RenderOptions,
) -> Result<(Image, RenderStats), Cancelled> {
    let cam = &tracer.scene.camera;
    let rays = cam.rays();
    let w = cam.width;
    // Every pixel is traced on its own, so a range of rows renders exactly
    // the pixels the whole image has there.
    let rows = options.rows.clone().unwrap_or(0..cam.height);
    let first_row = rows.start;
    let h = rows.end.saturating_sub(rows.start);
    let mut image = Image {
        width: w,
        height: h,
        pixels: vec![DVec3::ZERO; w as usize * h as usize],
    };
    let total = h.div_ceil(BAND) as usize;
    let done = AtomicU64::new(0);
    // A tracer may serve several renders: count only this one's paths.
    let before = tracer.space().path_report().unwrap_or_default();
    let grid = (tracer.scene.settings.samples as f64).sqrt().ceil() as u32;
    let band_stats: Vec<Option<RenderStats>> = image
        .pixels
        .par_chunks_mut((w * BAND) as usize)
        .enumerate()
        .map_init(Scratch::default, |s, (band, pixels)| {
            if options.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                return None;
            }
            let mut stats = RenderStats::default();
            let y0 = first_row + band as u32 * BAND;
            for (i, out) in pixels.iter_mut().enumerate() {
                // Checked per pixel: one pixel of a pathological scene can
                // take a second, a band of them minutes.
                if options.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                    return None;
                }
                s.trouble = Trouble::default();
                let (x, y) = (i as u32 % w, y0 + i as u32 / w);
                let mut sum = DVec3::ZERO;
                let mut broken = false;
                for sy in 0..grid {
                    for sx in 0..grid {
                        let px = x as f64 + (sx as f64 + 0.5) / grid as f64;
                        let py = y as f64 + (sy as f64 + 0.5) / grid as f64;
                        let (c, bad) = trace_ray(tracer, rays.direction(px, py), s, &mut stats);
                        sum += c;
                        broken |= bad;
                    }
                }
                stats.count(s.trouble, broken);
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
    for band in band_stats {
        stats += band.ok_or(Cancelled)?;
    }
    stats.integration = tracer
        .space()
        .path_report()
        .map(|after| after.since(&before));
    Ok((image, stats))
}

/// An estimate of each row's cost, in units of work (rays and function
/// evaluations), from a render at most `side` pixels on its longer side
/// whose rows are spread over the rows they stand for. Deterministic: the
/// same scene gives the same costs on every machine, so every shard of a
/// render cuts the image at the same rows.
pub fn row_costs(scene: &Scene, side: u32) -> Vec<u64> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let divisor = w.max(h).div_ceil(side.max(1)).max(1);
    let mut small = scene.clone();
    small.camera.width = (w / divisor).max(1);
    small.camera.height = (h / divisor).max(1);
    small.settings.samples = 1;
    let tracer = Tracer::new(&small);
    let rays = small.camera.rays();
    let (sw, sh) = (small.camera.width, small.camera.height);
    let small_costs: Vec<u64> = (0..sh)
        .into_par_iter()
        .map_init(Scratch::default, |s, y| {
            let mut stats = RenderStats::default();
            for x in 0..sw {
                let d = rays.direction(x as f64 + 0.5, y as f64 + 0.5);
                trace_ray(&tracer, d, s, &mut stats);
            }
            let evaluations = std::mem::take(&mut s.evaluations);
            stats.primary_rays + stats.shadow_rays + evaluations
        })
        .collect();
    (0..h)
        .map(|y| small_costs[(y as u64 * sh as u64 / h as u64) as usize] + 1)
        .collect()
}

/// Render a scene with default options.
pub fn render(scene: &Scene) -> (Image, RenderStats) {
    render_with(&Tracer::new(scene), &RenderOptions::default())
        .expect("no cancel token, so no cancellation")
}
