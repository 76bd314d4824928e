//! The expression IR: a number-type-independent DAG ([`Graph`]), symbolic
//! derivatives built in the same graph, a linear [`Tape`] to evaluate it in
//! any [`Number`] type, and recognition of closed-form surfaces
//! ([`Quadric`]).
//!
//! Input: a graph built by the compiler from a shape expression.
//! Output: an [`Implicit`] function the tracer evaluates per ray.

/// The [`Number`] methods a polynomial never uses, each giving the
/// type's `undefined()` (NaN), for the number types that exist to carry
/// polynomials ([`Taylor`], [`Magnitude`]): a tape that is not a
/// polynomial cannot be mistaken for one.
macro_rules! undefined_beyond_polynomials {
    () => {
        undefined_beyond_polynomials!(unary: abs, sign, sqrt, exp, ln, sin, cos, tan, asin, acos, atan, sinh, cosh, tanh, shc, chc, shc_slope, floor, fract, smooth_step, integer_jumps, zero_jumps);
        undefined_beyond_polynomials!(binary: min, max, atan2, smooth_min, when, unless);
        fn select(self, _: Self, _: Self) -> Self {
            Self::undefined()
        }
        fn noise(_: [Self; 3], _: [u8; 3]) -> Self {
            Self::undefined()
        }
    };
    (unary: $($f:ident),*) => {
        $(fn $f(self) -> Self {
            Self::undefined()
        })*
    };
    (binary: $($f:ident),*) => {
        $(fn $f(self, _: Self) -> Self {
            Self::undefined()
        })*
    };
}

mod dual;
mod graph;
pub mod interval;
pub mod jit;
pub mod lanes;
mod magnitude;
mod noise;
mod number;
mod op;
mod poly;
pub mod prune;
mod sharp;
mod tape;
mod taylor;
mod trig;
pub mod univariate;

pub use dual::Dual;
pub use graph::{Graph, Node, NodeId};
pub use interval::Interval;
pub use lanes::{F64Lanes, IntervalLanes};
pub use magnitude::{Magnitude, ValueErrors};
pub use number::{power_of_two_below, LineForm, Number};
pub use op::{Binary, Noise, Unary};
pub use poly::{
    as_quadric, polynomial_degree, rational_numerator, with_line_powers, Quadric,
    MAX_NUMERATOR_DEGREE, MAX_POLYNOMIAL_DEGREE,
};
pub use sharp::{SplitScratch, SplitSum};
pub use tape::{without_outer_parentheses, Tape};
pub use taylor::Taylor;

use std::sync::Arc;

use glam::DVec3;

/// A compiled implicit function `f(x, y, z)`: negative inside, zero on the
/// surface, with its symbolic gradient.
#[derive(Debug, Clone)]
pub struct Implicit {
    /// `f` alone, for marching.
    pub value_tape: Tape,
    /// `f, df/dx, df/dy, df/dz`, sharing subexpressions, for shading.
    pub gradient_tape: Tape,
    /// Set when `f` is a plane or quadric, so rays meet it in closed form.
    pub quadric: Option<Quadric>,
    /// Set when `f` is a polynomial in x, y, z of degree 3 to
    /// [`MAX_POLYNOMIAL_DEGREE`]: along a straight path it is a polynomial
    /// of that degree in the path's parameter, solved by
    /// [`univariate::first_root_of_bernstein`].
    pub degree: Option<usize>,
    /// For a polynomial, its value tape with runs of products of a linear
    /// base made whole powers ([`with_line_powers`]), which the polynomial
    /// route evaluates along lines; `None` when it would be the value tape.
    /// For a rational function, its numerator's ([`rational_numerator`]).
    pub line_tape: Option<Tape>,
    /// Which stand-in for `f` the polynomial route solves, if any (a
    /// rational function's numerator, or `a - c^2` for `sqrt(a) - c`): a
    /// root found on it is checked on `f` itself, which is undefined
    /// where a denominator vanishes.
    pub proxy: Proxy,
    /// Set when `f` is the `min` of 2 to [`MOST_UNION_PARTS`] parts, each
    /// a quadric or a polynomial (or solved through a stand-in), in order:
    /// along a straight path from a point outside every part, `f`'s first
    /// root is the first of its parts' first roots, each found by its own
    /// route (a union of a torus and a ball took four times as long as
    /// the two as objects, by interval isolation).
    pub union: Option<Arc<[Implicit]>>,
    /// Set when `f` may jump (it uses `floor`, `fract`, `sign` or `if`):
    /// root finding then tells a jump across zero, which is not a root,
    /// from a crossing.
    pub has_jumps: bool,
    /// Set when `f` may jump where only its slope shows it
    /// ([`Tape::has_slope_jumps`]): a change of sign where its slope is
    /// unbounded may then be a jump, not a root.
    pub has_slope_jumps: bool,
    /// Operations as written, before simplification.
    pub size_written: usize,
    /// Operations of `f` after simplification.
    pub size_simplified: usize,
    /// The simplified graph the tapes were compiled from, and `f` in it,
    /// for [`Implicit::pruned`].
    graph: Arc<Graph>,
    root: NodeId,
    /// The tapes as native code, compiled on first use; `None` for the
    /// many short-lived formulas of [`Implicit::value_only`], which would
    /// spend more compiling than they save.
    native: Option<Arc<Native>>,
}

/// [`Implicit`]'s tapes compiled to machine code ([`jit`]), each when it
/// is first evaluated: a formula a render never evaluates at a point
/// costs nothing, and one it evaluates a million times runs about ten
/// times faster than interpreted, with the same bits.
#[derive(Debug, Default)]
struct Native {
    value: std::sync::OnceLock<Option<jit::CompiledTape>>,
    gradient: std::sync::OnceLock<Option<jit::CompiledTape>>,
    magnitude: std::sync::OnceLock<Option<jit::CompiledMagnitude>>,
    /// A stand-in's tape (see [`Implicit::proxy`]), at points.
    stand_in: std::sync::OnceLock<Option<jit::CompiledTape>>,
}

/// Tapes longer than this stay interpreted by [`Implicit`]: compiling
/// takes about 45 us per operation (see [`jit::MAX_COMPILED_OPERATIONS`]),
/// so this bounds it near 70 ms, which a render of a formula this long
/// recovers many times over.
const MOST_NATIVE_OPERATIONS: usize = 1_500;

fn compile_if_short(tape: &Tape) -> Option<jit::CompiledTape> {
    if tape.operations() > MOST_NATIVE_OPERATIONS {
        return None;
    }
    jit::CompiledTape::new(tape)
}

/// The polynomial route's tape of `f` (see [`Implicit::line_tape`]).
fn line_tape(g: &Graph, f: NodeId, degree: Option<usize>) -> Option<Tape> {
    degree?;
    let (lg, root) = with_line_powers(g, f)?;
    Some(Tape::new(&lg, &[root]))
}

/// What the polynomial route solves for `f`: its degree and line tape
/// ([`Implicit::degree`], [`Implicit::line_tape`]), and whether they are
/// a rational function's numerator's.
fn polynomial_form(g: &Graph, f: NodeId, quadric: bool) -> PolynomialForm {
    let degree = polynomial_degree(g, f).filter(|&d| d >= 3);
    if degree.is_some() || quadric {
        return (degree, line_tape(g, f, degree), Proxy::None, None);
    }
    let numerator = rational_numerator(g, f).map(|p| (p, Proxy::Numerator));
    let Some(((ng, n), proxy)) = numerator.or_else(|| root_level(g, f).map(|p| (p, Proxy::Square)))
    else {
        return (None, None, Proxy::None, None);
    };
    match polynomial_degree(&ng, n) {
        Some(d) if d >= 1 => {
            let tape = line_tape(&ng, n, Some(d)).unwrap_or_else(|| Tape::new(&ng, &[n]));
            // `sqrt(a) - c` with `a` quadratic (`length(p - q) - r`, a
            // capsule's cell) is the quadric `a - c^2`: the same zeros,
            // and the same sign everywhere, so met in closed form.
            let quadric = (proxy == Proxy::Square && d == 2)
                .then(|| as_quadric(&ng, n))
                .flatten();
            (Some(d), Some(tape), proxy, quadric)
        }
        _ => (None, None, Proxy::None, None),
    }
}

/// What [`polynomial_form`] finds: the degree, the tape the polynomial
/// route evaluates along lines, the stand-in it solves, and the quadric
/// with `f`'s zeros and signs, when the stand-in is one.
type PolynomialForm = (Option<usize>, Option<Tape>, Proxy, Option<Quadric>);

/// The most parts [`Implicit::union`] searches one by one, each within
/// its own box, as separate objects are: a union of more is better served
/// by its cells' shorter formulas (a union of nine balls took ten times
/// as long by its cells as the nine balls as objects). Cells' formulas
/// are searched by parts too: a union of 2000 balls, whose cells hold up
/// to dozens, traced in 0.31 s this way and 1.24 s with 4 parts at most
/// (its cells' parts took 385 MB against 184 MB, within the bounds on
/// cells' formulas).
pub const MOST_UNION_PARTS: usize = 64;

/// The parts of `f` as a union (see [`Implicit::union`]): the operands of
/// its nest of `min`s, in order, each as a function of its own, when
/// there are 2 to [`MOST_UNION_PARTS`] and each is met in closed form or
/// by the polynomial route. With `native` (a whole object's function),
/// the parts are compiled to machine code on first use; a cell's shorter
/// formulas, of which there may be thousands, stay interpreted.
fn union_parts(g: &Graph, f: NodeId, native: bool) -> Option<Arc<[Implicit]>> {
    // A shift or a positive scaling of a union is the union of the parts
    // shifted or scaled (`min(a, b) - 0.1`, an inflated union): each such
    // map is nondecreasing, so the same part is the least.
    let mut maps = Vec::new();
    let mut f = f;
    let positive = |k: NodeId| g.as_const(k).filter(|c| *c > 0.0 && c.is_finite());
    let finite = |k: NodeId| g.as_const(k).filter(|c| c.is_finite());
    loop {
        f = match g.node(f) {
            Node::Binary(Binary::Min, _, _) => break,
            Node::Binary(op @ (Binary::Add | Binary::Sub), m, k) if finite(k).is_some() => {
                maps.push((op, k));
                m
            }
            Node::Binary(Binary::Add, k, m) if finite(k).is_some() => {
                maps.push((Binary::Add, k));
                m
            }
            Node::Binary(op @ (Binary::Mul | Binary::Div), m, k) if positive(k).is_some() => {
                maps.push((op, k));
                m
            }
            Node::Binary(Binary::Mul, k, m) if positive(k).is_some() => {
                maps.push((Binary::Mul, k));
                m
            }
            _ => return None,
        };
    }
    let mut parts = Vec::new();
    let mut stack = vec![f];
    while let Some(n) = stack.pop() {
        match g.node(n) {
            Node::Binary(Binary::Min, a, b) => stack.extend([b, a]),
            _ if parts.len() == MOST_UNION_PARTS => return None,
            _ => parts.push(n),
        }
    }
    let parts: Vec<Implicit> = parts
        .into_iter()
        .map(|part| {
            let mut p = if maps.is_empty() {
                Implicit::value_only_with(g, part, false)
            } else {
                // The maps, innermost (last peeled) first.
                let mut pg = Graph::new();
                let mut at = pg.import(g, part, &[]);
                for &(op, k) in maps.iter().rev() {
                    let k = pg.constant(g.as_const(k).expect("a constant"));
                    at = pg.binary(op, at, k);
                }
                Implicit::value_only_with(&pg, at, false)
            };
            if native {
                p.native = Some(Arc::default());
            }
            p
        })
        .collect();
    let solvable = |p: &Implicit| p.quadric.is_some() || p.degree.is_some();
    parts.iter().all(solvable).then(|| parts.into())
}

/// What the polynomial route solves in place of `f` when `f` is no
/// polynomial (see [`Implicit::proxy`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Proxy {
    /// `f` itself.
    None,
    /// A rational function's numerator ([`rational_numerator`]).
    Numerator,
    /// `a - c^2` for `sqrt(a) - c` (see `root_level`).
    Square,
}

/// For `f = sqrt(a) - c` or `c - sqrt(a)` with `c` a nonnegative constant
/// and `a` nonnegative as written (a distance: `length(p - q) - r`, a
/// capsule's cell in a union), the polynomial `a - c^2` (or `c^2 - a`) in a
/// graph of its own: it has `f`'s sign wherever `f` is defined, and its
/// zeros. A root found on it is checked on `f`, as a rational function's
/// numerator's is.
fn root_level(graph: &Graph, f: NodeId) -> Option<(Graph, NodeId)> {
    let sqrt_of = |n: NodeId| match graph.node(n) {
        Node::Unary(Unary::Sqrt, a) => Some(a),
        _ => None,
    };
    // (a, c, whether f is c - sqrt(a))
    let (a, c, outside_in) = match graph.node(f) {
        Node::Binary(Binary::Sub, s, k) if graph.as_const(k).is_some() => {
            (sqrt_of(s)?, graph.as_const(k)?, false)
        }
        Node::Binary(Binary::Sub, k, s) if graph.as_const(k).is_some() => {
            (sqrt_of(s)?, graph.as_const(k)?, true)
        }
        Node::Binary(Binary::Add, s, k) | Node::Binary(Binary::Add, k, s)
            if graph.as_const(k).is_some() && sqrt_of(s).is_some() =>
        {
            (sqrt_of(s)?, -graph.as_const(k)?, false)
        }
        _ => return None,
    };
    if !(c >= 0.0 && c.is_finite() && graph.nonnegative_as_written(a)) {
        return None;
    }
    let mut g = Graph::new();
    let a = g.import(graph, a, &[]);
    let level = g.constant(c * c);
    let proxy = if outside_in {
        g.binary(Binary::Sub, level, a)
    } else {
        g.binary(Binary::Sub, a, level)
    };
    Some((g, proxy))
}

impl Implicit {
    /// Simplify, differentiate and compile the expression at `root`.
    pub fn new(graph: &Graph, root: NodeId) -> Implicit {
        let size_written = graph.reachable_count(&[root]);
        let mut g = Graph::new();
        let f = g.import(graph, root, &[]);
        let grad: Vec<NodeId> = (0..3).map(|axis| g.derivative(f, axis)).collect();
        let quadric = as_quadric(&g, f);
        let (degree, line_tape, proxy, stand_in) = polynomial_form(&g, f, quadric.is_some());
        let quadric = quadric.or(stand_in);
        let value_tape = Tape::new(&g, &[f]);
        Implicit {
            union: union_parts(&g, f, true),
            root: f,
            has_jumps: value_tape.has_jumps(),
            has_slope_jumps: value_tape.has_slope_jumps(),
            value_tape,
            gradient_tape: Tape::new(&g, &[f, grad[0], grad[1], grad[2]]),
            quadric,
            line_tape,
            proxy,
            degree,
            size_written,
            size_simplified: g.reachable_count(&[f]),
            graph: Arc::new(g),
            native: Some(Arc::default()),
        }
    }

    /// The formula's value where it is a constant (depends on no input),
    /// else `None`.
    pub fn constant(&self) -> Option<f64> {
        self.graph.as_const(self.root)
    }

    /// `c` where the formula is `c / g` with `c` a nonzero constant and
    /// `g` finite wherever it is defined: such a formula is never 0, and
    /// changes sign only where `g` does, through infinity (`1 / (x^2 + y^2
    /// + z^2 - 1)` has no surface). A `g` with a pole of its own is
    /// infinite there, where `c / g` is 0 (`1 / tan(x)` at x = pi/2).
    pub fn constant_over(&self) -> Option<f64> {
        match self.graph.node(self.root) {
            Node::Binary(Binary::Div, a, g) => self
                .graph
                .as_const(a)
                .filter(|c| *c != 0.0 && !Tape::new(&self.graph, &[g]).has_slope_jumps()),
            _ => None,
        }
    }

    /// `f` at `root` without a gradient tape: its gradient is computed
    /// by forward differentiation of the value tape, three passes, which
    /// pays for a formula evaluated for a gradient only once per hit and
    /// too many to build gradient tapes for (the cells of
    /// [`prune`]). Nothing may read its `gradient_tape`, which is empty.
    pub fn value_only(graph: &Graph, root: NodeId) -> Implicit {
        Implicit::value_only_with(graph, root, true)
    }

    /// [`Implicit::value_only`], with its parts as a union only if
    /// `union`: a union's parts are searched as they are, and asking each
    /// for parts of its own recursed through every part's parts (a chain
    /// of 24 `min(c, c - 0.1)`, once `c - 0.1` was a union, ran for
    /// minutes).
    fn value_only_with(graph: &Graph, root: NodeId, union: bool) -> Implicit {
        let size_written = graph.reachable_count(&[root]);
        let mut g = Graph::new();
        let f = g.import(graph, root, &[]);
        let value_tape = Tape::new(&g, &[f]);
        let quadric = as_quadric(&g, f);
        let (degree, line_tape, proxy, stand_in) = polynomial_form(&g, f, quadric.is_some());
        let quadric = quadric.or(stand_in);
        Implicit {
            union: if union {
                union_parts(&g, f, false)
            } else {
                None
            },
            root: f,
            has_jumps: value_tape.has_jumps(),
            has_slope_jumps: value_tape.has_slope_jumps(),
            gradient_tape: Tape::new(&g, &[]),
            quadric,
            degree,
            line_tape,
            proxy,
            value_tape,
            size_written,
            size_simplified: g.reachable_count(&[f]),
            graph: Arc::new(g),
            native: None,
        }
    }

    /// A tape of `f`'s gradient and Hessian at `root` of `graph`, its
    /// outputs `fx, fy, fz, fxx, fyy, fzz, fxy, fxz, fyz`: what the
    /// curvatures of the surface need (built only for a colour field that
    /// reads them).
    pub fn second_derivatives(graph: &Graph, root: NodeId) -> Tape {
        let mut g = Graph::new();
        let f = g.import(graph, root, &[]);
        let d: Vec<NodeId> = (0..3).map(|axis| g.derivative(f, axis)).collect();
        let dd = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]
            .map(|(i, j)| g.derivative(d[i], j as u8));
        let outputs: Vec<NodeId> = d.iter().copied().chain(dd).collect();
        Tape::new(&g, &outputs)
    }

    /// `f` at the point `p` (in the coordinates the object is written in);
    /// NaN or infinite where `f` is undefined. `slots` is scratch space reused
    /// between calls.
    #[inline]
    pub fn value(&self, p: DVec3, slots: &mut Vec<f64>) -> f64 {
        if let Some(code) = self.native_value() {
            let mut out = [0.0];
            code.eval_into(&[p.x, p.y, p.z], &mut out);
            return out[0];
        }
        self.value_tape.eval(&[p.x, p.y, p.z], slots)
    }

    /// The value tape as native code, if it is compiled (or can be now).
    #[inline]
    pub fn native_value(&self) -> Option<&jit::CompiledTape> {
        let native = self.native.as_deref()?;
        native
            .value
            .get_or_init(|| compile_if_short(&self.value_tape))
            .as_ref()
    }

    /// The tape of the polynomial the polynomial route solves: `f`'s own,
    /// or its stand-in's (a numerator, `a - c^2`; see [`Implicit::proxy`]).
    pub fn solved_tape(&self) -> &Tape {
        match self.proxy {
            Proxy::None => &self.value_tape,
            _ => self.line_tape.as_ref().unwrap_or(&self.value_tape),
        }
    }

    /// The polynomial of [`Implicit::solved_tape`] at `p`: native code
    /// where it is compiled, else the interpreter (the same bits).
    #[inline]
    pub fn solved_value(&self, p: DVec3, slots: &mut Vec<f64>) -> f64 {
        if self.proxy == Proxy::None {
            return self.value(p, slots);
        }
        let code = self.native.as_deref().and_then(|native| {
            native
                .stand_in
                .get_or_init(|| compile_if_short(self.solved_tape()))
                .as_ref()
        });
        match code {
            Some(code) => {
                let mut out = [0.0];
                code.eval_into(&[p.x, p.y, p.z], &mut out);
                out[0]
            }
            None => self.solved_tape().eval(&[p.x, p.y, p.z], slots),
        }
    }

    /// The [`Magnitude`] pass of [`Implicit::solved_tape`] as native
    /// code, for a polynomial the route interpolates (see
    /// [`univariate::MOST_INTERPOLATED_DEGREE`]).
    #[inline]
    pub fn native_magnitude(&self) -> Option<&jit::CompiledMagnitude> {
        let native = self.native.as_deref()?;
        native
            .magnitude
            .get_or_init(|| {
                let interpolated = self
                    .degree
                    .is_some_and(|d| d <= univariate::MOST_INTERPOLATED_DEGREE);
                let tape = self.solved_tape();
                (interpolated && tape.operations() <= MOST_NATIVE_OPERATIONS)
                    .then(|| jit::CompiledMagnitude::new(tape))
                    .flatten()
            })
            .as_ref()
    }

    fn native_gradient(&self) -> Option<&jit::CompiledTape> {
        let native = self.native.as_deref()?;
        native
            .gradient
            .get_or_init(|| compile_if_short(&self.gradient_tape))
            .as_ref()
    }

    /// The value and the gradient at `p`.
    #[inline]
    pub fn value_and_gradient(&self, p: DVec3, slots: &mut Vec<f64>) -> (f64, DVec3) {
        if self.gradient_tape.output_count() == 0 {
            return self.value_and_gradient_forward(p);
        }
        let mut out = [0.0; 4];
        match self.native_gradient() {
            Some(code) => code.eval_into(&[p.x, p.y, p.z], &mut out),
            None => self
                .gradient_tape
                .eval_into(&[p.x, p.y, p.z], slots, &mut out),
        }
        (out[0], DVec3::new(out[1], out[2], out[3]))
    }

    /// One pass of forward differentiation, the three partials side by
    /// side in lanes; the slots are kept per thread, as this runs per hit.
    fn value_and_gradient_forward(&self, p: DVec3) -> (f64, DVec3) {
        type Partials = Dual<F64Lanes<3>>;
        thread_local! {
            static SLOTS: std::cell::RefCell<Vec<Partials>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        let unit = |axis: usize| F64Lanes(std::array::from_fn(|k| f64::from(k == axis)));
        let inputs = [p.x, p.y, p.z].map(|c| F64Lanes([c; 3]));
        let inputs: [Partials; 3] = std::array::from_fn(|axis| Dual {
            v: inputs[axis],
            d: unit(axis),
        });
        let d = SLOTS.with_borrow_mut(|slots| self.value_tape.eval(&inputs, slots));
        (d.v.0[0], DVec3::from_array(d.d.0))
    }

    /// `f` as a sum of one polynomial per coordinate and the rest, each
    /// part expanded about `centre`, whose enclosures over boxes near it
    /// are sharper than [`Implicit::interval`]'s; `None` where it has no
    /// such part of degree 2 or more.
    pub fn split_sum(&self, centre: DVec3) -> Option<SplitSum> {
        SplitSum::of(&self.graph, self.root, centre)
    }

    /// `f` over a box, enclosing every value `f` takes there.
    pub fn interval(&self, lo: DVec3, hi: DVec3, slots: &mut Vec<Interval>) -> Interval {
        let inputs = [
            Interval::new(lo.x, hi.x),
            Interval::new(lo.y, hi.y),
            Interval::new(lo.z, hi.z),
        ];
        self.value_tape.eval(&inputs, slots)
    }
}
