//! One pixel's ray, examined (`nes probe`).
//!
//! Input: a compiled [`Scene`] and a pixel. Output: a [`Probe`]: each
//! object's function along the ray's path, the points where the scene's
//! method evaluated it, the intervals it bounded it by, the roots (where
//! the function changes sign along the path), and where the ray stopped;
//! printed as a table ([`std::fmt::Display`]) and drawn by [`plot`]. It
//! answers "why does this pixel show that?": a sample step that jumps over
//! a thin object shows as samples on one side of zero around a dip of the
//! curve below it.
//!
//! In the torus the curve is each object's function as written, at the
//! path's point in the cell; the copies of an object that straddles a face
//! are not folded in (the samples are those of whichever copy the method
//! searched, so they can sit off the curve near a face).

use std::fmt;

use glam::DVec3;
use plotters::prelude::*;

use crate::expr::Interval;
use crate::scene::Scene;
use crate::space::points_along;
use crate::trace::intersect::Scratch;
use crate::trace::{Route, Tracer};

/// Curve points per object.
const CURVE_POINTS: usize = 1200;

/// One pixel's central ray, examined: what [`probe`] returns, printed as a
/// table by its `Display` and drawn by [`plot`].
#[derive(Debug, Clone, PartialEq)]
pub struct Probe {
    /// The pixel, `(column, row)` from the top-left corner.
    pub pixel: (u32, u32),
    /// Where the ray starts: the camera's position.
    pub origin: DVec3,
    /// The unit direction the ray starts in, through the pixel's centre.
    pub direction: DVec3,
    /// The scene's method, by name (`auto`, `march`, ...).
    pub method: String,
    /// The stretch of the path shown: `[0, extent]`.
    pub extent: f64,
    /// A `--distance` past the ray's end (`max_distance`, or the
    /// space's), which `extent` was cut to.
    pub cut_from: Option<f64>,
    /// Where the ray stopped, and on which object.
    pub stop: Option<(f64, usize)>,
    /// One entry per object, in the scene's order.
    pub objects: Vec<ObjectProbe>,
    /// Where paths are integrated per ray (a metric space): the probed
    /// ray's integrator steps, its unit-speed drift and how it ended.
    pub integration: Option<String>,
    /// Whether the path ended before its length (a metric space's path
    /// left the domain, met a singular point, ...).
    pub ended_early: bool,
}

/// One object's function along the probed path.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectProbe {
    /// The solid as written.
    pub label: String,
    /// How the scene's method searches this object.
    pub route: Route,
    /// How the object's hits are found, in words.
    pub how: String,
    /// `(t, f)` along the path, evenly spaced.
    pub curve: Vec<(f64, f64)>,
    /// `(t, f)` where the method evaluated `f`, in its order.
    pub samples: Vec<(f64, f64)>,
    /// Pieces `[a, b]` of the path and the interval enclosing `f` there.
    pub pieces: Vec<(f64, f64, Interval)>,
    /// Where `f` changes sign along the shown path, to 1e-9.
    pub roots: Vec<f64>,
}

/// Why a probe cannot be made.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ProbeError {
    /// The pixel asked for is not in the image.
    #[error("pixel ({x}, {y}) is outside the {width} x {height} image")]
    Outside {
        /// The column asked for.
        x: u32,
        /// The row asked for.
        y: u32,
        /// The image's width in pixels.
        width: u32,
        /// The image's height in pixels.
        height: u32,
    },
}

/// Probe pixel `(x, y)` of `scene`, showing the path up to `distance` (by
/// default up to half again the stopping distance, or the whole path).
pub fn probe(scene: &Scene, x: u32, y: u32, distance: Option<f64>) -> Result<Probe, ProbeError> {
    let cam = scene.camera;
    if x >= cam.width || y >= cam.height {
        return Err(ProbeError::Outside {
            x,
            y,
            width: cam.width,
            height: cam.height,
        });
    }
    let tracer = Tracer::new(scene);
    let origin = cam.position;
    let direction = cam.rays().direction(x as f64 + 0.5, y as f64 + 0.5);
    let limit = scene.settings.max_distance;
    let mut s = Scratch::logging();
    let hit = tracer.nearest_hit(origin, direction, limit, &mut s);
    let log = s.log.take().unwrap_or_default();
    // The tracer is new, so its space's report is this one path's.
    let ended_early = tracer
        .space()
        .path_report()
        .is_some_and(|r| r.ended_early() > 0);
    let integration = tracer.space().path_report().map(|r| {
        let mut text = format!(
            "geodesic integrated in {} steps ({} rejected), unit-speed drift |g(v, v) - 1| at most {:.1e}",
            r.accepted, r.rejected, r.max_drift
        );
        if r.ended_early() > 0 {
            text.push_str("; ");
            text.push_str(&r.ended_early_warning());
        }
        text
    });
    let stop = hit.map(|h| (h.t, h.object));
    let extent = distance
        .unwrap_or(match stop {
            Some((t, _)) => (1.5 * t).max(1.0),
            None => limit,
        })
        .min(limit);

    let ts: Vec<f64> = (0..CURVE_POINTS)
        .map(|i| extent * i as f64 / (CURVE_POINTS - 1) as f64)
        .collect();
    let points = points_along(tracer.space(), origin, direction, &ts);
    let mut slots = Vec::new();
    let integrated = tracer.space().integrates();
    let objects = scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, obj)| {
            let f = &obj.function;
            // In S3 and H3 an object's formula is in its own coordinates,
            // where its placement takes the path.
            let placed = tracer
                .images_of(i)
                .first()
                .copied()
                .filter(|image| image.as_offset().is_none());
            let local = |p: DVec3| placed.map_or(p, |image| image.to_local(p));
            let curve: Vec<(f64, f64)> = ts
                .iter()
                .zip(&points)
                .filter_map(|(&t, p)| p.map(|p| (t, f.value(local(p), &mut slots))))
                .collect();
            let value_at = |t: f64, slots: &mut Vec<f64>| {
                points_along(tracer.space(), origin, direction, &[t])[0]
                    .map(|p| f.value(local(p), slots))
                    .unwrap_or(f64::NAN)
            };
            let by_parts = obj.pruned.is_some() || tracer.routes()[i] == Route::Union;
            let mut roots = Vec::new();
            for pair in curve.windows(2) {
                let ((mut a, mut fa), (mut b, fb)) = (pair[0], pair[1]);
                if !(fa.is_finite() && fb.is_finite()) || fa.signum() == fb.signum() {
                    continue;
                }
                if fa == 0.0 {
                    roots.push(a);
                    continue;
                }
                while b - a > 1e-9 * (1.0 + b.abs()) {
                    let m = 0.5 * (a + b);
                    let fm = value_at(m, &mut slots);
                    if !fm.is_finite() {
                        break;
                    }
                    if fm.signum() == fa.signum() {
                        (a, fa) = (m, fm);
                    } else {
                        b = m;
                    }
                }
                roots.push(0.5 * (a + b));
            }
            ObjectProbe {
                label: obj.label.clone(),
                route: tracer.routes()[i],
                how: crate::tools::explain::route_text(
                    tracer.routes()[i],
                    obj,
                    scene.settings.step,
                    integrated,
                    matches!(scene.space, crate::space::SpaceKind::Metric(_)),
                ),
                curve,
                // A union's parts and a cell's shorter formula equal `f`
                // only near its zeros: their samples are shown at `f` as
                // written, where the method evaluated.
                samples: log
                    .samples
                    .iter()
                    .filter(|s| s.object == i)
                    .map(|s| match by_parts {
                        true => (s.t, value_at(s.t, &mut slots)),
                        false => (s.t, s.value),
                    })
                    .collect(),
                pieces: log
                    .pieces
                    .iter()
                    .filter(|p| p.object == i)
                    .map(|p| (p.a, p.b, p.range))
                    .collect(),
                roots,
            }
        })
        .collect();
    Ok(Probe {
        pixel: (x, y),
        origin,
        direction,
        method: scene.settings.method.name().to_string(),
        extent,
        cut_from: distance.filter(|&d| d > extent),
        stop,
        objects,
        integration,
        ended_early,
    })
}

fn vec_text(v: DVec3) -> String {
    format!("({:.4}, {:.4}, {:.4})", v.x, v.y, v.z)
}

impl fmt::Display for Probe {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "pixel ({}, {}): ray from {} towards {}, method {}",
            self.pixel.0,
            self.pixel.1,
            vec_text(self.origin),
            vec_text(self.direction),
            self.method
        )?;
        match self.stop {
            Some((t, i)) => writeln!(
                f,
                "stopped at t = {t:.9} on object {} ({})",
                i + 1,
                self.objects[i].label
            )?,
            None if self.ended_early => writeln!(
                f,
                "no hit: the path ended before its length (why: the next line); the curves below stop where it ended"
            )?,
            None => writeln!(f, "no hit: the ray ran its whole length")?,
        }
        if let Some(text) = &self.integration {
            writeln!(f, "{text}")?;
        }
        write!(f, "path shown: t from 0 to {:.4}", self.extent)?;
        match self.cut_from {
            Some(asked) => writeln!(
                f,
                " (where the ray ends, max_distance or the space's; --distance asked for {asked:e})"
            )?,
            None => writeln!(f)?,
        }
        for (i, o) in self.objects.iter().enumerate() {
            writeln!(f)?;
            let roots: Vec<String> = o.roots.iter().map(|t| format!("{t:.9}")).collect();
            writeln!(
                f,
                "object {} ({}), {}\n  f changes sign at t = {}",
                i + 1,
                o.label,
                o.how,
                if roots.is_empty() {
                    "nowhere on the shown path".to_string()
                } else {
                    roots.join(", ")
                }
            )?;
            if o.samples.is_empty() && o.pieces.is_empty() {
                let why = if o.route == Route::Closed && !o.how.starts_with("sampled") {
                    "solved in closed form, no samples"
                } else if o.route == Route::Union {
                    "no samples: the parts the path meets are solved in closed form, or the path misses every part's box, or a nearer hit came first"
                } else {
                    "no samples: the path misses its bound (or the cells of it where the surface may lie), a nearer hit came first, or the cells' shorter formulas it met are solved in closed form"
                };
                writeln!(f, "  {why}")?;
                continue;
            }
            writeln!(
                f,
                "  {} point evaluations, {} interval pieces",
                o.samples.len(),
                o.pieces.len()
            )?;
            writeln!(f, "  {:>16} {:>16}", "t", "f(t)")?;
            for (t, v) in &o.samples {
                writeln!(f, "  {t:>16.9} {v:>16.6e}")?;
            }
            if !o.pieces.is_empty() {
                writeln!(
                    f,
                    "  {:>16} {:>16} {:>14} {:>14}  holds zero?",
                    "from t", "to t", "f at least", "f at most"
                )?;
                for (a, b, range) in &o.pieces {
                    writeln!(
                        f,
                        "  {a:>16.9} {b:>16.9} {:>14.6e} {:>14.6e}  {}",
                        range.lo,
                        range.hi,
                        if range.contains(0.0) { "maybe" } else { "no" }
                    )?;
                }
            }
        }
        Ok(())
    }
}

/// Maps f to a symmetric log scale: linear near zero, logarithmic for
/// large values (an `x^8` surface spans 1e8 along one ray).
fn symlog(v: f64) -> f64 {
    v.signum() * (1.0 + v.abs()).log10()
}

fn unsymlog(y: f64) -> f64 {
    y.signum() * (10f64.powf(y.abs()) - 1.0)
}

/// Draw the probe: `f` of every object against distance along the path
/// (symmetric log scale), the method's samples as dots, interval pieces
/// as bars, roots as crosses on the axis, and where the ray stopped as a
/// vertical line. PNG at `png` and SVG at `svg`.
pub fn plot(probe: &Probe, png: &std::path::Path, svg: &std::path::Path) -> Result<(), String> {
    crate::tools::plot::write_png_and_svg(probe, png, svg, (900, 560))
}

impl crate::tools::plot::Figure for Probe {
    fn draw<DB>(&self, root: DrawingArea<DB, plotters::coord::Shift>) -> Result<(), String>
    where
        DB: DrawingBackend,
        DB::ErrorType: 'static,
    {
        let probe = self;
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        root.fill(&WHITE).map_err(err)?;
        let mut y_max: f64 = 0.5;
        for o in &probe.objects {
            for &(_, v) in o.curve.iter().chain(&o.samples) {
                if v.is_finite() {
                    y_max = y_max.max(symlog(v).abs());
                }
            }
        }
        let y_max = y_max * 1.05;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!(
                    "f along the ray of pixel ({}, {}), method {}",
                    probe.pixel.0, probe.pixel.1, probe.method
                ),
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..probe.extent, -y_max..y_max)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("distance along the path, t")
            .y_desc("f (symmetric log scale)")
            .y_label_formatter(&|y| {
                let v = unsymlog(*y);
                if v.abs() < 1e-9 {
                    "0".into()
                } else if v.abs() < 100.0 {
                    format!("{v:.1}")
                } else {
                    format!("{v:.0e}")
                }
            })
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(err)?;
        chart
            .draw_series(LineSeries::new(
                [(0.0, 0.0), (probe.extent, 0.0)],
                BLACK.mix(0.6),
            ))
            .map_err(err)?;
        let palette = [
            RGBColor(31, 119, 180),
            RGBColor(214, 39, 40),
            RGBColor(44, 160, 44),
            RGBColor(148, 103, 189),
            RGBColor(255, 127, 14),
            RGBColor(140, 86, 75),
            RGBColor(227, 119, 194),
        ];
        for (i, o) in probe.objects.iter().enumerate() {
            let colour = palette[i % palette.len()];
            for &(a, b, range) in &o.pieces {
                let (lo, hi) = (range.lo, range.hi);
                if !(lo.is_finite() || hi.is_finite()) {
                    continue;
                }
                let clamp = |v: f64| symlog(v).clamp(-y_max, y_max);
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [
                            (a, clamp(if lo.is_nan() { -f64::MAX } else { lo })),
                            (b, clamp(if hi.is_nan() { f64::MAX } else { hi })),
                        ],
                        colour.mix(0.12).filled(),
                    )))
                    .map_err(err)?;
            }
            // The curve, broken where f is not finite.
            let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
            for &(t, v) in &o.curve {
                if v.is_finite() {
                    runs.last_mut().expect("one run").push((t, symlog(v)));
                } else if !runs.last().expect("one run").is_empty() {
                    runs.push(Vec::new());
                }
            }
            let mut first = true;
            for run in runs.into_iter().filter(|r| r.len() > 1) {
                let series = chart
                    .draw_series(LineSeries::new(run, colour.stroke_width(2)))
                    .map_err(err)?;
                if std::mem::take(&mut first) {
                    series
                        .label(format!("object {}: {}", i + 1, o.label))
                        .legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
                        });
                }
            }
            chart
                .draw_series(
                    o.samples
                        .iter()
                        .filter(|(t, v)| v.is_finite() && *t <= probe.extent)
                        .map(|&(t, v)| Circle::new((t, symlog(v)), 4, colour.filled())),
                )
                .map_err(err)?;
            chart
                .draw_series(
                    o.samples
                        .iter()
                        .filter(|(t, v)| v.is_finite() && *t <= probe.extent)
                        .map(|&(t, v)| Circle::new((t, symlog(v)), 4, BLACK.stroke_width(1))),
                )
                .map_err(err)?;
            chart
                .draw_series(
                    o.roots
                        .iter()
                        .map(|&t| Cross::new((t, 0.0), 6, BLACK.stroke_width(2))),
                )
                .map_err(err)?;
        }
        if let Some((t, _)) = probe.stop {
            chart
                .draw_series(DashedLineSeries::new(
                    [(t, -y_max), (t, y_max)],
                    6,
                    4,
                    BLACK.stroke_width(1),
                ))
                .map_err(err)?
                .label(format!("ray stopped, t = {t:.4}"))
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
        }
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
            .map_err(err)?
            .label("dots: the method's samples; bars: interval pieces; x: roots")
            .legend(|(x, y)| Circle::new((x + 9, y), 3, BLACK.filled()));
        crate::tools::plot::legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        root.present().map_err(err)
    }
}
