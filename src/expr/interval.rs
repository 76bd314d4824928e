//! Interval arithmetic, rounded outward: evaluating a tape over intervals
//! gives a range that contains every value the expression takes for inputs
//! in the input intervals.
//!
//! An empty interval (a function undefined everywhere on the box, like
//! `sqrt` of a negative range) is represented by NaN bounds; it contains
//! nothing, zero included.

use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::ops::{Add, Div, Mul, Neg, Sub};

use super::number::{pow_f64, LineForm, Number};
use super::trig;

/// A closed range `[lo, hi]` of reals that encloses a quantity: every
/// operation ([`Number`]) encloses its exact result, rounding bounds
/// outward where they are computed. Either bound may be infinite; NaN
/// bounds mean empty.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// The lower bound (`-inf` allowed; NaN for the empty interval).
    pub lo: f64,
    /// The upper bound, `>= lo` (`+inf` allowed; NaN for the empty interval).
    pub hi: f64,
}

impl Interval {
    /// Every real: what an operation gives when it knows nothing (a division
    /// by a range through 0, `tan` over a pole).
    pub const ENTIRE: Interval = Interval {
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
    };
    /// The empty interval (NaN bounds): the function is undefined everywhere
    /// on the input box; it contains no number.
    pub const EMPTY: Interval = Interval {
        lo: f64::NAN,
        hi: f64::NAN,
    };

    /// `[lo, hi]`, with the bounds swapped if given in the wrong order; empty
    /// if either is NaN. Not widened: the bounds are taken as exact.
    pub fn new(lo: f64, hi: f64) -> Interval {
        if lo.is_nan() || hi.is_nan() {
            return Interval::EMPTY;
        }
        Interval {
            lo: lo.min(hi),
            hi: lo.max(hi),
        }
    }

    /// `[lo, hi]` (ordered, not NaN) widened outward by an ulp or more:
    /// holds values computed with one rounding error.
    #[inline]
    pub fn hull_of(lo: f64, hi: f64) -> Interval {
        Interval::outward(lo, hi)
    }

    /// The single number `x`, exactly (not widened); empty for NaN.
    pub fn point(x: f64) -> Interval {
        Interval::new(x, x)
    }

    /// Whether the interval is empty (a NaN bound).
    pub fn is_empty(self) -> bool {
        // NaN in either bound (never ordered).
        self.lo.is_nan() || self.hi.is_nan()
    }

    /// Whether `lo <= x <= hi`; never for the empty interval.
    pub fn contains(self, x: f64) -> bool {
        self.lo <= x && x <= self.hi
    }

    /// `hi - lo`: infinite for an unbounded interval, NaN for the empty one.
    pub fn width(self) -> f64 {
        self.hi - self.lo
    }

    /// One ulp outward on each side: enough for the correctly rounded
    /// arithmetic operations and for libm's near-correct functions.
    fn widen(self) -> Interval {
        if self.is_empty() {
            return self;
        }
        let o = Interval::outward(self.lo, self.hi);
        // `outward` turns an upper bound of -inf (or a lower one of +inf)
        // into NaN; those stay as they are.
        Interval {
            lo: if self.lo == f64::INFINITY {
                self.lo
            } else {
                o.lo
            },
            hi: if self.hi == f64::NEG_INFINITY {
                self.hi
            } else {
                o.hi
            },
        }
    }

    /// For transcendental functions, whose libm error may exceed an ulp.
    fn widen_more(self) -> Interval {
        let w = self.widen().widen();
        // An infinite bound stays put (inf - inf would read as empty).
        let out = |x: f64| if x.is_finite() { x.abs() * 1e-15 } else { 0.0 };
        Interval {
            lo: w.lo - out(w.lo),
            hi: w.hi + out(w.hi),
        }
    }

    fn monotone_up(self, f: impl Fn(f64) -> f64) -> Interval {
        if self.is_empty() {
            return self;
        }
        Interval::new(f(self.lo), f(self.hi)).widen_more()
    }

    fn clamp_domain(self, lo: f64, hi: f64) -> Interval {
        if self.is_empty() || self.hi < lo || self.lo > hi {
            return Interval::EMPTY;
        }
        Interval::new(self.lo.max(lo), self.hi.min(hi))
    }

    /// The smallest interval holding both.
    pub fn hull(self, o: Interval) -> Interval {
        if self.is_empty() {
            return o;
        }
        if o.is_empty() {
            return self;
        }
        Interval::new(self.lo.min(o.lo), self.hi.max(o.hi))
    }

    /// Whether the interval is no wider than the rounding of one value
    /// (a few ulps of its size): an exact integer, say `floor(x) / 3 * 3`,
    /// computed outward. A jump slope is not claimed for such a range: a
    /// quantity that varies by so little along a piece crosses no jump
    /// the search could resolve, and claiming one would make every piece
    /// on which `mod(floor(x), 2)` is constant look non-monotone.
    fn rounding_wide(self) -> bool {
        let size = self.lo.abs().max(self.hi.abs());
        let ulp = (size.next_up() - size).max(f64::from_bits(1));
        self.width() <= 8.0 * ulp
    }

    /// Whether the interval contains `base + k * period` for some integer k.
    fn contains_periodic(self, base: f64, period: f64) -> bool {
        let k = ((self.lo - base) / period).ceil();
        base + k * period <= self.hi
    }

    /// sin(x + quadrants pi/2) over the interval: cos is sin a quadrant on.
    pub(crate) fn sin_cos(self, quadrants: u64) -> Interval {
        if self.is_empty() {
            return self;
        }
        if self.width() >= TAU || !self.width().is_finite() {
            return Interval::new(-1.0, 1.0);
        }
        if !(self.lo.abs() <= trig::REDUCIBLE && self.hi.abs() <= trig::REDUCIBLE) {
            return self.sin_cos_of_large(quadrants as f64 * FRAC_PI_2);
        }
        let (lo, hi) = trig::sin_over(self.lo, self.hi, quadrants);
        Interval { lo, hi }
    }

    /// sin(x + phase) past the reducible range, through libm.
    #[cold]
    fn sin_cos_of_large(self, phase: f64) -> Interval {
        let f = |x: f64| (x + phase).sin();
        let mut r = Interval::new(f(self.lo), f(self.hi));
        if self.contains_periodic(FRAC_PI_2 - phase, TAU) {
            r.hi = 1.0;
        }
        if self.contains_periodic(-FRAC_PI_2 - phase, TAU) {
            r.lo = -1.0;
        }
        // `x + phase` rounds by up to an ulp of the sum, and sine moves at
        // most as much as its argument: at large arguments that is far more
        // than an ulp of the result (cos(1e8) was off by 1e-8).
        let slack = 2.0 * f64::EPSILON * (self.lo.abs().max(self.hi.abs()) + phase.abs());
        let r = Interval::new(r.lo - slack, r.hi + slack).widen_more();
        Interval::new(r.lo.max(-1.0), r.hi.min(1.0))
    }
}

impl Interval {
    /// Bounds already ordered (or NaN), widened one ulp outward: the hot
    /// path of the four operations, with no reordering and one check.
    ///
    /// Moving a bound by `|x| 2^-52` plus the smallest subnormal is at
    /// least one ulp for every finite `x`, in branch-free operations where
    /// `next_up` takes several branches. An infinite bound stays as it is:
    /// `[inf, inf]` is a value that overflowed, and `min` of it and
    /// another is the other (it once became NaN, read as empty, and a
    /// union lost every member beside `x^1000 - 1`). A NaN bound stays
    /// NaN (`f64::min` and `max` take the number, so `inf - inf` is NaN
    /// only through the subtraction, and a NaN bound through neither).
    #[inline]
    fn outward(lo: f64, hi: f64) -> Interval {
        const ULP: f64 = f64::EPSILON;
        const TINY: f64 = f64::from_bits(1);
        Interval {
            lo: (lo - (lo.abs() * ULP + TINY)).min(lo),
            hi: (hi + (hi.abs() * ULP + TINY)).max(hi),
        }
    }
}

impl Add for Interval {
    type Output = Interval;
    #[inline]
    fn add(self, o: Interval) -> Interval {
        Interval::outward(self.lo + o.lo, self.hi + o.hi)
    }
}

impl Sub for Interval {
    type Output = Interval;
    #[inline]
    fn sub(self, o: Interval) -> Interval {
        Interval::outward(self.lo - o.hi, self.hi - o.lo)
    }
}

impl Neg for Interval {
    type Output = Interval;
    #[inline]
    fn neg(self) -> Interval {
        Interval {
            lo: -self.hi,
            hi: -self.lo,
        }
    }
}

/// A product where 0 * inf counts as 0: the bounds are limits, and a zero
/// factor bound means the factor's values approach 0, not that inf occurs.
fn bound_mul(a: f64, b: f64) -> f64 {
    if a == 0.0 || b == 0.0 {
        0.0
    } else {
        a * b
    }
}

impl Mul for Interval {
    type Output = Interval;
    #[inline]
    fn mul(self, o: Interval) -> Interval {
        let (p, q) = (self.lo * o.lo, self.lo * o.hi);
        let (r, t) = (self.hi * o.lo, self.hi * o.hi);
        // NaN (an empty factor or 0 * inf) or inf - inf: the careful path.
        if (p + q + r + t).is_nan() {
            return mul_slow(self, o);
        }
        let lo = min2(min2(p, q), min2(r, t));
        let hi = max2(max2(p, q), max2(r, t));
        Interval::outward(lo, hi)
    }
}

/// The bounds of `alpha + beta t` for `t` in `[lo, hi]` (NaN bounds stay
/// NaN), moved outward by the form's error bound, which covers the
/// rounding here too.
#[inline(always)]
pub(crate) fn along_bounds(lo: f64, hi: f64, form: &LineForm) -> (f64, f64) {
    let (a, b) = (form.alpha + form.beta * lo, form.alpha + form.beta * hi);
    if form.beta >= 0.0 {
        (a - form.err, b + form.err)
    } else {
        (b - form.err, a + form.err)
    }
}

/// Minimum and maximum of numbers known not to be NaN (one instruction
/// each, where `f64::min` must also handle NaN).
#[inline]
fn min2(a: f64, b: f64) -> f64 {
    if a < b {
        a
    } else {
        b
    }
}

#[inline]
fn max2(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// Products with an infinite or empty factor.
#[cold]
fn mul_slow(a: Interval, o: Interval) -> Interval {
    if a.is_empty() || o.is_empty() {
        return Interval::EMPTY;
    }
    let p = [
        bound_mul(a.lo, o.lo),
        bound_mul(a.lo, o.hi),
        bound_mul(a.hi, o.lo),
        bound_mul(a.hi, o.hi),
    ];
    let lo = p.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Interval::new(lo, hi).widen()
}

impl Div for Interval {
    type Output = Interval;
    fn div(self, o: Interval) -> Interval {
        if self.is_empty() || o.is_empty() {
            return Interval::EMPTY;
        }
        if o.contains(0.0) {
            // By exactly zero: undefined, as in IEEE 1788 (f64 gives an
            // infinity, by the zero's sign). Lints rely on it: `(x - 1) /
            // 0` is undefined everywhere, and no search is spent on it.
            if o.lo == 0.0 && o.hi == 0.0 {
                return Interval::EMPTY;
            }
            return Interval::ENTIRE;
        }
        if o.lo > 0.0 {
            let (lo, hi) = quotient_by_positive(self.lo, self.hi, o.lo, o.hi);
            Interval::outward(lo, hi)
        } else {
            let (lo, hi) = quotient_by_positive(-self.hi, -self.lo, -o.hi, -o.lo);
            Interval::outward(lo, hi)
        }
    }
}

/// The bounds of `[a_lo, a_hi] / [b_lo, b_hi]` for `b_lo > 0`, each one
/// division rounded to nearest (the caller moves them outward): the
/// smallest quotient divides the lower bound by the largest divisor if it
/// is not negative and by the smallest if it is; the largest likewise.
/// Shared with the lanes, which compute exactly what this does.
#[inline(always)]
pub(crate) fn quotient_by_positive(a_lo: f64, a_hi: f64, b_lo: f64, b_hi: f64) -> (f64, f64) {
    let lo = a_lo / if a_lo >= 0.0 { b_hi } else { b_lo };
    let hi = a_hi / if a_hi >= 0.0 { b_lo } else { b_hi };
    (lo, hi)
}

impl Number for Interval {
    #[inline]
    fn constant(c: f64) -> Self {
        Interval::point(c)
    }
    #[inline]
    fn along(t: Self, form: &LineForm) -> Self {
        let (lo, hi) = along_bounds(t.lo, t.hi, form);
        Interval { lo, hi }
    }
    #[inline]
    fn constant_value(self) -> Option<f64> {
        (self.lo == self.hi).then_some(self.lo)
    }
    #[inline]
    fn square(self) -> Self {
        if self.is_empty() {
            return self;
        }
        let (a, b) = (self.lo * self.lo, self.hi * self.hi);
        if self.contains(0.0) {
            Interval::new(0.0, a.max(b).next_up())
        } else {
            let r = Interval::new(a.min(b), a.max(b)).widen();
            Interval::new(r.lo.max(0.0), r.hi)
        }
    }
    fn abs(self) -> Self {
        if self.is_empty() {
            return self;
        }
        if self.contains(0.0) {
            Interval::new(0.0, self.hi.max(-self.lo))
        } else if self.hi < 0.0 {
            -self
        } else {
            self
        }
    }
    fn sign(self) -> Self {
        if self.is_empty() {
            return self;
        }
        Interval::new(f64::sign(self.lo), f64::sign(self.hi))
    }
    fn sqrt(self) -> Self {
        let d = self.clamp_domain(0.0, f64::INFINITY);
        if d.is_empty() {
            return d;
        }
        let r = Interval::new(d.lo.sqrt(), d.hi.sqrt()).widen();
        Interval::new(r.lo.max(0.0), r.hi)
    }
    fn exp(self) -> Self {
        let r = self.monotone_up(f64::exp);
        Interval::new(r.lo.max(0.0), r.hi)
    }
    fn ln(self) -> Self {
        self.clamp_domain(0.0, f64::INFINITY).monotone_up(f64::ln)
    }
    fn sin(self) -> Self {
        self.sin_cos(0)
    }
    fn cos(self) -> Self {
        self.sin_cos(1)
    }
    fn sin_and_cos(self) -> (Self, Self) {
        let reducible = self.lo.abs() <= trig::REDUCIBLE && self.hi.abs() <= trig::REDUCIBLE;
        if self.is_empty() || self.width() >= TAU || !self.width().is_finite() || !reducible {
            return (self.sin_cos(0), self.sin_cos(1));
        }
        let ((slo, shi), (clo, chi)) = trig::sin_cos_over(self.lo, self.hi);
        (Interval { lo: slo, hi: shi }, Interval { lo: clo, hi: chi })
    }
    fn tan(self) -> Self {
        if self.is_empty() {
            return self;
        }
        if self.width() >= PI || self.contains_periodic(FRAC_PI_2, PI) {
            return Interval::ENTIRE;
        }
        self.monotone_up(f64::tan)
    }
    fn asin(self) -> Self {
        self.clamp_domain(-1.0, 1.0).monotone_up(f64::asin)
    }
    fn acos(self) -> Self {
        let d = self.clamp_domain(-1.0, 1.0);
        if d.is_empty() {
            return d;
        }
        Interval::new(d.hi.acos(), d.lo.acos()).widen_more()
    }
    fn atan(self) -> Self {
        self.monotone_up(f64::atan)
    }
    fn sinh(self) -> Self {
        self.monotone_up(f64::sinh)
    }
    fn cosh(self) -> Self {
        if self.is_empty() {
            return self;
        }
        let a = self.lo.cosh();
        let b = self.hi.cosh();
        let lo = if self.contains(0.0) { 1.0 } else { a.min(b) };
        let r = Interval::new(lo, a.max(b)).widen_more();
        Interval::new(r.lo.max(1.0), r.hi)
    }
    fn tanh(self) -> Self {
        let r = self.monotone_up(f64::tanh);
        Interval::new(r.lo.max(-1.0), r.hi.min(1.0))
    }
    fn shc(self) -> Self {
        // Rising up to sin's first turn below zero, at sqrt(-x) = 4.4934,
        // where it is -0.21723; beyond it stays within [-0.2173, 1].
        if self.is_empty() || self.lo >= -20.19 {
            return self.monotone_up(super::number::shc);
        }
        let top = if self.hi > 0.0 {
            Interval::point(self.hi).monotone_up(super::number::shc).hi
        } else {
            1.0
        };
        Interval::new(-0.2173, top.max(1.0))
    }
    fn chc(self) -> Self {
        // Rising from cos(pi) = -1 at x = -pi^2; within [-1, 1] below.
        if self.is_empty() || self.lo >= -std::f64::consts::PI * std::f64::consts::PI {
            let r = self.monotone_up(super::number::chc);
            return Interval::new(r.lo.max(-1.0), r.hi);
        }
        let top = Interval::point(self.hi.max(0.0))
            .monotone_up(super::number::chc)
            .hi;
        Interval::new(-1.0, top.max(1.0))
    }
    fn shc_slope(self) -> Self {
        // Rising for x >= 0 (its series has positive terms); below zero
        // it lies within [-1/6, 1/6].
        if self.is_empty() || self.lo >= 0.0 {
            return self.monotone_up(super::number::shc_slope);
        }
        let top = Interval::point(self.hi.max(0.0))
            .monotone_up(super::number::shc_slope)
            .hi;
        Interval::new(-0.17, top.max(0.17))
    }
    fn pow(self, e: Self) -> Self {
        if self.is_empty() || e.is_empty() {
            return Interval::EMPTY;
        }
        // Small whole powers by `powi`, whose error (a few ulps up to
        // x^16) the widening covers; past that it grows with the exponent
        // (0.99757557^1000 by squarings is about 130 ulps off), and
        // `powf`, within an ulp, takes over below.
        if e.lo == e.hi && e.lo.abs() <= POWI_LARGEST && (e.lo as i64) as f64 == e.lo {
            let n = e.lo as i64;
            if n == 0 {
                return Interval::point(1.0);
            }
            let base = if n < 0 {
                Interval::point(1.0) / self
            } else {
                self
            };
            let n = n.unsigned_abs();
            let f = |x: f64| x.powi(n as i32);
            let r = if n % 2 == 1 {
                Interval::new(f(base.lo), f(base.hi))
            } else if base.contains(0.0) {
                Interval::new(0.0, f(base.lo).max(f(base.hi)))
            } else {
                Interval::new(f(base.lo), f(base.hi))
            };
            return r.widen_more();
        }
        // A larger whole exponent: `powf` takes a negative
        // base to it as a whole power, with its parity's sign, and so the
        // value does (`x^1000000000` once lost its half where x < 0).
        if e.lo == e.hi && e.lo.is_finite() && e.lo.fract() == 0.0 {
            let n = e.lo;
            let odd = (0.5 * n).fract() != 0.0;
            let f = |x: f64| x.powf(n);
            let r = if !self.contains(0.0) || (odd && n > 0.0) {
                Interval::new(f(self.lo), f(self.hi))
            } else if n > 0.0 {
                Interval::new(0.0, f(self.lo).max(f(self.hi)))
            } else if odd {
                // Through a pole whose sides go to -inf and +inf.
                Interval::new(f64::NEG_INFINITY, f64::INFINITY)
            } else {
                Interval::new(f(self.lo).min(f(self.hi)), f64::INFINITY)
            };
            return r.widen_more();
        }
        // Real exponent: defined for a positive base only, as powf is
        // (and 0 ^ e); but powf takes a negative base to any whole
        // exponent the range holds (`pow(x, y)` at y = 0 is 1 for x = -2).
        let whole = negative_base_at_whole_exponents(self, e);
        let d = self.clamp_domain(0.0, f64::INFINITY);
        if d.is_empty() {
            return whole.unwrap_or(d);
        }
        let positive = Interval::positive_base_pow(d, e);
        match whole {
            Some(w) => positive.hull(w),
            None => positive,
        }
    }
    fn min(self, o: Self) -> Self {
        if self.is_empty() || o.is_empty() {
            return Interval::EMPTY;
        }
        Interval::new(self.lo.min(o.lo), self.hi.min(o.hi))
    }
    fn max(self, o: Self) -> Self {
        if self.is_empty() || o.is_empty() {
            return Interval::EMPTY;
        }
        Interval::new(self.lo.max(o.lo), self.hi.max(o.hi))
    }
    fn smooth_min(self, o: Self) -> Self {
        if self.is_empty() || o.is_empty() {
            return Interval::EMPTY;
        }
        // Rising in both operands: the ends give the range. The blend's
        // few roundings are covered by moving each end out by a relative
        // 4 ulps and an absolute one of the blend's size (at most 1/4).
        let lo = super::number::smooth_min_f64(self.lo, o.lo);
        let hi = super::number::smooth_min_f64(self.hi, o.hi);
        let slack = |v: f64| 4.0 * f64::EPSILON * (v.abs() + 1.0);
        Interval::new(lo - slack(lo), hi + slack(hi)).widen()
    }
    fn floor(self) -> Self {
        if self.is_empty() {
            return self;
        }
        Interval::new(self.lo.floor(), self.hi.floor())
    }
    fn fract(self) -> Self {
        if self.is_empty() {
            return self;
        }
        if self.lo.floor() != self.hi.floor() || !self.width().is_finite() {
            return Interval::new(0.0, 1.0);
        }
        // Within one step, `x - floor(x)` is `x` shifted: its two ends,
        // each rounded once, and never outside [0, 1].
        let k = self.lo.floor();
        let r = Interval::new(self.lo - k, self.hi - k).widen();
        Interval::new(r.lo.max(0.0), r.hi.min(1.0))
    }
    fn smooth_step(self) -> Self {
        if self.is_empty() {
            return self;
        }
        let r = self.monotone_up(super::number::smooth_step_f64);
        Interval::new(r.lo.max(0.0), r.hi.min(1.0))
    }
    fn integer_jumps(self) -> Self {
        if self.is_empty() {
            return self;
        }
        if self.lo.ceil() <= self.hi && !self.rounding_wide() {
            Interval::ENTIRE
        } else {
            Interval::point(0.0)
        }
    }
    fn zero_jumps(self) -> Self {
        if self.is_empty() {
            return self;
        }
        if self.contains(0.0) && !self.rounding_wide() {
            Interval::ENTIRE
        } else {
            Interval::point(0.0)
        }
    }
    fn when(self, b: Self) -> Self {
        if self.is_empty() {
            return self;
        }
        if self.lo > 0.0 {
            b
        } else if self.hi <= 0.0 {
            Interval::point(0.0)
        } else {
            b.hull(Interval::point(0.0))
        }
    }
    fn select(self, a: Self, b: Self) -> Self {
        if self.is_empty() {
            return self;
        }
        if self.lo > 0.0 {
            a
        } else if self.hi <= 0.0 {
            b
        } else {
            a.hull(b)
        }
    }
    fn noise(p: [Self; 3], partial: [u8; 3]) -> Self {
        super::noise::enclose(p, partial)
    }
    fn unless(self, b: Self) -> Self {
        if self.is_empty() {
            return self;
        }
        if self.lo > 0.0 {
            Interval::point(0.0)
        } else if self.hi <= 0.0 {
            b
        } else {
            b.hull(Interval::point(0.0))
        }
    }
    fn atan2(self, x: Self) -> Self {
        if self.is_empty() || x.is_empty() {
            return Interval::EMPTY;
        }
        // Away from the branch cut (the negative x axis) atan2 is
        // continuous and each half-plane has a monotone form.
        if x.lo > 0.0 {
            return (self / x).atan();
        }
        let half_pi = Interval::new(PI / 2.0, PI / 2.0).widen();
        if self.lo > 0.0 {
            // Upper half-plane: pi/2 - atan(x / y), in (0, pi).
            return half_pi - (x / self).atan();
        }
        if self.hi < 0.0 {
            // Lower half-plane: -pi/2 - atan(x / y), in (-pi, 0).
            return -half_pi - (x / self).atan();
        }
        // Across the cut (or at the origin) the values near +pi and -pi
        // both occur: the hull is the whole range.
        Interval::new(-PI, PI).widen()
    }
    fn atan2_sides(self, x: Self) -> Option<(Self, Self)> {
        if self.is_empty() || x.is_empty() || self.lo > 0.0 || self.hi < 0.0 || x.lo >= 0.0 {
            return None;
        }
        // On each closed side atan2 is monotone in x and, in each
        // quadrant, in y: its extremes are at the corners, with +0 and -0
        // for y = 0 (pi and -pi where x < 0, 0 where x >= 0).
        let upper = {
            let top = self.hi.max(0.0);
            let least = if x.hi >= 0.0 { 0.0 } else { top.atan2(x.hi) };
            Interval::new(least, PI)
        };
        let lower = {
            let bottom = self.lo.min(-0.0);
            let most = if x.hi >= 0.0 {
                -0.0
            } else {
                bottom.atan2(x.hi)
            };
            Interval::new(-PI, most)
        };
        Some((upper.widen(), lower.widen()))
    }
    fn hull_with(self, other: Self) -> Self {
        self.hull(other)
    }
}

/// The largest whole exponent [`Number::pow`] takes by `powi`.
const POWI_LARGEST: f64 = 16.0;

impl Interval {
    /// `d^e` for a base `d` within `[0, inf]` and an exponent that is
    /// not one whole number.
    fn positive_base_pow(d: Interval, e: Interval) -> Interval {
        // A fixed exponent: monotone in the base, so its two ends.
        if e.lo == e.hi {
            let (a, b) = (pow_f64(d.lo, e.lo), pow_f64(d.hi, e.lo));
            return Interval::new(a.min(b), a.max(b)).widen_more();
        }
        let corners = [
            d.lo.powf(e.lo),
            d.lo.powf(e.hi),
            d.hi.powf(e.lo),
            d.hi.powf(e.hi),
        ];
        let lo = corners.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = corners.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let r = Interval::new(lo, hi);
        // powf over a box is monotone in each argument for base > 0 apart
        // from the base 1 crossing, which the corners cover; with the base
        // range touching 1 the value 1 is included.
        let r = if d.contains(1.0) {
            r.hull(Interval::point(1.0))
        } else {
            r
        };
        r.widen_more()
    }
}

/// The values `powf` gives over the negative part of `base` at the whole
/// numbers `e` holds, or `None` where there are none. `|x|^n` is monotone
/// in `|x|` and in `n`, so its extremes are at the corners; the sign is
/// the parity's for one whole number, either for several.
fn negative_base_at_whole_exponents(base: Interval, e: Interval) -> Option<Interval> {
    if base.lo >= 0.0 {
        return None;
    }
    let (n_lo, n_hi) = (e.lo.ceil(), e.hi.floor());
    if n_lo > n_hi {
        return None;
    }
    let (m_lo, m_hi) = (-(base.hi.min(0.0)), -base.lo);
    let corners = [
        m_lo.powf(n_lo),
        m_lo.powf(n_hi),
        m_hi.powf(n_lo),
        m_hi.powf(n_hi),
    ];
    let lo = corners.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = corners.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let r = if n_lo < n_hi {
        Interval::new(-hi, hi)
    } else if (0.5 * n_lo).fract() != 0.0 {
        Interval::new(-hi, -lo)
    } else {
        Interval::new(lo, hi)
    };
    Some(r.widen_more())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At large arguments the phase shift that turns cos into sin rounds
    /// by far more than an ulp of the result; the enclosure allows for it.
    #[test]
    fn cosine_of_a_large_argument_encloses_the_point_value() {
        for x in [1e8, 3.3e9, 123456789.123, 7e12] {
            let r = Interval::new(x, x).cos();
            assert!(
                r.contains(f64::cos(x)),
                "cos({x}) = {} outside {r:?}",
                f64::cos(x)
            );
            let r = Interval::new(x, x).sin();
            assert!(
                r.contains(f64::sin(x)),
                "sin({x}) = {} outside {r:?}",
                f64::sin(x)
            );
        }
    }

    /// Over intervals at every scale and position, sin and cos enclose
    /// libm's values at the ends and inside, and reach the extremes only
    /// where the interval passes one.
    #[test]
    fn sine_and_cosine_enclose_their_values() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..20_000 {
            let scale = 10f64.powf(next() * 8.0 - 3.0);
            let lo = (next() - 0.5) * 2.0 * scale.min(2e6);
            let hi = lo + next() * 7.0 * next().powi(3);
            let x = Interval::new(lo, hi);
            let (s, c) = (x.sin(), x.cos());
            for i in 0..=16 {
                let t = lo + (hi - lo) * i as f64 / 16.0;
                assert!(s.contains(t.sin()), "sin({t}) = {} outside {s:?}", t.sin());
                assert!(c.contains(t.cos()), "cos({t}) = {} outside {c:?}", t.cos());
            }
            if hi - lo < 0.5 && lo.abs() < 1e5 {
                // No extreme passed at these widths unless near one: the
                // enclosure is tight.
                let sampled = (0..=64)
                    .map(|i| (lo + (hi - lo) * i as f64 / 64.0).sin())
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                        (a.min(v), b.max(v))
                    });
                let sampled_width = sampled.1 - sampled.0;
                assert!(
                    s.width() <= sampled_width * 1.01 + (hi - lo).powi(2) + 1e-14,
                    "sin over [{lo}, {hi}]: {s:?}, sampled {sampled:?}"
                );
            }
        }
    }

    #[test]
    fn sine_covers_its_extremes() {
        let r = Interval::new(0.0, 2.0).sin();
        assert!(r.hi >= 1.0 && r.lo <= 0.0 && r.lo > -0.1);
        let r = Interval::new(3.0, 3.5).cos();
        assert!(r.lo <= -1.0);
    }

    #[test]
    fn square_of_a_range_through_zero_starts_at_zero() {
        let r = Interval::new(-1.0, 2.0).square();
        assert_eq!(r.lo, 0.0);
        assert!(r.hi >= 4.0);
    }

    /// ln(0) is -inf, a value: a range ending at an infinite bound is not
    /// empty.
    #[test]
    fn ln_of_zero_holds_minus_infinity() {
        let r = Interval::point(0.0).ln();
        assert!(!r.is_empty(), "{r:?}");
        assert_eq!(r.lo, f64::NEG_INFINITY);
        assert!(Interval::new(0.0, 1.0).ln().contains(-1e300));
    }

    /// Degenerate boxes and large powers, where the interval once left
    /// out what f64 computes: `pow(-2, 0)` is 1 though the exponent's
    /// range is not one number; `0.99757557^1000` by squarings came out
    /// about 130 ulps from `powf`'s.
    #[test]
    fn degenerate_boxes_and_large_powers_enclose_the_point_value() {
        let p = Interval::new(-2.0, -1.5).pow(Interval::new(0.0, 1e-7));
        assert!(p.contains(1.0), "{p:?}");
        let p = Interval::new(-2.0, -1.5).pow(Interval::new(2.5, 3.5));
        assert!(p.contains(-8.0) && p.contains((-1.5f64).powi(3)), "{p:?}");
        let odd = Interval::new(-2.0, -1.5).pow(Interval::new(1.0, 2.0));
        assert!(odd.contains(-2.0) && odd.contains(4.0), "{odd:?}");
        let x = 0.9975755733570949f64;
        for n in [17.0, 1000.0, 1001.0, -999.0] {
            for base in [x, -x, 1.0 / x] {
                let r = Interval::point(base).pow(Interval::point(n));
                assert!(r.contains(base.powf(n)), "{base}^{n}: {r:?}");
            }
        }
    }

    #[test]
    fn sqrt_of_a_negative_range_is_empty() {
        assert!(Interval::new(-3.0, -1.0).sqrt().is_empty());
        assert!(!Interval::new(-3.0, -1.0).sqrt().contains(0.0));
    }
}
