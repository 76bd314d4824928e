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

use crate::scene::Scene;
use crate::shade;
use crate::trace::intersect::Scratch;
use crate::trace::Tracer;

/// What the caller can control while a render runs.
#[derive(Default)]
pub struct RenderOptions<'a> {
    /// Checked before each band of rows; when set, the render stops and
    /// returns [`Cancelled`].
    pub cancel: Option<&'a AtomicBool>,
    /// Called after each band with (bands done, bands in all).
    pub progress: Option<&'a (dyn Fn(usize, usize) + Sync)>,
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
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RenderStats {
    /// Rays from the camera.
    pub primary_rays: u64,
    /// Rays from hits towards lights.
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
    let (w, h) = (cam.width, cam.height);
    let mut image = Image {
        width: w,
        height: h,
        pixels: vec![DVec3::ZERO; (w * h) as usize],
    };
    let total = h.div_ceil(BAND) as usize;
    let done = AtomicU64::new(0);
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
            let y0 = band as u32 * BAND;
            for (i, out) in pixels.iter_mut().enumerate() {
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
    for band in band_stats {
        stats += band.ok_or(Cancelled)?;
    }
    Ok((image, stats))
}

/// Render a scene with default options.
pub fn render(scene: &Scene) -> (Image, RenderStats) {
    render_with(&Tracer::new(scene), &RenderOptions::default())
        .expect("no cancel token, so no cancellation")
}
