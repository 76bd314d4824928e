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

/// `tape`'s first output over the box `lo..hi` at points computed within
/// `input` of exact ones in each coordinate: each input and affine step
/// sized by its exact range over the box, its error from the inputs' and
/// its own rounding (as [`super::Tape::line_forms`] bounds them along a
/// line).
fn over_box(
    tape: &super::Tape,
    lo: glam::DVec3,
    hi: glam::DVec3,
    input: f64,
    slots: &mut Vec<Magnitude>,
) -> Magnitude {
    // As the line forms take it: generous for a sum of three products.
    const SLACK: f64 = 8.0 * f64::EPSILON;
    let (middle, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    let form = |c: &[f64; 4]| {
        let (mut centre, mut spread, mut terms, mut weight) = (c[3], 0.0, c[3].abs(), 0.0);
        for axis in 0..3 {
            if c[axis] != 0.0 {
                centre += c[axis] * middle[axis];
                spread += c[axis].abs() * half[axis];
                terms += c[axis].abs() * lo[axis].abs().max(hi[axis].abs());
                weight += c[axis].abs();
            }
        }
        // The range's bound from rounded middles and halves: a few units
        // of the terms' sizes more.
        Magnitude::bounds(
            centre.abs() + spread + terms * SLACK,
            terms * SLACK + weight * input * (1.0 + SLACK) + TINY,
        )
    };
    tape.eval_with_forms(
        slots,
        |i| match i {
            0..=2 => {
                let mut c = [0.0; 4];
                c[i as usize] = 1.0;
                form(&c)
            }
            _ => Magnitude::undefined(),
        },
        form,
    )
}

/// How far a polynomial's `f64` value may be from its exact value at
/// points of a box, computed within some error of exact ones: a table
/// made once per object and render, which a straight path's stretch reads
/// in place of its own [`Magnitude`] pass (a tenth of the Chmutov
/// octic's render).
///
/// A pass's bound is a polynomial in the inputs' error `e` with
/// non-negative coefficients, so convex in it, and below its chord:
/// `E(e) <= E(0) + (E(top) - E(0)) e / top` for `e <= top`. Over a box
/// it also only grows with the box. The table holds `E(0)` and that
/// slope for the cells of grids of 1, 2, 4 and 8 cells a side over the
/// object's bound; a stretch reads the finest grid where its own box
/// (its ends' and their rounding) spans at most two cells a side, and
/// takes the largest of those.
#[derive(Debug, Clone, PartialEq)]
pub struct ValueErrors {
    /// The bound's corner and a finest cell's size.
    corner: glam::DVec3,
    cell: glam::DVec3,
    /// How far outside the bound a stretch's box may reach: the cells are
    /// tested that much larger.
    margin: f64,
    /// The largest input error the slopes hold for.
    top: f64,
    /// Per grid, coarsest first, per cell `i + n (j + n k)`: the error at
    /// exact inputs and its slope in the inputs' error.
    levels: Vec<Vec<(f64, f64)>>,
}

impl ValueErrors {
    /// Cells a side of the finest grid: 2^LEVELS.
    const LEVELS: u32 = 3;
    /// Inputs computed from paths whose start and reach are up to this
    /// many times the bound's size are served; a farther one takes its
    /// own pass.
    const FARTHEST: f64 = 1024.0;
    /// The error of a computed point `o + t d` in each coordinate, as a
    /// multiple of `eps (|o| + |d| |t|)`: the parameter's rounding, the
    /// product's and the sum's make 4, with room to spare (the line forms
    /// take 8).
    const POINT_ROUNDING: f64 = 16.0 * f64::EPSILON;

    /// The table for `tape` (a polynomial in x, y and z) over the box
    /// `lo..hi`; `None` where a bound is not finite (not a polynomial, or
    /// sizes that overflow).
    pub fn over_box(tape: &super::Tape, lo: glam::DVec3, hi: glam::DVec3) -> Option<ValueErrors> {
        let scale = lo.abs().max(hi.abs()).max_element() + (hi - lo).max_element();
        if !(scale.is_finite() && scale > 0.0) {
            return None;
        }
        // A path's stretch is clipped to the bound with a margin of about
        // 1e-9 of its coordinates, and its box includes its rounding.
        let margin = 1e-6 * scale;
        let top = Self::POINT_ROUNDING * Self::FARTHEST * scale;
        let mut slots = Vec::new();
        let mut levels = Vec::new();
        for level in 0..=Self::LEVELS {
            let n = 1usize << level;
            let size = (hi - lo) / n as f64;
            let mut cells = Vec::with_capacity(n * n * n);
            for k in 0..n {
                for j in 0..n {
                    for i in 0..n {
                        let at = glam::DVec3::new(i as f64, j as f64, k as f64);
                        let (a, b) = (
                            lo + at * size - glam::DVec3::splat(margin),
                            lo + (at + 1.0) * size + glam::DVec3::splat(margin),
                        );
                        let exact = over_box(tape, a, b, 0.0, &mut slots).error;
                        let far = over_box(tape, a, b, top, &mut slots).error;
                        let slope = (far - exact) / top;
                        if !(exact.is_finite() && slope.is_finite()) {
                            return None;
                        }
                        cells.push((exact, slope.max(0.0)));
                    }
                }
            }
            levels.push(cells);
        }
        Some(ValueErrors {
            corner: lo,
            cell: (hi - lo) / (1u32 << Self::LEVELS) as f64,
            margin,
            top,
            levels,
        })
    }

    /// The bound for the points of the line `o + t d` computed at `t` from
    /// `from` to `to`, or `None` when they reach past the bound or start
    /// too far for the table.
    #[inline]
    pub fn along(&self, o: glam::DVec3, d: glam::DVec3, from: f64, to: f64) -> Option<f64> {
        let reach = from.abs().max(to.abs());
        let input = Self::POINT_ROUNDING * (o.abs().max_element() + d.abs().max_element() * reach);
        if !(input <= self.top && input <= self.margin) {
            return None;
        }
        let (p, q) = (o + from * d, o + to * d);
        let finest = 1i64 << Self::LEVELS;
        // The stretch's box in finest cells, each end rounded outward.
        let mut first = [0i64; 3];
        let mut last = [0i64; 3];
        for axis in 0..3 {
            let (a, b) = (p[axis].min(q[axis]), p[axis].max(q[axis]));
            let low = (a - input - self.corner[axis]) / self.cell[axis];
            let high = (b + input - self.corner[axis]) / self.cell[axis];
            // Past the bound by more than the cells' margin: not served.
            let slack = self.margin / self.cell[axis];
            if !(low >= -slack && high <= finest as f64 + slack) {
                return None;
            }
            first[axis] = (low.floor() as i64).clamp(0, finest - 1);
            last[axis] = (high.floor() as i64).clamp(0, finest - 1);
        }
        // The finest grid where the box spans at most three cells a side.
        let mut level = Self::LEVELS;
        loop {
            let shift = Self::LEVELS - level;
            let spans = (0..3).all(|a| (last[a] >> shift) - (first[a] >> shift) <= 2);
            if spans || level == 0 {
                break;
            }
            level -= 1;
        }
        let shift = Self::LEVELS - level;
        let n = 1i64 << level;
        let cells = &self.levels[level as usize];
        let mut worst = 0.0f64;
        for k in first[2] >> shift..=last[2] >> shift {
            for j in first[1] >> shift..=last[1] >> shift {
                for i in first[0] >> shift..=last[0] >> shift {
                    let (exact, slope) = cells[(i + n * (j + n * k)) as usize];
                    worst = worst.max(exact + slope * input);
                }
            }
        }
        Some(worst)
    }
}
