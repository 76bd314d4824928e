//! A forward error bound for a polynomial's `f64` values along a stretch
//! of a line, by one evaluation of its tape.
//!
//! Input: a tape that is a polynomial (sums, products, whole powers,
//! division by constants), evaluated along a line with the parameter a
//! [`Magnitude`] covering the stretch. Output: a [`Magnitude`] whose
//! `error` bounds, at every point of the stretch at once, how far `f` as
//! `f64` computes it (at the rounded point the line's forms give) may be
//! from the exact value of `f` on the exact line. The polynomial route
//! evaluates `f` at a few points of a stretch in `f64` and
//! interpolates (see [`crate::expr::univariate::Interpolation`]); this
//! bound is what keeps that route from missing a root.
//!
//! Each value carries `size`, a bound on its exact magnitude over the
//! stretch, and `error`. For `c = a * b` computed, `|c^ - ab| <= |a^ - a|
//! |b^| + |a| |b^ - b| + u |a^ b^|`, so the bound needs only the operands'
//! sizes and errors (the running error analysis of Wilkinson and Higham,
//! taken over the whole stretch rather than at one point). Operations a
//! polynomial does not use give NaN, so a tape that is not one cannot be
//! given a bound.

use std::ops::{Add, Div, Mul, Neg, Sub};

use super::number::{LineForm, Number};

/// The unit roundoff of `f64` arithmetic rounding to nearest.
pub(super) const UNIT: f64 = f64::EPSILON / 2.0;

/// An absolute error each operation may add where its result underflows.
pub(super) const TINY: f64 = f64::MIN_POSITIVE;

/// A bound on a value's size and on its computed value's error, over a
/// stretch of a line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Magnitude {
    /// At least the exact value's magnitude anywhere on the stretch.
    pub size: f64,
    /// At least how far the computed value may be from the exact one.
    pub error: f64,
    /// The exact range: for a constant of the tape (exact as written)
    /// both its value, for the line's parameter its stretch's ends, NaN
    /// otherwise (kept in two numbers rather than options: a tape's slots
    /// are copied at every step).
    low: f64,
    high: f64,
}

impl Magnitude {
    /// The line's parameter over `start + length s`, `s` in `[0, 1]`, as
    /// computed in floating point (each point off by its rounding).
    pub fn parameter(start: f64, length: f64) -> Magnitude {
        let [low, high, error] = Magnitude::stretch(start, length);
        Magnitude {
            size: low.abs().max(high.abs()) + length.abs() * f64::EPSILON,
            error,
            low,
            high,
        }
    }

    /// The parameter's ends and the error of each computed point, as
    /// [`crate::expr::jit::CompiledMagnitude::eval`] takes them.
    pub fn stretch(start: f64, length: f64) -> [f64; 3] {
        [
            start,
            start + length,
            f64::EPSILON * (start.abs() + length.abs()),
        ]
    }

    fn undefined() -> Magnitude {
        Magnitude {
            size: f64::NAN,
            error: f64::NAN,
            low: f64::NAN,
            high: f64::NAN,
        }
    }

    fn bounds(size: f64, error: f64) -> Magnitude {
        Magnitude {
            size,
            error,
            low: f64::NAN,
            high: f64::NAN,
        }
    }

    /// The most the computed value may be in size.
    fn reach(self) -> f64 {
        self.size + self.error
    }

    /// A sum or a difference: sizes add whatever the signs.
    fn sum(self, o: Self) -> Self {
        Self::bounds(
            self.size + o.size,
            self.error + o.error + UNIT * (self.reach() + o.reach()) + TINY,
        )
    }
}

impl Add for Magnitude {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        self.sum(o)
    }
}

impl Sub for Magnitude {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        self.sum(o)
    }
}

impl Neg for Magnitude {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        self
    }
}

impl Mul for Magnitude {
    type Output = Self;
    #[inline]
    fn mul(self, o: Self) -> Self {
        Self::bounds(
            self.size * o.size,
            self.error * o.reach() + self.size * o.error + UNIT * self.reach() * o.reach() + TINY,
        )
    }
}

impl Div for Magnitude {
    type Output = Self;
    /// By a nonzero constant only: a polynomial divides by nothing else.
    #[inline]
    fn div(self, o: Self) -> Self {
        match o.constant_value() {
            Some(c) if c != 0.0 && c.is_finite() => Self::bounds(
                self.size / c.abs(),
                (self.error + UNIT * self.reach()) / c.abs() + TINY,
            ),
            _ => Self::undefined(),
        }
    }
}

impl Number for Magnitude {
    undefined_beyond_polynomials!();

    #[inline]
    fn constant(c: f64) -> Self {
        Magnitude {
            size: c.abs(),
            error: 0.0,
            low: c,
            high: c,
        }
    }

    /// `alpha + beta t` at a computed parameter within `t.error` of the
    /// exact one: the form's own error, and the exact slope times the
    /// parameter's. Its size over the stretch is the larger of its ends'
    /// (a coordinate far from the line's start may stay small there).
    #[inline]
    fn along(t: Self, form: &LineForm) -> Self {
        let (alpha, beta) = (form.alpha, form.beta);
        let size = if t.low.is_finite() && t.high.is_finite() {
            (alpha + beta * t.low)
                .abs()
                .max((alpha + beta * t.high).abs())
        } else {
            alpha.abs() + beta.abs() * t.size
        };
        Self::bounds(
            size * (1.0 + 2.0 * f64::EPSILON) + form.err,
            form.err + (beta.abs() + form.slope_err) * t.error,
        )
    }

    fn constant_value(self) -> Option<f64> {
        (self.low == self.high).then_some(self.low)
    }

    #[inline]
    fn square(self) -> Self {
        self * self
    }

    /// A whole non-negative constant exponent, as
    /// `pow_f64` computes it: by squarings
    /// within a few units of the last place, or by `powf`.
    fn pow(self, e: Self) -> Self {
        match e.constant_value() {
            Some(0.0) => Self::constant(1.0),
            Some(n) if n > 0.0 && n.fract() == 0.0 && n <= 64.0 => {
                let (reach, whole) = (self.reach(), n as i32);
                let below = reach.powi(whole - 1);
                Self::bounds(
                    self.size.powi(whole) * (1.0 + n * f64::EPSILON),
                    n * below * self.error + (n + 8.0) * f64::EPSILON * below * reach + TINY,
                )
            }
            _ => Self::undefined(),
        }
    }
}
