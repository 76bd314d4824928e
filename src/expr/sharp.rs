//! A sharper enclosure of `f` over boxes, for the searches that bound an
//! object at compile time. Input: `f`'s graph. Output: a [`SplitSum`],
//! `f` written as a sum of one polynomial in each coordinate alone and
//! the rest, `f = P_x(x) + P_y(y) + P_z(z) + R(x, y, z)`, whose enclosure
//! over a box takes each `P`'s range from its Bernstein coefficients,
//! subdivided where they are loose, and `R`'s by interval arithmetic.
//!
//! Interval arithmetic suffers the dependency problem worst on such
//! sums: Chmutov's `T8(x) + T8(y) + T8(z)`, whose `128 x^8 - 256 x^6 + ...`
//! over `[-2, 2]` encloses to about `[-16000, 33000]` though it stays
//! above -1, bounded its surface at 1.9 per axis where it reaches 1.014.

use glam::DVec3;

use super::graph::{Graph, Node, NodeId};
use super::interval::Interval;
use super::op::{Binary, Unary};
use super::poly::polynomial_degree;
use super::tape::Tape;
use super::taylor::Taylor;
use super::univariate::{power_to_bernstein, MOST_INTERPOLATED_DEGREE};

/// `f` split into one polynomial per coordinate and the rest (see the
/// module's comment).
#[derive(Debug, Clone)]
pub struct SplitSum {
    /// Per part, its coordinate, its coefficients in powers of that
    /// coordinate less the centre's (degree 2 to
    /// [`MOST_INTERPOLATED_DEGREE`]), and a bound on the sum of their
    /// errors.
    parts: Vec<(usize, Vec<f64>, f64)>,
    /// Where the parts are expanded: a part far from the origin, such as
    /// `((x - 1e7) / 1e-3)^2`, loses every digit in powers of `x` itself.
    centre: DVec3,
    /// Everything else: terms of several coordinates, or of one but not
    /// polynomial, and constants.
    rest: Tape,
}

/// Graphs larger than this are not split: the terms' dependencies are
/// found in one pass, but a long sum rarely has per-coordinate parts.
const MOST_NODES: usize = 4096;

/// Pieces the range of one part may be cut into.
const MOST_PIECES: usize = 256;

impl SplitSum {
    /// The split of the expression at `root`, its parts expanded about
    /// `centre`, or `None` where no part has degree 2 or more (no sharper
    /// enclosure to gain).
    pub fn of(graph: &Graph, root: NodeId, centre: DVec3) -> Option<SplitSum> {
        if root.0 as usize >= MOST_NODES {
            return None;
        }
        // The coordinates each node depends on: a bit per x, y, z, and
        // one for any other input. Operands have smaller ids.
        let mut masks = vec![0u8; root.0 as usize + 1];
        for id in 0..=root.0 {
            let node = graph.node(NodeId(id));
            masks[id as usize] = match node {
                Node::Input(slot) => 1 << slot.min(3),
                _ => node.operands().fold(0, |m, a| m | masks[a.0 as usize]),
            };
        }
        let mut terms = Vec::new();
        collect_terms(graph, root, 1.0, &mut terms);
        let mut by_axis: [Vec<(f64, NodeId)>; 3] = Default::default();
        let mut rest_terms = Vec::new();
        for (scale, id) in terms {
            match masks[id.0 as usize] {
                m @ (1 | 2 | 4) if polynomial_degree(graph, id).is_some() => {
                    by_axis[m.trailing_zeros() as usize].push((scale, id));
                }
                _ => rest_terms.push((scale, id)),
            }
        }
        let mut parts = Vec::new();
        for (axis, terms) in by_axis.into_iter().enumerate() {
            let (part, part_root) = sum_of(graph, &terms);
            let power = match polynomial_degree(&part, part_root) {
                Some(d) if (2..=MOST_INTERPOLATED_DEGREE).contains(&d) => {
                    power_coefficients(&Tape::new(&part, &[part_root]), axis, centre)
                }
                _ => None,
            };
            match power {
                Some((power, error)) => parts.push((axis, power, error)),
                None => rest_terms.extend(terms),
            }
        }
        if parts.is_empty() {
            return None;
        }
        let (rest, rest_root) = sum_of(graph, &rest_terms);
        Some(SplitSum {
            parts,
            centre,
            rest: Tape::new(&rest, &[rest_root]),
        })
    }

    /// An enclosure of `f` over the box `lo..hi`.
    pub fn interval(&self, lo: DVec3, hi: DVec3, scratch: &mut SplitScratch) -> Interval {
        let inputs = [
            Interval::new(lo.x, hi.x),
            Interval::new(lo.y, hi.y),
            Interval::new(lo.z, hi.z),
        ];
        let mut sum = self.rest.eval(&inputs, &mut scratch.intervals);
        for (axis, power, error) in &self.parts {
            // The box's side about the centre, rounded outward.
            let (a, b) = (
                lo[*axis] - self.centre[*axis],
                hi[*axis] - self.centre[*axis],
            );
            let (a, b) = (
                a - a.abs() * f64::EPSILON - f64::MIN_POSITIVE,
                b + b.abs() * f64::EPSILON + f64::MIN_POSITIVE,
            );
            sum = sum + polynomial_range(power, *error, a, b, scratch);
        }
        sum
    }
}

/// Buffers [`SplitSum::interval`] reuses from call to call.
#[derive(Debug, Default)]
pub struct SplitScratch {
    /// Slots for the rest's interval evaluation.
    pub intervals: Vec<Interval>,
    shifted: Vec<f64>,
    bernstein: Vec<f64>,
    pieces: Vec<(Piece, u32)>,
}

/// A piece's Bernstein coefficients (the first `n + 1` used).
type Piece = [f64; MOST_INTERPOLATED_DEGREE + 1];

/// The terms of the sum at `id`, each with its constant factor: sums,
/// differences and negations are opened, products by constants folded
/// into the factor.
fn collect_terms(graph: &Graph, id: NodeId, scale: f64, out: &mut Vec<(f64, NodeId)>) {
    match graph.node(id) {
        Node::Binary(Binary::Add, a, b) => {
            collect_terms(graph, a, scale, out);
            collect_terms(graph, b, scale, out);
        }
        Node::Binary(Binary::Sub, a, b) => {
            collect_terms(graph, a, scale, out);
            collect_terms(graph, b, -scale, out);
        }
        Node::Unary(Unary::Neg, a) => collect_terms(graph, a, -scale, out),
        Node::Binary(Binary::Mul, a, b) => match (graph.as_const(a), graph.as_const(b)) {
            (Some(k), _) if k.is_finite() => collect_terms(graph, b, scale * k, out),
            (_, Some(k)) if k.is_finite() => collect_terms(graph, a, scale * k, out),
            _ => out.push((scale, id)),
        },
        _ => out.push((scale, id)),
    }
}

/// `sum scale * term` as a graph of its own. A factor's product may round
/// (a scale of a scale): the parts' ranges and the rest's interval are
/// each rigorous for the sum the new graph computes, which is `f`'s sum
/// to within those roundings; the callers' boxes are tested with a margin
/// far above them.
fn sum_of(graph: &Graph, terms: &[(f64, NodeId)]) -> (Graph, NodeId) {
    let mut out = Graph::new();
    let mut sum = out.constant(0.0);
    for &(scale, id) in terms {
        let term = out.import(graph, id, &[]);
        let scaled = if scale == 1.0 {
            term
        } else {
            out.scaled(scale, term)
        };
        sum = out.add(sum, scaled);
    }
    (out, sum)
}

/// The coefficients of the polynomial `tape` (of degree at most
/// [`MOST_INTERPOLATED_DEGREE`] in coordinate `axis` alone) in powers of
/// that coordinate less `centre`'s, and a bound on the sum of their
/// errors: one evaluation in Taylor arithmetic.
fn power_coefficients(tape: &Tape, axis: usize, centre: DVec3) -> Option<(Vec<f64>, f64)> {
    let mut direction = DVec3::ZERO;
    direction[axis] = 1.0;
    let mut forms = Vec::new();
    tape.line_forms(centre, direction, 0.0, &mut forms);
    let u = Taylor::<{ MOST_INTERPOLATED_DEGREE + 1 }>::variable(0.0, 1.0);
    let p = tape.eval_on_line(&forms, u, &mut Vec::new());
    let power = p.coefficients[..=p.degree].to_vec();
    (p.error.is_finite() && power.iter().all(|c| c.is_finite())).then_some((power, p.error))
}

/// The range over `[a, b]` of the polynomial with coefficients `power`
/// (their errors summing to at most `error`): its Bernstein coefficients
/// there (after a Taylor shift to `a` and a scaling by `b - a`), and a
/// search that cuts only the pieces whose coefficients reach past the
/// extremes found so far (a piece's end coefficients are values the
/// polynomial takes). Rigorous: each end is moved outward by a bound on
/// the coefficients' errors and the cuts' rounding.
fn polynomial_range(
    power: &[f64],
    error: f64,
    a: f64,
    b: f64,
    scratch: &mut SplitScratch,
) -> Interval {
    let whole = Interval::new(f64::NEG_INFINITY, f64::INFINITY);
    if !(a.is_finite() && b.is_finite() && a <= b) {
        return whole;
    }
    let n = power.len() - 1;
    // Rounded up: the coefficients then cover at least `[a, b]`.
    let width = (b - a) * (1.0 + f64::EPSILON);
    // The Taylor shift `p(a + u)`, by repeated Horner steps, beside the
    // same sums of magnitudes, which bound its rounding.
    let shifted = &mut scratch.shifted;
    shifted.clear();
    shifted.extend_from_slice(power);
    let mut sizes = [0.0; MOST_INTERPOLATED_DEGREE + 1];
    for (size, c) in sizes.iter_mut().zip(power) {
        *size = c.abs();
    }
    for i in 0..n {
        for j in (i..n).rev() {
            shifted[j] += a * shifted[j + 1];
            sizes[j] += a.abs() * sizes[j + 1];
        }
    }
    // Then `u = width s`. Each coefficient's rounding is at most n + 2
    // units of its magnitudes' sum (the shift's Horner steps, then the
    // powers of the width); the given errors grow by at most
    // `(1 + |a|)^n (1 + width)^n`.
    let unit = f64::EPSILON;
    let mut rounding = 0.0;
    let mut scale = 1.0;
    for (k, c) in shifted.iter_mut().enumerate() {
        *c *= scale;
        rounding += 2.0 * (n + 2 + k) as f64 * unit * sizes[k] * scale;
        scale *= width;
    }
    let grown = error * ((1.0 + a.abs()) * (1.0 + width)).powi(n as i32);
    let total = (rounding + grown) * (1.0 + 1e-9);
    if !(total.is_finite() && shifted.iter().all(|c| c.is_finite())) {
        return whole;
    }
    let error = power_to_bernstein(shifted, total, &mut scratch.bernstein);
    let bernstein = &scratch.bernstein;
    let largest = bernstein.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    // Each halving's n passes of averages round each coefficient by at
    // most n units of the largest; halvings go at most 60 deep.
    let slack = error + (64 * (n + 1)) as f64 * f64::EPSILON * largest;
    let mut first = [0.0; MOST_INTERPOLATED_DEGREE + 1];
    first[..bernstein.len()].copy_from_slice(bernstein);
    let low = extreme(first, n, 1.0, largest, &mut scratch.pieces) - slack;
    let high = -extreme(first, n, -1.0, largest, &mut scratch.pieces) + slack;
    if !(low.is_finite() && high.is_finite()) {
        return whole;
    }
    Interval::new(low, high)
}

/// A lower bound on the minimum of `sign * p` over `[0, 1]`, `p` of
/// degree `n` given by its Bernstein coefficients: branch and bound to
/// within a millionth of `largest`, the largest coefficient, in at most
/// [`MOST_PIECES`] pieces.
fn extreme(
    bernstein: Piece,
    n: usize,
    sign: f64,
    largest: f64,
    open: &mut Vec<(Piece, u32)>,
) -> f64 {
    let tolerance = 1e-6 * largest;
    let first = bernstein.map(|c| sign * c);
    // The least value the polynomial is seen to take: piece ends.
    let mut best = first[0].min(first[n]);
    open.clear();
    open.push((first, 0));
    let mut lowest_left = f64::INFINITY;
    let mut pieces = 1;
    while let Some((b, depth)) = open.pop() {
        let lower = b[..=n].iter().copied().fold(f64::INFINITY, f64::min);
        if lower >= best - tolerance {
            continue;
        }
        if pieces >= MOST_PIECES || depth >= 60 {
            lowest_left = lowest_left.min(lower);
            continue;
        }
        // Halve: the left part's coefficients are each pass's first,
        // the right part's what the passes leave.
        let mut right = b;
        let mut left = [0.0; MOST_INTERPOLATED_DEGREE + 1];
        for (r, first) in left[..=n].iter_mut().enumerate() {
            *first = right[0];
            for i in 0..n - r {
                right[i] = 0.5 * (right[i] + right[i + 1]);
            }
        }
        best = best.min(left[n]);
        pieces += 2;
        open.push((left, depth + 1));
        open.push((right, depth + 1));
    }
    best.min(lowest_left) - tolerance
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The range of a univariate polynomial is enclosed, and tightly:
    /// sampled values lie inside, and the ends are within a thousandth
    /// of the sampled extremes (the tolerance is a millionth of the
    /// largest coefficient).
    #[test]
    fn a_parts_range_encloses_its_values_tightly() {
        let mut g = Graph::new();
        let x = g.input(0);
        // T8(x) = 128 x^8 - 256 x^6 + 160 x^4 - 32 x^2 + 1.
        let terms = [(128.0, 8), (-256.0, 6), (160.0, 4), (-32.0, 2)];
        let mut sum = g.constant(1.0);
        for (c, n) in terms {
            let p = g.powi(x, n);
            let t = g.scaled(c, p);
            sum = g.add(sum, t);
        }
        let (power, error) = power_coefficients(&Tape::new(&g, &[sum]), 0, DVec3::ZERO).unwrap();
        let t8 = |x: f64| (8.0 * x.clamp(-1.0, 1.0).acos()).cos();
        for (a, b) in [
            (-1.95, 1.95),
            (-1.0, 1.0),
            (0.3, 0.31),
            (1.02, 1.95),
            (-0.5, 0.9),
        ] {
            let range = polynomial_range(&power, error, a, b, &mut SplitScratch::default());
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for k in 0..=2000 {
                let x: f64 = a + (b - a) * k as f64 / 2000.0;
                let v = if x.abs() <= 1.0 {
                    t8(x)
                } else {
                    (8.0 * x.abs().acosh()).cosh()
                };
                lo = lo.min(v);
                hi = hi.max(v);
                assert!(
                    range.contains(v),
                    "[{a}, {b}]: {v} at {x} outside {range:?}"
                );
            }
            let scale = lo.abs().max(hi.abs()).max(1.0);
            assert!(
                lo - range.lo <= 1e-3 * scale,
                "[{a}, {b}]: low {} vs {lo}",
                range.lo
            );
            assert!(
                range.hi - hi <= 1e-3 * scale,
                "[{a}, {b}]: high {} vs {hi}",
                range.hi
            );
        }
    }
}
