//! Recognising planes and quadrics: expressions of degree at most 2 in
//! x, y, z, which a ray meets in closed form.

use glam::{DMat3, DVec3};

use super::graph::{Graph, HashMap, Node, NodeId};
use super::number::power_of_two_below;
use super::op::{Binary, Unary};

/// `q(p) = p . (M p) + b . p + c`, with `M` symmetric.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quadric {
    /// The quadratic part: `m` is symmetric, and its off-diagonal entries are
    /// half the coefficients of `xy`, `xz`, `yz`.
    pub m: DMat3,
    /// The linear part: the coefficients of `x`, `y`, `z`.
    pub b: DVec3,
    /// The constant term.
    pub c: f64,
    /// The largest |entry| of `m` and of `b`, computed once, for
    /// [`Quadric::cancels_at`], which runs per ray.
    largest: (f64, f64),
    /// The power of two the coefficients as written were multiplied by.
    scaled_by: f64,
}

impl Quadric {
    /// The quadric `p . m p + b . p + c` (`m` symmetric), its coefficients
    /// multiplied by the power of two that brings the largest into [1, 2):
    /// the surface is the same, the arithmetic on it exact to the last bit
    /// but for overflow and underflow, which it now escapes (a ball written
    /// `(x^2 + y^2 + z^2 - 1) * 1e160` squared its coefficients past
    /// 1e308, and one times 1e-200 below 1e-308).
    pub fn new(m: DMat3, b: DVec3, c: f64) -> Quadric {
        let largest_of = |m: DMat3, b: DVec3| {
            (
                m.abs().to_cols_array().into_iter().fold(0.0, f64::max),
                b.abs().max_element(),
            )
        };
        let (lm, lb) = largest_of(m, b);
        let top = lm.max(lb).max(c.abs());
        let scaled_by = Some(top)
            .filter(|t| t.is_finite() && *t > 0.0)
            .map(|t| power_of_two_below(t).recip())
            .filter(|s| s.is_finite())
            .unwrap_or(1.0);
        let (m, b, c) = (m * scaled_by, b * scaled_by, c * scaled_by);
        Quadric {
            m,
            b,
            c,
            largest: largest_of(m, b),
            scaled_by,
        }
    }

    /// The box around an ellipsoid (a quadric whose quadratic part is
    /// definite), widened by a relative 1e-9 for the rounding of its
    /// coefficients: `Some(None)` when the quadric has no real point
    /// (`x^2 + 1`), `None` when it is no ellipsoid (a plane, a cylinder, a
    /// hyperboloid: unbounded) or when the expanded coefficients cannot
    /// tell its size (a small ball far from the origin: `(x - 1e7)^2`
    /// expands to a constant term of 1e14, whose rounding exceeds a radius
    /// of 1e-3 squared). For `(p - c)^T M (p - c) = rho` the half extents
    /// are `sqrt(rho (M^-1)_ii)`.
    pub fn ellipsoid_box(&self) -> Option<Option<(DVec3, DVec3)>> {
        let (m, b, c) = if self.m.x_axis.x < 0.0 {
            (-self.m, -self.b, -self.c)
        } else {
            (self.m, self.b, self.c)
        };
        let minor2 = m.x_axis.x * m.y_axis.y - m.x_axis.y * m.y_axis.x;
        let definite = m.x_axis.x > 0.0 && minor2 > 0.0 && m.determinant() > 0.0;
        if !definite {
            return None;
        }
        let inverse = m.inverse();
        let centre = -0.5 * (inverse * b);
        let form = centre.dot(m * centre);
        let rho = form - c;
        // The rounding of the expanded terms, generously: rho is a small
        // difference of them for a small ball far out. (The centre's own
        // error moves rho only to second order: it is a stationary point.)
        let rho_error = 64.0 * f64::EPSILON * (form.abs() + c.abs());
        if !(rho.is_finite() && centre.is_finite()) || rho.abs() <= 1e3 * rho_error {
            return None;
        }
        if rho < 0.0 {
            return Some(None);
        }
        let diagonal = DVec3::new(inverse.x_axis.x, inverse.y_axis.y, inverse.z_axis.z);
        let half = (diagonal * rho).max(DVec3::ZERO).to_array().map(f64::sqrt);
        let half = DVec3::from_array(half);
        let slack = DVec3::splat(1e-9 * (1.0 + centre.abs().max_element() + half.max_element()));
        (half.is_finite()).then_some(Some((centre - half - slack, centre + half + slack)))
    }

    /// `q(p)`, from the expanded coefficients (which lose digits far from the
    /// origin; see [`Quadric::cancels_at`]).
    pub fn value(&self, p: DVec3) -> f64 {
        p.dot(self.m * p) + self.b.dot(p) + self.c
    }

    /// The gradient `2 M p + b` at `p`.
    pub fn gradient(&self, p: DVec3) -> DVec3 {
        2.0 * (self.m * p) + self.b
    }

    /// Whether evaluating the expanded form near `p` loses digits that
    /// matter: its largest term there exceeds 1e4, so rounding (1e-16
    /// relative) reaches 1e-12 absolute, the scale of a hit's accuracy.
    /// Then hits are polished with the expression as written.
    pub fn cancels_at(&self, p: DVec3) -> bool {
        let r = p.abs().max_element();
        let (m, b) = self.largest;
        // The terms as written, not as scaled.
        self.c.abs().max(b * r).max(m * r * r) > 1e4 * self.scaled_by
    }

    /// The smallest `t` in `[t0, t1]` where the line `o + t d` meets the
    /// quadric: the roots of `a t^2 + b t + c = 0`.
    pub fn first_root_on_line(&self, o: DVec3, d: DVec3, t0: f64, t1: f64) -> Option<f64> {
        let md = self.m * d;
        let a = d.dot(md);
        let b = 2.0 * o.dot(md) + self.b.dot(d);
        smallest_root_in(a, b, self.value(o), self.quadratic_noise(d), t0, t1, |t| t)
    }

    /// How large `d . m d` can come out when it is 0 but for rounding (a
    /// line along a cylinder's axis): the quadratic is then taken as
    /// linear. Judged against the quadratic part alone: against the
    /// constant term, a ball of radius 2e7 at 3e7 from the camera (`c`
    /// near 5e14) looked linear to every ray, and vanished.
    fn quadratic_noise(&self, d: DVec3) -> f64 {
        1e-14 * self.largest.0 * d.length_squared()
    }

    /// The range of `t` where `q(o + t d) <= 0`, widened by a margin for
    /// the expanded form's rounding, when it is one interval (possibly
    /// unbounded, possibly empty: then `lo > hi`); `None` when it is two
    /// (a quadratic opening downward along the line) or not finite.
    pub fn nonpositive_range_on_line(&self, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
        let md = self.m * d;
        let a = d.dot(md);
        let b = 2.0 * o.dot(md) + self.b.dot(d);
        let c = self.value(o);
        let scale = a.abs().max(b.abs()).max(c.abs());
        if !scale.is_finite() {
            return None;
        }
        if a.abs() <= 1e2 * self.quadratic_noise(d) {
            // Linear along the line: a half-line (or all or nothing).
            if b.abs() <= 1e-12 * scale {
                return Some(if c <= 0.0 {
                    (f64::NEG_INFINITY, f64::INFINITY)
                } else {
                    (1.0, 0.0)
                });
            }
            let root = -c / b;
            let margin = 1e-9 * (1.0 + root.abs());
            return Some(if b > 0.0 {
                (f64::NEG_INFINITY, root + margin)
            } else {
                (root - margin, f64::INFINITY)
            });
        }
        if a < 0.0 {
            return None;
        }
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return Some((1.0, 0.0));
        }
        // The stable pair of roots.
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        let (r1, r2) = if q != 0.0 { (q / a, c / q) } else { (0.0, 0.0) };
        let (lo, hi) = (r1.min(r2), r1.max(r2));
        let margin = 1e-9 * (1.0 + lo.abs().max(hi.abs()));
        Some((lo - margin, hi + margin))
    }

    /// The first meeting of a sphere or a plane (a quadric whose quadratic
    /// part is `lambda I`) with the circle of radius `R` through `p0` (at
    /// `t = 0`) about `p0 - R start`, leaving along `tangent`, for `t` in
    /// `[t0, t1]` within one loop.
    ///
    /// With `g` the quadric's gradient
    /// there and `s = t / R`, the quadric along the circle is
    /// `q(p0) + R (g.start - 2 lambda R)(cos s - 1) + R (g.tangent) sin s`;
    /// with `w = tan(s / 2)` this is a quadratic in `w` whose coefficients
    /// are all evaluated at `p0`, so nothing cancels even for a huge `R`.
    /// `None` (search instead) for other quadrics.
    pub fn first_root_on_circle(
        &self,
        p0: DVec3,
        radius: f64,
        start: DVec3,
        tangent: DVec3,
        t0: f64,
        t1: f64,
    ) -> Option<Option<f64>> {
        let lambda = self.m.x_axis.x;
        let isotropic = (self.m - DMat3::from_diagonal(DVec3::splat(lambda)))
            .to_cols_array()
            .iter()
            .all(|x| x.abs() <= 1e-12 * lambda.abs().max(1e-300));
        if !isotropic {
            return None;
        }
        let q0 = self.value(p0);
        let g = self.gradient(p0);
        let a = radius * (g.dot(start) - 2.0 * lambda * radius);
        let b = radius * g.dot(tangent);
        // q0 (1 + w^2) - 2 a w^2 + 2 b w = 0.
        let to_t = |w: f64| {
            let s = 2.0 * w.atan();
            radius
                * if s < 0.0 {
                    s + std::f64::consts::TAU
                } else {
                    s
                }
        };
        let (qa, qb) = (q0 - 2.0 * a, 2.0 * b);
        let noise = 1e-14 * qa.abs().max(qb.abs()).max(q0.abs());
        Some(smallest_root_in(qa, qb, q0, noise, t0, t1, to_t))
    }

    /// Degree 1: a plane (or a constant).
    pub fn is_linear(&self) -> bool {
        self.m == DMat3::ZERO
    }
}

/// The smallest `map(w)` in `[t0, t1]` over the roots `w` of
/// `a w^2 + b w + c = 0`, found by the numerically stable formula. An
/// `a` of at most `linear_below` (its rounding noise) is a linear
/// equation: a plane, or a ray parallel to a cylinder's axis.
fn smallest_root_in(
    a: f64,
    b: f64,
    c: f64,
    linear_below: f64,
    t0: f64,
    t1: f64,
    map: impl Fn(f64) -> f64,
) -> Option<f64> {
    let scale = a.abs().max(b.abs()).max(c.abs());
    if scale == 0.0 || !scale.is_finite() {
        return None;
    }
    let mut roots = [f64::NAN; 2];
    if a.abs() <= linear_below {
        if b != 0.0 {
            roots[0] = -c / b;
        }
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        roots = [q / a, if q != 0.0 { c / q } else { q / a }];
    }
    roots
        .iter()
        .map(|&w| map(w))
        .filter(|t| *t >= t0 && *t <= t1)
        .min_by(f64::total_cmp)
}

/// A polynomial of degree <= 2 in x, y, z. Coefficients of
/// 1, x, y, z, xx, yy, zz, xy, xz, yz.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Poly {
    k: [f64; 10],
    degree: u8,
}

const fn pair_index(i: usize, j: usize) -> usize {
    match (i, j) {
        (0, 0) => 4,
        (1, 1) => 5,
        (2, 2) => 6,
        (0, 1) | (1, 0) => 7,
        (0, 2) | (2, 0) => 8,
        _ => 9,
    }
}

impl Poly {
    fn constant(c: f64) -> Poly {
        let mut k = [0.0; 10];
        k[0] = c;
        Poly { k, degree: 0 }
    }
    fn var(i: usize) -> Poly {
        let mut k = [0.0; 10];
        k[1 + i] = 1.0;
        Poly { k, degree: 1 }
    }
    fn combine(a: Poly, b: Poly, sb: f64) -> Poly {
        let mut k = a.k;
        for (x, y) in k.iter_mut().zip(b.k) {
            *x += sb * y;
        }
        Poly {
            k,
            degree: a.degree.max(b.degree),
        }
    }
    fn scale(a: Poly, s: f64) -> Poly {
        Poly {
            k: a.k.map(|x| x * s),
            degree: a.degree,
        }
    }
    fn mul(a: Poly, b: Poly) -> Option<Poly> {
        if a.degree + b.degree > 2 {
            return None;
        }
        if a.degree == 0 {
            return Some(Poly::scale(b, a.k[0]));
        }
        if b.degree == 0 {
            return Some(Poly::scale(a, b.k[0]));
        }
        // Both linear.
        let mut k = [0.0; 10];
        k[0] = a.k[0] * b.k[0];
        for i in 0..3 {
            k[1 + i] = a.k[0] * b.k[1 + i] + b.k[0] * a.k[1 + i];
            for j in 0..3 {
                k[pair_index(i, j)] += a.k[1 + i] * b.k[1 + j];
            }
        }
        Some(Poly { k, degree: 2 })
    }
}

/// The quadric the expression at `root` is, if its degree in x, y, z is at
/// most 2 and it uses only polynomial operations.
pub fn as_quadric(graph: &Graph, root: NodeId) -> Option<Quadric> {
    let mut memo = HashMap::default();
    let p = poly(graph, root, &mut memo)?;
    let k = p.k;
    let m = DMat3::from_cols(
        DVec3::new(k[4], k[7] / 2.0, k[8] / 2.0),
        DVec3::new(k[7] / 2.0, k[5], k[9] / 2.0),
        DVec3::new(k[8] / 2.0, k[9] / 2.0, k[6]),
    );
    let b = DVec3::new(k[1], k[2], k[3]);
    let q = Quadric::new(m, b, k[0]);
    let finite = k.iter().all(|x| x.is_finite());
    // A constant is no surface at all.
    (finite && p.degree > 0).then_some(q)
}

fn poly(graph: &Graph, id: NodeId, memo: &mut HashMap<NodeId, Option<Poly>>) -> Option<Poly> {
    if let Some(p) = memo.get(&id) {
        return *p;
    }
    let p = match graph.node(id) {
        Node::Const(bits) => Some(Poly::constant(f64::from_bits(bits))),
        Node::Input(i) if i < 3 => Some(Poly::var(i as usize)),
        Node::Input(_) => None,
        Node::Unary(Unary::Neg, a) => poly(graph, a, memo).map(|a| Poly::scale(a, -1.0)),
        Node::Unary(Unary::Square, a) => poly(graph, a, memo).and_then(|a| Poly::mul(a, a)),
        Node::Unary(..) | Node::Noise(..) => None,
        Node::Binary(op, a, b) => {
            let pa = poly(graph, a, memo);
            let pb = poly(graph, b, memo);
            match (op, pa, pb) {
                (Binary::Add, Some(a), Some(b)) => Some(Poly::combine(a, b, 1.0)),
                (Binary::Sub, Some(a), Some(b)) => Some(Poly::combine(a, b, -1.0)),
                (Binary::Mul, Some(a), Some(b)) => Poly::mul(a, b),
                (Binary::Div, Some(a), Some(b)) if b.degree == 0 && b.k[0] != 0.0 => {
                    Some(Poly::scale(a, 1.0 / b.k[0]))
                }
                _ => None,
            }
        }
    };
    memo.insert(id, p);
    p
}

/// Folds the expression at `root` from its leaves up, each node once, by
/// an iterative post-order walk (deep expressions cannot overflow the
/// stack): `visit` is given a node and the values of the nodes folded so
/// far (its operands' among them), and stops the fold with `None`.
fn fold_up<T: Copy>(
    graph: &Graph,
    root: NodeId,
    mut visit: impl FnMut(NodeId, &HashMap<NodeId, T>) -> Option<T>,
) -> Option<T> {
    let mut memo: HashMap<NodeId, T> = HashMap::default();
    let mut stack = vec![(root, false)];
    while let Some((id, ready)) = stack.pop() {
        if memo.contains_key(&id) {
            continue;
        }
        let operands: Vec<NodeId> = graph.node(id).operands().collect();
        if !ready && operands.iter().any(|o| !memo.contains_key(o)) {
            stack.push((id, true));
            stack.extend(operands.iter().map(|&o| (o, false)));
            continue;
        }
        let value = visit(id, &memo)?;
        memo.insert(id, value);
    }
    memo.get(&root).copied()
}

/// The highest degree of a rational function's numerator the polynomial
/// route takes ([`rational_numerator`]): its Taylor products cost the
/// square of the degree, and past this interval isolation is as quick.
pub const MAX_NUMERATOR_DEGREE: usize = 16;

/// For a rational function `f = N / D` of x, y, z whose denominator is a
/// product of factors that are nonnegative as written (sums of squares
/// and positive constants, like the distances squared of metaballs'
/// `s / |p - c|^2`), the numerator `N = f D`, in a graph of its own: it
/// has the sign of `f` wherever `f` is defined, and its zeros there, so
/// along a line it is a polynomial whose roots are `f`'s. `None` when `f`
/// is a polynomial already, is not rational, has a denominator not
/// nonnegative as written, or a numerator of degree over
/// [`MAX_NUMERATOR_DEGREE`]. Where `D` vanishes `f` is undefined and `N`
/// may vanish too: a root found on `N` is checked on `f`.
pub fn rational_numerator(graph: &Graph, root: NodeId) -> Option<(Graph, NodeId)> {
    let mut g = Graph::new();
    let mut divided = false;
    // Each node as (numerator, denominator) with their degrees; no
    // denominator stands for 1. A degree past the limit stops the fold at
    // once: thousands of distinct denominators would otherwise build a
    // numerator of millions of operations before it is judged.
    type Fraction = (NodeId, Option<NodeId>, usize, usize);
    let (n, ..) = fold_up(graph, root, |id, memo: &HashMap<NodeId, Fraction>| {
        let get = |n: NodeId| {
            let (num, den, _, _) = memo[&n];
            (num, den)
        };
        let degree = |n: NodeId| {
            let (_, _, dn, dd) = memo[&n];
            (dn, dd)
        };
        let times = |g: &mut Graph, a: Option<NodeId>, b: Option<NodeId>| match (a, b) {
            (None, d) | (d, None) => d,
            (Some(a), Some(b)) => Some(g.mul(a, b)),
        };
        let over = |g: &mut Graph, n: NodeId, d: Option<NodeId>| d.map_or(n, |d| g.mul(n, d));
        let fraction = match graph.node(id) {
            Node::Const(bits) => (g.constant(f64::from_bits(bits)), None),
            Node::Input(i) if i < 3 => (g.input(i), None),
            Node::Unary(Unary::Neg, a) => {
                let (n, d) = get(a);
                (g.neg(n), d)
            }
            Node::Unary(Unary::Square, a) => {
                let (n, d) = get(a);
                let d = d.map(|d| g.unary(Unary::Square, d));
                (g.unary(Unary::Square, n), d)
            }
            Node::Binary(op @ (Binary::Add | Binary::Sub), a, b) => {
                let ((na, da), (nb, db)) = (get(a), get(b));
                let (left, right, d) = if da == db {
                    (na, nb, da)
                } else {
                    let left = over(&mut g, na, db);
                    let right = over(&mut g, nb, da);
                    (left, right, times(&mut g, da, db))
                };
                (g.binary(op, left, right), d)
            }
            Node::Binary(Binary::Mul, a, b) => {
                let ((na, da), (nb, db)) = (get(a), get(b));
                let n = g.mul(na, nb);
                (n, times(&mut g, da, db))
            }
            Node::Binary(Binary::Div, a, b) => {
                let ((na, da), (nb, db)) = (get(a), get(b));
                match g.as_const(nb) {
                    // A constant divisor keeps the sign, or turns it the
                    // same way everywhere: a polynomial's own division.
                    Some(c) if c != 0.0 && c.is_finite() => {
                        let n = over(&mut g, na, db);
                        let k = g.constant(c);
                        (g.div(n, k), da)
                    }
                    _ if g.nonnegative_as_written(nb) => {
                        divided = true;
                        let n = over(&mut g, na, db);
                        (n, times(&mut g, da, Some(nb)))
                    }
                    _ => return None,
                }
            }
            Node::Binary(Binary::Pow, a, b) => match graph.as_const(b) {
                Some(k) if k >= 0.0 && k.fract() == 0.0 && k <= MAX_NUMERATOR_DEGREE as f64 => {
                    let (n, d) = get(a);
                    let d = d.map(|d| g.powi(d, k as i64));
                    (g.powi(n, k as i64), d)
                }
                _ => return None,
            },
            _ => return None,
        };
        let (dn, dd) = match graph.node(id) {
            Node::Const(_) => (0, 0),
            Node::Input(_) => (1, 0),
            Node::Unary(_, a) => {
                let (dn, dd) = degree(a);
                let k = if matches!(graph.node(id), Node::Unary(Unary::Square, _)) {
                    2
                } else {
                    1
                };
                (k * dn, k * dd)
            }
            Node::Binary(Binary::Add | Binary::Sub, a, b) => {
                let ((na, da), (nb, db)) = (degree(a), degree(b));
                if get(a).1 == get(b).1 {
                    (na.max(nb), da)
                } else {
                    ((na + db).max(nb + da), da + db)
                }
            }
            Node::Binary(Binary::Mul, a, b) => {
                let ((na, da), (nb, db)) = (degree(a), degree(b));
                (na + nb, da + db)
            }
            Node::Binary(Binary::Div, a, b) => {
                let ((na, da), (nb, db)) = (degree(a), degree(b));
                if fraction.1 == get(a).1 {
                    (na + db, da)
                } else {
                    (na + db, da + nb)
                }
            }
            Node::Binary(_, a, b) => {
                let (na, da) = degree(a);
                let k = graph.as_const(b).unwrap_or(0.0) as usize;
                (k * na, k * da)
            }
            _ => return None,
        };
        if dn.max(dd) > MAX_NUMERATOR_DEGREE {
            return None;
        }
        Some((fraction.0, fraction.1, dn, dd))
    })?;
    let degree = polynomial_degree(&g, n)?;
    (divided && degree <= MAX_NUMERATOR_DEGREE).then_some((g, n))
}

/// The highest degree [`polynomial_degree`] reports: the polynomial route
/// computes up to this many plus one coefficients per ray.
pub const MAX_POLYNOMIAL_DEGREE: usize = 32;

/// The total degree of the expression at `root` in x, y and z, when it is a
/// polynomial of degree at most [`MAX_POLYNOMIAL_DEGREE`]: constants,
/// coordinates, sums, differences, negations, products, squares, whole
/// constant powers and quotients by constants. `None` otherwise (any other
/// operation, or an input beyond x, y, z).
pub fn polynomial_degree(graph: &Graph, root: NodeId) -> Option<usize> {
    fold_up(graph, root, |id, memo: &HashMap<NodeId, Option<usize>>| {
        let get = |n: NodeId| memo.get(&n).copied().flatten();
        let degree = match graph.node(id) {
            Node::Const(_) => Some(0),
            Node::Input(i) if i < 3 => Some(1),
            Node::Input(_) => None,
            Node::Unary(Unary::Neg, a) => get(a),
            Node::Unary(Unary::Square, a) => get(a).map(|d| 2 * d),
            Node::Unary(..) | Node::Noise(..) => None,
            Node::Binary(op, a, b) => match op {
                Binary::Add | Binary::Sub => get(a).zip(get(b)).map(|(p, q)| p.max(q)),
                Binary::Mul => get(a).zip(get(b)).map(|(p, q)| p + q),
                Binary::Div => graph
                    .as_const(b)
                    .filter(|k| *k != 0.0 && k.is_finite())
                    .and(get(a)),
                Binary::Pow => match graph.as_const(b) {
                    Some(n)
                        if n >= 0.0 && n.fract() == 0.0 && n <= MAX_POLYNOMIAL_DEGREE as f64 =>
                    {
                        get(a).map(|d| d * n as usize)
                    }
                    _ => None,
                },
                _ => None,
            },
        }
        .filter(|&d| d <= MAX_POLYNOMIAL_DEGREE);
        Some(degree)
    })
    .flatten()
}

/// The most a folded power may be: [`Taylor`](super::Taylor)'s binomial
/// powers go to 48.
const MOST_LINE_POWER: u32 = 48;

/// The polynomial at `root` rebuilt for evaluation along a line, with each
/// run of products of one base of degree at most one (`x^8` as squares of
/// squares, `x * x^2`) made one whole power. Along a line such a base is
/// `a + b s`, whose powers the Taylor evaluator writes by the binomial
/// theorem in `n + 1` terms with one error bound, where the run took full
/// series products (Chmutov's octic spent a third of its render in them).
/// `None` when there is no run of three or more to fold.
pub fn with_line_powers(graph: &Graph, root: NodeId) -> Option<(Graph, NodeId)> {
    let n = root.0 as usize + 1;
    // Operands have smaller ids than their nodes: one pass in id order
    // sees every operand first.
    let mut degree: Vec<Option<usize>> = Vec::with_capacity(n);
    let mut power: Vec<(NodeId, u32)> = Vec::with_capacity(n);
    for i in 0..n {
        let id = NodeId(i as u32);
        let get = |a: NodeId| degree[a.0 as usize];
        let (d, p) = match graph.node(id) {
            Node::Const(_) => (Some(0), (id, 1)),
            Node::Input(k) => ((k < 3).then_some(1), (id, 1)),
            Node::Unary(Unary::Neg, a) => (get(a), (id, 1)),
            Node::Unary(Unary::Square, a) => {
                let (base, k) = power[a.0 as usize];
                (get(a).map(|d| 2 * d), (base, 2 * k))
            }
            Node::Binary(Binary::Mul, a, b) => {
                let ((pa, ka), (pb, kb)) = (power[a.0 as usize], power[b.0 as usize]);
                let p = if pa == pb { (pa, ka + kb) } else { (id, 1) };
                (get(a).zip(get(b)).map(|(p, q)| p + q), p)
            }
            Node::Binary(Binary::Add | Binary::Sub, a, b) => {
                (get(a).zip(get(b)).map(|(p, q)| p.max(q)), (id, 1))
            }
            Node::Binary(Binary::Div, a, b) if graph.as_const(b).is_some() => (get(a), (id, 1)),
            _ => (None, (id, 1)),
        };
        degree.push(d);
        power.push(p);
    }
    // The nodes `root` reaches, rebuilt in id order without simplifying
    // (which would unfold the powers again).
    let mut reached = vec![false; n];
    let mut stack = vec![root];
    while let Some(id) = stack.pop() {
        if !std::mem::replace(&mut reached[id.0 as usize], true) {
            stack.extend(graph.node(id).operands());
        }
    }
    let mut g = Graph::unsimplified();
    let mut map: Vec<NodeId> = vec![NodeId(0); n];
    let mut folded = false;
    for i in (0..n).filter(|&i| reached[i]) {
        let id = NodeId(i as u32);
        let (base, k) = power[i];
        let linear_base = degree[base.0 as usize].is_some_and(|d| d <= 1);
        map[i] = if base != id && (3..=MOST_LINE_POWER).contains(&k) && linear_base {
            folded = true;
            let exponent = g.constant(k as f64);
            g.binary(Binary::Pow, map[base.0 as usize], exponent)
        } else {
            match graph.node(id) {
                Node::Const(bits) => g.constant(f64::from_bits(bits)),
                Node::Input(k) => g.input(k),
                Node::Unary(op, a) => g.unary(op, map[a.0 as usize]),
                Node::Binary(op, a, b) => g.binary(op, map[a.0 as usize], map[b.0 as usize]),
                // Not a polynomial: nothing to fold for.
                Node::Noise(..) => return None,
            }
        };
    }
    folded.then(|| (g, map[root.0 as usize]))
}
