//! Sine and cosine with a stated error, for interval enclosures: an
//! argument reduced once to a quadrant and a remainder in [-pi/4, pi/4],
//! and fdlibm's minimax kernels on the remainder.
//!
//! Input: an f64 argument, or an interval's ends, of magnitude at most
//! [`REDUCIBLE`]. Output: sin or cos within [`ERROR`] ([`shifted_sin`]),
//! or an interval's bounds ([`sin_over`]), from one reduction per end and
//! no branch, so that loops over lanes vectorise.
//!
//! Why not libm: an interval's sine needs sin at both ends and the
//! position of the ends between the extremes. With libm that is two
//! reductions per end inside `sin` plus a division and a `ceil` per
//! extreme; on trigonometric surfaces (the gyroid) that was two thirds of
//! the render. One reduction here gives all of it, and the error is known,
//! which is what an enclosure needs.

// The constants are fdlibm's, digit for digit as published, so that they
// can be checked against its source.
#![allow(clippy::excessive_precision)]

use std::f64::consts::FRAC_2_PI;

/// Arguments up to this magnitude are reduced here: `n * PIO2_1` and
/// `n * PIO2_2` are exact products for quadrant numbers below 2^20.
pub const REDUCIBLE: f64 = 1.0e6;

/// A bound on the absolute error of [`shifted_sin`]
/// for any argument up to [`REDUCIBLE`]: the kernels' approximation error
/// (under 2^-58), their evaluation in floating point (a few ulps of
/// numbers at most 1) and the remainder's rounding (an ulp of the
/// remainder plus `n` times the third part's truncation, about 1e-25 at
/// the largest `n`). Four times what those add up to.
pub const ERROR: f64 = 8.0 * f64::EPSILON;

// pi/2 in three parts: the first two have 33 significant bits, so their
// products with a quadrant number below 2^20 are exact (fdlibm's
// __ieee754_rem_pio2).
const PIO2_1: f64 = 1.570_796_326_734_125_614_17e0;
const PIO2_2: f64 = 6.077_100_506_303_965_976_6e-11;
const PIO2_2T: f64 = 2.022_266_248_795_950_631_54e-21;

/// sin(x) within [`ERROR`] up to [`REDUCIBLE`], libm's beyond: the
/// point evaluator's sine, so that points and intervals agree on one
/// kernel.
#[inline]
pub fn sin(x: f64) -> f64 {
    if x.abs() <= REDUCIBLE {
        shifted_sin(x, 0)
    } else {
        x.sin()
    }
}

/// cos(x), as [`sin`].
#[inline]
pub fn cos(x: f64) -> f64 {
    if x.abs() <= REDUCIBLE {
        shifted_sin(x, 1)
    } else {
        x.cos()
    }
}

/// [`sin`] and [`cos`] of one argument, bit for bit, from one reduction
/// and one pair of kernels (a formula with both, like the gyroid's,
/// pays for one).
#[inline]
pub fn sin_and_cos(x: f64) -> (f64, f64) {
    if x.abs() <= REDUCIBLE {
        let (_, r, q) = reduce(x);
        let k = kernels(r);
        (quadrant_value(k, q), quadrant_value(k, q.wrapping_add(1)))
    } else {
        (x.sin(), x.cos())
    }
}

/// sin(x + quadrants pi/2) for `|x|` within [`REDUCIBLE`], within
/// [`ERROR`]: the shift is exact, where adding a rounded pi/2 is not.
/// Branch-free, for lanes.
#[inline(always)]
pub fn shifted_sin(x: f64, quadrants: u64) -> f64 {
    let (_, r, q) = reduce(x);
    sin_in_quadrant(r, q.wrapping_add(quadrants))
}

/// `x` as `n pi/2 + r`: `n` (a whole number, as a float), `r`, and `n`
/// modulo 4 in the low bits of the third value. Branch-free, so that a
/// loop over lanes vectorises.
#[inline(always)]
fn reduce(x: f64) -> (f64, f64, u64) {
    // Round to nearest by the 1.5 * 2^52 shift (`f64::round` is a libm
    // call on the baseline x86-64 target); the shifted sum's low mantissa
    // bits are then `n` itself, modulo 4 included.
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    let shifted = x * FRAC_2_PI + SHIFT;
    let n = shifted - SHIFT;
    // x - n PIO2_1 is exact (the two are within a factor of two of each
    // other, or n is 0); each further step rounds once.
    let rest = ((x - n * PIO2_1) - n * PIO2_2) - n * PIO2_2T;
    (n, rest, shifted.to_bits())
}

/// sin of `quadrant pi/2 + r` (the quadrant modulo 4 in its low bits),
/// branch-free: both kernels, one chosen, the sign flipped by a bit.
#[inline(always)]
fn sin_in_quadrant(r: f64, quadrant: u64) -> f64 {
    quadrant_value(kernels(r), quadrant)
}

/// Both kernels at `r`: sin and cos on [-pi/4, pi/4].
#[inline(always)]
fn kernels(r: f64) -> (f64, f64) {
    (kernel(r, false), kernel(r, true))
}

/// sin of `quadrant pi/2 + r` from the kernels at `r`.
#[inline(always)]
fn quadrant_value((s, c): (f64, f64), quadrant: u64) -> f64 {
    let v = if quadrant & 1 == 0 { s } else { c };
    f64::from_bits(v.to_bits() ^ ((quadrant & 2) << 62))
}

/// A whole number from 0 to 3 as a float, without an integer conversion
/// (which the baseline target cannot do across vector lanes).
#[inline(always)]
fn small_float(d: u64) -> f64 {
    const TWO_52: f64 = 4_503_599_627_370_496.0;
    f64::from_bits(TWO_52.to_bits() | d) - TWO_52
}

/// The bounds of sin(x + quadrants pi/2) over `[lo, hi]`, for ends within
/// [`REDUCIBLE`] and `hi - lo` below 2 pi: the values at the ends, moved
/// out by [`ERROR`], and 1 or -1 where the interval passes a maximum or a
/// minimum. Between consecutive multiples of pi/2 the function is
/// monotone and its extremes sit on those multiples; a boundary misjudged
/// within rounding of an end misses an extreme by the square of that
/// distance, far inside the error allowed. Branch-free, for lanes.
#[inline(always)]
pub fn sin_over(lo: f64, hi: f64, quadrants: u64) -> (f64, f64) {
    let (l, h) = (reduce(lo), reduce(hi));
    over(l, h, kernels(l.1), kernels(h.1), quadrants)
}

/// [`sin_over`] for sine and cosine (quadrants 0 and 1) of one interval,
/// bit for bit, from one reduction of each end and one pair of kernels.
#[inline(always)]
pub fn sin_cos_over(lo: f64, hi: f64) -> ((f64, f64), (f64, f64)) {
    let (l, h) = (reduce(lo), reduce(hi));
    let (kl, kh) = (kernels(l.1), kernels(h.1));
    (over(l, h, kl, kh, 0), over(l, h, kl, kh, 1))
}

/// [`sin_over`] from the ends' reductions and kernels.
#[inline(always)]
fn over(
    (n_lo, r_lo, q_lo): (f64, f64, u64),
    (n_hi, r_hi, q_hi): (f64, f64, u64),
    k_lo: (f64, f64),
    k_hi: (f64, f64),
    quadrants: u64,
) -> (f64, f64) {
    let a = quadrant_value(k_lo, q_lo.wrapping_add(quadrants));
    let b = quadrant_value(k_hi, q_hi.wrapping_add(quadrants));
    let mut bottom = if a < b { a } else { b } - ERROR;
    let mut top = if a > b { a } else { b } + ERROR;
    // The first boundary at or after `lo` and the last at or before `hi`,
    // numbered as quadrants.
    let after = r_lo > 0.0;
    let first = n_lo + if after { 1.0 } else { 0.0 };
    let last = n_hi - if r_hi < 0.0 { 1.0 } else { 0.0 };
    let first_shifted = q_lo.wrapping_add(after as u64).wrapping_add(quadrants);
    // Shifted quadrant 1 is a maximum of sine, 3 a minimum.
    let to_top = small_float(1u64.wrapping_sub(first_shifted) & 3);
    let to_bottom = small_float(3u64.wrapping_sub(first_shifted) & 3);
    if first + to_top <= last {
        top = 1.0;
    }
    if first + to_bottom <= last {
        bottom = -1.0;
    }
    (
        if bottom > -1.0 { bottom } else { -1.0 },
        if top < 1.0 { top } else { 1.0 },
    )
}

/// sin (`odd` false) or cos (`odd` true) on [-pi/4, pi/4]: `r P(r^2)` or
/// `Q(r^2)` with fdlibm's minimax coefficients (__kernel_sin and
/// __kernel_cos, each within 2^-58), chosen from a table rather than by a
/// branch, since the quadrant is as good as random along a search and a
/// mispredicted branch costs more than the polynomial.
#[inline]
fn kernel(r: f64, odd: bool) -> f64 {
    const TABLE: [[f64; 8]; 2] = [
        [
            1.0,
            -1.666_666_666_666_663_243_48e-1,
            8.333_333_333_322_489_461_24e-3,
            -1.984_126_982_985_794_931_34e-4,
            2.755_731_370_707_006_767_89e-6,
            -2.505_076_025_340_686_341_95e-8,
            1.589_690_995_211_550_102_21e-10,
            0.0,
        ],
        [
            1.0,
            -0.5,
            4.166_666_666_666_660_190_37e-2,
            -1.388_888_888_887_410_957_49e-3,
            2.480_158_728_947_672_941_78e-5,
            -2.755_731_435_139_066_330_35e-7,
            2.087_572_321_298_174_827_90e-9,
            -1.135_964_755_778_819_482_65e-11,
        ],
    ];
    let c = &TABLE[odd as usize];
    let z = r * r;
    let p = c[0]
        + z * (c[1] + z * (c[2] + z * (c[3] + z * (c[4] + z * (c[5] + z * (c[6] + z * c[7]))))));
    if odd {
        p
    } else {
        r * p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against libm (within an ulp of the true value) over a dense sweep
    /// and at quadrant boundaries up to the largest reducible argument.
    #[test]
    fn agrees_with_libm_within_the_stated_error() {
        let mut worst: f64 = 0.0;
        let mut check = |x: f64| {
            worst = worst.max((sin(x) - x.sin()).abs());
            worst = worst.max((cos(x) - x.cos()).abs());
            let (_, rest, _) = reduce(x);
            assert!(rest.abs() <= std::f64::consts::FRAC_PI_4 + 1e-12, "{x}");
        };
        for i in -200_000..=200_000 {
            check(i as f64 * 1.37e-4);
        }
        for k in [1i64, 2, 3, 7, 100, 12345, 600_000] {
            let b = k as f64 * std::f64::consts::FRAC_PI_2;
            for x in [b, b.next_up(), b.next_down(), -b, b + 0.785, b - 0.785] {
                check(x);
            }
        }
        for x in [999_999.9, -999_999.9, 123_456.789, 1e-300, 0.0, -0.0] {
            check(x);
        }
        assert!(worst <= ERROR / 4.0, "worst error {worst:e}");
    }

    #[test]
    fn past_the_reducible_range_libm_answers() {
        for x in [2e6, -3.7e9, 1e300] {
            assert_eq!((sin(x), cos(x)), (x.sin(), x.cos()));
        }
        assert!(sin(f64::NAN).is_nan() && cos(f64::INFINITY).is_nan());
    }
}
