//! The arithmetic an expression can be evaluated in.
//!
//! The expression IR never names a number type: a [`crate::expr::Tape`] is
//! evaluated in any [`Number`]. `f64` is the per-ray type; intervals (for
//! guaranteed root isolation) and dual numbers plug in here without touching
//! the IR.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A linear function `alpha + beta t` of a path's parameter `t`: what an
/// affine step of a tape (or a coordinate) is along a straight path, for
/// `|t|` up to the reach it was made for. The coefficients are computed
/// in floating point; `err` bounds how far `alpha + beta t`, computed,
/// may be from the exact value there (including the rounding of the
/// points the path is evaluated at), and `slope_err` how far `beta` may be
/// from the exact slope, so that interval types can enclose both.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[repr(C)]
pub struct LineForm {
    /// The value at `t = 0`, the line's start.
    pub alpha: f64,
    /// The change per unit of `t`.
    pub beta: f64,
    /// A bound on how far the computed `alpha + beta t` may be from the exact
    /// value, for `|t|` within the form's reach; non-negative.
    pub err: f64,
    /// A bound on how far `beta` may be from the exact slope; non-negative.
    pub slope_err: f64,
}

/// A number type a [`crate::expr::Tape`] can be evaluated in: `f64` (point
/// values), [`crate::expr::Interval`] (enclosures, rounded outward),
/// [`crate::expr::Dual`] (a value with its derivative along one parameter)
/// and their lane forms. Each mathematical method implements the
/// [`crate::expr::Unary`] or [`crate::expr::Binary`] operation of the same
/// name; where a function is undefined, `f64` gives NaN (or an infinity) and
/// intervals give the empty interval or clip to the function's domain.
pub trait Number:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// The constant `c`: a point interval, or a dual with derivative 0.
    fn constant(c: f64) -> Self;
    /// `form.alpha + form.beta * t`; interval types also enclose every
    /// value the exact coefficients give. `t` must lie within the reach
    /// the form was made for.
    fn along(t: Self, form: &LineForm) -> Self;
    /// `Some(c)` when this is exactly the constant `c`, with no spread
    /// (and, for duals, no derivative).
    fn constant_value(self) -> Option<f64>;
    /// `x²`. Intervals get the tight range: from 0 for a range through 0,
    /// where `x * x` would give a negative lower bound. Duals get `2 x x'`.
    fn square(self) -> Self;
    /// `|x|`. A dual's derivative is `sign(x) x'`, so 0 at `x = 0`.
    fn abs(self) -> Self;
    /// -1, 0 or 1 (0 at 0).
    fn sign(self) -> Self;
    /// `√x`: NaN for `x < 0` in `f64`; intervals drop the negative part of
    /// the range (empty if nothing is left).
    fn sqrt(self) -> Self;
    /// `eˣ`.
    fn exp(self) -> Self;
    /// The natural logarithm: `ln 0 = -inf`, NaN for `x < 0` in `f64`;
    /// intervals drop the negative part of the range.
    fn ln(self) -> Self;
    /// Sine of an angle in radians.
    fn sin(self) -> Self;
    /// Cosine of an angle in radians.
    fn cos(self) -> Self;
    /// `(sin x, cos x)`, bit for bit what [`Number::sin`] and
    /// [`Number::cos`] give: where a formula has both of one argument (the
    /// tape pairs them), types whose two share their work override it.
    #[inline]
    fn sin_and_cos(self) -> (Self, Self) {
        (self.sin(), self.cos())
    }
    /// Tangent of an angle in radians; an interval that holds a pole (or is at
    /// least pi wide) gives the whole real line.
    fn tan(self) -> Self;
    /// Arcsine, in `[-pi/2, pi/2]`: NaN outside `[-1, 1]` in `f64`; intervals
    /// clip to `[-1, 1]`.
    fn asin(self) -> Self;
    /// Arccosine, in `[0, pi]`: NaN outside `[-1, 1]` in `f64`; intervals clip
    /// to `[-1, 1]`.
    fn acos(self) -> Self;
    /// Arctangent, in `(-pi/2, pi/2)`.
    fn atan(self) -> Self;
    /// Hyperbolic sine.
    fn sinh(self) -> Self;
    /// Hyperbolic cosine (at least 1).
    fn cosh(self) -> Self;
    /// Hyperbolic tangent, in `[-1, 1]`.
    fn tanh(self) -> Self;
    /// `sinh(sqrt(x)) / sqrt(x)`, `sin(sqrt(-x)) / sqrt(-x)` below zero
    /// (see [`crate::expr::Unary::Shc`]).
    fn shc(self) -> Self;
    /// `cosh(sqrt(x))`, `cos(sqrt(-x))` below zero.
    fn chc(self) -> Self;
    /// The derivative of [`Number::shc`].
    fn shc_slope(self) -> Self;
    /// `self` to the power `e`, as `f64::powf`: a negative base gives NaN
    /// unless `e` is a whole number (then `(-2)^3 = -8`), and `x^0 = 1` even
    /// for NaN. Intervals follow negative bases only for a constant whole
    /// exponent (by its parity; a negative one as `1 / x^n`); with any other
    /// exponent they drop the negative part of the base. Duals use
    /// `e a^(e-1) a'` for a constant exponent (defined for negative bases),
    /// else `a^b (b' ln a + b a'/a)`.
    fn pow(self, e: Self) -> Self;
    /// The smaller of the two. Unlike `f64::min`, a NaN operand gives NaN, so
    /// an undefined branch is seen; an empty interval operand gives empty.
    /// Duals take the chosen side's slope, the mean of both where they are
    /// equal, and over intervals where the sides cross, the hull of both.
    fn min(self, o: Self) -> Self;
    /// The larger of the two, with the conventions of [`Number::min`].
    fn max(self, o: Self) -> Self;
    /// `atan2(self, x)`: the angle of the point `(x, self)`, in `[-pi, pi]`,
    /// as the language's `atan2(y, x)` with `self` as `y`. Intervals are tight
    /// in each open half-plane `x > 0`, `y > 0`, `y < 0`; a box across the
    /// branch cut (the negative x axis) gives `[-pi, pi]`, which is its
    /// hull.
    fn atan2(self, x: Self) -> Self;
    /// For a box across atan2's branch cut (`self`, as `y`, holds 0, and
    /// `x` reaches below 0), its values on each side, `y >= +0` and `y <=
    /// -0`: an evaluator goes on with each and takes the hull of what
    /// follows, which is tight where the formula is continuous across the
    /// cut (`cos(1.5 atan2(y, x))`), where `[-pi, pi]` is not. `None` for
    /// points and for types that keep the whole range (duals, whose
    /// slope must see the jump).
    fn atan2_sides(self, _x: Self) -> Option<(Self, Self)> {
        None
    }
    /// The hull of the two, for types with ranges (see
    /// [`Number::atan2_sides`]); others never need it.
    fn hull_with(self, _other: Self) -> Self {
        self
    }
    /// The polynomial smooth minimum of blend radius 1 (see
    /// [`crate::expr::Binary::SmoothMin`]): at most `min(self, o)`, at
    /// least that minus 1/4, equal to it where the operands differ by 1 or
    /// more. NaN if either is NaN. Intervals take its values at the ends
    /// (it rises with both operands); duals use `h a' + (1 - h) b'`.
    fn smooth_min(self, o: Self) -> Self;
    /// The largest integer at most `self`. Intervals: `[floor lo, floor
    /// hi]`. Duals: slope 0, except over an interval holding an integer
    /// (see [`Number::integer_jumps`]).
    fn floor(self) -> Self;
    /// `self - floor(self)`, in `[0, 1)`. Intervals within one integer
    /// step are exact; across a step, `[0, 1]`.
    fn fract(self) -> Self;
    /// `t^2 (3 - 2t)` with `t` clamped to `[0, 1]`; rising, so intervals
    /// take the ends.
    fn smooth_step(self) -> Self;
    /// 0 (NaN for NaN); an interval holding an integer gives every real,
    /// else `[0, 0]`: the slope of a jump at the integers.
    fn integer_jumps(self) -> Self;
    /// 0 (NaN for NaN); an interval holding 0 gives every real, else
    /// `[0, 0]`.
    fn zero_jumps(self) -> Self;
    /// `b` where `self > 0`, else 0; NaN where `self` is NaN. Intervals
    /// across 0 give the hull of `b` and 0.
    fn when(self, b: Self) -> Self;
    /// `b` where `self <= 0`, else 0; NaN where `self` is NaN.
    fn unless(self, b: Self) -> Self;
    /// `a` where `self > 0`, else `b`; NaN where `self` is NaN: the sum
    /// `self.when(a) + self.unless(b)`, which tapes compute in one step.
    /// Intervals across 0 give the hull of `a` and `b`.
    fn select(self, a: Self, b: Self) -> Self;
    /// Gradient noise at `p`, or its partial derivative of order `partial`
    /// per axis ([`crate::expr::Noise`]); NaN at a non-finite point.
    /// Intervals enclose it over the box `p`.
    fn noise(p: [Self; 3], partial: [u8; 3]) -> Self;
}

/// [`Number::fract`] in `f64`: in `[0, 1)` (a value that rounds up to 1
/// is taken as 0), NaN for NaN and the infinities.
#[inline]
pub fn fract_f64(x: f64) -> f64 {
    let f = x - x.floor();
    if f >= 1.0 {
        0.0
    } else {
        f
    }
}

/// The largest `|2 e|` [`pow_f64`] takes by products and a square root:
/// `x^8` by three squarings is within 4 ulps, and with the root and a
/// reciprocal within 6, inside the margin intervals add to `powf`'s ends.
const FAST_POWER: u32 = 16;

/// [`Number::pow`] in `f64`: `f64::powf`, but for whole and half-whole
/// exponents up to 8 in size, by squarings and a square root (a few
/// times faster; superquadrics `|x|^2.5` spend most of a render in
/// `powf` otherwise), within 6 ulps of the exact power. Zero and
/// non-finite bases go to `powf`, which alone gets their signs right.
#[inline]
pub fn pow_f64(x: f64, e: f64) -> f64 {
    let twice = 2.0 * e;
    // Casts, not `fract`: without SSE4.1 that is a call into libm.
    let n = twice as i32;
    if n as f64 != twice || n.unsigned_abs() > FAST_POWER || x == 0.0 || !x.is_finite() {
        return x.powf(e);
    }
    let m = n.unsigned_abs();
    let mut p = if m & 1 == 1 { x.sqrt() } else { 1.0 };
    let (mut base, mut k) = (x, m >> 1);
    while k > 0 {
        if k & 1 == 1 {
            p *= base;
        }
        base *= base;
        k >>= 1;
    }
    if e < 0.0 {
        1.0 / p
    } else {
        p
    }
}

/// [`Number::smooth_step`] in `f64`.
#[inline]
pub fn smooth_step_f64(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The blend weight of [`Number::smooth_min`] at `a`, `b`:
/// `clamp(1/2 + (b - a) / 2, 0, 1)`, NaN for NaN.
#[inline]
pub fn smooth_min_weight(a: f64, b: f64) -> f64 {
    let h = 0.5 + 0.5 * (b - a);
    if h.is_nan() {
        h
    } else {
        h.clamp(0.0, 1.0)
    }
}

/// [`Number::smooth_min`] in `f64`.
#[inline]
pub fn smooth_min_f64(a: f64, b: f64) -> f64 {
    // Two equal infinities, whose difference is NaN: the blend is the
    // same infinity (an interval's unbounded end, in S3 beyond the cut
    // locus, once turned a smooth union's bound into "no surface").
    if a == b && a.is_infinite() {
        return a;
    }
    let h = smooth_min_weight(a, b);
    if h == 0.0 {
        // Also for an infinite operand, where the blend would give NaN.
        b
    } else if h == 1.0 {
        a
    } else {
        b * (1.0 - h) + a * h - h * (1.0 - h)
    }
}

impl Number for f64 {
    #[inline]
    fn constant(c: f64) -> Self {
        c
    }
    #[inline]
    fn along(t: Self, form: &LineForm) -> Self {
        form.alpha + form.beta * t
    }
    #[inline]
    fn constant_value(self) -> Option<f64> {
        Some(self)
    }
    #[inline]
    fn square(self) -> Self {
        self * self
    }
    #[inline]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline]
    fn sign(self) -> Self {
        if self > 0.0 {
            1.0
        } else if self < 0.0 {
            -1.0
        } else {
            // 0 stays 0 and NaN stays NaN.
            self
        }
    }
    #[inline]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline]
    fn exp(self) -> Self {
        f64::exp(self)
    }
    #[inline]
    fn ln(self) -> Self {
        f64::ln(self)
    }
    #[inline]
    fn sin(self) -> Self {
        super::trig::sin(self)
    }
    #[inline]
    fn cos(self) -> Self {
        super::trig::cos(self)
    }
    #[inline]
    fn sin_and_cos(self) -> (Self, Self) {
        super::trig::sin_and_cos(self)
    }
    #[inline]
    fn tan(self) -> Self {
        f64::tan(self)
    }
    #[inline]
    fn asin(self) -> Self {
        f64::asin(self)
    }
    #[inline]
    fn acos(self) -> Self {
        f64::acos(self)
    }
    #[inline]
    fn atan(self) -> Self {
        f64::atan(self)
    }
    #[inline]
    fn sinh(self) -> Self {
        f64::sinh(self)
    }
    #[inline]
    fn cosh(self) -> Self {
        f64::cosh(self)
    }
    #[inline]
    fn tanh(self) -> Self {
        f64::tanh(self)
    }
    fn shc(self) -> Self {
        shc(self)
    }
    fn chc(self) -> Self {
        chc(self)
    }
    fn shc_slope(self) -> Self {
        shc_slope(self)
    }
    #[inline]
    fn pow(self, e: Self) -> Self {
        pow_f64(self, e)
    }
    #[inline]
    fn min(self, o: Self) -> Self {
        // NaN-propagating, so a broken branch is seen, not hidden.
        if self.is_nan() || o.is_nan() {
            f64::NAN
        } else {
            f64::min(self, o)
        }
    }
    #[inline]
    fn max(self, o: Self) -> Self {
        if self.is_nan() || o.is_nan() {
            f64::NAN
        } else {
            f64::max(self, o)
        }
    }
    #[inline]
    fn atan2(self, x: Self) -> Self {
        f64::atan2(self, x)
    }
    #[inline]
    fn smooth_min(self, o: Self) -> Self {
        smooth_min_f64(self, o)
    }
    #[inline]
    fn floor(self) -> Self {
        f64::floor(self)
    }
    #[inline]
    fn fract(self) -> Self {
        fract_f64(self)
    }
    #[inline]
    fn smooth_step(self) -> Self {
        smooth_step_f64(self)
    }
    #[inline]
    fn integer_jumps(self) -> Self {
        self * 0.0
    }
    #[inline]
    fn zero_jumps(self) -> Self {
        self * 0.0
    }
    #[inline]
    fn when(self, b: Self) -> Self {
        if self > 0.0 {
            b
        } else if self.is_nan() {
            f64::NAN
        } else {
            0.0
        }
    }
    #[inline]
    fn unless(self, b: Self) -> Self {
        if self > 0.0 {
            0.0
        } else if self.is_nan() {
            f64::NAN
        } else {
            b
        }
    }
    #[inline]
    fn select(self, a: Self, b: Self) -> Self {
        if self > 0.0 {
            a
        } else if self.is_nan() {
            f64::NAN
        } else {
            b
        }
    }
    fn noise(p: [Self; 3], partial: [u8; 3]) -> Self {
        super::noise::value(p, partial)
    }
}

/// `sinh(sqrt(x)) / sqrt(x)` (`sin(sqrt(-x)) / sqrt(-x)` below zero), by
/// its series near zero.
pub fn shc(x: f64) -> f64 {
    if x > 1e-3 {
        let r = x.sqrt();
        r.sinh() / r
    } else if x < -1e-3 {
        let r = (-x).sqrt();
        r.sin() / r
    } else {
        1.0 + x / 6.0 * (1.0 + x / 20.0 * (1.0 + x / 42.0))
    }
}

/// `cosh(sqrt(x))` (`cos(sqrt(-x))` below zero).
pub fn chc(x: f64) -> f64 {
    if x >= 0.0 {
        x.sqrt().cosh()
    } else {
        (-x).sqrt().cos()
    }
}

/// The derivative of [`shc`]: `(chc(x) - shc(x)) / 2x`, by its series
/// `sum (k+1) x^k / (2k+3)!` near zero.
pub fn shc_slope(x: f64) -> f64 {
    if x.abs() > 1e-2 {
        (chc(x) - shc(x)) / (2.0 * x)
    } else {
        1.0 / 6.0 + x * (2.0 / 120.0 + x * (3.0 / 5040.0 + x * 4.0 / 362880.0))
    }
}

/// The largest power of two at most `x` (finite and positive), exactly.
pub fn power_of_two_below(x: f64) -> f64 {
    let exponent_bits = x.to_bits() & (0x7ff << 52);
    if exponent_bits == 0 {
        // Subnormal: its leading bit, by a shift into the normal range.
        power_of_two_below(x * 2f64.powi(64)) * 2f64.powi(-64)
    } else {
        f64::from_bits(exponent_bits)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The distance between two finite doubles of one sign, in ulps.
    fn ulps(a: f64, b: f64) -> u64 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
    }

    #[test]
    fn fast_powers_stay_within_six_ulps_of_powf() {
        let mut next = crate::testing::uniform(0x9e37_79b9_7f4a_7c15u64);
        let mut worst = 0;
        for half_steps in -16..=16 {
            let e = half_steps as f64 / 2.0;
            for _ in 0..2000 {
                // Bases from 1e-6 to 1e6.
                let x = 10f64.powf(12.0 * next() - 6.0);
                let (fast, exact) = (pow_f64(x, e), x.powf(e));
                worst = worst.max(ulps(fast, exact));
                assert!(ulps(fast, exact) <= 6, "{x}^{e}: {fast} against {exact}");
            }
        }
        // The fast route was taken: whole powers by products differ from
        // powf somewhere.
        assert!(worst > 0);
    }

    #[test]
    fn fast_powers_keep_powf_at_the_edges() {
        let bases = [
            0.0,
            -0.0,
            -2.0,
            -0.5,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for half_steps in -17..=17 {
            let e = half_steps as f64 / 2.0;
            for x in bases {
                let (fast, exact) = (pow_f64(x, e), x.powf(e));
                let same = fast.to_bits() == exact.to_bits() || (fast.is_nan() && exact.is_nan());
                // A negative base to a whole power goes by products: the
                // value, not the bits, must agree.
                let close = x.is_finite()
                    && x != 0.0
                    && exact.is_finite()
                    && ulps(fast.abs(), exact.abs()) <= 6
                    && fast.signum() == exact.signum();
                assert!(same || close, "{x}^{e}: {fast} against {exact}");
            }
        }
    }
}
