//! `space metric { g ...  domain ...  steps N  sample S }`: the metric
//! tensor as written, lowered to expressions in x, y, z, checked and
//! handed to [`Metric::derive`] for its geodesic equation; and the checks
//! that need the camera (positive definite there, inside the domain).
//!
//! Input: the space block's properties. Output: a [`SpaceKind::Metric`],
//! or diagnostics with spans and hints.

use std::sync::Arc;

use glam::{DAffine3, DVec3};

use super::settings::Props;
use super::{Compiler, Reported};
use crate::ast::{self, Expr, ExprKind};
use crate::diagnostic::{Code, Diagnostic, Span};
use crate::expr::{Graph, NodeId};
use crate::space::{
    symmetric_index, Metric, MetricKind, SpaceKind, DEFAULT_METRIC_SAMPLE, DEFAULT_METRIC_STEPS,
};

/// Where the metric's parts were written, for diagnostics that need the
/// camera.
#[derive(Debug, Clone, Copy)]
pub(super) struct MetricSpans {
    pub tensor: Span,
    pub domain: Option<Span>,
}

/// The forms `g` takes, for hints.
const FORMS: &str = "write `g diag(gxx, gyy, gzz)`, `g conformal(n)` for n^2 (dx^2 + dy^2 + dz^2), or the whole matrix `g [(gxx, gxy, gxz), (gxy, gyy, gyz), (gxz, gyz, gzz)]`";

/// What a formula in the metric block is.
#[derive(Clone, Copy, PartialEq)]
enum Part {
    /// An entry of `g`: a number-valued formula.
    Entry,
    /// The `domain`: a condition.
    Domain,
}

impl Compiler {
    /// An entry of `g` (a number) or the domain (a condition, as the
    /// region negative inside), lowered in x, y, z.
    fn metric_part(&mut self, g: &mut Graph, e: &Expr, part: Part) -> Result<NodeId, Reported> {
        let point = super::affine_point(g, DAffine3::IDENTITY);
        let value = self.lowerer(g).lower(
            e,
            super::lower::Frame {
                params: super::lower::Scope::EMPTY,
                point: Some(point),
            },
        )?;
        match (part, value) {
            (Part::Entry, super::lower::Value::Num(n)) => Ok(n),
            (Part::Domain, super::lower::Value::Cond(c)) => Ok(g.neg(c)),
            (Part::Entry, v) => self.fail(
                Diagnostic::new(
                    Code::WrongKind,
                    format!("an entry of the metric is a number, not {}", v.kind_name()),
                )
                .label(e.span, format!("this is {}", v.kind_name()))
                .help(if matches!(v, super::lower::Value::Cond(_)) {
                    "a condition belongs in `domain`, which says where the chart is valid; an entry is a formula such as `1 + x^2` or `if z > 0 then 1 else 2`"
                } else {
                    "each entry is a formula in x, y, z giving a number, such as `1 + x^2` or `exp(2*z)`"
                }),
            ),
            (Part::Domain, v) => self.fail(
                Diagnostic::new(
                    Code::WrongKind,
                    format!("the domain is a condition, not {}", v.kind_name()),
                )
                .label(e.span, format!("this is {}", v.kind_name()))
                .help("write where the chart is valid as a condition: `domain z > 0`, `domain x^2 + y^2 + z^2 < 1`"),
            ),
        }
    }

    pub(super) fn metric_space(&mut self, block: &ast::Block) -> Result<SpaceKind, Reported> {
        let props = Props::new(
            self,
            &block.properties,
            "the metric space",
            &["g", "domain", "steps", "sample"],
            &[],
        );
        let mut failed = props.failed;
        let Some(tensor) = props.get("g") else {
            return self.fail(
                Diagnostic::new(Code::MissingSetting, "the metric space has no metric `g`")
                    .label(block.span, "this block needs `g`")
                    .help(FORMS),
            );
        };
        let mut graph = Graph::new();
        let entries = self.tensor(&mut graph, &tensor.value);
        let domain = props.get("domain").map(|p| {
            let n = self.metric_part(&mut graph, &p.value, Part::Domain);
            (n, p.value.span)
        });
        let mut max_steps = DEFAULT_METRIC_STEPS;
        if let Some(p) = props.get("steps") {
            match self.integer(
                &p.value,
                "steps",
                1.0,
                1e7,
                "steps is how many integrator steps one path may take; each costs twelve evaluations of the geodesic equation",
            ) {
                Ok(n) => max_steps = n as u32,
                Err(Reported) => failed = true,
            }
        }
        let mut sample = DEFAULT_METRIC_SAMPLE;
        if let Some(p) = props.get("sample") {
            match self.limited(
                &p.value,
                &super::settings::Limit {
                    name: "the metric space's sample spacing",
                    min: 1e-4,
                    max: 100.0,
                    above_min: false,
                    whole: false,
                    hint: "sample is the arc length between the points of a path tested for a surface; a surface thinner than it along the path can be missed (0.0625 by default)",
                },
            ) {
                Ok(s) => sample = s,
                Err(Reported) => failed = true,
            }
        }
        let domain = match domain {
            Some((Ok(n), span)) => Some((n, span)),
            Some((Err(Reported), _)) => {
                failed = true;
                None
            }
            None => None,
        };
        let Ok(entries) = entries else {
            return Err(Reported);
        };
        if failed {
            return Err(Reported);
        }
        self.metric_spans = Some(MetricSpans {
            tensor: tensor.value.span,
            domain: domain.map(|d| d.1),
        });
        let metric = Metric::derive(&graph, entries, domain.map(|d| d.0), max_steps, sample);
        Ok(SpaceKind::Metric(MetricKind(Arc::new(metric))))
    }

    /// The six entries `xx, xy, xz, yy, yz, zz` of `g` as written.
    fn tensor(&mut self, g: &mut Graph, e: &Expr) -> Result<[NodeId; 6], Reported> {
        let entry = |c: &mut Compiler, g: &mut Graph, e: &Expr| c.metric_part(g, e, Part::Entry);
        match &e.kind {
            ExprKind::Call { name, args } if name.name == "diag" || name.name == "conformal" => {
                let want = if name.name == "diag" { 3 } else { 1 };
                if args.len() != want {
                    return self.fail(
                        Diagnostic::new(
                            Code::ArgumentCount,
                            format!(
                                "`{}` takes {want} argument{}, not {}",
                                name.name,
                                if want == 1 { "" } else { "s" },
                                args.len()
                            ),
                        )
                        .label(e.span, "here")
                        .help(FORMS),
                    );
                }
                let zero = g.constant(0.0);
                if name.name == "diag" {
                    let mut d = Vec::new();
                    for a in args {
                        d.push(entry(self, g, a));
                    }
                    let d: Vec<NodeId> = d.into_iter().collect::<Result<_, _>>()?;
                    Ok([d[0], zero, zero, d[1], zero, d[2]])
                } else {
                    let n = entry(self, g, &args[0])?;
                    let n2 = g.mul(n, n);
                    Ok([n2, zero, zero, n2, zero, n2])
                }
            }
            ExprKind::List(rows) => {
                let rows_ok = rows.len() == 3
                    && rows.iter().all(|r| match &r.kind {
                        ExprKind::Tuple(items) | ExprKind::List(items) => items.len() == 3,
                        _ => false,
                    });
                if !rows_ok {
                    return self.fail(
                        Diagnostic::new(
                            Code::WrongKind,
                            "a metric written as a matrix has three rows of three entries",
                        )
                        .label(e.span, "not a 3 x 3 matrix")
                        .help(FORMS),
                    );
                }
                let mut cells: Vec<Vec<(Result<NodeId, Reported>, Span)>> = Vec::new();
                for r in rows {
                    let (ExprKind::Tuple(items) | ExprKind::List(items)) = &r.kind else {
                        unreachable!("checked above");
                    };
                    cells.push(items.iter().map(|i| (entry(self, g, i), i.span)).collect());
                }
                if cells.iter().flatten().any(|c| c.0.is_err()) {
                    return Err(Reported);
                }
                let at = |i: usize, j: usize| cells[i][j].0.expect("checked above");
                let mut failed = false;
                for i in 0..3 {
                    for j in i + 1..3 {
                        if at(i, j) != at(j, i) && !same_value(g, at(i, j), at(j, i)) {
                            let axis = ["x", "y", "z"];
                            self.diags.push(
                                Diagnostic::new(
                                    Code::OutOfRange,
                                    format!(
                                        "the metric is not symmetric: g{}{} and g{}{} differ",
                                        axis[i], axis[j], axis[j], axis[i]
                                    ),
                                )
                                .label(cells[i][j].1, format!("g{}{}", axis[i], axis[j]))
                                .label(cells[j][i].1, format!("g{}{}", axis[j], axis[i]))
                                .help("a metric tensor is symmetric: the entry in row i, column j equals the one in row j, column i; write the same formula in both"),
                            );
                            failed = true;
                        }
                    }
                }
                if failed {
                    return Err(Reported);
                }
                let mut out = [at(0, 0); 6];
                for i in 0..3 {
                    for j in i..3 {
                        out[symmetric_index(i, j)] = at(i, j);
                    }
                }
                Ok(out)
            }
            _ => self.fail(
                Diagnostic::new(Code::WrongKind, "this is not a metric tensor")
                    .label(e.span, "not diag(...), conformal(...) or a 3 x 3 matrix")
                    .help(FORMS),
            ),
        }
    }

    /// The checks that need the camera: it must stand inside the domain,
    /// where the metric is positive definite.
    pub(super) fn check_metric_at_camera(&mut self, metric: &Metric, camera: DVec3) -> bool {
        let Some(spans) = self.metric_spans else {
            return true;
        };
        let at = format!("({}, {}, {})", camera.x, camera.y, camera.z);
        if !metric.in_domain(camera) {
            self.diags.push(
                Diagnostic::new(
                    Code::OutOfRange,
                    format!("the camera at {at} is outside the chart's domain"),
                )
                .label(spans.domain.unwrap_or(spans.tensor), "the domain")
                .help("move the camera inside the domain, or widen the domain"),
            );
            return false;
        }
        let g = metric.tensor_at(camera);
        if metric.frame_at(camera).is_none() {
            let f = |v: f64| format!("{v:.4}");
            self.diags.push(
                Diagnostic::new(
                    Code::OutOfRange,
                    format!(
                        "the metric is {} at the camera {at}: g = [({}, {}, {}), ({}, {}, {}), ({}, {}, {})]",
                        if g.iter().all(|v| v.is_finite()) { "not positive definite" } else { "not finite" },
                        f(g[0]), f(g[1]), f(g[2]), f(g[1]), f(g[3]), f(g[4]), f(g[2]), f(g[4]), f(g[5])
                    ),
                )
                .label(spans.tensor, "this metric")
                .help(if g.iter().all(|v| v.is_finite()) {
                    "a metric gives every direction a positive length squared: every leading minor of the matrix must be positive there (its diagonal entries first); move the camera, or check the formula's signs"
                } else {
                    "an entry is NaN or infinite there (a root of a negative number, a division by zero, an overflowing exp): move the camera, or give a `domain` that leaves such points out"
                }),
            );
            return false;
        }
        true
    }
}

/// Whether two entries are the same function, tested at a few points
/// (entries written differently, `x*y` and `y*x`, are different nodes).
fn same_value(g: &Graph, a: NodeId, b: NodeId) -> bool {
    let ta = crate::expr::Tape::new(g, &[a]);
    let tb = crate::expr::Tape::new(g, &[b]);
    let mut slots = Vec::new();
    let points = [
        [0.3, -0.7, 1.1],
        [1.7, 0.2, -0.4],
        [-2.3, 1.9, 0.6],
        [0.05, 3.1, 2.2],
    ];
    points.iter().all(|p| {
        let (u, v) = (ta.eval(p, &mut slots), tb.eval(p, &mut slots));
        (u - v).abs() <= 1e-12 * (1.0 + u.abs()) || (u.is_nan() && v.is_nan())
    })
}
