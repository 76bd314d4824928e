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
pub struct LineForm {
    pub alpha: f64,
    pub beta: f64,
    pub err: f64,
    pub slope_err: f64,
}

pub trait Number:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    fn constant(c: f64) -> Self;
    /// `form.alpha + form.beta * t`; interval types also enclose every
    /// value the exact coefficients give. `t` must lie within the reach
    /// the form was made for.
    fn along(t: Self, form: &LineForm) -> Self;
    /// `Some(c)` when this is exactly the constant `c`, with no spread
    /// (and, for duals, no derivative).
    fn constant_value(self) -> Option<f64>;
    fn square(self) -> Self;
    fn abs(self) -> Self;
    /// -1, 0 or 1 (0 at 0).
    fn sign(self) -> Self;
    fn sqrt(self) -> Self;
    fn exp(self) -> Self;
    fn ln(self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn tan(self) -> Self;
    fn asin(self) -> Self;
    fn acos(self) -> Self;
    fn atan(self) -> Self;
    fn sinh(self) -> Self;
    fn cosh(self) -> Self;
    fn tanh(self) -> Self;
    fn pow(self, e: Self) -> Self;
    fn min(self, o: Self) -> Self;
    fn max(self, o: Self) -> Self;
    fn atan2(self, x: Self) -> Self;
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
        f64::sin(self)
    }
    #[inline]
    fn cos(self) -> Self {
        f64::cos(self)
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
    #[inline]
    fn pow(self, e: Self) -> Self {
        f64::powf(self, e)
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
}
