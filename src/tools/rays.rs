//! Ray diagrams (`nes rays`): how a bundle of rays travels through the
//! scene's space.
//!
//! Input: a compiled [`Scene`], a set of pixels and an axis-aligned view.
//! Output: a [`Diagram`] (every ray's path as traced, the points where the
//! method evaluated an object, where the path wrapped, the hit, the shadow
//! paths to each light and whether they were blocked, the objects' cross
//! sections in the drawing plane, the torus cell, the sphere space's
//! circles), all in the space's coordinates, and [`draw`], which projects
//! it onto the view's plane as SVG or PNG. View rays are red and shadow
//! rays blue, as in the seed report's figures.

use std::ops::ControlFlow;

use glam::DVec3;
use plotters::prelude::*;

use crate::scene::Scene;
use crate::space::{points_along, Space};
use crate::trace::intersect::{Scratch, SearchLog};
use crate::trace::Tracer;

/// Which pixels' rays to draw.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Selection {
    /// Every `every`-th pixel of row `y`.
    Row {
        /// The row, from 0 at the top.
        y: u32,
        /// The spacing in pixels (0 counts as 1); the picked pixels are spread over
        /// the whole row and include its middle pixel.
        every: u32,
    },
    /// Every `every`-th pixel of column `x`.
    Column {
        /// The column, from 0 at the left.
        x: u32,
        /// The spacing in pixels (0 counts as 1); the picked pixels are spread over
        /// the whole column and include its middle pixel.
        every: u32,
    },
    /// Every `every`-th pixel in both directions.
    Grid {
        /// The spacing in pixels along both axes (0 counts as 1), the middle row
        /// and column included.
        every: u32,
    },
    /// These pixels, `(column, row)`, in this order (`--pixel X,Y ...`).
    Pixels(Vec<(u32, u32)>),
}

impl Selection {
    /// The pixels `(column, row)` selected in a `width` x `height` image, row
    /// by row for a grid; an error naming the first pixel outside the image.
    pub fn pixels(&self, width: u32, height: u32) -> Result<Vec<(u32, u32)>, String> {
        let check = |x: u32, y: u32| {
            if x < width && y < height {
                Ok((x, y))
            } else {
                Err(format!(
                    "pixel ({x}, {y}) is outside the {width} x {height} image"
                ))
            }
        };
        let centred = |n: u32, every: u32| {
            // Spread over the whole row or column, the middle pixel kept.
            let every = every.max(1);
            let first = (n / 2) % every;
            (first..n).step_by(every as usize).collect::<Vec<u32>>()
        };
        match self {
            Selection::Row { y, .. } if *y >= height => Err(format!(
                "row {y} is outside the {width} x {height} image (rows run from 0 to {})",
                height - 1
            )),
            Selection::Column { x, .. } if *x >= width => Err(format!(
                "column {x} is outside the {width} x {height} image (columns run from 0 to {})",
                width - 1
            )),
            Selection::Row { y, every } => centred(width, *every)
                .into_iter()
                .map(|x| check(x, *y))
                .collect(),
            Selection::Column { x, every } => centred(height, *every)
                .into_iter()
                .map(|y| check(*x, y))
                .collect(),
            Selection::Grid { every } => {
                let xs = centred(width, *every);
                let ys = centred(height, *every);
                Ok(ys
                    .iter()
                    .flat_map(|&y| xs.iter().map(move |&x| (x, y)))
                    .collect())
            }
            Selection::Pixels(list) => list.iter().map(|&(x, y)| check(x, y)).collect(),
        }
    }
}

/// An axis-aligned drawing plane: the axis dropped, and the plane's
/// position along it (where the objects' cross sections are taken); or,
/// with `perspective`, a 3D drawing seen from above and to the side.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// The axis left out of the drawing (0, 1, 2 for x, y, z): the drawing's
    /// axes are the other two ([`View::axes`]).
    pub dropped: usize,
    /// The plane's coordinate along the dropped axis, where the objects' cross
    /// sections are taken (the camera's for `side`, `top` and `front`).
    pub level: f64,
    /// Whether this is the 3D view (`3d`), drawn in perspective from an eye
    /// that [`diagram`] places; `dropped` and `level` then do not project.
    pub perspective: bool,
    /// Where the 3D drawing is seen from: placed by [`diagram`] once the
    /// drawing's extent is known.
    eye: Option<Eye>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Eye {
    position: DVec3,
    right: DVec3,
    up: DVec3,
    forward: DVec3,
}

const AXIS_NAMES: [&str; 3] = ["x", "y", "z"];

impl View {
    /// `side` (the x-z plane), `top` (x-y), `front` (y-z), each through
    /// the camera, a plane such as `y=0.5`, or `3d`.
    pub fn parse(text: &str, camera: DVec3) -> Result<View, String> {
        let view = |dropped: usize| View {
            dropped,
            level: camera[dropped],
            perspective: false,
            eye: None,
        };
        match text.trim() {
            "3d" => Ok(View {
                perspective: true,
                ..view(1)
            }),
            "side" => Ok(view(1)),
            "top" => Ok(view(2)),
            "front" => Ok(view(0)),
            other => {
                let (axis, value) = other
                    .split_once('=')
                    .ok_or_else(|| format!("unknown view `{other}`"))?;
                let dropped = AXIS_NAMES
                    .iter()
                    .position(|a| *a == axis.trim())
                    .ok_or_else(|| format!("unknown axis `{}`", axis.trim()))?;
                let level: f64 = value
                    .trim()
                    .parse()
                    .map_err(|_| format!("`{}` is not a number", value.trim()))?;
                if !level.is_finite() {
                    return Err(format!("`{}` is not a finite number", value.trim()));
                }
                Ok(View {
                    dropped,
                    level,
                    perspective: false,
                    eye: None,
                })
            }
        }
    }

    /// The two axes drawn: horizontal, vertical.
    pub fn axes(&self) -> (usize, usize) {
        match self.dropped {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        }
    }

    /// The drawing's coordinates of `p`; NaN behind the 3D eye.
    fn project(&self, p: DVec3) -> (f64, f64) {
        if let Some(eye) = self.eye {
            let q = p - eye.position;
            let depth = q.dot(eye.forward);
            if depth <= 1e-9 {
                return (f64::NAN, f64::NAN);
            }
            return (q.dot(eye.right) / depth, q.dot(eye.up) / depth);
        }
        let (h, v) = self.axes();
        (p[h], p[v])
    }

    /// Look at the box `lo..hi` from above and to the side, far enough
    /// to see all of it.
    fn place_eye(&mut self, lo: DVec3, hi: DVec3) {
        let centre = 0.5 * (lo + hi);
        let radius = (0.5 * (hi - lo).length()).max(1.0);
        let (az, el) = (-55f64.to_radians(), 28f64.to_radians());
        let towards_eye = DVec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
        let forward = -towards_eye;
        let right = forward.cross(DVec3::Z).normalize();
        let up = right.cross(forward);
        self.eye = Some(Eye {
            position: centre + 3.0 * radius * towards_eye,
            right,
            up,
            forward,
        });
    }

    fn lift(&self, a: f64, b: f64) -> DVec3 {
        let (h, v) = self.axes();
        let mut p = DVec3::ZERO;
        p[h] = a;
        p[v] = b;
        p[self.dropped] = self.level;
        p
    }
}

/// One ray as the tracer followed it.
#[derive(Debug, Clone, PartialEq)]
pub struct RayDrawing {
    /// The pixel, `(column, row)`.
    pub pixel: (u32, u32),
    /// Where the ray starts: the camera's position.
    pub origin: DVec3,
    /// The unit direction the ray starts in.
    pub direction: DVec3,
    /// The path up to the hit (or its end), one polyline per unbroken
    /// stretch (the torus breaks it where it wraps).
    pub path: Vec<Vec<DVec3>>,
    /// Where the method evaluated an object's function along the path.
    pub samples: Vec<DVec3>,
    /// Where the path left the cell through a face (torus).
    pub wraps: Vec<DVec3>,
    /// Where the ray hit (in the space's coordinates) and which object (an
    /// index into the scene's objects); `None` for a miss.
    pub hit: Option<(DVec3, usize)>,
    /// The shadow paths cast from the hit, one per light that a path reaches
    /// and that faces the surface; empty for a miss or with `shadows off`.
    pub shadows: Vec<ShadowDrawing>,
    /// The whole loop the path follows, where paths are closed; else
    /// empty.
    pub circle: Vec<DVec3>,
}

/// A shadow path from a hit towards a light.
#[derive(Debug, Clone, PartialEq)]
pub struct ShadowDrawing {
    /// Which light (an index into the scene's lights).
    pub light: usize,
    /// The path up to the light or to where it was blocked, one polyline per
    /// unbroken stretch.
    pub path: Vec<Vec<DVec3>>,
    /// Where the search evaluated an object's function along the path.
    pub samples: Vec<DVec3>,
    /// Where it was blocked, if it was.
    pub blocked_at: Option<DVec3>,
}

/// Everything `nes rays` draws, in the space's coordinates: made by
/// [`diagram`], drawn by [`draw`].
#[derive(Debug, Clone, PartialEq)]
pub struct Diagram {
    /// The drawing plane (or the 3D view, with its eye placed).
    pub view: View,
    /// One drawing per selected pixel, in the selection's order.
    pub rays: Vec<RayDrawing>,
    /// Per object, the segments of its zero contour in the drawing plane
    /// (in plane coordinates).
    pub contours: Vec<Vec<[(f64, f64); 2]>>,
    /// Each object's label (the solid as written), in the scene's order.
    pub labels: Vec<String>,
    /// Each object's colour, linear RGB.
    pub colours: Vec<DVec3>,
    /// The space's fundamental cell, if it has one.
    pub cell: Option<crate::space::Cell>,
    /// Each object's bound (drawn as a box in the 3D view); `None` for
    /// one without, and for one placed by the space's motions (S3, H3),
    /// whose bound is a box in its own coordinates, no box in the scene's.
    pub bounds: Vec<Option<(DVec3, DVec3)>>,
    /// Whether each object is placed by the space's motions (S3, H3), so
    /// that the 3D view draws no box for it (and says so in its legend).
    pub placed: Vec<bool>,
    /// The camera's position.
    pub camera: DVec3,
    /// Each light's position, in the scene's order.
    pub lights: Vec<DVec3>,
    /// The drawn region: (horizontal range, vertical range).
    pub extent: ((f64, f64), (f64, f64)),
    /// The space's name (`euclidean`, `torus`, `sphere`).
    pub space: String,
}

/// The polylines of the path from `origin` along `direction` up to `end`,
/// broken where the path jumps (a torus face), and the jump points.
fn trace_path(
    space: &dyn Space,
    origin: DVec3,
    direction: DVec3,
    end: f64,
) -> (Vec<Vec<DVec3>>, Vec<DVec3>) {
    let mut lines: Vec<Vec<DVec3>> = Vec::new();
    let mut wraps = Vec::new();
    space.walk(origin, direction, end, &mut |seg| {
        let (t0, t1) = seg.range();
        let t1 = t1.min(end);
        let n = seg.drawing_pieces();
        let points: Vec<DVec3> = (0..=n)
            .map(|k| seg.point(t0 + (t1 - t0) * k as f64 / n as f64))
            .collect();
        match lines.last_mut() {
            Some(last)
                if last
                    .last()
                    .is_some_and(|q| (*q - points[0]).length() <= 1e-9 * (1.0 + q.length())) =>
            {
                last.extend_from_slice(&points[1..]);
            }
            Some(last) => {
                if let Some(&q) = last.last() {
                    wraps.push(q);
                }
                lines.push(points);
            }
            None => lines.push(points),
        }
        if t1 >= end {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    (lines, wraps)
}

fn logged_points(
    space: &dyn Space,
    origin: DVec3,
    direction: DVec3,
    log: &SearchLog,
) -> Vec<DVec3> {
    let mut ts: Vec<f64> = log.samples.iter().map(|s| s.t).collect();
    ts.sort_by(f64::total_cmp);
    ts.dedup();
    points_along(space, origin, direction, &ts)
        .into_iter()
        .flatten()
        .collect()
}

/// The diagram of `pixels` of `scene` in `view`.
pub fn diagram(scene: &Scene, pixels: &[(u32, u32)], view: View) -> Diagram {
    let tracer = Tracer::new(scene);
    let space = tracer.space();
    let settings = &scene.settings;
    let cam = scene.camera;
    let rays_gen = cam.rays();
    let loop_length = space.loop_length();
    let mut rays = Vec::new();
    for &(x, y) in pixels {
        let direction = rays_gen.direction(x as f64 + 0.5, y as f64 + 0.5);
        let origin = cam.position;
        let mut s = Scratch::logging();
        let hit = tracer.nearest_hit(origin, direction, settings.max_distance, &mut s);
        let log = s.log.take().unwrap_or_default();
        let end = hit.as_ref().map_or(settings.max_distance, |h| h.t);
        let (path, wraps) = trace_path(space, origin, direction, end);
        let samples = logged_points(space, origin, direction, &log);
        let circle = match loop_length {
            Some(length) => trace_path(space, origin, direction, length)
                .0
                .into_iter()
                .flatten()
                .collect(),
            None => Vec::new(),
        };
        let mut shadows = Vec::new();
        if let (Some(h), true) = (&hit, settings.shadows) {
            let n = tracer.normal(h, &mut s);
            let start = tracer.shadow_start(h, n);
            for (li, light) in scene.lights.iter().enumerate() {
                let Some((to_light, length)) = tracer.light_path(h.point, light.position) else {
                    continue;
                };
                if n.dot(to_light) <= 0.0 {
                    // Facing away: no shadow ray is cast.
                    continue;
                }
                s.log = Some(SearchLog::default());
                let block = tracer.shadow_hit(start, to_light, length, &mut s);
                let log = s.log.take().unwrap_or_default();
                let shadow_space = tracer.shadow_space();
                let stop = block.as_ref().map_or(length, |b| b.t);
                let (path, _) = trace_path(shadow_space, start, to_light, stop);
                shadows.push(ShadowDrawing {
                    light: li,
                    path,
                    samples: logged_points(shadow_space, start, to_light, &log),
                    blocked_at: block.map(|b| b.point),
                });
            }
        }
        rays.push(RayDrawing {
            pixel: (x, y),
            origin,
            direction,
            path,
            samples,
            wraps,
            hit: hit.map(|h| (h.point, h.object)),
            shadows,
            circle,
        });
    }

    let cell = space.cell();
    let mut view = view;
    if view.perspective {
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        let mut include = |p: DVec3| {
            if p.is_finite() {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        };
        include(cam.position);
        scene.lights.iter().for_each(|l| include(l.position));
        for r in &rays {
            r.path.iter().flatten().for_each(|&p| include(p));
        }
        if let Some(cell) = cell {
            include(cell.min);
            include(cell.max);
        }
        view.place_eye(lo, hi);
    }
    // The region drawn: everything the rays reach, the camera, the lights
    // and the cell, squared up a little.
    let mut lo = (f64::INFINITY, f64::INFINITY);
    let mut hi = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    let mut include = |p: DVec3| {
        let (a, b) = view.project(p);
        if a.is_finite() && b.is_finite() {
            lo = (lo.0.min(a), lo.1.min(b));
            hi = (hi.0.max(a), hi.1.max(b));
        }
    };
    include(cam.position);
    for r in &rays {
        r.path.iter().flatten().for_each(|&p| include(p));
        r.circle.iter().for_each(|&p| include(p));
        for sh in &r.shadows {
            sh.path.iter().flatten().for_each(|&p| include(p));
        }
    }
    for l in &scene.lights {
        include(l.position);
    }
    if let Some(cell) = cell {
        include(cell.min);
        include(cell.max);
    }
    let span = (hi.0 - lo.0).max(hi.1 - lo.1);
    let pad = 0.05
        * if view.perspective {
            span
        } else {
            span.max(1.0)
        };
    let extent = ((lo.0 - pad, hi.0 + pad), (lo.1 - pad, hi.1 + pad));

    let contours = scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            if view.perspective {
                Vec::new()
            } else {
                contour(
                    &o.function,
                    tracer.images_of(i),
                    &view,
                    extent,
                    space.chart_radius(),
                )
            }
        })
        .collect();
    // A placed object's bound (S3, H3) is a box in its own coordinates,
    // which is no box in the scene's: only the other bounds are drawn.
    let bounds = scene
        .objects
        .iter()
        .map(|o| {
            o.bound
                .filter(|_| o.placement.is_empty())
                .map(|b| (b.min, b.max))
        })
        .collect();
    Diagram {
        view,
        rays,
        contours,
        labels: scene.objects.iter().map(|o| o.label.clone()).collect(),
        colours: scene.objects.iter().map(|o| o.colour.flat()).collect(),
        cell,
        bounds,
        placed: scene
            .objects
            .iter()
            .map(|o| !o.placement.is_empty())
            .collect(),
        camera: cam.position,
        lights: scene.lights.iter().map(|l| l.position).collect(),
        extent,
        space: scene.space.name().to_string(),
    }
}

/// Grid cells per side for the cross sections.
const CONTOUR_GRID: usize = 300;

/// The zero contour of an object (every copy of it) in the view's plane,
/// by marching squares; each crossing placed by linear interpolation.
/// Only within `chart` of the origin, where the space's coordinates name
/// each point once ([`Space::chart_radius`]): beyond, in S3, they name
/// points again, and an object would be drawn a second time.
fn contour(
    f: &crate::expr::Implicit,
    images: &[crate::space::Image],
    view: &View,
    ((h0, h1), (v0, v1)): ((f64, f64), (f64, f64)),
    chart: Option<f64>,
) -> Vec<[(f64, f64); 2]> {
    if images.is_empty() {
        return Vec::new();
    }
    let n = CONTOUR_GRID;
    let mut slots = Vec::new();
    let at = |i: usize, j: usize| {
        (
            h0 + (h1 - h0) * i as f64 / n as f64,
            v0 + (v1 - v0) * j as f64 / n as f64,
        )
    };
    // The union of the copies: the smallest value.
    let mut values = vec![f64::NAN; (n + 1) * (n + 1)];
    for j in 0..=n {
        for i in 0..=n {
            let (a, b) = at(i, j);
            let p = view.lift(a, b);
            if chart.is_some_and(|r| p.length() > r) {
                continue;
            }
            values[j * (n + 1) + i] = images
                .iter()
                .map(|image| f.value(image.to_local(p), &mut slots))
                .fold(f64::INFINITY, f64::min);
        }
    }
    let value = |i: usize, j: usize| values[j * (n + 1) + i];
    let mut out = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
            let mut crossings = Vec::new();
            for k in 0..4 {
                let (p, q) = (corners[k], corners[(k + 1) % 4]);
                let (fp, fq) = (value(p.0, p.1), value(q.0, q.1));
                if !(fp.is_finite() && fq.is_finite()) || (fp < 0.0) == (fq < 0.0) {
                    continue;
                }
                let w = fp / (fp - fq);
                let (pa, pb) = at(p.0, p.1);
                let (qa, qb) = at(q.0, q.1);
                crossings.push((pa + w * (qa - pa), pb + w * (qb - pb)));
            }
            for pair in crossings.chunks(2) {
                if let [a, b] = pair {
                    out.push([*a, *b]);
                }
            }
        }
    }
    out
}

/// Draw `diagram` to `path`: SVG if it ends in `.svg`, PNG otherwise.
pub fn draw(diagram: &Diagram, path: &std::path::Path) -> Result<(), String> {
    crate::tools::plot::write(diagram, path, (1000, 800))
}

impl crate::tools::plot::Figure for Diagram {
    fn draw<DB>(&self, root: DrawingArea<DB, plotters::coord::Shift>) -> Result<(), String>
    where
        DB: DrawingBackend,
        DB::ErrorType: 'static,
    {
        let d = self;
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        root.fill(&WHITE).map_err(err)?;
        // Equal scales on both axes: widen the narrower range.
        let ((mut h0, mut h1), (mut v0, mut v1)) = d.extent;
        let (plot_w, plot_h) = (1000.0 - 100.0, 800.0 - 100.0);
        let per_unit = ((plot_w) / (h1 - h0)).min(plot_h / (v1 - v0));
        let (hc, vc) = (0.5 * (h0 + h1), 0.5 * (v0 + v1));
        (h0, h1) = (hc - 0.5 * plot_w / per_unit, hc + 0.5 * plot_w / per_unit);
        (v0, v1) = (vc - 0.5 * plot_h / per_unit, vc + 0.5 * plot_h / per_unit);
        let (ha, va) = d.view.axes();
        let caption = if d.view.perspective {
            format!(
                "{} rays in the {} space, in perspective",
                d.rays.len(),
                d.space
            )
        } else {
            format!(
                "{} rays in the {} space, plane {} = {}",
                d.rays.len(),
                d.space,
                AXIS_NAMES[d.view.dropped],
                d.view.level
            )
        };
        let mut chart = ChartBuilder::on(&root)
            .caption(caption, ("sans-serif", 20))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(45)
            .build_cartesian_2d(h0..h1, v0..v1)
            .map_err(err)?;
        let project = |p: DVec3| d.view.project(p);
        // Points behind the 3D eye project to NaN: left out.
        let polyline = |points: &[DVec3]| -> Vec<(f64, f64)> {
            points
                .iter()
                .map(|&p| project(p))
                .filter(|q| q.0.is_finite() && q.1.is_finite())
                .collect()
        };
        if d.view.perspective {
            // No axes in perspective: the box edges and the axis arrows
            // from the camera give the directions.
            let edges = |lo: DVec3, hi: DVec3| {
                let corner = |i: usize| {
                    DVec3::new(
                        if i & 1 == 0 { lo.x } else { hi.x },
                        if i & 2 == 0 { lo.y } else { hi.y },
                        if i & 4 == 0 { lo.z } else { hi.z },
                    )
                };
                let mut out = Vec::new();
                for i in 0..8usize {
                    for bit in [1usize, 2, 4] {
                        if i & bit == 0 {
                            out.push(vec![project(corner(i)), project(corner(i | bit))]);
                        }
                    }
                }
                out
            };
            if let Some(cell) = d.cell {
                chart
                    .draw_series(
                        edges(cell.min, cell.max)
                            .into_iter()
                            .map(|e| PathElement::new(e, BLACK.mix(0.5))),
                    )
                    .map_err(err)?
                    .label(cell.legend)
                    .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK.mix(0.5)));
            }
            let placed = d.placed.iter().filter(|&&p| p).count();
            if placed > 0 {
                // A placed object's bound is a box in its own coordinates,
                // which is no box in the drawing's: none is drawn, and the
                // legend says so.
                chart
                    .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())
                    .map_err(err)?
                    .label(format!(
                        "{placed} object{} moved by the {} space's motions: no bound box drawn",
                        if placed == 1 { "" } else { "s" },
                        d.space
                    ))
                    .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], WHITE));
            }
            for (i, b) in d.bounds.iter().enumerate() {
                if d.placed[i] {
                    continue;
                }
                let Some((lo, hi)) = b else { continue };
                // Planes have huge bounds: draw only boxes near the rays.
                if (*hi - *lo).max_element() > 1e3 {
                    continue;
                }
                let colour = rgb8(d.colours[i]);
                chart
                    .draw_series(
                        edges(*lo, *hi)
                            .into_iter()
                            .map(move |e| PathElement::new(e, colour.mix(0.6))),
                    )
                    .map_err(err)?
                    .label(format!("object {}: {} (its bound)", i + 1, d.labels[i]))
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2))
                    });
            }
            // Axis arrows at the camera, a tenth of the way to the eye.
            let length = d
                .view
                .eye
                .map_or(1.0, |e| 0.1 * (e.position - d.camera).length());
            for (axis, name) in [(DVec3::X, "x"), (DVec3::Y, "y"), (DVec3::Z, "z")] {
                let from = d.camera;
                let to = d.camera + length * axis;
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![project(from), project(to)],
                        BLACK.stroke_width(1),
                    )))
                    .map_err(err)?;
                chart
                    .draw_series(std::iter::once(Text::new(
                        name.to_string(),
                        project(to),
                        ("sans-serif", 14),
                    )))
                    .map_err(err)?;
            }
        } else {
            chart
                .configure_mesh()
                .x_desc(AXIS_NAMES[ha])
                .y_desc(AXIS_NAMES[va])
                .light_line_style(WHITE.mix(0.0))
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(err)?;
        }
        if let (Some(cell), false) = (d.cell, d.view.perspective) {
            let (a, b) = (project(cell.min), project(cell.max));
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [a, b],
                    BLACK.mix(0.5).stroke_width(1),
                )))
                .map_err(err)?
                .label(cell.legend)
                .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 16, y + 5)], BLACK.mix(0.5)));
        }
        // Cross sections, in each object's own colour (darkened so that
        // light colours stay visible).
        for (i, segs) in d.contours.iter().enumerate() {
            let colour = rgb8(d.colours[i]);
            let series = chart
                .draw_series(
                    segs.iter()
                        .map(|s| PathElement::new(vec![s[0], s[1]], colour.stroke_width(2))),
                )
                .map_err(err)?;
            if !segs.is_empty() {
                series
                    .label(format!("object {}: {}", i + 1, d.labels[i]))
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2))
                    });
            }
        }
        let view_red = RGBColor(220, 30, 30);
        let shadow_blue = RGBColor(30, 80, 220);
        // Whole loops of closed paths, faint, under everything.
        let mut loop_legend = false;
        for r in &d.rays {
            if r.circle.len() > 1 {
                let s = chart
                    .draw_series(std::iter::once(PathElement::new(
                        polyline(&r.circle),
                        BLACK.mix(0.12),
                    )))
                    .map_err(err)?;
                if !std::mem::replace(&mut loop_legend, true) {
                    s.label("grey: the rest of each ray's closed loop")
                        .legend(|(x, y)| {
                            PathElement::new(vec![(x, y), (x + 16, y)], BLACK.mix(0.3))
                        });
                }
            }
        }
        let mut legend_done = [false; 4];
        for r in &d.rays {
            for line in &r.path {
                let s = chart
                    .draw_series(std::iter::once(PathElement::new(
                        polyline(line),
                        view_red.mix(0.7).stroke_width(1),
                    )))
                    .map_err(err)?;
                if !std::mem::replace(&mut legend_done[0], true) {
                    s.label("view rays; dots: where the method evaluated")
                        .legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 16, y)], view_red.stroke_width(2))
                        });
                }
            }
            chart
                .draw_series(
                    r.samples
                        .iter()
                        .filter(|&&p| project(p).0.is_finite())
                        .map(|&p| Circle::new(project(p), 2, view_red.filled())),
                )
                .map_err(err)?;
            chart
                .draw_series(
                    r.wraps
                        .iter()
                        .filter(|&&p| project(p).0.is_finite())
                        .map(|&p| Cross::new(project(p), 3, BLACK.mix(0.6))),
                )
                .map_err(err)?;
            for sh in &r.shadows {
                let style = if sh.blocked_at.is_some() {
                    shadow_blue.mix(0.35).stroke_width(1)
                } else {
                    shadow_blue.mix(0.8).stroke_width(1)
                };
                for line in &sh.path {
                    let s = chart
                        .draw_series(std::iter::once(PathElement::new(polyline(line), style)))
                        .map_err(err)?;
                    if !std::mem::replace(&mut legend_done[1], true) {
                        s.label("shadow rays (faint, ending in a ring: blocked)")
                            .legend(move |(x, y)| {
                                PathElement::new(
                                    vec![(x, y), (x + 16, y)],
                                    shadow_blue.stroke_width(2),
                                )
                            });
                    }
                }
                chart
                    .draw_series(
                        sh.samples
                            .iter()
                            .map(|&p| Circle::new(project(p), 2, shadow_blue.filled())),
                    )
                    .map_err(err)?;
                if let Some(b) = sh.blocked_at {
                    chart
                        .draw_series(std::iter::once(Circle::new(
                            project(b),
                            4,
                            shadow_blue.stroke_width(1),
                        )))
                        .map_err(err)?;
                }
            }
            if let Some((p, _)) = r.hit {
                chart
                    .draw_series(std::iter::once(Circle::new(project(p), 3, BLACK.filled())))
                    .map_err(err)?;
            }
        }
        chart
            .draw_series(std::iter::once(TriangleMarker::new(
                project(d.camera),
                7,
                BLACK.filled(),
            )))
            .map_err(err)?
            .label("camera; black dots: hits")
            .legend(|(x, y)| TriangleMarker::new((x + 8, y), 5, BLACK.filled()));
        let gold = RGBColor(230, 170, 0);
        let lights = chart
            .draw_series(
                d.lights
                    .iter()
                    .map(|&p| Circle::new(project(p), 7, gold.filled())),
            )
            .map_err(err)?;
        if !d.lights.is_empty() {
            lights
                .label("lights")
                .legend(move |(x, y)| Circle::new((x + 8, y), 5, gold.filled()));
        }
        crate::tools::plot::legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        root.present().map_err(err)
    }
}

/// An object's linear colour as drawn: darkened a little, so that light
/// colours (a white floor) stay visible on white.
fn rgb8(linear: DVec3) -> RGBColor {
    let [r, g, b] = crate::shade::to_srgb8(linear * 0.8);
    RGBColor(r, g, b)
}
