//! The operations of the expression IR, each defined once.
//!
//! Input: an operation and its operands in any [`Number`] type. Output:
//! its value in that type. The graph folds constants with these
//! definitions and the tape evaluates with them, so **constant folding
//! and evaluation can never disagree**; a new operation is added here,
//! with its `Number` method, its derivative in `graph.rs` and its tape
//! opcode.

use super::number::Number;

/// Gradient noise, the one three-argument operation: Perlin's improved
/// noise of the point `(a, b, c)` (the builtin `noise(q)`), or its partial
/// derivative of order `partial` per axis, evaluated by [`Number::noise`]
/// (the function itself is defined in `noise.rs`). Its derivative in
/// `x`, `y` or `z` is the same operation with one order higher.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Noise {
    /// How many times it is differentiated in each of its three arguments.
    pub partial: [u8; 3],
}

impl Noise {
    /// The noise itself.
    pub const VALUE: Noise = Noise { partial: [0, 0, 0] };

    /// The operation in any number type.
    #[inline]
    pub fn apply<N: Number>(self, p: [N; 3]) -> N {
        N::noise(p, self.partial)
    }

    /// Its derivative in argument `axis`.
    pub fn differentiated(self, axis: usize) -> Noise {
        let mut partial = self.partial;
        partial[axis] = partial[axis].saturating_add(1);
        Noise { partial }
    }

    /// Whether it is identically zero: differentiated more often in one
    /// argument than the polynomials it is made of allow.
    pub fn vanishes(self) -> bool {
        self.partial
            .iter()
            .any(|&k| k >= super::noise::VANISHING_ORDER)
    }
}

/// A one-argument operation of the expression IR. Each is evaluated by the
/// [`Number`] method of the same name ([`Unary::apply`]), so its conventions
/// (domains, NaN, interval rounding) are documented there.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Unary {
    /// `-a`.
    Neg,
    /// `a²`, from `a^2`, `a * a` and even integer powers once simplified; kept
    /// apart from multiplication so that intervals stay tight.
    Square,
    /// `|a|`: the builtin `abs`.
    Abs,
    /// `sign(a)`: -1, 0 or 1; 0 at 0, NaN stays NaN. Its derivative is taken as
    /// 0 everywhere.
    Sign,
    /// `√a`: the builtin `sqrt`, and `a^0.5`.
    Sqrt,
    /// `eᵃ`: the builtin `exp`.
    Exp,
    /// The natural logarithm: the builtin `ln` (the language's `log`, base 10,
    /// is built as `log10(e) * ln(a)`).
    Ln,
    /// Sine, in radians.
    Sin,
    /// Cosine, in radians.
    Cos,
    /// Tangent, in radians.
    Tan,
    /// Arcsine, in `[-pi/2, pi/2]`; defined on `[-1, 1]`.
    Asin,
    /// Arccosine, in `[0, pi]`; defined on `[-1, 1]`.
    Acos,
    /// Arctangent, in `(-pi/2, pi/2)`.
    Atan,
    /// Hyperbolic sine.
    Sinh,
    /// Hyperbolic cosine.
    Cosh,
    /// Hyperbolic tangent.
    Tanh,
    /// `sinh(sqrt(x)) / sqrt(x)`, which is `sin(sqrt(-x)) / sqrt(-x)` for
    /// negative `x`: the entire function `sum x^k / (2k+1)!`. With
    /// [`Unary::Chc`] it writes the curved spaces' maps from normal
    /// coordinates without dividing by the distance (which vanishes at
    /// the centre). Not in the language: the builtins of S3 and H3 use it.
    Shc,
    /// `cosh(sqrt(x))`, `cos(sqrt(-x))` for negative `x`: `sum x^k / (2k)!`.
    Chc,
    /// The derivative of [`Unary::Shc`], `(chc(x) - shc(x)) / 2x`, entire
    /// (1/6 at 0).
    ShcSlope,
    /// The largest integer at most `a`: the builtin `floor` (and `ceil`,
    /// `round` built from it). It jumps at every integer.
    Floor,
    /// `a - floor(a)`, in `[0, 1)`: the builtin `fract` (and `mod`). It
    /// jumps from 1 to 0 at every integer.
    Fract,
    /// `t^2 (3 - 2t)` for `t` clamped to `[0, 1]`: the builtin
    /// `smoothstep(e0, e1, x)` at `t = (x - e0) / (e1 - e0)`. It rises, so
    /// its interval is its values at the ends.
    SmoothStep,
    /// 0 wherever it is evaluated at a point, and over an interval that
    /// holds an integer, every real: the slope of `floor` and `fract`,
    /// whose jumps a point derivative cannot see. Only derivatives hold
    /// it, so an interval search never takes a piece across a jump for a
    /// monotone one.
    IntegerJumps,
    /// The same for a jump at 0: the slope a condition's `if` adds (and
    /// `sign`'s).
    ZeroJumps,
}

/// A two-argument operation of the expression IR, evaluated by
/// [`Binary::apply`] with the [`Number`] method of the same name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Binary {
    /// `a + b`.
    Add,
    /// `a - b`.
    Sub,
    /// `a * b`.
    Mul,
    /// `a / b`; in `f64`, `x / 0` is infinite (no information to the renderer)
    /// and `0 / 0` NaN; an interval divisor holding 0 gives the whole line.
    Div,
    /// `a^b` and the builtin `pow(a, b)`, as `f64::powf`: a negative base gives
    /// NaN unless `b` is a whole number. Constant whole exponents up to 64 in
    /// size are built as products (`Graph::powi`) and `^0.5` as a square root,
    /// when the graph simplifies.
    Pow,
    /// The smaller operand, NaN if either is NaN: `min(a, b, ...)` (nested),
    /// `union` and the upper end of `clamp`.
    Min,
    /// The larger operand, NaN if either is NaN: `max(a, b, ...)` (nested),
    /// `intersection`, `difference` and the lower end of `clamp`.
    Max,
    /// `atan2(a, b)`: the angle of the point `(b, a)`, in `[-pi, pi]`; `a` is
    /// the language's `y`, `b` its `x`.
    Atan2,
    /// The polynomial smooth minimum with blend radius 1:
    /// `b (1 - h) + a h - h (1 - h)` with `h = clamp(1/2 + (b - a) / 2, 0,
    /// 1)`; the language's `smin(a, b, k)` is `k * SmoothMin(a / k, b / k)`.
    /// It rises with both operands (its partial derivatives are `h` and
    /// `1 - h`), so its interval is its values at the ends: tight, where
    /// the blend written out with `clamp` loses to the dependency problem.
    SmoothMin,
    /// `b` where `a > 0`, else 0 (NaN where `a` is NaN): half of the
    /// language's `if`, which is `When(c, then) + Unless(c, else)` for a
    /// condition `c` written as a number that is positive where it holds.
    /// Each half is 0 where its branch is not taken, whatever that branch's
    /// value (an undefined `sqrt` there included).
    When,
    /// `b` where `a <= 0`, else 0 (NaN where `a` is NaN): the other half of
    /// `if`.
    Unless,
}

impl Binary {
    /// Whether `a op b == b op a`, so operands may be put in one order.
    pub fn commutative(self) -> bool {
        matches!(
            self,
            Binary::Add | Binary::Mul | Binary::Min | Binary::Max | Binary::SmoothMin
        )
    }
}

impl Unary {
    /// The operation in any number type: the one definition every
    /// evaluator (tapes, constant folding) uses.
    #[inline(always)]
    pub fn apply<N: Number>(self, a: N) -> N {
        match self {
            Unary::Neg => -a,
            Unary::Square => a.square(),
            Unary::Abs => a.abs(),
            Unary::Sign => a.sign(),
            Unary::Sqrt => a.sqrt(),
            Unary::Exp => a.exp(),
            Unary::Ln => a.ln(),
            Unary::Sin => a.sin(),
            Unary::Cos => a.cos(),
            Unary::Tan => a.tan(),
            Unary::Asin => a.asin(),
            Unary::Acos => a.acos(),
            Unary::Atan => a.atan(),
            Unary::Sinh => a.sinh(),
            Unary::Cosh => a.cosh(),
            Unary::Tanh => a.tanh(),
            Unary::Shc => a.shc(),
            Unary::Chc => a.chc(),
            Unary::ShcSlope => a.shc_slope(),
            Unary::Floor => a.floor(),
            Unary::Fract => a.fract(),
            Unary::SmoothStep => a.smooth_step(),
            Unary::IntegerJumps => a.integer_jumps(),
            Unary::ZeroJumps => a.zero_jumps(),
        }
    }
}

impl Binary {
    /// The operation in any number type: the one definition every
    /// evaluator (tapes, constant folding) uses.
    #[inline(always)]
    pub fn apply<N: Number>(self, a: N, b: N) -> N {
        match self {
            Binary::Add => a + b,
            Binary::Sub => a - b,
            Binary::Mul => a * b,
            Binary::Div => a / b,
            Binary::Pow => a.pow(b),
            Binary::Min => a.min(b),
            Binary::Max => a.max(b),
            Binary::Atan2 => a.atan2(b),
            Binary::SmoothMin => a.smooth_min(b),
            Binary::When => a.when(b),
            Binary::Unless => a.unless(b),
        }
    }
}
