//! `nes accuracy`: run time against error, for the scene as written.
//!
//! Input: a checked [`Scene`]. Output: a table, one row per method and
//! setting (a ladder of epsilons, steps and integrator tolerances), each
//! render timed and its per-pixel hits compared with a reference rendered
//! with the tightest settings (closed form where every object has one).
//! Also the hit comparison used by the benches.

use std::fmt;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use crate::scene::{Method, Scene, SpaceKind};
use crate::trace::intersect::Scratch;
use crate::trace::Tracer;

/// What a pixel's central primary ray hits first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelHit {
    pub object: usize,
    /// Distance along the path.
    pub t: f64,
    /// The shading normal there.
    pub normal: DVec3,
}

/// Each pixel's hit, row by row.
pub fn primary_hits(scene: &Scene) -> Vec<Option<PixelHit>> {
    let tracer = Tracer::new(scene);
    let cam = scene.camera;
    let rays = cam.rays();
    (0..cam.height)
        .into_par_iter()
        .flat_map_iter(|y| {
            let tracer = &tracer;
            let mut s = Scratch::default();
            (0..cam.width).map(move |x| {
                let d = rays.direction(x as f64 + 0.5, y as f64 + 0.5);
                tracer
                    .first_hit(cam.position, d, scene.settings.max_distance, false, &mut s)
                    .map(|h| PixelHit {
                        object: h.object,
                        t: h.t,
                        normal: crate::shade::normal(tracer, &h, &mut s),
                    })
            })
        })
        .collect()
}

/// How a set of hits differs from a reference for the same pixels.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct HitErrors {
    /// Pixels where both hit the same object.
    pub compared: usize,
    pub mean_distance_error: f64,
    pub max_distance_error: f64,
    /// The largest angle between the normals, in degrees.
    pub max_normal_error: f64,
    /// Pixels whose hit object differs (a miss against a hit included).
    pub differing: usize,
    /// Pixels the reference hits and these miss.
    pub missed: usize,
}

pub fn compare_hits(got: &[Option<PixelHit>], reference: &[Option<PixelHit>]) -> HitErrors {
    let mut e = HitErrors::default();
    let mut sum = 0.0;
    for (g, r) in got.iter().zip(reference) {
        match (g, r) {
            (Some(a), Some(b)) if a.object == b.object => {
                let d = (a.t - b.t).abs();
                sum += d;
                e.max_distance_error = e.max_distance_error.max(d);
                let angle = a.normal.dot(b.normal).clamp(-1.0, 1.0).acos().to_degrees();
                if angle.is_finite() {
                    e.max_normal_error = e.max_normal_error.max(angle);
                }
                e.compared += 1;
            }
            (None, None) => {}
            (None, Some(_)) => {
                e.missed += 1;
                e.differing += 1;
            }
            _ => e.differing += 1,
        }
    }
    e.mean_distance_error = sum / e.compared.max(1) as f64;
    e
}

/// One render of the ladder.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub method: Method,
    /// The setting varied, as text (`epsilon 1e-6`).
    pub setting: String,
    /// Whether this is what the scene renders with by default.
    pub default: bool,
    pub seconds: f64,
    pub rays_per_second: f64,
    pub errors: HitErrors,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    pub width: u32,
    pub height: u32,
    pub reference: String,
    pub rows: Vec<Row>,
}

/// Renders `scene` with every applicable method over its ladder of
/// settings and compares each with the reference.
pub fn measure(scene: &Scene) -> Report {
    let sphere = matches!(scene.space, SpaceKind::Sphere { .. });
    let all_closed = scene.objects.iter().all(|o| o.function.quadric.is_some());
    let eps = scene.settings.epsilon;
    let mut reference_scene = scene.clone();
    reference_scene.settings.method = if all_closed {
        Method::Exact
    } else {
        Method::Interval
    };
    reference_scene.settings.epsilon = (eps / 1000.0).max(1e-12);
    let reference_text = if all_closed {
        "closed form (every object is a plane or a quadric)".to_string()
    } else {
        format!(
            "interval isolation, epsilon {:e}",
            reference_scene.settings.epsilon
        )
    };
    let reference = primary_hits(&reference_scene);

    let default_method = scene.settings.method;
    let mut runs: Vec<(Method, String, Scene, bool)> = Vec::new();
    let variant = |method: Method, f: &dyn Fn(&mut Scene) -> String| {
        let mut s = scene.clone();
        s.settings.method = method;
        let text = f(&mut s);
        (method, text, s)
    };
    if all_closed {
        let (m, t, s) = variant(Method::Exact, &|_| "-".to_string());
        runs.push((
            m,
            t,
            s,
            matches!(default_method, Method::Auto | Method::Exact),
        ));
    }
    for e in [1e-3, 1e-4, 1e-6, 1e-8] {
        let (m, t, s) = variant(Method::Interval, &|s| {
            s.settings.epsilon = e;
            format!("epsilon {e:e}")
        });
        let default =
            !all_closed && matches!(default_method, Method::Auto | Method::Interval) && e == eps;
        runs.push((m, t, s, default));
    }
    for method in [Method::Adaptive, Method::March] {
        for step in [0.1, 0.05, 0.02, 0.01] {
            let (m, t, s) = variant(method, &|s| {
                s.settings.step = step;
                format!("step {step}")
            });
            let default = default_method == method && step == scene.settings.step;
            runs.push((m, t, s, default));
        }
    }
    if sphere {
        for tol in [1e-4, 1e-6, 1e-8, 1e-10] {
            let (m, t, s) = variant(Method::Ode, &|s| {
                s.settings.tolerance = tol;
                format!("tolerance {tol:e}")
            });
            let default = default_method == Method::Ode && tol == scene.settings.tolerance;
            runs.push((m, t, s, default));
        }
    }

    let rows = runs
        .into_iter()
        .map(|(method, setting, s, default)| {
            let start = Instant::now();
            let (_, stats) = crate::render(&s);
            let seconds = start.elapsed().as_secs_f64();
            let errors = compare_hits(&primary_hits(&s), &reference);
            Row {
                method,
                setting,
                default,
                seconds,
                rays_per_second: (stats.primary_rays + stats.shadow_rays) as f64 / seconds,
                errors,
            }
        })
        .collect();
    Report {
        width: scene.camera.width,
        height: scene.camera.height,
        reference: reference_text,
        rows,
    }
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} x {} pixels; reference: {}; * marks the default",
            self.width, self.height, self.reference
        )?;
        writeln!(
            f,
            "{:<10} {:<18} {:>9} {:>11} {:>10} {:>10} {:>9} {:>8} {:>7}",
            "method",
            "setting",
            "time",
            "rays/s",
            "mean |dt|",
            "max |dt|",
            "normal",
            "differ",
            "missed"
        )?;
        for r in &self.rows {
            let e = &r.errors;
            writeln!(
                f,
                "{:<10} {:<18} {:>8.3}s {:>11.3e} {:>10.2e} {:>10.2e} {:>8.2}° {:>8} {:>7}{}",
                r.method.name(),
                r.setting,
                r.seconds,
                r.rays_per_second,
                e.mean_distance_error,
                e.max_distance_error,
                e.max_normal_error,
                e.differing,
                e.missed,
                if r.default { "  *" } else { "" }
            )?;
        }
        Ok(())
    }
}
