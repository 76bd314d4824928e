//! Dual numbers: a value and its derivative with respect to one parameter,
//! carried through a tape evaluation together (forward-mode automatic
//! differentiation).
//!
//! Root isolation along a straight path evaluates a value tape in
//! `Dual<Interval>` with the path's parameter as the one input: one pass,
//! one dispatch per operation, gives both the range of `f` over a piece
//! and the range of its slope along the path. The rules are those of the
//! symbolic derivative (`Graph::derivative`), so a dual evaluation and the
//! gradient tape dotted with the direction agree, and both treat the
//! non-smooth builtins alike: `abs`, `min` and `max` get the hull of their
//! one-sided slopes where their arguments meet; `sign`, `floor`, `fract`
//! and `if` have slope 0 at a point and every real over an interval
//! that holds their jump, so no piece across a jump passes for monotone.

use std::ops::{Add, Div, Mul, Neg, Sub};

use super::number::{LineForm, Number};
use super::op::Noise;

/// `v + d ε` with `ε² = 0`: `d` is the derivative of `v`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dual<N> {
    /// The value.
    pub v: N,
    /// Its derivative with respect to the one parameter.
    pub d: N,
}

impl<N: Number> Dual<N> {
    /// The parameter itself at `v`: its derivative is 1.
    pub fn variable(v: N) -> Self {
        Dual {
            v,
            d: N::constant(1.0),
        }
    }

    /// `outer(v) * d`: the chain rule, for a function whose derivative at
    /// `v` is `outer`.
    #[inline]
    fn chain(self, v: N, outer: N) -> Self {
        Dual {
            v,
            d: outer * self.d,
        }
    }
}

impl<N: Number> Add for Dual<N> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        Dual {
            v: self.v + o.v,
            d: self.d + o.d,
        }
    }
}

impl<N: Number> Sub for Dual<N> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        Dual {
            v: self.v - o.v,
            d: self.d - o.d,
        }
    }
}

impl<N: Number> Neg for Dual<N> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        Dual {
            v: -self.v,
            d: -self.d,
        }
    }
}

impl<N: Number> Mul for Dual<N> {
    type Output = Self;
    #[inline]
    fn mul(self, o: Self) -> Self {
        Dual {
            v: self.v * o.v,
            d: self.d * o.v + self.v * o.d,
        }
    }
}

impl<N: Number> Div for Dual<N> {
    type Output = Self;
    #[inline]
    fn div(self, o: Self) -> Self {
        // (a/b)' = a'/b - (a/b) b'/b, as the symbolic rule has it.
        let q = self.v / o.v;
        Dual {
            v: q,
            d: self.d / o.v - q * o.d / o.v,
        }
    }
}

impl<N: Number> Number for Dual<N> {
    #[inline]
    fn constant(c: f64) -> Self {
        Dual {
            v: N::constant(c),
            d: N::constant(0.0),
        }
    }

    #[inline]
    fn along(t: Self, form: &LineForm) -> Self {
        // d/ds (alpha + beta t(s)) = beta t'(s), with t' = 1 for the
        // parameter itself (reach 1).
        let slope = LineForm {
            alpha: 0.0,
            beta: form.beta,
            err: form.slope_err,
            slope_err: 0.0,
        };
        Dual {
            v: N::along(t.v, form),
            d: N::along(t.d, &slope),
        }
    }

    #[inline]
    fn square(self) -> Self {
        let half = self.v * self.d;
        Dual {
            v: self.v.square(),
            d: half + half,
        }
    }

    fn abs(self) -> Self {
        self.chain(self.v.abs(), self.v.sign())
    }

    fn sign(self) -> Self {
        Dual {
            v: self.v.sign(),
            d: self.v.zero_jumps() * self.d,
        }
    }

    fn sqrt(self) -> Self {
        let r = self.v.sqrt();
        self.chain(r, N::constant(1.0) / (N::constant(2.0) * r))
    }

    fn exp(self) -> Self {
        let e = self.v.exp();
        self.chain(e, e)
    }

    fn ln(self) -> Self {
        self.chain(self.v.ln(), N::constant(1.0) / self.v)
    }

    fn sin(self) -> Self {
        self.chain(self.v.sin(), self.v.cos())
    }

    fn cos(self) -> Self {
        self.chain(self.v.cos(), -self.v.sin())
    }

    fn sin_and_cos(self) -> (Self, Self) {
        let (s, c) = self.v.sin_and_cos();
        (self.chain(s, c), self.chain(c, -s))
    }

    fn tan(self) -> Self {
        let t = self.v.tan();
        self.chain(t, N::constant(1.0) + t.square())
    }

    fn asin(self) -> Self {
        let r = (N::constant(1.0) - self.v.square()).sqrt();
        self.chain(self.v.asin(), N::constant(1.0) / r)
    }

    fn acos(self) -> Self {
        let r = (N::constant(1.0) - self.v.square()).sqrt();
        self.chain(self.v.acos(), -(N::constant(1.0) / r))
    }

    fn atan(self) -> Self {
        let r = N::constant(1.0) + self.v.square();
        self.chain(self.v.atan(), N::constant(1.0) / r)
    }

    fn sinh(self) -> Self {
        self.chain(self.v.sinh(), self.v.cosh())
    }

    fn cosh(self) -> Self {
        self.chain(self.v.cosh(), self.v.sinh())
    }

    fn tanh(self) -> Self {
        let t = self.v.tanh();
        self.chain(t, N::constant(1.0) - t.square())
    }

    fn shc(self) -> Self {
        self.chain(self.v.shc(), self.v.shc_slope())
    }

    fn chc(self) -> Self {
        self.chain(self.v.chc(), self.v.shc() * N::constant(0.5))
    }

    fn shc_slope(self) -> Self {
        // (shc/2 - 3 shc') / 2x: only gradient tapes hold this operation,
        // and they are never evaluated in dual numbers.
        let d = (self.v.shc() * N::constant(0.5) - self.v.shc_slope() * N::constant(3.0))
            / (self.v * N::constant(2.0));
        self.chain(self.v.shc_slope(), d)
    }

    fn pow(self, e: Self) -> Self {
        let p = self.v.pow(e.v);
        // An exponent that does not vary is the symbolic rule's constant
        // case, e a^(e-1) a', which stays defined for a negative base.
        if let Some(c) = e.constant_value() {
            let outer = N::constant(c) * self.v.pow(N::constant(c - 1.0));
            return self.chain(p, outer);
        }
        // (a^b)' = a^b (b' ln a + b a'/a)
        Dual {
            v: p,
            d: p * (e.d * self.v.ln() + e.v * self.d / self.v),
        }
    }

    fn min(self, o: Self) -> Self {
        self.pick(o, -1.0)
    }

    fn max(self, o: Self) -> Self {
        self.pick(o, 1.0)
    }

    fn atan2(self, x: Self) -> Self {
        // atan2(a, b)' = (b a' - a b') / (a^2 + b^2), and across the
        // branch cut (a through 0 where b < 0) the jump from pi to -pi,
        // unbounded over an interval there and 0 at points, as the
        // symbolic rule writes it.
        let r = self.v.square() + x.v.square();
        let cut = self.v.zero_jumps() * (-x.v).max(N::constant(0.0));
        Dual {
            v: self.v.atan2(x.v),
            d: (x.v * self.d - self.v * x.d) / r + cut * self.d,
        }
    }

    fn smooth_min(self, o: Self) -> Self {
        // h a' + (1 - h) b', as the symbolic derivative builds it.
        let half = N::constant(0.5);
        let h = (half + (o.v - self.v) * half)
            .max(N::constant(0.0))
            .min(N::constant(1.0));
        Dual {
            v: self.v.smooth_min(o.v),
            d: o.d + h * (self.d - o.d),
        }
    }

    fn floor(self) -> Self {
        Dual {
            v: self.v.floor(),
            d: self.v.integer_jumps() * self.d,
        }
    }

    fn fract(self) -> Self {
        Dual {
            v: self.v.fract(),
            d: self.d + self.v.integer_jumps() * self.d,
        }
    }

    fn smooth_step(self) -> Self {
        // 6 t (1 - t) on [0, 1], 0 outside, as the symbolic rule.
        let t = self.v.max(N::constant(0.0)).min(N::constant(1.0));
        let slope = N::constant(6.0) * t * (N::constant(1.0) - t);
        self.chain(self.v.smooth_step(), slope)
    }

    fn integer_jumps(self) -> Self {
        let j = self.v.integer_jumps();
        Dual { v: j, d: j }
    }

    fn zero_jumps(self) -> Self {
        let j = self.v.zero_jumps();
        Dual { v: j, d: j }
    }

    fn when(self, b: Self) -> Self {
        Dual {
            v: self.v.when(b.v),
            d: self.v.when(b.d) + self.v.zero_jumps() * self.d,
        }
    }

    fn select(self, a: Self, b: Self) -> Self {
        Dual {
            v: self.v.select(a.v, b.v),
            d: self.v.select(a.d, b.d) + self.v.zero_jumps() * self.d,
        }
    }

    fn unless(self, b: Self) -> Self {
        Dual {
            v: self.v.unless(b.v),
            d: self.v.unless(b.d) + self.v.zero_jumps() * self.d,
        }
    }

    fn noise(p: [Self; 3], partial: [u8; 3]) -> Self {
        // The chain rule: the value's partials in each argument, times
        // that argument's slope.
        let v = p.map(|c| c.v);
        let mut d = N::constant(0.0);
        for (axis, c) in p.iter().enumerate() {
            if c.d.constant_value() != Some(0.0) {
                let slope = Noise { partial }.differentiated(axis);
                d = d + N::noise(v, slope.partial) * c.d;
            }
        }
        Dual {
            v: N::noise(v, partial),
            d,
        }
    }

    fn constant_value(self) -> Option<f64> {
        (self.d.constant_value() == Some(0.0))
            .then(|| self.v.constant_value())
            .flatten()
    }
}

impl<N: Number> Dual<N> {
    /// `min` (`toward` -1) or `max` (+1): the slope of the side taken,
    /// the mean of both where `a = b`, and over intervals where the sides
    /// cross, the hull of both.
    #[inline]
    fn pick(self, o: Self, toward: f64) -> Self {
        let v = if toward < 0.0 {
            self.v.min(o.v)
        } else {
            self.v.max(o.v)
        };
        // By selection, as the symbolic rule (see `Graph::derivative`),
        // so that a side not taken whose slope overflows costs nothing.
        let (first, second) = if toward < 0.0 {
            (o.d, self.d)
        } else {
            (self.d, o.d)
        };
        let diff = self.v - o.v;
        let mean = N::constant(0.5) * (self.d + o.d);
        Dual {
            v,
            d: diff.select(first, (-diff).select(second, mean)),
        }
    }
}
