//! A space whose metric the scene writes: `space metric { g ... }`.
//!
//! Input: the metric tensor's six entries as expressions in the chart's
//! coordinates x, y, z (built by the compiler in an expression [`Graph`]),
//! the chart's domain, and the integrator's settings. Output: the
//! [`MetricSpace`] that walks rays along its geodesics, each accepted
//! integrator step a segment with dense output.
//!
//! The geodesic equation `x'' = -Gamma(x', x')` is derived symbolically:
//! with `D_v g` the derivative of the metric along the velocity `v`,
//! `Gamma^i_jk v^j v^k = g^il ((D_v g) v - 1/2 d_l (v^T g v))_l`, which
//! needs only the 18 first derivatives of `g` and its inverse (adjugate
//! over determinant), all in the graph, simplified and compiled into one
//! tape of the position and velocity. The Christoffel symbols themselves
//! are built too, for `nes explain`'s sizes.
//!
//! **Directions are given in the orthonormal frame that Gram-Schmidt makes
//! of the coordinate basis** (`d/dx`, then `d/dy`, then `d/dz`) at each
//! point: the Cholesky factor `L` of `g = L L^T` turns a chart vector `v`
//! into its frame components `L^T v`, and a gradient (a covector) into
//! `L^-1 grad`. Rays are parametrised by arc length in the metric, so a
//! path's chart velocity has `g(v, v) = 1`; how far the integration drifts
//! from that is measured at every step, enters the step-size control and
//! is reported.

use std::cell::RefCell;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use glam::DVec3;

use super::dop853;
use super::{Aabb, Segment, Space};
use crate::expr::jit::CompiledTape;
use crate::expr::{Graph, NodeId, Tape};

/// The most sample points per integrator step at which a step is searched
/// for changes of sign: a step has one per `sample` of its length (its arc
/// length or its length in the chart, whichever is longer), at least one,
/// so the largest step is this many samples long.
pub const MAX_CHART_GRID: usize = 32;

/// How far from the origin chart coordinates may go: a path that gets
/// farther ends (its coordinates would soon lose the digits a hit needs).
pub const CHART_REACH: f64 = 1e6;

/// The index of entry `(i, j)` of a symmetric 3 x 3 matrix stored as
/// `xx, xy, xz, yy, yz, zz`.
pub const fn symmetric_index(i: usize, j: usize) -> usize {
    let (i, j) = if i <= j { (i, j) } else { (j, i) };
    match (i, j) {
        (0, 0) => 0,
        (0, 1) => 1,
        (0, 2) => 2,
        (1, 1) => 3,
        (1, 2) => 4,
        _ => 5,
    }
}

/// A step may add up to this many times its share of the drift before it
/// is refused: the drift's change over one step is a difference of two
/// roundings-prone values, not a smooth estimate, and refusing every step
/// that passes its share retried about one step in two (S2 x R, the
/// lens); the next step's size still aims at the share.
const DRIFT_SLACK: f64 = 2.0;

/// Steps one path may take across kinks of its metric before a step that
/// cannot meet the tolerance ends it (as where the metric is singular).
const MAX_FORCED_STEPS: u32 = 16;

/// A drift of the unit-speed constraint above this is warned about: a
/// hundred times the drift the default tolerance aims at.
pub const DRIFT_WARNING: f64 = 1e-6;

/// Steps a path may take by default.
pub const DEFAULT_METRIC_STEPS: u32 = 20_000;
/// The default spacing of the samples along a path that are searched for
/// surfaces.
pub const DEFAULT_METRIC_SAMPLE: f64 = 0.0625;

/// A metric written in a scene, compiled: what [`MetricSpace`] integrates.
#[derive(Debug)]
pub struct Metric {
    /// x, y, z to the six entries `xx, xy, xz, yy, yz, zz`.
    tensor: Tape,
    /// x, y, z, vx, vy, vz to the acceleration `-Gamma(v, v)`, all in one
    /// symbolic expression (inverse metric included).
    acceleration: Tape,
    /// x, y, z, vx, vy, vz to the six entries and the lowered equation's
    /// three components `r_l = ((D_v g) v)_l - 1/2 v^T (d_l g) v`: what the
    /// integrator evaluates, solving `g a = -r` numerically per evaluation
    /// (see [`Metric::rates`]).
    lowered: Tape,
    /// `lowered` as machine code, where this machine can run it: the same
    /// bits, several times faster. Compiled on the first evaluation, so
    /// that checking a scene (or failing to) never waits for Cranelift.
    compiled_lowered: std::sync::OnceLock<Option<CompiledTape>>,
    /// x, y, z to a value negative inside the chart's domain.
    domain: Option<Tape>,
    /// Sizes for `nes explain`.
    pub sizes: MetricSizes,
    /// Steps a path may take before it ends.
    pub max_steps: u32,
    /// The spacing of the sample points searched for surfaces, in arc
    /// length and in chart distance alike; the largest integrator step is
    /// [`MAX_CHART_GRID`] of them.
    pub sample: f64,
    /// How the metric was written, for labels.
    pub label: String,
}

impl PartialEq for Metric {
    /// A metric is itself: two compiled from the same text are still two.
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self, other)
    }
}

/// How big the derived expressions are, in operations after
/// simplification.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MetricSizes {
    /// The six entries of the metric.
    pub metric: usize,
    /// The Christoffel symbols `Gamma^i_jk` (18 distinct), together.
    pub christoffel: usize,
    /// How many of the 18 are not identically zero.
    pub christoffel_nonzero: usize,
    /// The geodesic equation's right-hand side as one expression.
    pub acceleration: usize,
    /// The entries with the lowered equation `(D_v g) v - 1/2 d(v^T g v)`,
    /// which the integrator evaluates.
    pub evaluated: usize,
}

/// The orthonormal frame at a point: the Cholesky factor of the metric.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    l11: f64,
    l21: f64,
    l31: f64,
    l22: f64,
    l32: f64,
    l33: f64,
}

impl Frame {
    /// The frame of the metric `g` (entries `xx, xy, xz, yy, yz, zz`);
    /// `None` where it is not positive definite or not finite.
    pub fn of(g: &[f64; 6]) -> Option<Frame> {
        let l11 = g[0].sqrt();
        let l21 = g[1] / l11;
        let l31 = g[2] / l11;
        let l22 = (g[3] - l21 * l21).sqrt();
        let l32 = (g[4] - l31 * l21) / l22;
        let l33 = (g[5] - l31 * l31 - l32 * l32).sqrt();
        let f = Frame {
            l11,
            l21,
            l31,
            l22,
            l32,
            l33,
        };
        let ok = [l11, l21, l31, l22, l32, l33].iter().all(|v| v.is_finite())
            && l11 > 0.0
            && l22 > 0.0
            && l33 > 0.0;
        ok.then_some(f)
    }

    /// The frame components of the chart vector `v`: `L^T v`.
    #[inline]
    pub fn to_frame(&self, v: DVec3) -> DVec3 {
        DVec3::new(
            self.l11 * v.x + self.l21 * v.y + self.l31 * v.z,
            self.l22 * v.y + self.l32 * v.z,
            self.l33 * v.z,
        )
    }

    /// The chart vector whose frame components are `d`: `L^-T d`.
    #[inline]
    pub fn to_chart(&self, d: DVec3) -> DVec3 {
        let z = d.z / self.l33;
        let y = (d.y - self.l32 * z) / self.l22;
        let x = (d.x - self.l21 * y - self.l31 * z) / self.l11;
        DVec3::new(x, y, z)
    }

    /// The frame components of the covector (gradient) `w`: `L^-1 w`, the
    /// vector `g^-1 w` in the frame.
    #[inline]
    pub fn covector_to_frame(&self, w: DVec3) -> DVec3 {
        let a = w.x / self.l11;
        let b = (w.y - self.l21 * a) / self.l22;
        let c = (w.z - self.l31 * a - self.l32 * b) / self.l33;
        DVec3::new(a, b, c)
    }
}

/// The solution of `g a = r` for a symmetric positive definite `g`, by its
/// adjugate (no square roots); `None` where `g` is not positive definite
/// (a leading minor is not positive) or not finite.
#[inline]
fn solve_symmetric(g: &[f64; 6], r: DVec3) -> Option<DVec3> {
    let [xx, xy, xz, yy, yz, zz] = *g;
    let c00 = yy * zz - yz * yz;
    let c01 = xz * yz - xy * zz;
    let c02 = xy * yz - xz * yy;
    let c11 = xx * zz - xz * xz;
    let c12 = xy * xz - xx * yz;
    let c22 = xx * yy - xy * xy;
    let det = xx * c00 + xy * c01 + xz * c02;
    // `!(.. > 0)` also refuses NaN.
    if !(xx > 0.0 && c22 > 0.0 && det > 0.0 && det.is_finite()) {
        return None;
    }
    let k = 1.0 / det;
    Some(DVec3::new(
        (c00 * r.x + c01 * r.y + c02 * r.z) * k,
        (c01 * r.x + c11 * r.y + c12 * r.z) * k,
        (c02 * r.x + c12 * r.y + c22 * r.z) * k,
    ))
}

/// `v^T g v` for the symmetric `g`.
#[inline]
fn quadratic_form(g: &[f64; 6], v: DVec3) -> f64 {
    g[0] * v.x * v.x
        + g[3] * v.y * v.y
        + g[5] * v.z * v.z
        + 2.0 * (g[1] * v.x * v.y + g[2] * v.x * v.z + g[4] * v.y * v.z)
}

/// `v^T g v` with every term's absolute value: the scale of its rounding.
#[inline]
fn absolute_form(g: &[f64; 6], v: DVec3) -> f64 {
    let a = v.abs();
    g[0].abs() * a.x * a.x
        + g[3].abs() * a.y * a.y
        + g[5].abs() * a.z * a.z
        + 2.0 * (g[1].abs() * a.x * a.y + g[2].abs() * a.x * a.z + g[4].abs() * a.y * a.z)
}

thread_local! {
    /// Scratch slots for the metric's tapes, one set per tape and thread
    /// (a buffer is resized whenever a tape of another length uses it):
    /// the tracer's queries reach the space through `&self`.
    static SLOTS: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
    static TENSOR_SLOTS: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
    static DOMAIN_SLOTS: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
    static SYMBOLIC_SLOTS: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
}

impl Metric {
    /// Derive the geodesic equation of the metric whose entries (`xx, xy,
    /// xz, yy, yz, zz`) are `entries` in `graph` (inputs 0, 1, 2 are x, y,
    /// z), with the domain negative inside at `domain`, if any.
    pub fn derive(
        graph: &Graph,
        entries: [NodeId; 6],
        domain: Option<NodeId>,
        max_steps: u32,
        sample: f64,
    ) -> Metric {
        let mut g = Graph::new();
        let e: Vec<NodeId> = entries.iter().map(|&n| g.import(graph, n, &[])).collect();
        let at = |i: usize, j: usize| e[symmetric_index(i, j)];
        // d_k g_ij, for every k and stored entry.
        let dg: Vec<Vec<NodeId>> = (0..3)
            .map(|k| e.iter().map(|&n| g.derivative(n, k as u8)).collect())
            .collect();
        let d = |k: usize, i: usize, j: usize| dg[k][symmetric_index(i, j)];
        // The inverse: adjugate over determinant.
        let cof = |g: &mut Graph,
                   a: (usize, usize),
                   b: (usize, usize),
                   c: (usize, usize),
                   d: (usize, usize)| {
            let p = g.mul(at(a.0, a.1), at(b.0, b.1));
            let q = g.mul(at(c.0, c.1), at(d.0, d.1));
            g.sub(p, q)
        };
        let c00 = cof(&mut g, (1, 1), (2, 2), (1, 2), (1, 2));
        let c01 = cof(&mut g, (0, 2), (1, 2), (0, 1), (2, 2));
        let c02 = cof(&mut g, (0, 1), (1, 2), (0, 2), (1, 1));
        let c11 = cof(&mut g, (0, 0), (2, 2), (0, 2), (0, 2));
        let c12 = cof(&mut g, (0, 1), (0, 2), (0, 0), (1, 2));
        let c22 = cof(&mut g, (0, 0), (1, 1), (0, 1), (0, 1));
        let det = {
            let a = g.mul(at(0, 0), c00);
            let b = g.mul(at(0, 1), c01);
            let c = g.mul(at(0, 2), c02);
            let ab = g.add(a, b);
            g.add(ab, c)
        };
        let adj = [c00, c01, c02, c11, c12, c22];
        let inverse: Vec<NodeId> = adj.iter().map(|&c| g.div(c, det)).collect();
        let inv = |i: usize, j: usize| inverse[symmetric_index(i, j)];

        // The Christoffel symbols, for their sizes.
        let mut christoffel = Vec::new();
        for i in 0..3 {
            for j in 0..3 {
                for k in j..3 {
                    let mut sum = g.constant(0.0);
                    for l in 0..3 {
                        let a = d(j, l, k);
                        let b = d(k, l, j);
                        let c = d(l, j, k);
                        let ab = g.add(a, b);
                        let first_kind = g.sub(ab, c);
                        let term = g.mul(inv(i, l), first_kind);
                        sum = g.add(sum, term);
                    }
                    christoffel.push(g.scaled(0.5, sum));
                }
            }
        }
        let christoffel_nonzero = christoffel
            .iter()
            .filter(|&&n| g.as_const(n) != Some(0.0))
            .count();

        // The contracted form the integrator evaluates.
        let v: Vec<NodeId> = (3..6).map(|s| g.input(s)).collect();
        let mut lowered = Vec::new();
        for l in 0..3 {
            // ((D_v g) v)_l = sum_jk v^j d_j g_lk v^k
            let mut w = g.constant(0.0);
            // 1/2 v^T (d_l g) v
            let mut q = g.constant(0.0);
            for j in 0..3 {
                for k in 0..3 {
                    let vv = g.mul(v[j], v[k]);
                    let a = g.mul(d(j, l, k), vv);
                    w = g.add(w, a);
                    let b = g.mul(d(l, j, k), vv);
                    q = g.add(q, b);
                }
            }
            let half = g.scaled(0.5, q);
            lowered.push(g.sub(w, half));
        }
        let mut acceleration = Vec::new();
        for i in 0..3 {
            let mut sum = g.constant(0.0);
            for (l, &lo) in lowered.iter().enumerate() {
                let term = g.mul(inv(i, l), lo);
                sum = g.add(sum, term);
            }
            acceleration.push(g.neg(sum));
        }
        let domain = domain.map(|n| {
            let mut gd = Graph::new();
            let root = gd.import(graph, n, &[]);
            Tape::new(&gd, &[root])
        });
        let tensor = Tape::new(&g, &e);
        let mut evaluated = e.clone();
        evaluated.extend(lowered.iter().copied());
        let lowered_tape = Tape::new(&g, &evaluated);
        let label = written(&tensor);
        Metric {
            sizes: MetricSizes {
                metric: g.reachable_count(&e),
                christoffel: g.reachable_count(&christoffel),
                christoffel_nonzero,
                acceleration: g.reachable_count(&acceleration),
                evaluated: g.reachable_count(&evaluated),
            },
            tensor,
            compiled_lowered: std::sync::OnceLock::new(),
            lowered: lowered_tape,
            acceleration: Tape::new(&g, &acceleration),
            domain,
            max_steps,
            sample,
            label,
        }
    }

    /// Flat space in Cartesian coordinates, `dx^2 + dy^2 + dz^2`: what
    /// `--space metric` gives a scene that writes no metric.
    pub fn flat() -> Metric {
        let mut g = Graph::new();
        let (one, zero) = (g.constant(1.0), g.constant(0.0));
        Metric::derive(
            &g,
            [one, zero, zero, one, zero, one],
            None,
            DEFAULT_METRIC_STEPS,
            DEFAULT_METRIC_SAMPLE,
        )
    }

    /// The metric's entries at `p`.
    pub fn tensor_at(&self, p: DVec3) -> [f64; 6] {
        let mut out = [0.0; 6];
        TENSOR_SLOTS
            .with_borrow_mut(|slots| self.tensor.eval_into(&[p.x, p.y, p.z], slots, &mut out));
        out
    }

    /// The orthonormal frame at `p`; `None` where the metric is not
    /// positive definite or not finite.
    pub fn frame_at(&self, p: DVec3) -> Option<Frame> {
        Frame::of(&self.tensor_at(p))
    }

    /// Whether `p` is inside the chart's domain (everywhere, if the scene
    /// gave none).
    pub fn in_domain(&self, p: DVec3) -> bool {
        match &self.domain {
            None => true,
            Some(t) => DOMAIN_SLOTS.with_borrow_mut(|slots| t.eval(&[p.x, p.y, p.z], slots) < 0.0),
        }
    }

    /// The geodesic equation's right-hand side for the state (position,
    /// velocity), and the metric at the position (`None` where it is not
    /// positive definite: the rates are then NaN).
    ///
    /// With `r_l = ((D_v g) v)_l - 1/2 v^T (d_l g) v` (compiled, or
    /// interpreted to the same bits), the acceleration is `-g^-1 r`, solved
    /// numerically by the adjugate. The symbolic inverse cannot be
    /// simplified by the graph (the determinant of Nil's metric is 1,
    /// written as 20 operations): interpreted it was the slower (see
    /// `metric_rates` in `benches/hot_paths.rs`), and compiled into the
    /// same function it saved 0.6% of Nil's instructions (6.32 G -> 6.28 G
    /// at 160 x 100), not worth a slower interpreter.
    #[inline]
    fn rates(&self, y: &[f64; 6], slots: &mut Vec<f64>) -> ([f64; 6], [f64; 6]) {
        let mut d = [0.0; 9];
        match self.compiled() {
            Some(c) => c.eval_into(y, &mut d),
            None => self.lowered.eval_into(y, slots, &mut d),
        }
        let g: [f64; 6] = d[..6].try_into().expect("six entries");
        let r = DVec3::new(d[6], d[7], d[8]);
        let a = solve_symmetric(&g, r).map_or(DVec3::NAN, |a| -a);
        ([y[3], y[4], y[5], a.x, a.y, a.z], g)
    }

    /// The integrator's expression as machine code, compiled the first
    /// time it is asked for; `None` where it cannot be.
    #[inline]
    fn compiled(&self) -> Option<&CompiledTape> {
        self.compiled_lowered
            .get_or_init(|| CompiledTape::new(&self.lowered))
            .as_ref()
    }

    /// Whether the integrator's expression runs as machine code (else
    /// interpreted, to the same bits).
    pub fn is_compiled(&self) -> bool {
        self.compiled().is_some()
    }

    /// The geodesic equation's right-hand side from the one symbolic
    /// expression (inverse included), for checking the integrator's solve
    /// ([`Metric::acceleration_at`]).
    pub fn symbolic_acceleration(&self, p: DVec3, v: DVec3) -> DVec3 {
        let mut a = [0.0; 3];
        SYMBOLIC_SLOTS.with_borrow_mut(|slots| {
            self.acceleration
                .eval_into(&[p.x, p.y, p.z, v.x, v.y, v.z], slots, &mut a)
        });
        DVec3::from_array(a)
    }

    /// The acceleration the integrator uses, `-Gamma(v, v)` at `p`.
    pub fn acceleration_at(&self, p: DVec3, v: DVec3) -> DVec3 {
        let (r, _) =
            SLOTS.with_borrow_mut(|slots| self.rates(&[p.x, p.y, p.z, v.x, v.y, v.z], slots));
        DVec3::new(r[3], r[4], r[5])
    }
}

/// The metric in words, from its simplified entries: `diag(...)` when it
/// is diagonal, the matrix otherwise.
fn written(tensor: &Tape) -> String {
    let e: Vec<String> = (0..6).map(|k| tensor.describe_output(k, 60)).collect();
    if e[1] == "0" && e[2] == "0" && e[4] == "0" {
        if e[0] == e[3] && e[3] == e[5] {
            if e[0] == "1" {
                return "dx^2 + dy^2 + dz^2".to_string();
            }
            return format!("{} (dx^2 + dy^2 + dz^2)", e[0]);
        }
        return format!("diag({}, {}, {})", e[0], e[3], e[5]);
    }
    format!(
        "[({}, {}, {}), ({}, {}, {}), ({}, {}, {})]",
        e[0], e[1], e[2], e[1], e[3], e[4], e[2], e[4], e[5]
    )
}

/// Why a path ended before its length.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum End {
    /// It reached its length (or the search stopped it).
    Done,
    /// It left the chart's domain.
    LeftDomain,
    /// The metric stopped being positive definite or finite, or the
    /// equation's right-hand side did.
    Singular,
    /// It used up the steps a path may take.
    OutOfSteps,
    /// Its coordinates grew past [`CHART_REACH`].
    Escaped,
}

/// What the integration did over a render, for summaries and
/// `nes explain`: how many paths ended early and why, and how far the
/// unit-speed constraint drifted.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PathReport {
    /// Paths walked (primary and shadow rays, probes).
    pub paths: u64,
    /// Steps accepted, over all paths.
    pub accepted: u64,
    /// Steps rejected and retried smaller.
    pub rejected: u64,
    /// Steps taken across a kink of the metric, where no step meets the
    /// tolerance (see `MAX_FORCED_STEPS`).
    pub forced: u64,
    /// Paths that left the chart's domain.
    pub left_domain: u64,
    /// Paths that reached a point where the metric is singular.
    pub singular: u64,
    /// Paths that used up their steps.
    pub out_of_steps: u64,
    /// Paths whose coordinates grew past [`CHART_REACH`].
    pub escaped: u64,
    /// Shadow paths to a light that shooting could not find (the point
    /// gets no light from it).
    pub shooting_failed: u64,
    /// The largest `|g(v, v) - 1|` seen at any accepted step.
    pub max_drift: f64,
}

impl PathReport {
    /// Paths that ended before their length, for any reason.
    pub fn ended_early(&self) -> u64 {
        self.left_domain + self.singular + self.out_of_steps + self.escaped
    }

    /// The counts of two reports added, the larger drift.
    pub fn merged(&self, o: &PathReport) -> PathReport {
        PathReport {
            paths: self.paths + o.paths,
            accepted: self.accepted + o.accepted,
            rejected: self.rejected + o.rejected,
            forced: self.forced + o.forced,
            left_domain: self.left_domain + o.left_domain,
            singular: self.singular + o.singular,
            out_of_steps: self.out_of_steps + o.out_of_steps,
            escaped: self.escaped + o.escaped,
            shooting_failed: self.shooting_failed + o.shooting_failed,
            max_drift: self.max_drift.max(o.max_drift),
        }
    }

    /// What happened after `earlier` was taken (of the same counters):
    /// the counts' difference; the drift is the largest over both.
    pub fn since(&self, earlier: &PathReport) -> PathReport {
        PathReport {
            paths: self.paths - earlier.paths,
            accepted: self.accepted - earlier.accepted,
            rejected: self.rejected - earlier.rejected,
            forced: self.forced - earlier.forced,
            left_domain: self.left_domain - earlier.left_domain,
            singular: self.singular - earlier.singular,
            out_of_steps: self.out_of_steps - earlier.out_of_steps,
            escaped: self.escaped - earlier.escaped,
            shooting_failed: self.shooting_failed - earlier.shooting_failed,
            max_drift: self.max_drift,
        }
    }

    /// One line for a summary: steps per path and the drift.
    pub fn summary(&self) -> String {
        let forced = if self.forced > 0 {
            format!(
                ", {} steps taken across a kink or jump of the metric (no step there meets the tolerance)",
                self.forced
            )
        } else {
            String::new()
        };
        format!(
            "geodesics: {} paths, {:.1} integrator steps each ({} rejected), unit-speed drift |g(v, v) - 1| at most {:.1e}{forced}",
            self.paths,
            self.accepted as f64 / self.paths.max(1) as f64,
            self.rejected,
            self.max_drift
        )
    }

    /// The warning for a drift of the unit-speed constraint large enough
    /// that paths cannot be trusted to the pixel, if any.
    pub fn drift_warning(&self) -> Option<String> {
        (self.max_drift > DRIFT_WARNING).then(|| {
            format!(
                "the unit-speed constraint drifted to {:.2e} on some path (over {DRIFT_WARNING:e}): those paths are inexact, most often near where the chart's scale runs away (the half-space's z = 0) or where the metric jumps (an `if` whose branches differ at its boundary: geodesics do not refract there); lower `tolerance` in `render {{ }}`, keep them out with `domain`, or make the metric continuous",
                self.max_drift
            )
        })
    }

    /// The warning for shadow paths shooting did not find, if any.
    pub fn shooting_warning(&self) -> Option<String> {
        (self.shooting_failed > 0).then(|| {
            format!(
                "{} shadow paths to a light could not be found by shooting (no geodesic, or Newton's method did not converge); those points get no light from it: `shadows euclidean` casts straight ones instead",
                self.shooting_failed
            )
        })
    }

    /// The warning for paths that ended early, with why and what to do.
    pub fn ended_early_warning(&self) -> String {
        let mut why = Vec::new();
        let n = |k: u64, what: &str| format!("{k} {what}");
        if self.left_domain > 0 {
            why.push(n(self.left_domain, "left the chart's domain"));
        }
        if self.singular > 0 {
            why.push(n(
                self.singular,
                "reached a point where the metric is singular or not finite",
            ));
        }
        if self.out_of_steps > 0 {
            why.push(n(
                self.out_of_steps,
                "used up their integrator steps (raise `steps` in the space block)",
            ));
        }
        if self.escaped > 0 {
            why.push(n(
                self.escaped,
                "went farther than 1e6 from the origin in the chart",
            ));
        }
        format!(
            "{} of {} paths ended early and show the background (or cast no shadow) beyond: {}",
            self.ended_early(),
            self.paths,
            why.join("; ")
        )
    }
}

#[derive(Debug, Default)]
struct Counters {
    paths: AtomicU64,
    accepted: AtomicU64,
    rejected: AtomicU64,
    forced: AtomicU64,
    left_domain: AtomicU64,
    singular: AtomicU64,
    out_of_steps: AtomicU64,
    escaped: AtomicU64,
    shooting_failed: AtomicU64,
    /// The bits of a non-negative f64: their order is the numbers' order.
    max_drift: AtomicU64,
}

/// A metric space, ready to walk rays: its metric and the integrator's
/// tolerance, with counters of what the walks did.
#[derive(Debug)]
pub struct MetricSpace {
    metric: Arc<Metric>,
    tolerance: f64,
    counters: Counters,
    /// The box holding every object's bound, if known: a step that stays
    /// outside it needs no samples, so it may be as long as the error
    /// control allows.
    focus: Option<Aabb>,
}

impl MetricSpace {
    /// The space of `metric`, integrated to the relative `tolerance`.
    pub fn new(metric: Arc<Metric>, tolerance: f64) -> MetricSpace {
        MetricSpace {
            metric,
            tolerance,
            counters: Counters::default(),
            focus: None,
        }
    }

    /// Integrate the geodesic from `origin` with chart velocity `v`
    /// (`g(v, v) = 1`) for length `limit`, visiting each accepted step.
    fn integrate(
        &self,
        origin: DVec3,
        v: DVec3,
        limit: f64,
        visit: &mut dyn FnMut(&Segment) -> ControlFlow<()>,
    ) -> End {
        let m = &*self.metric;
        let tol = self.tolerance;
        let h_max = m.sample * MAX_CHART_GRID as f64;
        let mut slots = SLOTS.with_borrow_mut(std::mem::take);
        let mut y = [origin.x, origin.y, origin.z, v.x, v.y, v.z];
        let (mut k1, g0) = m.rates(&y, &mut slots);
        let mut drift = (quadratic_form(&g0, v) - 1.0).abs();
        // After a rejection the next step may not grow (Hairer's advice:
        // growing straight after a rejection invites another).
        let mut just_rejected = false;
        let mut drift_refusals = 0;
        // Steps taken across a kink of the metric (see below).
        let (mut forcing, mut path_forced, mut forced_steps) = (false, 0u32, 0u64);
        let mut max_drift = drift;
        let mut t = 0.0;
        // The first step from the rates' size and change (Hairer's
        // estimate, one evaluation): a fixed small one took four steps to
        // grow into the error control's.
        let mut h = dop853::initial_step(&y, &k1, tol, h_max.min(limit), |ys| {
            m.rates(ys, &mut slots).0
        });
        let (mut accepted, mut rejected) = (0u64, 0u64);
        let mut end = End::Done;
        // Why the last rejection happened, if not the error estimate: a
        // step that keeps landing outside the domain ends the path there.
        while t < limit {
            if accepted >= m.max_steps as u64 {
                end = End::OutOfSteps;
                break;
            }
            // A step spans at most MAX_CHART_GRID samples in arc length
            // and in the chart (see `ChartStep::new`), unless it starts
            // outside the focus and is found to stay out of it.
            let speed = DVec3::new(y[3], y[4], y[5]).length();
            let sampled = h_max.min(h_max / speed.max(1e-300));
            // Out of the focus a step may be as long, in arc length, as
            // the chart distance to it, and shorter where a chart unit is
            // a long arc (the chart speed is below 1): there a long arc
            // is a short move in the chart, where the error control's
            // absolute part says little (the half-space near z = 0).
            let to_focus = self.focus.map_or(0.0, |f| {
                let p = DVec3::new(y[0], y[1], y[2]);
                (f.min - p).max(p - f.max).max(DVec3::ZERO).length()
            });
            h = h.min(sampled.max(to_focus * speed.min(1.0))).min(limit - t);
            let (y_new, k) = dop853::trial(&y, k1, h, |ys| m.rates(ys, &mut slots).0);
            // The rates are NaN where the metric is not positive definite:
            // a step that met such a point, or overflowed, is refused.
            // (A fold, not `all`: with no early exit it vectorises.)
            let finite = y_new
                .iter()
                .chain(k.as_flattened())
                .fold(true, |ok, v| ok & v.is_finite());
            let err = if finite {
                dop853::error_norm(&y, &y_new, &k, h, tol)
            } else {
                f64::NAN
            };
            // The rates at the new state (the next step's first, and the
            // interpolant's end) and the drift there, for a step the error
            // estimate accepts.
            // A step that may be taken: the estimate accepts it, or it is
            // forced across a kink (below).
            let candidate = err <= 1.0 || forcing && err.is_finite();
            let (k_new, g_new) = if candidate {
                m.rates(&y_new, &mut slots)
            } else {
                ([f64::NAN; 6], [f64::NAN; 6])
            };
            let p_new = DVec3::new(y_new[0], y_new[1], y_new[2]);
            let v_new = DVec3::new(y_new[3], y_new[4], y_new[5]);
            let drift_new = (quadratic_form(&g_new, v_new) - 1.0).abs();
            // The constraint's drift may grow by at most the tolerance over
            // the whole path: its share of this step.
            let share = tol * (h / limit.max(h)).max(1e-3);
            // A change within the rounding of `g(v, v)` itself (its terms
            // grow with the metric's entries far out in a chart) is not
            // the integrator's to control.
            let rounding = 16.0 * f64::EPSILON * absolute_form(&g_new, v_new);
            let err_drift = if candidate {
                ((drift_new - drift).abs() - rounding).max(0.0) / share
            } else {
                0.0
            };
            let new_rates_finite = !candidate || k_new.iter().all(|v| v.is_finite());
            // The drift enters the control, but a step the error estimate
            // accepts is not refused for the drift more than twice: where
            // the drift does not fall with the step (near a chart's
            // boundary at infinity it need not), smaller steps only cost;
            // the drift is reported either way.
            let err = if err.is_nan() || candidate && drift_new.is_nan() || !new_rates_finite {
                f64::INFINITY
            } else if drift_refusals >= 2 && h <= sampled {
                // A longer step, out of the focus, never skips the drift
                // control: shortening it helps, down to a sampled one.
                err
            } else {
                err.max(err_drift / DRIFT_SLACK)
            };
            // The next step's size aims at the drift's share itself.
            let err_for_size = if err.is_finite() {
                err.max(err_drift)
            } else {
                err
            };
            let refused_for_drift = err_drift > DRIFT_SLACK && err <= err_drift / DRIFT_SLACK;
            let outside = !m.in_domain(p_new);
            let escaped = p_new.abs().max_element() > CHART_REACH;
            let forced = forcing && err > 1.0 && err.is_finite();
            if (err <= 1.0 || forced) && !outside && !escaped {
                let step = ChartStep::new(&y, &y_new, &k, &k_new, t, h, limit, m.sample);
                if h > sampled && self.focus.is_some_and(|f| step.whole.overlaps(&f)) {
                    // A long step that reaches the focus is taken again,
                    // short enough to be sampled.
                    h = sampled;
                    continue;
                }
                accepted += 1;
                forced_steps += forced as u64;
                forcing = false;
                drift = drift_new;
                max_drift = max_drift.max(drift);
                if visit(&Segment::chart(&step, m)).is_break() {
                    break;
                }
                t += h;
                y = y_new;
                k1 = k_new;
                h *= dop853::step_factor(err_for_size, if just_rejected { 1.0 } else { 5.0 });
                just_rejected = false;
                drift_refusals = 0;
            } else {
                rejected += 1;
                just_rejected = true;
                drift_refusals += refused_for_drift as u32;
                // The step no longer moves the point in the chart (by
                // chart distance, not arc length: where the metric is tiny
                // a short arc is a long way in the chart).
                let floor = 1e-9 * (1.0 + origin.abs().max_element()) / speed.max(1.0);
                if h < floor {
                    // A metric with a kink (`if`, `max`, `abs`) has rates
                    // that jump across it: no step straddling the jump
                    // meets the tolerance, however short. Where the metric
                    // and the rates are finite on both sides, one step of
                    // the shortest length is taken across, its error about
                    // that length times the jump; a few per path, then the
                    // path ends as before.
                    let finite_trial = err.is_finite() && !outside && !escaped;
                    if finite_trial && !forcing && path_forced < MAX_FORCED_STEPS {
                        forcing = true;
                        path_forced += 1;
                        h = 2.0 * floor;
                        continue;
                    }
                    end = if outside {
                        End::LeftDomain
                    } else if escaped {
                        End::Escaped
                    } else {
                        End::Singular
                    };
                    break;
                }
                h *= if err.is_finite() && !outside && !escaped {
                    dop853::step_factor(err_for_size, 1.0)
                } else {
                    0.25
                };
            }
        }
        SLOTS.with_borrow_mut(|s| *s = slots);
        let c = &self.counters;
        c.accepted.fetch_add(accepted, Ordering::Relaxed);
        c.rejected.fetch_add(rejected, Ordering::Relaxed);
        c.forced.fetch_add(forced_steps, Ordering::Relaxed);
        c.max_drift
            .fetch_max(max_drift.to_bits(), Ordering::Relaxed);
        end
    }

    /// What the walks so far did.
    pub fn report(&self) -> PathReport {
        let c = &self.counters;
        let get = |a: &AtomicU64| a.load(Ordering::Relaxed);
        PathReport {
            paths: get(&c.paths),
            accepted: get(&c.accepted),
            rejected: get(&c.rejected),
            forced: get(&c.forced),
            left_domain: get(&c.left_domain),
            singular: get(&c.singular),
            out_of_steps: get(&c.out_of_steps),
            escaped: get(&c.escaped),
            shooting_failed: get(&c.shooting_failed),
            max_drift: f64::from_bits(get(&c.max_drift)),
        }
    }
}

impl Space for MetricSpace {
    fn walk(
        &self,
        origin: DVec3,
        direction: DVec3,
        limit: f64,
        visit: &mut dyn FnMut(&Segment) -> ControlFlow<()>,
    ) {
        let c = &self.counters;
        c.paths.fetch_add(1, Ordering::Relaxed);
        let end = match self.metric.frame_at(origin) {
            None => End::Singular,
            Some(_) if !self.metric.in_domain(origin) => End::LeftDomain,
            Some(frame) => {
                let v = frame.to_chart(direction);
                self.integrate(origin, v, limit, visit)
            }
        };
        let counter = match end {
            End::Done => None,
            End::LeftDomain => Some(&c.left_domain),
            End::Singular => Some(&c.singular),
            End::OutOfSteps => Some(&c.out_of_steps),
            End::Escaped => Some(&c.escaped),
        };
        if let Some(counter) = counter {
            counter.fetch_add(1, Ordering::Relaxed);
        }
    }

    fn connect(&self, from: DVec3, to: DVec3) -> Option<(DVec3, f64)> {
        let found = shoot(self, from, to);
        if found.is_none() {
            self.counters
                .shooting_failed
                .fetch_add(1, Ordering::Relaxed);
        }
        found
    }

    fn step_off(&self, point: DVec3, direction: DVec3, distance: f64) -> DVec3 {
        match self.metric.frame_at(point) {
            Some(f) => point + f.to_chart(direction) * distance,
            None => point,
        }
    }

    fn to_frame(&self, at: DVec3, chart: DVec3) -> DVec3 {
        match self.metric.frame_at(at) {
            Some(f) => f.to_frame(chart),
            None => chart,
        }
    }

    fn frame_normal(&self, image: &super::Image, local: DVec3, gradient: DVec3) -> DVec3 {
        let _ = image;
        match self.metric.frame_at(local) {
            Some(f) => f.covector_to_frame(gradient),
            None => gradient,
        }
    }

    fn straight_paths(&self) -> bool {
        false
    }

    fn focus(&mut self, region: Aabb) {
        self.focus = Some(region);
    }

    fn reach(&self, origin: DVec3, _limit: f64) -> Aabb {
        // Unit speed in the metric says nothing of speed in the chart.
        Aabb {
            min: origin.min(DVec3::ZERO) - DVec3::splat(CHART_REACH),
            max: origin.max(DVec3::ZERO) + DVec3::splat(CHART_REACH),
        }
    }

    fn path_report(&self) -> Option<PathReport> {
        Some(self.report())
    }
}

/// Shooting: the geodesic from `from` that reaches `to`, as its starting
/// direction (in the frame) and length, by Newton's method on the
/// direction's two angles and the length, with the Jacobian from
/// neighbouring paths; started from the straight chart line. `None` where
/// it does not converge.
fn shoot(space: &MetricSpace, from: DVec3, to: DVec3) -> Option<(DVec3, f64)> {
    let m = &*space.metric;
    let frame = m.frame_at(from)?;
    let chord = frame.to_frame(to - from);
    let mut length = chord.length();
    if length == 0.0 || !length.is_finite() {
        return None;
    }
    let scale = 1.0 + (to - from).length();
    let (mut theta, mut phi) = angles(chord / length);
    let end_of = |theta: f64, phi: f64, length: f64| -> Option<DVec3> {
        let d = direction_of(theta, phi);
        let v = frame.to_chart(d);
        let mut last = None;
        let end = space.integrate(from, v, length, &mut |seg| {
            last = Some(seg.point(seg.range().1));
            ControlFlow::Continue(())
        });
        (end == End::Done).then_some(last?)
    };
    for _ in 0..30 {
        let p = end_of(theta, phi, length)?;
        let miss = p - to;
        // The integration is good to about its tolerance per unit length;
        // a path that ends within a millionth of the distance reaches the
        // light as far as a shadow can tell.
        if miss.length() <= 1e-6 * scale {
            return Some((direction_of(theta, phi), length));
        }
        let dh = 1e-6;
        let jt = (end_of(theta + dh, phi, length)? - p) / dh;
        let jp = (end_of(theta, phi + dh, length)? - p) / dh;
        let jl = (end_of(theta, phi, length + dh * length)? - p) / (dh * length);
        let jac = glam::DMat3::from_cols(jt, jp, jl);
        if jac.determinant().abs() < 1e-300 {
            return None;
        }
        let mut step = jac.inverse() * miss;
        // Damped: far from the answer a full Newton step overshoots into
        // another winding of the geodesics.
        let most = (step.x.abs().max(step.y.abs()) / 0.3).max(step.z.abs() / (0.3 * length));
        if most > 1.0 {
            step /= most;
        }
        theta -= step.x;
        phi -= step.y;
        length -= step.z;
        if !(length > 0.0 && length.is_finite()) {
            return None;
        }
    }
    None
}

/// Polar and azimuthal angles of a unit vector.
fn angles(d: DVec3) -> (f64, f64) {
    (d.z.clamp(-1.0, 1.0).acos(), d.y.atan2(d.x))
}

fn direction_of(theta: f64, phi: f64) -> DVec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    DVec3::new(st * cp, st * sp, ct)
}

/// One accepted integrator step with its dense output (the quintic
/// Hermite interpolant of the position through both ends' positions,
/// velocities and accelerations; the velocity is its derivative), and the
/// path's points at sample points across it, at most `sample` apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChartStep {
    /// The range searched (up to the path's length).
    pub t0: f64,
    /// Its end.
    pub t1: f64,
    h: f64,
    /// Per coordinate, the interpolant's coefficients in the fraction of
    /// the step.
    coefficients: [[f64; 6]; 3],
    /// The states at both ends, exactly as integrated.
    ends: [[f64; 6]; 2],
    /// Sample pieces: their ends are the sample points.
    pieces: usize,
    /// How far the path may stray from the chord between two neighbouring
    /// grid points, per coordinate.
    pad: f64,
    whole: Aabb,
}

impl ChartStep {
    /// The step from `y` to `y_new` of size `h`, whose stage rates are
    /// `stages` and whose rates at `y_new` are `rates_new`.
    #[allow(clippy::too_many_arguments)]
    fn new(
        y: &[f64; 6],
        y_new: &[f64; 6],
        stages: &[[f64; 6]],
        rates_new: &[f64; 6],
        t: f64,
        h: f64,
        limit: f64,
        sample: f64,
    ) -> ChartStep {
        let coefficients = std::array::from_fn(|i| {
            dop853::quintic(
                [y[i], y_new[i]],
                [y[3 + i], y_new[3 + i]],
                [stages[0][3 + i], rates_new[3 + i]],
                h,
            )
        });
        let all = || stages.iter().chain(std::iter::once(rates_new));
        // How far the step goes in the chart, about: its chart speed at
        // the fastest of its stages times `h`. Objects are written in
        // chart coordinates, so where the metric is small (a chart unit is
        // a short arc) samples must be spaced by chart distance, not arc
        // length, or a small object falls between two of them.
        // (The stages are finite here: plain comparisons, not `f64::max`'s
        // NaN handling, keep this cheap.)
        let larger = |m: f64, x: f64| if x > m { x } else { m };
        let speed = all()
            .map(|s| s[0] * s[0] + s[1] * s[1] + s[2] * s[2])
            .fold(0.0, larger)
            .sqrt();
        let mut step = ChartStep {
            t0: t,
            t1: (t + h).min(limit),
            h,
            coefficients,
            ends: [*y, *y_new],
            pieces: ((h.max(speed * h) / sample).ceil() as usize).clamp(1, MAX_CHART_GRID),
            pad: 0.0,
            whole: Aabb {
                min: DVec3::ZERO,
                max: DVec3::ZERO,
            },
        };
        // The chart acceleration at the stages bounds the bending between
        // samples (a chord of length s bulges by at most |x''| s^2 / 8),
        // doubled for the stretches between stages, plus the interpolant's
        // error at the coordinates' scale.
        let a_max = all()
            .map(|s| larger(larger(s[3].abs(), s[4].abs()), s[5].abs()))
            .fold(0.0, larger);
        let piece = h / step.pieces as f64;
        let scale = DVec3::new(y[0], y[1], y[2]).abs().max_element() + 1.0;
        step.pad = 2.0 * a_max * piece * piece / 8.0 + 1e-9 * scale;
        // The whole step's box from the interpolant's Bernstein
        // coefficients, whose hull holds it (no point evaluated: most
        // steps end the search here, far from every object).
        let (lo, hi) = dop853::quintic_range(&step.coefficients);
        let slack = DVec3::splat(1e-9 * scale);
        step.whole = Aabb {
            min: lo - slack,
            max: hi + slack,
        };
        step
    }

    /// The fraction of the step at distance `t`, and the end's state where
    /// it is one of the two (as integrated, not interpolated).
    #[inline]
    fn fraction(&self, t: f64) -> (f64, Option<&[f64; 6]>) {
        let theta = if self.h > 0.0 {
            (t - self.t0) / self.h
        } else {
            0.0
        };
        let end = match theta {
            0.0 => Some(&self.ends[0]),
            1.0 => Some(&self.ends[1]),
            _ => None,
        };
        (theta, end)
    }

    #[inline]
    fn state(&self, t: f64) -> [f64; 6] {
        let (theta, end) = self.fraction(t);
        if let Some(y) = end {
            return *y;
        }
        let mut y = [0.0; 6];
        for (i, c) in self.coefficients.iter().enumerate() {
            let (value, slope) = dop853::quintic_at(c, theta);
            y[i] = value;
            y[3 + i] = slope / self.h;
        }
        y
    }

    /// The point at distance `t`.
    pub fn point(&self, t: f64) -> DVec3 {
        let (theta, end) = self.fraction(t);
        if let Some(y) = end {
            return DVec3::new(y[0], y[1], y[2]);
        }
        let c = &self.coefficients;
        DVec3::new(
            dop853::quintic_value(&c[0], theta),
            dop853::quintic_value(&c[1], theta),
            dop853::quintic_value(&c[2], theta),
        )
    }

    /// The chart velocity at distance `t`.
    pub fn velocity(&self, t: f64) -> DVec3 {
        let y = self.state(t);
        DVec3::new(y[3], y[4], y[5])
    }

    /// The distance along the path of grid point `k`.
    #[inline]
    pub fn grid_time(&self, k: usize) -> f64 {
        if k == self.pieces {
            self.t0 + self.h
        } else {
            self.t0 + self.h * (k as f64 / self.pieces as f64)
        }
    }

    /// The grid pieces `[k, k + 1]` that overlap `[a, b]`.
    pub fn grid_pieces(&self, a: f64, b: f64) -> std::ops::Range<usize> {
        if self.h <= 0.0 {
            return 0..1;
        }
        let n = self.pieces as f64;
        let first = (((a - self.t0) / self.h) * n).floor().clamp(0.0, n - 1.0) as usize;
        let last = (((b - self.t0) / self.h) * n).ceil().clamp(1.0, n) as usize;
        first..last.max(first + 1)
    }

    /// A box holding the path between `p` (at `a`) and `q` (at `b`), two
    /// points at most a grid piece apart.
    pub fn chord_box_of(&self, p: DVec3, q: DVec3) -> Aabb {
        Aabb {
            min: p.min(q) - DVec3::splat(self.pad),
            max: p.max(q) + DVec3::splat(self.pad),
        }
    }

    /// A box holding the path for `t` in `[a, b]`.
    pub fn chord_box(&self, a: f64, b: f64) -> Aabb {
        if a <= self.t0 && b >= self.grid_time(self.pieces) {
            return self.whole;
        }
        let mut bx: Option<Aabb> = None;
        for k in self.grid_pieces(a, b) {
            let ta = self.grid_time(k).max(a);
            let tb = self.grid_time(k + 1).min(b);
            let piece = self.chord_box_of(self.point(ta), self.point(tb));
            bx = Some(match bx {
                None => piece,
                Some(b) => Aabb {
                    min: b.min.min(piece.min),
                    max: b.max.max(piece.max),
                },
            });
        }
        bx.unwrap_or(self.whole)
    }
}
