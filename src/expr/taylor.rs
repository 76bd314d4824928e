//! Truncated Taylor series in one parameter: a polynomial's coefficients
//! along a path, computed by evaluating its tape once.
//!
//! A tape evaluated in `Taylor<N>` with the path's parameter as its input
//! gives the first `N` coefficients of `f(start + s direction)` in `s`.
//! For a polynomial of degree below `N` these are all its coefficients,
//! exactly as the arithmetic rounds them; the polynomial route solves
//! them (see [`crate::expr::univariate`]). A series carries a running
//! bound on the sum of its coefficients' errors: the errors of its
//! operands carried through the operation, the operation's own rounding,
//! and the line form's error bound for the path's coordinates. One number
//! is enough: every Bernstein coefficient on `[0, 1]` is a combination of
//! the power coefficients with weights in `[0, 1]`, so the sum bounds each
//! one's error, and it keeps a series small to copy.
//!
//! Addition, multiplication, squares, whole powers and division by
//! constants are exact truncations. The other operations (a quotient by a
//! series included) are not needed by polynomials and give NaN
//! coefficients, so a tape that is not a polynomial cannot be mistaken
//! for one.

use std::ops::{Add, Div, Mul, Neg, Sub};

use super::number::{LineForm, Number};

/// `C(n, k)` for `n, k <= 48`, exact (all below 2^53).
static BINOMIALS: [[f64; 49]; 49] = binomials();

const fn binomials() -> [[f64; 49]; 49] {
    let mut table = [[0.0; 49]; 49];
    let mut row = [0u64; 49];
    row[0] = 1;
    let mut n = 0;
    while n < 49 {
        // Row n from row n - 1, in place from the right.
        let mut k = n;
        while k > 0 {
            row[k] += row[k - 1];
            k -= 1;
        }
        let mut j = 0;
        while j <= n {
            table[n][j] = row[j] as f64;
            j += 1;
        }
        n += 1;
    }
    table
}

/// The first `N` Taylor coefficients of a function of one parameter `s`
/// about `s = 0`, with their errors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Taylor<const N: usize> {
    /// Coefficients of `s^0 .. s^(N-1)`; those above `degree` are 0.
    pub coefficients: [f64; N],
    /// A bound on the sum of how far each coefficient may be from the
    /// exact one.
    pub error: f64,
    /// The highest coefficient that may be non-zero, so products skip the
    /// zeros above it.
    pub degree: usize,
}

impl<const N: usize> Taylor<N> {
    /// The affine function `value + slope s`.
    pub fn variable(value: f64, slope: f64) -> Self {
        let mut t = Self::constant(value);
        if N > 1 {
            t.coefficients[1] = slope;
            t.degree = 1;
        }
        t
    }

    fn undefined() -> Self {
        Taylor {
            coefficients: [f64::NAN; N],
            error: f64::NAN,
            degree: N - 1,
        }
    }

    /// This series times the constant `k` (itself exact).
    fn scaled(mut self, k: f64) -> Self {
        for c in &mut self.coefficients[..=self.degree] {
            *c *= k;
        }
        self.error = self.error * k.abs() + ROUNDING * self.size();
        self
    }

    /// A sum or difference, coefficient by coefficient: the operands'
    /// errors add, and each coefficient rounds once.
    #[inline(always)]
    fn combine(mut self, o: Self, op: impl Fn(f64, f64) -> f64) -> Self {
        let degree = self.degree.max(o.degree);
        let used = if N <= SMALL { N } else { degree + 1 };
        for i in 0..used {
            self.coefficients[i] = op(self.coefficients[i], o.coefficients[i]);
        }
        self.degree = degree;
        self.error += o.error + ROUNDING * self.size();
        self
    }

    /// `(a + b s)^n` for a series of degree at most one (a coordinate
    /// along a line), by the binomial theorem: `n + 1` terms where
    /// repeated squaring takes about `log2(n)` full products, with an
    /// error bound that does not grow with each product's rounding.
    /// Coefficient k is `C(n, k) a^(n-k) b^k`, each power a run of
    /// multiplications and each binomial exact (n <= 48), so it rounds at
    /// most `n + 2` times: within `(n + 2) u` of itself, and the sizes sum
    /// to at most `S^n`, `S = |a| + |b|`. A base off by `E` in l1 norm
    /// (which products do not grow) is off by at most `(S + E)^n - S^n <=
    /// n E (S + E)^(n - 1)` after it.
    fn affine_power(self, n: u32) -> Self {
        debug_assert!(self.degree <= 1 && (1..=48).contains(&n));
        let a = self.coefficients[0];
        let b = if N > 1 && self.degree == 1 {
            self.coefficients[1]
        } else {
            0.0
        };
        let n_us = n as usize;
        let top = if b == 0.0 { 0 } else { n_us.min(N - 1) };
        // a^(n - k) for k = top down to 0, as one run of multiplications
        // (the powers coefficient k needs), held for k's up to N.
        let mut powers_of_a = [1.0; N];
        let mut power = 1.0;
        for _ in 0..n_us - top {
            power *= a;
        }
        for k in (0..=top).rev() {
            powers_of_a[k] = power;
            power *= a;
        }
        let binomials = &BINOMIALS[n_us];
        let mut coefficients = [0.0; N];
        let mut power_of_b = 1.0;
        for (k, c) in coefficients.iter_mut().enumerate().take(top + 1) {
            *c = binomials[k] * powers_of_a[k] * power_of_b;
            power_of_b *= b;
        }
        let size = a.abs() + b.abs();
        let nf = n as f64;
        // S^n and (S + E)^(n - 1) by runs of products (no `powi` call).
        let (mut size_n, mut grown) = (1.0, 1.0);
        for _ in 1..n_us {
            size_n *= size;
            grown *= size + self.error;
        }
        size_n *= size;
        let propagated = if self.error == 0.0 {
            0.0
        } else {
            nf * self.error * grown
        };
        let rounding = (nf + 2.0) * ROUNDING * size_n;
        // The bound's own arithmetic (the powers above), generously.
        let error = (propagated + rounding) * (1.0 + 8.0 * (nf + 2.0) * f64::EPSILON);
        Taylor {
            coefficients,
            error,
            degree: top,
        }
    }

    /// The sum of the coefficients' sizes (their l1 norm): what bounds
    /// the rounding of an operation on them.
    #[inline]
    fn size(&self) -> f64 {
        if N <= SMALL {
            self.coefficients.iter().map(|c| c.abs()).sum()
        } else {
            self.coefficients[..=self.degree]
                .iter()
                .map(|c| c.abs())
                .sum()
        }
    }
}

/// The unit roundoff, generously: one rounding of an operation's result
/// is at most this much of its size, with room for the rounding of the
/// error bounds themselves.
const ROUNDING: f64 = 1.01 * f64::EPSILON;

/// Up to this many coefficients, loops run over all of them (the ones
/// above the degree are zero): fixed bounds unroll and vectorise, which
/// is faster than skipping the zeros.
const SMALL: usize = 9;

impl<const N: usize> Add for Taylor<N> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        self.combine(o, |a, b| a + b)
    }
}

impl<const N: usize> Sub for Taylor<N> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        self.combine(o, |a, b| a - b)
    }
}

impl<const N: usize> Neg for Taylor<N> {
    type Output = Self;
    #[inline]
    fn neg(mut self) -> Self {
        for c in &mut self.coefficients[..=self.degree] {
            *c = -*c;
        }
        self
    }
}

impl<const N: usize> Mul for Taylor<N> {
    type Output = Self;
    #[inline]
    fn mul(self, o: Self) -> Self {
        // Constants as written are exact: a product with one scales.
        if o.degree == 0 && o.error == 0.0 {
            return self.scaled(o.coefficients[0]);
        }
        if self.degree == 0 && self.error == 0.0 {
            return o.scaled(self.coefficients[0]);
        }
        let degree = (self.degree + o.degree).min(N - 1);
        let mut coefficients = [0.0; N];
        if N <= SMALL {
            for i in 0..N {
                let a = self.coefficients[i];
                for j in 0..N - i {
                    coefficients[i + j] += a * o.coefficients[j];
                }
            }
        } else {
            for (i, &a) in self.coefficients[..=self.degree].iter().enumerate() {
                let m = o.degree.min(degree - i);
                for (c, &b) in coefficients[i..=i + m]
                    .iter_mut()
                    .zip(&o.coefficients[..=m])
                {
                    *c += a * b;
                }
            }
        }
        // The sum of |errors| of a product's coefficients is at most
        // |a| Eb + Ea |b| + Ea Eb in l1 norms; each coefficient sums at
        // most N products, N roundings of terms whose sizes sum to at most
        // |a| |b|.
        let (sa, sb) = (self.size(), o.size());
        let error =
            sa * o.error + self.error * (sb + o.error) + (N as f64 + 1.0) * ROUNDING * sa * sb;
        Taylor {
            coefficients,
            error,
            degree,
        }
    }
}

impl<const N: usize> Div for Taylor<N> {
    type Output = Self;
    /// Division by a constant series (exact truncation, the divisor's
    /// error carried); by anything else the quotient is not a polynomial,
    /// and every coefficient is NaN, as for the other non-polynomial
    /// operations.
    #[inline]
    fn div(self, o: Self) -> Self {
        if o.degree != 0 {
            return Self::undefined();
        }
        let b0 = o.coefficients[0];
        // The divisor's own error, to first order, and the reciprocal's
        // extra rounding.
        let relative = o.error / b0.abs() + 2.0 * ROUNDING;
        let mut r = self.scaled(1.0 / b0);
        r.error += relative * r.size();
        r
    }
}

impl<const N: usize> Number for Taylor<N> {
    undefined_beyond_polynomials!();

    #[inline]
    fn constant(c: f64) -> Self {
        let mut coefficients = [0.0; N];
        coefficients[0] = c;
        Taylor {
            coefficients,
            error: 0.0,
            degree: 0,
        }
    }

    #[inline]
    fn along(t: Self, form: &LineForm) -> Self {
        // The form's error bound covers alpha + beta t for t within its
        // reach, computed; the slope's error adds to the higher terms.
        let size = t.size();
        let mut r = t;
        for c in &mut r.coefficients[..=r.degree] {
            *c *= form.beta;
        }
        r.coefficients[0] += form.alpha;
        // An affine error within `err` over `[0, 1]` has coefficients whose
        // sizes sum to at most 3 err.
        r.error = t.error * (form.beta.abs() + form.slope_err)
            + size * form.slope_err
            + 3.0 * form.err
            + ROUNDING * r.size();
        r
    }

    fn constant_value(self) -> Option<f64> {
        (self.degree == 0).then_some(self.coefficients[0])
    }

    /// Each cross term once, doubled: half a product's work (for few
    /// coefficients the product's fixed loops are faster).
    #[inline]
    fn square(self) -> Self {
        if self.degree <= 1 {
            return self.affine_power(2);
        }
        if N <= SMALL {
            return self * self;
        }
        if self.degree == 0 && self.error == 0.0 {
            return Self::constant(self.coefficients[0] * self.coefficients[0]);
        }
        let da = self.degree;
        let degree = (2 * da).min(N - 1);
        let mut coefficients = [0.0; N];
        let a = &self.coefficients[..=da];
        for (i, &ai) in a.iter().enumerate() {
            if 2 * i > degree {
                break;
            }
            coefficients[2 * i] += ai * ai;
            let twice = 2.0 * ai;
            let m = da.min(degree - i);
            for (c, &aj) in coefficients[2 * i + 1..=i + m].iter_mut().zip(&a[i + 1..]) {
                *c += twice * aj;
            }
        }
        let size = self.size();
        let error =
            self.error * (2.0 * size + self.error) + (N as f64 + 1.0) * ROUNDING * size * size;
        Taylor {
            coefficients,
            error,
            degree,
        }
    }

    /// A whole non-negative constant exponent, by repeated squaring; NaN
    /// coefficients otherwise.
    fn pow(self, e: Self) -> Self {
        match e.constant_value() {
            Some(0.0) => Self::constant(1.0),
            Some(n) if self.degree <= 1 && n.fract() == 0.0 && (1.0..=48.0).contains(&n) => {
                self.affine_power(n as u32)
            }
            Some(n) if n >= 0.0 && n.fract() == 0.0 && n <= 64.0 => {
                let mut n = n as u32;
                let mut result = Self::constant(1.0);
                let mut base = self;
                while n > 0 {
                    if n & 1 == 1 {
                        result = result * base;
                    }
                    n >>= 1;
                    if n > 0 {
                        base = base * base;
                    }
                }
                result
            }
            _ => Self::undefined(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `(1 + 2s)^3 - s (3 - s)` expanded by the series arithmetic matches
    /// the coefficients worked out by hand: 1 + 3s + 13s^2 + 8s^3.
    #[test]
    fn products_and_powers_expand_a_polynomial() {
        type T = Taylor<6>;
        let s = T::variable(0.0, 1.0);
        let one = T::constant(1.0);
        let a = (one + T::constant(2.0) * s).pow(T::constant(3.0));
        let b = s * (T::constant(3.0) - s);
        let p = a - b;
        assert_eq!(p.degree, 3);
        assert_eq!(&p.coefficients[..4], &[1.0, 3.0, 13.0, 8.0]);
        assert_eq!(p.coefficients[4], 0.0);
        // Small numbers, so every error bound is a few roundings.
        assert!(p.error > 0.0 && p.error < 1e-12, "{}", p.error);
    }

    /// A line coordinate's powers by the binomial theorem: exact
    /// coefficients for small whole numbers, and an error bound that
    /// covers a base moved anywhere within its stated error.
    #[test]
    fn powers_of_a_line_coordinate() {
        type T = Taylor<17>;
        for (a, b) in [
            (1.0, 2.0),
            (-3.0, 1.0),
            (2.0, -3.0),
            (0.0, 1.0),
            (-1.0, 0.0),
        ] {
            for n in 1..=12u32 {
                let p = T::variable(a, b).pow(T::constant(n as f64));
                let mut binomial: i128 = 1;
                for k in 0..=n as usize {
                    let exact =
                        binomial * (a as i128).pow(n - k as u32) * (b as i128).pow(k as u32);
                    assert_eq!(p.coefficients[k], exact as f64, "({a} + {b}s)^{n}, s^{k}");
                    binomial = binomial * (n as i128 - k as i128) / (k as i128 + 1);
                }
                assert_eq!(p.degree, if b == 0.0 { 0 } else { n as usize });
            }
        }
        // A base known to within 1e-3 (split over its two coefficients in
        // any proportion) stays within the bound after the power.
        let mut base = T::variable(0.7, -1.3);
        base.error = 1e-3;
        for n in [2u32, 5, 8, 13] {
            let p = base.pow(T::constant(n as f64));
            for share in [0.0, 0.3, 1.0] {
                for signs in [(1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)] {
                    let moved = T::variable(
                        0.7 + signs.0 * share * 1e-3,
                        -1.3 + signs.1 * (1.0 - share) * 1e-3,
                    );
                    let mut q = T::constant(1.0);
                    for _ in 0..n {
                        q = q * moved;
                    }
                    let off: f64 = (0..17)
                        .map(|k| (q.coefficients[k] - p.coefficients[k]).abs())
                        .sum();
                    assert!(off <= p.error, "n = {n}: off by {off}, bound {}", p.error);
                }
            }
            // Not wildly loose: within 4x of the first-order change.
            assert!(
                p.error < 4.0 * n as f64 * 1e-3 * 2.0f64.powi(n as i32 - 1) * 1.01,
                "{}",
                p.error
            );
        }
    }

    /// Division by a constant scales, with the divisor's rounding in the
    /// error; by a series it is not a polynomial, and is undefined.
    #[test]
    fn division_by_constants_only() {
        type T = Taylor<5>;
        let s = T::variable(2.0, 0.5);
        let p = s * s + T::constant(1.0);
        let h = p / T::constant(4.0);
        assert_eq!(&h.coefficients[..3], &[5.0 / 4.0, 0.5, 1.0 / 16.0]);
        assert_eq!(h.degree, 2);
        assert!(h.error > 0.0 && h.error < 1e-14, "{}", h.error);
        assert!((p / s).coefficients.iter().all(|c| c.is_nan()));
    }

    /// Non-polynomial operations poison every coefficient.
    #[test]
    fn other_operations_are_undefined() {
        let s = Taylor::<4>::variable(1.0, 1.0);
        assert!(s.sin().coefficients.iter().all(|c| c.is_nan()));
        assert!(s.pow(Taylor::constant(0.5)).coefficients[0].is_nan());
    }
}
