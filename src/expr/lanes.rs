//! Numbers in lanes: `K` independent values carried through one tape
//! evaluation, stored as arrays so that the common operations compile to
//! SIMD instructions. One dispatch per operation then serves `K` values;
//! root isolation uses them to test the pieces of a split at once.
//!
//! Both types are ordinary [`Number`]s, so the tape and the IR know nothing
//! of them. Addition, subtraction, multiplication, division by a positive
//! range, negation, squaring, square roots, `abs`, `min`, `max` and
//! trigonometry of narrow ranges run across the lanes at once; every other
//! function falls back to the scalar type lane by lane, with identical
//! results.

use std::ops::{Add, Div, Mul, Neg, Sub};

use super::interval::{along_bounds, quotient_by_positive, Interval};
use super::number::{LineForm, Number};
use super::trig;

/// `K` intervals, structure-of-arrays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntervalLanes<const K: usize> {
    /// Each lane's lower bound, as [`Interval::lo`].
    pub lo: [f64; K],
    /// Each lane's upper bound, as [`Interval::hi`].
    pub hi: [f64; K],
}

/// `K` numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct F64Lanes<const K: usize>(pub [f64; K]);

/// Moves bounds outward by at least one ulp, as [`Interval`] does; an
/// infinite bound stays (a lower bound of +inf is a value that
/// overflowed, not an empty lane), and a NaN one stays NaN.
#[inline(always)]
fn down(x: f64) -> f64 {
    (x - (x.abs() * f64::EPSILON + f64::from_bits(1))).min(x)
}

#[inline(always)]
fn up(x: f64) -> f64 {
    (x + (x.abs() * f64::EPSILON + f64::from_bits(1))).max(x)
}

#[inline(always)]
fn min2(a: f64, b: f64) -> f64 {
    if a < b {
        a
    } else {
        b
    }
}

#[inline(always)]
fn max2(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// The functions that lane types compute one lane at a time with the
/// scalar type's own implementation.
macro_rules! lane_by_lane {
    () => {
        lane_by_lane!(unary: sign, exp, ln, tan, asin, acos, atan, sinh, cosh, tanh, shc, chc, shc_slope, floor, fract, smooth_step, integer_jumps, zero_jumps);
        lane_by_lane!(binary: atan2, smooth_min, when, unless);
    };
    (unary: $($f:ident),*) => {
        $(fn $f(self) -> Self {
            self.map(Number::$f)
        })*
    };
    (binary: $($f:ident),*) => {
        $(fn $f(self, o: Self) -> Self {
            self.zip(o, Number::$f)
        })*
    };
}

impl<const K: usize> IntervalLanes<K> {
    /// The lanes `f(0), ..., f(K - 1)`.
    pub fn from_fn(mut f: impl FnMut(usize) -> Interval) -> Self {
        let mut r = IntervalLanes {
            lo: [0.0; K],
            hi: [0.0; K],
        };
        for k in 0..K {
            let i = f(k);
            r.lo[k] = i.lo;
            r.hi[k] = i.hi;
        }
        r
    }

    /// Lane `k` as an [`Interval`]; panics if `k >= K`.
    #[inline]
    pub fn lane(&self, k: usize) -> Interval {
        Interval {
            lo: self.lo[k],
            hi: self.hi[k],
        }
    }

    /// Whether some lane is empty (a NaN bound).
    #[inline(always)]
    fn any_empty(&self) -> bool {
        let mut sum = 0.0;
        for k in 0..K {
            sum += self.lo[k] + self.hi[k];
        }
        // inf + -inf is NaN too: such lanes take the scalar path, which
        // is as right.
        sum.is_nan()
    }

    /// A function rising in both operands (`min`, `max`): `end` of the
    /// lower ends and of the upper ends, across the lanes at once, which
    /// is what `scalar` gives lane by lane; `scalar` itself where a lane
    /// is empty.
    #[inline(always)]
    fn end_by_end(
        self,
        o: Self,
        end: impl Fn(f64, f64) -> f64,
        scalar: impl Fn(Interval, Interval) -> Interval,
    ) -> Self {
        if self.any_empty() || o.any_empty() {
            return self.zip(o, scalar);
        }
        let mut r = self;
        for k in 0..K {
            r.lo[k] = end(self.lo[k], o.lo[k]);
            r.hi[k] = end(self.hi[k], o.hi[k]);
        }
        r
    }

    #[inline]
    fn map(self, f: impl Fn(Interval) -> Interval) -> Self {
        Self::from_fn(|k| f(self.lane(k)))
    }

    #[inline]
    fn zip(self, o: Self, f: impl Fn(Interval, Interval) -> Interval) -> Self {
        Self::from_fn(|k| f(self.lane(k), o.lane(k)))
    }
}

impl<const K: usize> Add for IntervalLanes<K> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        let mut r = self;
        for k in 0..K {
            r.lo[k] = down(self.lo[k] + o.lo[k]);
            r.hi[k] = up(self.hi[k] + o.hi[k]);
        }
        r
    }
}

impl<const K: usize> Sub for IntervalLanes<K> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        let mut r = self;
        for k in 0..K {
            r.lo[k] = down(self.lo[k] - o.hi[k]);
            r.hi[k] = up(self.hi[k] - o.lo[k]);
        }
        r
    }
}

impl<const K: usize> Neg for IntervalLanes<K> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        let mut r = self;
        for k in 0..K {
            r.lo[k] = -self.hi[k];
            r.hi[k] = -self.lo[k];
        }
        r
    }
}

impl<const K: usize> Mul for IntervalLanes<K> {
    type Output = Self;
    #[inline]
    fn mul(self, o: Self) -> Self {
        let mut r = self;
        let mut careful = false;
        for k in 0..K {
            let (p, q) = (self.lo[k] * o.lo[k], self.lo[k] * o.hi[k]);
            let (s, t) = (self.hi[k] * o.lo[k], self.hi[k] * o.hi[k]);
            // NaN: an empty lane or 0 * inf; the scalar type handles those.
            careful |= (p + q + s + t).is_nan();
            r.lo[k] = down(min2(min2(p, q), min2(s, t)));
            r.hi[k] = up(max2(max2(p, q), max2(s, t)));
        }
        if careful {
            return mul_careful(self, o);
        }
        r
    }
}

/// The rare products with an empty lane or `0 * inf`, lane by lane; kept
/// out of line so that the fast path inlines into the evaluator.
#[cold]
#[inline(never)]
fn mul_careful<const K: usize>(a: IntervalLanes<K>, b: IntervalLanes<K>) -> IntervalLanes<K> {
    a.zip(b, |a, b| a * b)
}

/// sin(x + quadrants pi/2) across the lanes: [`trig::sin_over`] in every
/// lane when every lane is within its range (one loop that vectorises),
/// otherwise the scalar type lane by lane; both give what
/// [`Interval::sin_cos`] gives.
#[inline]
fn sin_cos_lanes<const K: usize>(x: IntervalLanes<K>, quadrants: u64) -> IntervalLanes<K> {
    let reducible = |v: f64| v.abs() <= trig::REDUCIBLE;
    let in_range = (0..K).all(|k| {
        x.hi[k] - x.lo[k] < std::f64::consts::TAU && reducible(x.lo[k]) && reducible(x.hi[k])
    });
    if !in_range {
        return x.map(|i| i.sin_cos(quadrants));
    }
    let mut r = x;
    for k in 0..K {
        (r.lo[k], r.hi[k]) = trig::sin_over(x.lo[k], x.hi[k], quadrants);
    }
    r
}

#[cold]
#[inline(never)]
fn div_careful<const K: usize>(a: IntervalLanes<K>, b: IntervalLanes<K>) -> IntervalLanes<K> {
    a.zip(b, |a, b| a / b)
}

#[cold]
#[inline(never)]
fn square_careful<const K: usize>(a: IntervalLanes<K>) -> IntervalLanes<K> {
    a.map(Number::square)
}

impl<const K: usize> Div for IntervalLanes<K> {
    type Output = Self;
    #[inline]
    fn div(self, o: Self) -> Self {
        // A divisor above zero in every lane (a sum of squares plus a
        // constant, the usual case) divides across the lanes at once.
        if !(0..K).all(|k| o.lo[k] > 0.0) {
            return div_careful(self, o);
        }
        let mut r = self;
        for k in 0..K {
            let (lo, hi) = quotient_by_positive(self.lo[k], self.hi[k], o.lo[k], o.hi[k]);
            r.lo[k] = down(lo);
            r.hi[k] = up(hi);
        }
        r
    }
}

impl<const K: usize> Number for IntervalLanes<K> {
    fn atan2_sides(self, x: Self) -> Option<(Self, Self)> {
        let sides: [Option<(Interval, Interval)>; K] =
            std::array::from_fn(|k| self.lane(k).atan2_sides(x.lane(k)));
        if sides.iter().all(Option::is_none) {
            return None;
        }
        let side = |upper: bool| {
            IntervalLanes::from_fn(|k| match sides[k] {
                Some((u, l)) => {
                    if upper {
                        u
                    } else {
                        l
                    }
                }
                None => self.lane(k).atan2(x.lane(k)),
            })
        };
        Some((side(true), side(false)))
    }
    fn hull_with(self, other: Self) -> Self {
        IntervalLanes::from_fn(|k| self.lane(k).hull(other.lane(k)))
    }
    #[inline]
    fn constant(c: f64) -> Self {
        let i = Interval::point(c);
        IntervalLanes {
            lo: [i.lo; K],
            hi: [i.hi; K],
        }
    }
    #[inline(always)]
    fn along(t: Self, form: &LineForm) -> Self {
        let mut r = t;
        for k in 0..K {
            (r.lo[k], r.hi[k]) = along_bounds(t.lo[k], t.hi[k], form);
        }
        r
    }
    fn constant_value(self) -> Option<f64> {
        let c = self.lo[0];
        (0..K)
            .all(|k| self.lo[k] == c && self.hi[k] == c)
            .then_some(c)
    }
    #[inline(always)]
    fn square(self) -> Self {
        let mut r = self;
        let mut careful = false;
        for k in 0..K {
            let (a, b) = (self.lo[k] * self.lo[k], self.hi[k] * self.hi[k]);
            careful |= (a + b).is_nan();
            let through_zero = self.lo[k] <= 0.0 && self.hi[k] >= 0.0;
            let lo = if through_zero { 0.0 } else { down(min2(a, b)) };
            r.lo[k] = max2(lo, 0.0);
            r.hi[k] = up(max2(a, b));
        }
        if careful {
            return square_careful(self);
        }
        r
    }
    fn sin(self) -> Self {
        sin_cos_lanes(self, 0)
    }
    fn cos(self) -> Self {
        sin_cos_lanes(self, 1)
    }
    fn sin_and_cos(self) -> (Self, Self) {
        let reducible = |v: f64| v.abs() <= trig::REDUCIBLE;
        let in_range = (0..K).all(|k| {
            self.hi[k] - self.lo[k] < std::f64::consts::TAU
                && reducible(self.lo[k])
                && reducible(self.hi[k])
        });
        if !in_range {
            return (sin_cos_lanes(self, 0), sin_cos_lanes(self, 1));
        }
        let (mut s, mut c) = (self, self);
        for k in 0..K {
            ((s.lo[k], s.hi[k]), (c.lo[k], c.hi[k])) = trig::sin_cos_over(self.lo[k], self.hi[k]);
        }
        (s, c)
    }
    lane_by_lane!();
    lane_by_lane!(binary: pow);
    #[inline(always)]
    fn sqrt(self) -> Self {
        // Every lane non-empty and reaching zero or above, none starting
        // at +inf: [`Interval::sqrt`]'s steps, across the lanes at once.
        let usable = (0..K).all(|k| self.hi[k] >= 0.0 && self.lo[k] < f64::INFINITY);
        if !usable {
            return self.map(Number::sqrt);
        }
        let mut r = self;
        for k in 0..K {
            r.lo[k] = max2(down(max2(self.lo[k], 0.0).sqrt()), 0.0);
            r.hi[k] = up(self.hi[k].sqrt());
        }
        r
    }
    #[inline(always)]
    fn abs(self) -> Self {
        if self.any_empty() {
            return self.map(Number::abs);
        }
        let mut r = self;
        for k in 0..K {
            let (lo, hi) = (self.lo[k], self.hi[k]);
            let through_zero = lo <= 0.0 && hi >= 0.0;
            let negative = hi < 0.0;
            r.lo[k] = if through_zero {
                0.0
            } else if negative {
                -hi
            } else {
                lo
            };
            r.hi[k] = if through_zero {
                hi.max(-lo)
            } else if negative {
                -lo
            } else {
                hi
            };
        }
        r
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        self.end_by_end(o, f64::min, Number::min)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        self.end_by_end(o, f64::max, Number::max)
    }
    fn select(self, a: Self, b: Self) -> Self {
        Self::from_fn(|k| Number::select(self.lane(k), a.lane(k), b.lane(k)))
    }
    fn noise(p: [Self; 3], partial: [u8; 3]) -> Self {
        Self::from_fn(|k| Interval::noise(p.map(|c| c.lane(k)), partial))
    }
}

impl<const K: usize> F64Lanes<K> {
    /// sin(x + quadrants pi/2) in every lane, as `f64`'s sin and cos
    /// compute it: across the lanes at once when every lane is within the
    /// kernel's range.
    #[inline]
    fn shifted_sin(self, quadrants: u64) -> Self {
        if !self.0.iter().all(|x| x.abs() <= trig::REDUCIBLE) {
            return self.map(|x| {
                if quadrants == 0 {
                    Number::sin(x)
                } else {
                    Number::cos(x)
                }
            });
        }
        F64Lanes(self.0.map(|x| trig::shifted_sin(x, quadrants)))
    }

    #[inline]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        F64Lanes(self.0.map(f))
    }

    #[inline]
    fn zip(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        F64Lanes(std::array::from_fn(|k| f(self.0[k], o.0[k])))
    }
}

macro_rules! f64_lanes_op {
    ($trait:ident, $method:ident, $op:tt) => {
        impl<const K: usize> $trait for F64Lanes<K> {
            type Output = Self;
            #[inline]
            fn $method(self, o: Self) -> Self {
                let mut r = self;
                for k in 0..K {
                    r.0[k] = self.0[k] $op o.0[k];
                }
                r
            }
        }
    };
}

f64_lanes_op!(Add, add, +);
f64_lanes_op!(Sub, sub, -);
f64_lanes_op!(Mul, mul, *);
f64_lanes_op!(Div, div, /);

impl<const K: usize> Neg for F64Lanes<K> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        self.map(|x| -x)
    }
}

impl<const K: usize> Number for F64Lanes<K> {
    #[inline]
    fn constant(c: f64) -> Self {
        F64Lanes([c; K])
    }
    #[inline]
    fn along(t: Self, form: &LineForm) -> Self {
        t.map(|t| form.alpha + form.beta * t)
    }
    fn constant_value(self) -> Option<f64> {
        let c = self.0[0];
        self.0.iter().all(|&x| x == c).then_some(c)
    }
    #[inline]
    fn square(self) -> Self {
        self.map(|x| x * x)
    }
    fn sin(self) -> Self {
        self.shifted_sin(0)
    }
    fn cos(self) -> Self {
        self.shifted_sin(1)
    }
    fn sin_and_cos(self) -> (Self, Self) {
        let (mut s, mut c) = (self, self);
        for k in 0..K {
            (s.0[k], c.0[k]) = trig::sin_and_cos(self.0[k]);
        }
        (s, c)
    }
    lane_by_lane!();
    lane_by_lane!(unary: abs, sqrt);
    lane_by_lane!(binary: min, max);
    /// A whole exponent from 1 to 8 the same in every lane, with every
    /// base finite and nonzero: `pow_f64`'s
    /// squarings, across the lanes at once (the polynomial route's
    /// values at its nodes raise coordinates to powers).
    fn pow(self, e: Self) -> Self {
        let n = e.0[0];
        let whole = n.fract() == 0.0 && (1.0..=8.0).contains(&n) && e.0.iter().all(|&x| x == n);
        if !(whole && self.0.iter().all(|&x| x != 0.0 && x.is_finite())) {
            return self.zip(e, Number::pow);
        }
        let (mut p, mut base, mut k) = (self, self, n as u32);
        let mut first = true;
        while k > 0 {
            if k & 1 == 1 {
                p = if first {
                    base
                } else {
                    p.zip(base, |a, b| a * b)
                };
                first = false;
            }
            base = base.map(|x| x * x);
            k >>= 1;
        }
        p
    }
    fn select(self, a: Self, b: Self) -> Self {
        F64Lanes(std::array::from_fn(|k| {
            Number::select(self.0[k], a.0[k], b.0[k])
        }))
    }
    fn noise(p: [Self; 3], partial: [u8; 3]) -> Self {
        F64Lanes(std::array::from_fn(|k| {
            f64::noise(p.map(|c| c.0[k]), partial)
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every lane of every operation equals the scalar result, or encloses
    /// it (the fast paths round outward by the same rule).
    #[test]
    fn lanes_agree_with_the_scalar_types() {
        let xs = [
            Interval::new(-2.0, 3.0),
            Interval::new(0.5, 0.75),
            Interval::new(-1e300, -1e-300),
            Interval::new(0.0, f64::INFINITY),
            Interval::EMPTY,
            Interval::new(-0.0, 0.0),
            Interval::new(1.0, 1.0),
            Interval::new(f64::NEG_INFINITY, 2.0),
        ];
        let a = IntervalLanes::<8>::from_fn(|k| xs[k]);
        let b = IntervalLanes::<8>::from_fn(|k| xs[(k + 3) % 8]);
        let same = |got: Interval, want: Interval| {
            (got.is_empty() && want.is_empty()) || (got.lo <= want.lo && got.hi >= want.hi)
        };
        for k in 0..8 {
            let (x, y) = (xs[k], xs[(k + 3) % 8]);
            assert!(same((a + b).lane(k), x + y), "{x:?} + {y:?}");
            assert!(same((a - b).lane(k), x - y), "{x:?} - {y:?}");
            assert!(same((a * b).lane(k), x * y), "{x:?} * {y:?}");
            assert!(same(a.square().lane(k), x.square()), "{x:?}^2");
            assert!(same((-a).lane(k), -x), "-{x:?}");
        }
        // The vectorised sine, cosine and quotient compute exactly what the
        // scalar types do, in range (every lane at once) and out of it
        // (lane by lane).
        let in_range = [
            Interval::new(-2.0, 3.0),
            Interval::new(0.5, 0.75),
            Interval::new(-1e5, -99_999.5),
            Interval::point(std::f64::consts::FRAC_PI_2),
            Interval::new(-0.0, 0.0),
            Interval::new(3.0, 9.0),
            Interval::new(-7.0, -6.9),
            Interval::new(1e-300, 2e-300),
        ];
        let divisors = in_range.map(|i| Interval::new(i.lo.abs() + 0.1, i.hi.abs() + 1.0));
        // Every upper bound at or above zero: square roots across the lanes.
        let rooted = [
            Interval::new(0.5, 0.75),
            Interval::new(-2.0, 3.0),
            Interval::new(0.0, f64::INFINITY),
            Interval::new(-0.0, 0.0),
            Interval::new(3.0, 9.0),
            Interval::new(1e-300, 2e-300),
            Interval::new(f64::NEG_INFINITY, 2.0),
            Interval::new(1.0, 1.0),
        ];
        for set in [in_range, xs, rooted] {
            let x = IntervalLanes::<8>::from_fn(|k| set[k]);
            let d = IntervalLanes::<8>::from_fn(|k| divisors[k]);
            let p = F64Lanes::<8>(set.map(|i| i.lo));
            for k in 0..8 {
                let same = |a: Interval, b: Interval| {
                    (a.is_empty() && b.is_empty()) || (a.lo == b.lo && a.hi == b.hi)
                };
                assert!(same(x.sin().lane(k), set[k].sin()), "sin {:?}", set[k]);
                assert!(same(x.cos().lane(k), set[k].cos()), "cos {:?}", set[k]);
                assert!(
                    same((x / d).lane(k), set[k] / divisors[k]),
                    "{:?} / {:?}",
                    set[k],
                    divisors[k]
                );
                // Square roots, abs, min and max: identical, with every lane
                // non-empty (across the lanes) or with an empty one (lane by
                // lane).
                let y = IntervalLanes::<8>::from_fn(|k| set[(k + 5) % 8]);
                let other = set[(k + 5) % 8];
                assert!(same(x.sqrt().lane(k), set[k].sqrt()), "sqrt {:?}", set[k]);
                assert!(same(x.abs().lane(k), set[k].abs()), "abs {:?}", set[k]);
                assert!(
                    same(x.min(y).lane(k), set[k].min(other)),
                    "min {:?}",
                    set[k]
                );
                assert!(
                    same(x.max(y).lane(k), set[k].max(other)),
                    "max {:?}",
                    set[k]
                );
                let equal = |a: f64, b: f64| a == b || a.is_nan() && b.is_nan();
                assert!(equal(p.sin().0[k], Number::sin(p.0[k])), "sin({})", p.0[k]);
                assert!(equal(p.cos().0[k], Number::cos(p.0[k])), "cos({})", p.0[k]);
            }
        }
        let p = F64Lanes::<4>([1.0, -2.0, 0.0, f64::NAN]);
        let q = F64Lanes::<4>([3.0, 0.5, -1.0, 2.0]);
        for k in 0..3 {
            assert_eq!((p * q).0[k], p.0[k] * q.0[k]);
            assert_eq!((p / q).0[k], p.0[k] / q.0[k]);
            assert_eq!(p.min(q).0[k], Number::min(p.0[k], q.0[k]));
        }
        assert!(p.min(q).0[3].is_nan());
    }
}
