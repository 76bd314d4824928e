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
use plotters::prelude::*;
use rayon::prelude::*;

use crate::scene::{Method, Route, Scene};
use crate::trace::intersect::Scratch;
use crate::trace::Tracer;

/// What a pixel's central primary ray hits first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelHit {
    /// The object hit (an index into the scene's objects).
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
                    .nearest_hit(cam.position, d, scene.settings.max_distance, &mut s)
                    .map(|h| PixelHit {
                        object: h.object,
                        t: h.t,
                        normal: tracer.normal(&h, &mut s),
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
    /// The mean of `|t - t_reference|` over the `compared` pixels (0 when none
    /// is), in scene units of distance along the path.
    pub mean_distance_error: f64,
    /// The largest `|t - t_reference|` over the `compared` pixels.
    pub max_distance_error: f64,
    /// The largest angle between the normals, in degrees.
    pub max_normal_error: f64,
    /// Pixels whose hit object differs (a miss against a hit included).
    pub differing: usize,
    /// Pixels the reference hits and these miss.
    pub missed: usize,
}

/// How `got` differs from `reference`, pixel by pixel (both in the order of
/// [`primary_hits`]; extra pixels of the longer list are ignored). Distance
/// and normal errors are taken only where both hit the same object.
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
    /// The method rendered with.
    pub method: Method,
    /// The setting varied, as text (`epsilon 1e-6`).
    pub setting: String,
    /// Whether this is what the scene renders with by default.
    pub default: bool,
    /// Wall-clock time of the fastest of up to 5 full renders (with shading and
    /// shadows), in seconds.
    pub seconds: f64,
    /// Primary and shadow rays of one render divided by `seconds`.
    pub rays_per_second: f64,
    /// Its primary hits against the reference's.
    pub errors: HitErrors,
}

/// What [`measure`] found: printed as a table by its `Display`, drawn by
/// [`plot`].
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// The image width measured at, in pixels.
    pub width: u32,
    /// The image height measured at, in pixels.
    pub height: u32,
    /// How the reference was rendered, in words.
    pub reference: String,
    /// One row per method and setting, in ladder order: closed form (if every
    /// object has one), interval epsilons, adaptive and march steps, then ode
    /// tolerances (if the space can integrate).
    pub rows: Vec<Row>,
}

/// The reference's integrator tolerance where every path is integrated:
/// ten times tighter than the ladder's tightest. At 1e-12 the unit-speed
/// constraint's share of the step control is at the rounding level and
/// steps are rejected about a hundred times per path on the lens scene,
/// and its hits moved off those of 1e-10 and 1e-11 alike.
const REFERENCE_TOLERANCE: f64 = 1e-11;

/// Renders `scene` with every applicable method over its ladder of
/// settings and compares each with the reference.
pub fn measure(scene: &Scene) -> Report {
    let integrable = scene.space.can_integrate();
    // A space whose every path is integrated whatever the method (a
    // metric's): the methods' ladders would measure one thing four times,
    // so only the integrator's tolerance and the hit's epsilon vary.
    let always_integrated = {
        let mut s = scene.clone();
        s.settings.method = Method::Interval;
        s.build_space().integrates()
    };
    let all_closed =
        !always_integrated && scene.objects.iter().all(|o| o.function.quadric.is_some());
    let eps = scene.settings.epsilon;
    let mut reference_scene = scene.clone();
    reference_scene.settings.method = if all_closed {
        Method::Exact
    } else if always_integrated {
        Method::Ode
    } else {
        Method::Interval
    };
    reference_scene.settings.epsilon = (eps / 1000.0).max(1e-12);
    if always_integrated {
        reference_scene.settings.tolerance = REFERENCE_TOLERANCE;
    }
    // Four significant digits: 1e-6 / 1000 prints as 1e-9, not
    // 9.999999999999999e-10.
    let shown: f64 = format!("{:.4e}", reference_scene.settings.epsilon)
        .parse()
        .unwrap_or(reference_scene.settings.epsilon);
    let reference_text = if all_closed {
        "closed form (every object is a plane or a quadric)".to_string()
    } else if always_integrated {
        format!(
            "paths integrated to tolerance {REFERENCE_TOLERANCE:e}, hits to epsilon {shown:e} (1000x tighter than the scene's)"
        )
    } else {
        format!("interval isolation, epsilon {shown:e} (1000x tighter than the scene's)")
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
    // Where `auto` takes another route than interval isolation for some
    // object (a polynomial's exact roots, a quadric's closed form), its
    // own row is the default, not the interval ladder's.
    let straight = scene.build_space().straight_paths();
    let auto_differs = !all_closed
        && !always_integrated
        && scene.objects.iter().any(|o| {
            Route::for_object(o, Method::Auto, straight)
                != Route::for_object(o, Method::Interval, straight)
        });
    if auto_differs {
        let (m, t, s) = variant(Method::Auto, &|_| format!("epsilon {eps:e}"));
        runs.push((m, t, s, default_method == Method::Auto));
    }
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
        if always_integrated {
            if e == eps {
                continue; // the tolerance ladder's default row has it
            }
            let (m, t, s) = variant(Method::Ode, &|s| {
                s.settings.epsilon = e;
                format!("epsilon {e:e}")
            });
            runs.push((m, t, s, false));
            continue;
        }
        let (m, t, s) = variant(Method::Interval, &|s| {
            s.settings.epsilon = e;
            format!("epsilon {e:e}")
        });
        let default = !all_closed
            && (default_method == Method::Interval
                || (default_method == Method::Auto && !auto_differs))
            && e == eps;
        runs.push((m, t, s, default));
    }
    let ladders: &[Method] = if always_integrated {
        &[]
    } else {
        &[Method::Adaptive, Method::March]
    };
    for &method in ladders {
        for step in [0.1, 0.05, 0.02, 0.01] {
            let (m, t, s) = variant(method, &|s| {
                s.settings.step = step;
                format!("step {step}")
            });
            let default = default_method == method && step == scene.settings.step;
            runs.push((m, t, s, default));
        }
    }
    if integrable {
        for tol in [1e-4, 1e-6, 1e-8, 1e-10] {
            let (m, t, s) = variant(Method::Ode, &|s| {
                s.settings.tolerance = tol;
                format!("tolerance {tol:e}")
            });
            let default = (always_integrated || default_method == Method::Ode)
                && tol == scene.settings.tolerance;
            runs.push((m, t, s, default));
        }
    }

    let rows = runs
        .into_iter()
        .map(|(method, setting, s, default)| {
            // The fastest of several renders when one is quick: a single
            // 20 ms render is mostly timer and scheduler noise.
            let mut seconds = f64::INFINITY;
            let mut spent = 0.0;
            let mut stats = crate::RenderStats::default();
            for _ in 0..5 {
                let start = Instant::now();
                stats = crate::render(&s).1;
                let took = start.elapsed().as_secs_f64();
                seconds = seconds.min(took);
                spent += took;
                if spent > 0.3 {
                    break;
                }
            }
            let errors = compare_hits(&primary_hits(&s), &reference);
            // In a metric space each setting's unit-speed drift is part of
            // its accuracy.
            let setting = match stats.integration {
                Some(r) => format!("{setting}, drift {:.0e}", r.max_drift),
                None => setting,
            };
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
        let width = self
            .rows
            .iter()
            .map(|r| r.setting.chars().count())
            .max()
            .unwrap_or(0)
            .max(18);
        writeln!(
            f,
            "{:<10} {:<width$} {:>9} {:>11} {:>10} {:>10} {:>9} {:>8} {:>7}",
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
                "{:<10} {:<width$} {:>8.3}s {:>11.3e} {:>10.2e} {:>10.2e} {:>8.2}° {:>8} {:>7}{}",
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

/// Errors below this are drawn at it (a log axis has no zero).
const ERROR_FLOOR: f64 = 1e-12;

/// The rows on the Pareto front of (time, largest distance error): no
/// other row is both faster and more accurate. Rows with differing pixels
/// are not on it (their error is not the whole story).
pub fn pareto_front(rows: &[Row]) -> Vec<usize> {
    let error = |r: &Row| r.errors.max_distance_error.max(ERROR_FLOOR);
    let clean = |r: &Row| r.errors.differing == 0;
    (0..rows.len())
        .filter(|&i| {
            clean(&rows[i])
                && !rows.iter().any(|o| {
                    clean(o)
                        && o.seconds <= rows[i].seconds
                        && error(o) <= error(&rows[i])
                        && (o.seconds < rows[i].seconds || error(o) < error(&rows[i]))
                })
        })
        .collect()
}

/// Draws the report as time (x, log) against the largest hit-distance
/// error (y, log): one curve per method, hollow points where pixels differ
/// from the reference, the Pareto front dashed, the default circled.
pub fn plot(report: &Report, png: &std::path::Path, svg: &std::path::Path) -> Result<(), String> {
    crate::tools::plot::write_png_and_svg(report, png, svg, (900, 600))
}

impl crate::tools::plot::Figure for Report {
    fn draw<DB>(&self, root: DrawingArea<DB, plotters::coord::Shift>) -> Result<(), String>
    where
        DB: DrawingBackend,
        DB::ErrorType: 'static,
    {
        let report = self;
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        root.fill(&WHITE).map_err(err)?;
        let error = |r: &Row| r.errors.max_distance_error.max(ERROR_FLOOR);
        let (mut t0, mut t1) = (f64::INFINITY, 0.0f64);
        // Whole decades of time, so that the log axis has labelled ticks.
        let decade_below = |t: f64| 10f64.powf(t.log10().floor());
        let decade_above = |t: f64| 10f64.powf(t.log10().ceil());
        let (mut e0, mut e1) = (f64::INFINITY, 0.0f64);
        for r in &report.rows {
            t0 = t0.min(r.seconds);
            t1 = t1.max(r.seconds);
            e0 = e0.min(error(r));
            e1 = e1.max(error(r));
        }
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!(
                    "run time against error, {} x {}",
                    report.width, report.height
                ),
                ("sans-serif", 22),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                (decade_below(t0 / 1.2)..decade_above(t1 * 1.2)).log_scale(),
                (e0 / 10.0..e1 * 10.0).log_scale(),
            )
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("render time (s)")
            .y_desc("largest hit-distance error")
            .x_label_formatter(&|x| format!("{x}"))
            .y_label_formatter(&|y| {
                if *y <= ERROR_FLOOR * 1.01 {
                    "0 (exact)".to_string()
                } else {
                    format!("{y:.0e}")
                }
            })
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(err)?;
        let colours = [BLUE, RED, GREEN, MAGENTA, CYAN, BLACK];
        let mut methods: Vec<Method> = Vec::new();
        for r in &report.rows {
            if !methods.contains(&r.method) {
                methods.push(r.method);
            }
        }
        for (i, &m) in methods.iter().enumerate() {
            let colour = colours[i % colours.len()];
            let points: Vec<(f64, f64)> = report
                .rows
                .iter()
                .filter(|r| r.method == m)
                .map(|r| (r.seconds, error(r)))
                .collect();
            chart
                .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
                .map_err(err)?
                .label(m.name())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
                });
            let rows: Vec<&Row> = report.rows.iter().filter(|r| r.method == m).collect();
            chart
                .draw_series(rows.iter().map(|r| {
                    let style = if r.errors.differing == 0 {
                        colour.filled()
                    } else {
                        colour.stroke_width(2)
                    };
                    Circle::new((r.seconds, error(r)), 5, style)
                }))
                .map_err(err)?;
        }
        let front: Vec<(f64, f64)> = pareto_front(&report.rows)
            .into_iter()
            .map(|i| (report.rows[i].seconds, error(&report.rows[i])))
            .collect();
        let mut front = front;
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(DashedLineSeries::new(
                front.clone(),
                6,
                4,
                BLACK.stroke_width(1),
            ))
            .map_err(err)?;
        // Crosses as well as the dashes: a front of one point has no line.
        chart
            .draw_series(
                front
                    .iter()
                    .map(|&p| Cross::new(p, 8, BLACK.stroke_width(2))),
            )
            .map_err(err)?
            .label("Pareto front")
            .legend(|(x, y)| Cross::new((x + 9, y), 5, BLACK.stroke_width(2)));
        chart
            .draw_series(
                report
                    .rows
                    .iter()
                    .filter(|r| r.default)
                    .map(|r| Circle::new((r.seconds, error(r)), 12, BLACK.stroke_width(2))),
            )
            .map_err(err)?
            .label("the default")
            .legend(|(x, y)| Circle::new((x + 9, y), 6, BLACK.stroke_width(2)));
        // An empty series, for the legend's key to hollow markers.
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
            .map_err(err)?
            .label("hollow: some pixel shows another object")
            .legend(|(x, y)| Circle::new((x + 9, y), 4, BLACK.stroke_width(1)));
        crate::tools::plot::legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        root.present().map_err(err)
    }
}
