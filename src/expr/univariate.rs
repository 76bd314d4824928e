//! The first real root of a polynomial in one variable on `[0, 1]`, by
//! subdivision of its Bernstein form, with the coefficients' rounding
//! error taken into account.
//!
//! Input: the power-form coefficients `a_k` of `p(s) = sum a_k s^k` and a
//! bound on the sum of their errors, or `p`'s values at the nodes of an
//! [`Interpolation`] and a bound on their errors. Output: the smallest
//! root in `[0, 1]` to a tolerance, none, or "out of steps".
//!
//! On `[0, 1]` the Bernstein coefficients `b_i` of `p` bound it (`p` lies
//! in their hull, the convex-hull property), and the number of sign
//! changes among them bounds the number of roots (Descartes' rule of signs
//! for the Bernstein basis). The search clips from the left: with
//! `p(lo) > 0`, the steepest line from the first coefficient below all
//! the others (each lowered by its error) lies below `p`, so no root
//! comes before that line crosses zero; the piece is cut there (de
//! Casteljau), which converges quadratically on a simple root (Bezier
//! clipping, one-sided), or halved when the cut would be small (roots
//! close together), leftmost half first. The first point where `p` is
//! within its error of zero, or a piece narrower than the tolerance that
//! cannot be excluded (a tangency, a double root), is the root. **No root of the polynomial the coefficients describe, to
//! within their error, is ever missed.**

/// What the search found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FirstRoot {
    /// The smallest root, within the tolerance.
    At(f64),
    /// No root before this point, where the polynomial is within its
    /// coefficients' error of zero: the root is here as far as the
    /// coefficients can tell, which may be less exact than the tolerance
    /// (near a singular point of the surface, where the value is flat).
    Near(f64),
    /// No root in `[0, 1]`.
    None,
    /// The piece budget ran out before `[0, 1]` was settled.
    OutOfSteps,
}

/// Reused buffers for [`first_root_of_bernstein`].
#[derive(Debug, Default, Clone)]
pub struct RootScratch {
    stack: Vec<f64>,
    work: Vec<f64>,
    slopes: Vec<f64>,
}

/// The Bernstein coefficients on `[0, 1]` of `sum power[k] s^k`, into
/// `out`, where `error` bounds the sum of the power coefficients' errors;
/// returns a bound on each Bernstein coefficient's error.
pub fn power_to_bernstein(power: &[f64], error: f64, out: &mut Vec<f64>) -> f64 {
    let n = power.len() - 1;
    out.clear();
    out.extend_from_slice(power);
    // b_i = sum_k C(i, k) / C(n, k) a_k, the binomial transform of
    // a_k / C(n, k), as n passes of adjacent sums. The weights lie in
    // [0, 1], so each b_i is off by at most `error`.
    let mut binomial = 1.0;
    for (k, c) in out.iter_mut().enumerate() {
        *c /= binomial;
        binomial = binomial * (n - k) as f64 / (k + 1) as f64;
    }
    for pass in 1..=n {
        for i in (pass..=n).rev() {
            out[i] += out[i - 1];
        }
    }
    // The conversion's own rounding: n sums of at most the largest each.
    let largest = out.iter().fold(0.0f64, |m, b| m.max(b.abs()));
    error + 4.0 * n as f64 * f64::EPSILON * largest
}

/// The smallest root in `[0, 1]`, to within `tolerance` in `s`, of `p`
/// given by its Bernstein coefficients (`p(s) = sum bernstein[i] C(n, i)
/// s^i (1 - s)^(n - i)`), each off by at most `error`. Cuts pieces at
/// most `max_pieces` times; returns the number of cuts made. With `any`,
/// a piece proven to hold exactly one root is not refined: its middle is
/// returned (enough to know a path is blocked).
pub fn first_root_of_bernstein(
    bernstein: &[f64],
    error: f64,
    tolerance: f64,
    max_pieces: u64,
    any: bool,
    scratch: &mut RootScratch,
) -> (FirstRoot, u64) {
    // The search with the degree a constant, for the degrees users write:
    // its loops unroll (Chmutov's degree-8 searches took a third fewer
    // instructions, 710 M -> 453 M at 400 x 250).
    macro_rules! by_degree {
        ($($n:literal)*) => {
            match bernstein.len() - 1 {
                $($n => search(
                    $n, bernstein, error, tolerance, max_pieces, any, scratch,
                ),)*
                n => search(n, bernstein, error, tolerance, max_pieces, any, scratch),
            }
        };
    }
    by_degree!(2 3 4 5 6 7 8 9 10 11 12)
}

/// [`first_root_of_bernstein`] for `bernstein` of degree `n`.
#[inline(always)]
fn search(
    n: usize,
    bernstein: &[f64],
    error: f64,
    tolerance: f64,
    max_pieces: u64,
    any: bool,
    scratch: &mut RootScratch,
) -> (FirstRoot, u64) {
    scratch.stack.clear();
    scratch.stack.extend([0.0, 1.0]);
    scratch.stack.extend_from_slice(bernstein);
    let stride = n + 3;
    let RootScratch {
        stack,
        work,
        slopes,
    } = scratch;
    work.clear();
    work.resize(2 * (n + 1), 0.0);
    // n / i, the inverse of each coefficient's abscissa, once per search.
    if slopes.len() != n + 1 {
        slopes.clear();
        slopes.extend((0..=n).map(|i| n as f64 / i as f64));
    }
    let largest = stack[2..].iter().fold(0.0f64, |m, b| m.max(b.abs()));
    if !(stack[2..].iter().all(|b| b.is_finite()) && error.is_finite()) {
        return (FirstRoot::None, 0);
    }
    // The rounding of every later halving (averages never grow the
    // values), to a generous depth.
    let uncertainty = error + 4.0 * 64.0 * f64::EPSILON * largest + f64::MIN_POSITIVE;

    let mut steps = 0;
    while stack.len() >= stride {
        let top = stack.len() - stride;
        let (lo, hi) = (stack[top], stack[top + 1]);
        let b = &stack[top + 2..];
        // p(lo) is b_0: within its error of zero, lo is a root.
        if b[0].abs() <= uncertainty {
            return (FirstRoot::Near(lo), steps);
        }
        // With the signs made so that p(lo) > 0, q_i = b_i - error are
        // lower bounds of the exact coefficients, and the steepest line
        // from (0, q_0) below every (i/n, q_i) is below the polynomial
        // (Bernstein polynomials reproduce lines): no root before it
        // crosses zero, at `clear` in the piece's own [0, 1].
        let sign = if b[0] < 0.0 { -1.0 } else { 1.0 };
        let q0 = sign * b[0] - uncertainty;
        // One pass: the lowest lower bound, the steepest line, whether
        // every sign is certain, and how often the signs change.
        let (mut steepest, mut lowest) = (0.0f64, q0);
        let (mut certain, mut changes, mut negative) = (true, 0u32, b[0] < 0.0);
        for (&bi, &over) in b[1..].iter().zip(&slopes[1..]) {
            let qi = sign * bi - uncertainty;
            if qi < lowest {
                lowest = qi;
            }
            let slope = (q0 - qi) * over;
            if slope > steepest {
                steepest = slope;
            }
            certain &= bi.abs() > uncertainty;
            changes += u32::from((bi < 0.0) != negative);
            negative = bi < 0.0;
        }
        // Every coefficient above zero by more than its error: no root
        // (the convex hull property).
        let clear = if lowest > 0.0 || steepest <= 0.0 {
            f64::INFINITY
        } else {
            q0 / steepest
        };
        if clear >= 1.0 {
            stack.truncate(top);
            continue;
        }
        // Certain signs that change once: exactly one root (Descartes),
        // refined on `p`.
        if certain && changes == 1 {
            if any {
                return (FirstRoot::At(0.5 * (lo + hi)), steps);
            }
            return (refine(b, lo, hi, tolerance), steps);
        }
        if hi - lo <= tolerance {
            // Not excluded and no narrower: a touching root, or one the
            // coefficients' error cannot place more exactly.
            return (FirstRoot::Near(lo + clear * (hi - lo)), steps);
        }
        if steps >= max_pieces {
            return (FirstRoot::OutOfSteps, steps);
        }
        steps += 1;
        // Clip the part proven empty when it is a good share of the piece
        // (near a simple root the line is nearly the tangent, and the
        // clips converge quadratically); otherwise halve, leftmost half
        // first (several roots close together, or a touching one).
        let cut = if clear > 0.5 { clear } else { 0.5 };
        let at = lo + cut * (hi - lo);
        let (left, right) = work.split_at_mut(n + 1);
        right.copy_from_slice(&stack[top + 2..top + stride]);
        // de Casteljau at `cut`: in place, each pass leaves the entry past
        // its last untouched, so `right` ends as the right part's
        // coefficients, and the first entry of each pass is the left's.
        for (r, first) in left.iter_mut().enumerate() {
            *first = right[0];
            for i in 0..n - r {
                right[i] += cut * (right[i + 1] - right[i]);
            }
        }
        stack.truncate(top);
        stack.extend([at, hi]);
        stack.extend_from_slice(&work[n + 1..]);
        if cut == 0.5 {
            stack.extend([lo, at]);
            stack.extend_from_slice(&work[..n + 1]);
        }
    }
    (FirstRoot::None, steps)
}

/// `sum b_i C(n, i) s^i (1 - s)^(n - i)` for `s` in `[0, 1]`, by Horner's
/// rule in `s / (1 - s)` (or in `(1 - s) / s` past the middle, so the
/// ratio stays at most 1 and no term grows).
pub fn bernstein_value(b: &[f64], s: f64) -> f64 {
    let n = b.len() - 1;
    let (ratio, scale, reversed) = if s <= 0.5 {
        (s / (1.0 - s), 1.0 - s, false)
    } else {
        ((1.0 - s) / s, s, true)
    };
    let coefficient = |i: usize| if reversed { b[n - i] } else { b[i] };
    // p / scale^n = sum_i b_i C(n, i) ratio^i, Horner from the top.
    let mut binomial = 1.0;
    let mut acc = coefficient(n);
    for k in 1..=n {
        let i = n - k;
        binomial = binomial * (i + 1) as f64 / k as f64;
        acc = acc * ratio + coefficient(i) * binomial;
    }
    acc * scale.powi(n as i32)
}

/// The root in `[lo, hi]` of the polynomial whose Bernstein
/// coefficients on that piece are `piece`, where its ends' values differ
/// in sign: on the piece's power form (forward differences of its
/// coefficients), in the piece's own parameter, where the terms are no
/// larger than the coefficients. A value within the coefficients' error
/// of zero still has the computed polynomial's sign, and following it
/// stays inside the bracket (stopping there could pass the root by the
/// error's width, where the surface is flat).
#[inline(always)]
fn refine(piece: &[f64], lo: f64, hi: f64, tolerance: f64) -> FirstRoot {
    let n = piece.len() - 1;
    let mut power = [0.0; 49];
    let power = &mut power[..=n.min(48)];
    if n > 48 {
        return FirstRoot::At(0.5 * (lo + hi));
    }
    // a_k = C(n, k) (forward difference of order k of b at 0).
    power.copy_from_slice(piece);
    for pass in 1..=n {
        for i in (pass..=n).rev() {
            power[i] -= power[i - 1];
        }
    }
    let mut binomial = 1.0;
    for (k, a) in power.iter_mut().enumerate() {
        *a *= binomial;
        binomial = binomial * (n - k) as f64 / (k + 1) as f64;
    }
    let width = hi - lo;
    let s = newton_in_bracket(power, piece[0], piece[n], tolerance / width);
    FirstRoot::At((lo + s * width).clamp(lo, hi))
}

/// The root in `[0, 1]` of the polynomial with power coefficients
/// `power`, whose values at the ends, `at_0` and `at_1`, differ in sign,
/// to within `tolerance`: Newton's steps inside a bracket that every
/// value narrows, a halving where a step would leave it or would not be
/// half the one before (as `rtsafe` does in Numerical Recipes), and, once
/// a step is shorter than the tolerance, a value just past it, so that
/// the bracket closes on the root rather than creeping up to it from one
/// side as regula falsi does.
#[inline(always)]
fn newton_in_bracket(power: &[f64], at_0: f64, at_1: f64, tolerance: f64) -> f64 {
    const MOST_STEPS: usize = 200;
    let value_and_slope = |s: f64| {
        let (mut value, mut slope) = (0.0, 0.0);
        for &a in power.iter().rev() {
            slope = slope * s + value;
            value = value * s + a;
        }
        (value, slope)
    };
    let (mut a, mut b, mut fa) = (0.0, 1.0, at_0);
    if at_0 == 0.0 {
        return 0.0;
    }
    // The secant's point first: the piece was clipped around one root.
    let mut x = at_0 / (at_0 - at_1);
    if !(x > a && x < b) {
        x = 0.5;
    }
    let mut previous_step: f64 = 1.0;
    for _ in 0..MOST_STEPS {
        let (value, slope) = value_and_slope(x);
        if value == 0.0 {
            return x;
        }
        if (value < 0.0) == (fa < 0.0) {
            a = x;
            fa = value;
        } else {
            b = x;
        }
        if b - a <= tolerance {
            break;
        }
        let step = -value / slope;
        let next = x + step;
        if !(next > a && next < b) || 2.0 * value.abs() > (previous_step * slope).abs() {
            x = 0.5 * (a + b);
            previous_step = 0.5 * (b - a);
            if !(x > a && x < b) {
                break;
            }
        } else if step.abs() < 0.5 * tolerance {
            // Past the root the step points to by half the tolerance
            // (towards the bracket's far end when the step has no sign),
            // kept inside the bracket.
            let towards = if step > 0.0 || (step == 0.0 && b - x > x - a) {
                1.0
            } else {
                -1.0
            };
            x = (next + towards * 0.5 * tolerance).clamp(a, b);
            previous_step = step;
            if x == a || x == b {
                x = 0.5 * (a + b);
            }
        } else {
            x = next;
            previous_step = step;
        }
    }
    0.5 * (a + b)
}

/// The highest degree [`Interpolation`] serves. Its values-to-Bernstein
/// map amplifies the values' errors by its largest row sum, which about
/// doubles per degree (184 at 8, 2 900 at 12, 47 000 at 16), and the
/// nodes' grid grows coarser; past 12 Taylor arithmetic's coefficients
/// are worth their cost.
pub const MOST_INTERPOLATED_DEGREE: usize = 12;

/// A polynomial of degree `n` on `[0, 1]` from its values at `n + 1`
/// nodes: Chebyshev-Lobatto points rounded to multiples of 2^-12 (2^-7
/// at degree 12: so `0` and `1` are nodes, and the Bernstein basis at
/// the nodes is exact in 106 bits, which the inverse's check below
/// relies on), and the
/// inverse of the Bernstein-Vandermonde matrix, with a bound on how far
/// the stored inverse is from the exact one.
#[derive(Debug)]
pub struct Interpolation {
    /// Where `p` is to be evaluated, increasing, from 0 to 1.
    pub nodes: Vec<f64>,
    /// Column-major: `b_i = sum_j columns[j (n + 1) + i] v_j`, so that
    /// every `b_i` gains its `j`-th term at once (the sums run in lanes,
    /// each in the order `j = 0, 1, ...`).
    columns: Vec<f64>,
    /// The largest row sum of `|inverse|`.
    amplification: f64,
    /// `||I - inverse V||` (infinity norm) with the exact matrix `V`:
    /// then `|(V^-1 - inverse) v| <= residual / (1 - residual) |inverse v|`.
    residual: f64,
}

/// The [`Interpolation`] of degree `n`, `1 <= n <=`
/// [`MOST_INTERPOLATED_DEGREE`], built once.
pub fn interpolation(n: usize) -> &'static Interpolation {
    static TABLES: std::sync::OnceLock<Vec<Interpolation>> = std::sync::OnceLock::new();
    &TABLES.get_or_init(|| {
        (1..=MOST_INTERPOLATED_DEGREE)
            .map(Interpolation::new)
            .collect()
    })[n - 1]
}

/// `a * b` as the unevaluated sum of two floats, exactly.
fn two_product(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

/// `a + b` as the unevaluated sum of two floats, exactly.
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

impl Interpolation {
    fn new(n: usize) -> Interpolation {
        let m = n + 1;
        let mut binomial = vec![1i128; m];
        for k in 1..m {
            binomial[k] = binomial[k - 1] * (n + 1 - k) as i128 / k as i128;
        }
        // Nodes on a grid of 2^-bits, as fine as keeps every W below
        // 2^105 (exact as hi + lo, see below): 12 bits to degree 8, 7 at 12.
        let widest = binomial.iter().copied().max().unwrap_or(1);
        let binomial_bits = 128 - widest.leading_zeros() as usize;
        let scale_bits = ((105 - binomial_bits) / n).min(12) as u32;
        let scale = (1u64 << scale_bits) as f64;
        let ticks: Vec<i128> = (0..m)
            .map(|i| {
                let x = 0.5 * (1.0 - (std::f64::consts::PI * i as f64 / n as f64).cos());
                (x * scale).round() as i128
            })
            .collect();
        // V[j][k] = C(n, k) x_j^k (1 - x_j)^(n - k) = W[j][k] / 2^(bits n)
        // with W a whole number below 2^105, kept as hi + lo exactly.
        let full = 1i128 << scale_bits;
        let unit = 2f64.powi(-((scale_bits as usize * n) as i32));
        let exact: Vec<(f64, f64)> = (0..m * m)
            .map(|jk| {
                let (j, k) = (jk / m, jk % m);
                let w =
                    binomial[k] * ticks[j].pow(k as u32) * (full - ticks[j]).pow((n - k) as u32);
                let hi = w as f64;
                let lo = (w - hi as i128) as f64;
                (hi * unit, lo * unit)
            })
            .collect();
        let vandermonde: Vec<f64> = exact.iter().map(|&(hi, _)| hi).collect();
        let mut inverse = invert(&vandermonde, m);
        // I - inverse V, with V exact and the sums in double-double.
        let residual_of = |inverse: &[f64]| -> Vec<f64> {
            let mut r = vec![0.0; m * m];
            for i in 0..m {
                for k in 0..m {
                    let (mut hi, mut lo) = (if i == k { -1.0 } else { 0.0 }, 0.0);
                    for j in 0..m {
                        let a = inverse[i * m + j];
                        let (vh, vl) = exact[j * m + k];
                        for (p, e) in [two_product(a, vh), two_product(a, vl)] {
                            for t in [p, e] {
                                let (s, err) = two_sum(hi, t);
                                hi = s;
                                lo += err;
                            }
                        }
                    }
                    r[i * m + k] = -(hi + lo);
                }
            }
            r
        };
        // One step of refinement: inverse += R inverse.
        let r = residual_of(&inverse);
        let mut refined = inverse.clone();
        for i in 0..m {
            for k in 0..m {
                let correction: f64 = (0..m).map(|j| r[i * m + j] * inverse[j * m + k]).sum();
                refined[i * m + k] += correction;
            }
        }
        inverse = refined;
        let r = residual_of(&inverse);
        let amplification = (0..m)
            .map(|i| {
                inverse[i * m..(i + 1) * m]
                    .iter()
                    .map(|a| a.abs())
                    .sum::<f64>()
            })
            .fold(0.0, f64::max);
        // The residual's own rounding: the double-double sums lose at
        // most a few units of 2^-106 of the terms' sizes.
        let slack = 16.0 * (m * m) as f64 * f64::EPSILON * f64::EPSILON * amplification;
        let residual = (0..m)
            .map(|i| r[i * m..(i + 1) * m].iter().map(|a| a.abs()).sum::<f64>())
            .fold(0.0, f64::max)
            * (1.0 + 1e-6)
            + slack;
        assert!(
            residual < 1e-6,
            "interpolation of degree {n}: residual {residual}"
        );
        Interpolation {
            nodes: ticks.iter().map(|&t| t as f64 / scale).collect(),
            columns: (0..m * m)
                .map(|ji| inverse[(ji % m) * m + ji / m])
                .collect(),
            amplification,
            residual,
        }
    }

    /// The Bernstein coefficients on `[0, 1]` of the polynomial of degree
    /// `n` whose values at [`Interpolation::nodes`] are within
    /// `value_error` of `values`, into `out`; returns a bound on each
    /// coefficient's error (the values', amplified; the stored inverse's;
    /// the products' rounding).
    pub fn bernstein(&self, values: &[f64], value_error: f64, out: &mut Vec<f64>) -> f64 {
        macro_rules! by_size {
            ($($m:literal)*) => {
                match self.nodes.len() {
                    $($m => self.bernstein_of(values, value_error, $m, out),)*
                    m => self.bernstein_of(values, value_error, m, out),
                }
            };
        }
        by_size!(3 4 5 6 7 8 9 10 11 12 13)
    }

    /// [`Interpolation::bernstein`] with `m` nodes: with `m` a constant,
    /// the sums unroll into lanes.
    #[inline(always)]
    fn bernstein_of(&self, values: &[f64], value_error: f64, m: usize, out: &mut Vec<f64>) -> f64 {
        let values = &values[..m];
        let mut sums = [0.0; MOST_INTERPOLATED_DEGREE + 1];
        let sums = &mut sums[..m];
        for (column, &v) in self.columns.chunks_exact(m).zip(values) {
            for (b, &a) in sums.iter_mut().zip(column) {
                *b += a * v;
            }
        }
        out.clear();
        out.extend_from_slice(sums);
        let largest = sums.iter().fold(0.0f64, |l, b| l.max(b.abs()));
        let largest_value = values.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let rounding = (m + 1) as f64 * f64::EPSILON * self.amplification * largest_value;
        (self.amplification * value_error + self.residual * (largest + rounding) + rounding)
            / (1.0 - self.residual)
            * (1.0 + 1e-9)
    }
}

/// The inverse of the `m` by `m` row-major matrix `a`, by Gauss-Jordan
/// elimination with partial pivoting (for the small, well-conditioned
/// matrices of [`Interpolation`]).
fn invert(a: &[f64], m: usize) -> Vec<f64> {
    let mut left = a.to_vec();
    let mut right: Vec<f64> = (0..m * m)
        .map(|ik| if ik / m == ik % m { 1.0 } else { 0.0 })
        .collect();
    for col in 0..m {
        let pivot = (col..m)
            .max_by(|&p, &q| left[p * m + col].abs().total_cmp(&left[q * m + col].abs()))
            .unwrap_or(col);
        for k in 0..m {
            left.swap(col * m + k, pivot * m + k);
            right.swap(col * m + k, pivot * m + k);
        }
        let d = left[col * m + col];
        for k in 0..m {
            left[col * m + k] /= d;
            right[col * m + k] /= d;
        }
        for row in 0..m {
            if row != col {
                let factor = left[row * m + col];
                for k in 0..m {
                    left[row * m + k] -= factor * left[col * m + k];
                    right[row * m + k] -= factor * right[col * m + k];
                }
            }
        }
    }
    right
}

/// How [`illinois`] ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Refined {
    /// A zero, or the middle of a bracket narrowed to the tolerance.
    Root(f64),
    /// The middle of a bracket that could not be narrowed to the
    /// tolerance: no float lies between its ends, or the steps ran out.
    Unsettled(f64),
    /// The middle of a bracket whose inside is undefined (NaN or
    /// infinite) where it was evaluated, even at its middle.
    Undefined(f64),
}

/// Illinois (modified regula falsi) on a bracket `[a, b]` whose ends have
/// values `fa`, `fb` of opposite signs, until it is narrower than
/// `tolerance`: the one refinement every route's root ends with. Where one
/// end's value dwarfs the other's (a huge power's overflowing side) regula
/// falsi crawls, so it bisects; a non-finite value is retried at the
/// middle.
pub fn illinois(
    mut a: f64,
    mut b: f64,
    mut fa: f64,
    mut fb: f64,
    tolerance: f64,
    mut f: impl FnMut(f64) -> f64,
) -> Refined {
    const MOST_STEPS: usize = 200;
    if fa == 0.0 {
        return Refined::Root(a);
    }
    let mut side = 0;
    // The end a step of half the tolerance was last taken from.
    let mut stepped_from = f64::NAN;
    for _ in 0..MOST_STEPS {
        if b - a <= tolerance {
            return Refined::Root(0.5 * (a + b));
        }
        let (small, large) = (fa.abs().min(fb.abs()), fa.abs().max(fb.abs()));
        let mut m = if large > 1e8 * small {
            // One end lies far nearer the root than the other does (a
            // secant step landed next to it), or the other overflows. A
            // step of half the tolerance from the near end brackets the
            // root at once if it is that near; bisection would take
            // log2(width / tolerance) steps to learn as much.
            let near = if fa.abs() < fb.abs() { a } else { b };
            if near == stepped_from {
                0.5 * (a + b)
            } else {
                stepped_from = near;
                if near == a {
                    a + 0.5 * tolerance
                } else {
                    b - 0.5 * tolerance
                }
            }
        } else {
            (a * fb - b * fa) / (fb - fa)
        };
        if !(m > a && m < b) {
            m = 0.5 * (a + b);
            if !(m > a && m < b) {
                return Refined::Unsettled(0.5 * (a + b));
            }
        }
        let mut fm = f(m);
        if !fm.is_finite() {
            m = 0.5 * (a + b);
            fm = f(m);
            if !fm.is_finite() {
                return Refined::Undefined(0.5 * (a + b));
            }
        }
        if fm == 0.0 {
            return Refined::Root(m);
        }
        if (fm < 0.0) == (fa < 0.0) {
            a = m;
            fa = fm;
            if side == -1 {
                fb *= 0.5;
            }
            side = -1;
        } else {
            b = m;
            fb = fm;
            if side == 1 {
                fa *= 0.5;
            }
            side = 1;
        }
    }
    if b - a <= tolerance {
        Refined::Root(0.5 * (a + b))
    } else {
        Refined::Unsettled(0.5 * (a + b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn expand(roots: &[f64], scale: f64) -> Vec<f64> {
        // scale * prod (s - r)
        let mut p = vec![scale];
        for &r in roots {
            let mut q = vec![0.0; p.len() + 1];
            for (k, &c) in p.iter().enumerate() {
                q[k + 1] += c;
                q[k] -= r * c;
            }
            p = q;
        }
        p
    }

    /// The first root of the power form `power`, its coefficients' errors
    /// summing to `error`, as the Taylor route finds it.
    fn first_root(
        power: &[f64],
        error: f64,
        tolerance: f64,
        max_pieces: u64,
        any: bool,
        scratch: &mut RootScratch,
    ) -> (FirstRoot, u64) {
        let mut bernstein = Vec::new();
        let error = power_to_bernstein(power, error, &mut bernstein);
        first_root_of_bernstein(&bernstein, error, tolerance, max_pieces, any, scratch)
    }

    fn first(p: &[f64]) -> FirstRoot {
        let error = p.iter().map(|c| c.abs() * 1e-15).sum();
        first_root(p, error, 1e-12, 10_000, false, &mut RootScratch::default()).0
    }

    /// Values of a polynomial with known roots at the nodes give its
    /// Bernstein coefficients (those the power form converts to) within
    /// the bound the interpolation returns, at every degree it serves;
    /// and that bound is near the rounding of the values.
    #[test]
    fn interpolated_bernstein_coefficients_are_within_their_bound() {
        for n in 1..=MOST_INTERPOLATED_DEGREE {
            let table = interpolation(n);
            assert_eq!(table.nodes.len(), n + 1);
            assert_eq!((table.nodes[0], table.nodes[n]), (0.0, 1.0));
            assert!(table.residual < 1e-12, "degree {n}: {}", table.residual);
            let roots: Vec<f64> = (0..n).map(|k| (k as f64 + 0.37) / n as f64).collect();
            let power = expand(&roots, 3.0);
            let mut exact = Vec::new();
            let exact_error = power_to_bernstein(&power, 0.0, &mut exact);
            let p = |s: f64| power.iter().rev().fold(0.0, |acc, &a| acc * s + a);
            let values: Vec<f64> = table.nodes.iter().map(|&x| p(x)).collect();
            // Horner's rounding on [0, 1], generously.
            let value_error =
                4.0 * (n + 1) as f64 * f64::EPSILON * power.iter().map(|a| a.abs()).sum::<f64>();
            let mut b = Vec::new();
            let error = table.bernstein(&values, value_error, &mut b);
            for (i, (got, want)) in b.iter().zip(&exact).enumerate() {
                assert!(
                    (got - want).abs() <= error + exact_error,
                    "degree {n}, b_{i}: {got} vs {want}, bound {error}"
                );
            }
            assert!(
                error <= 1.01 * table.amplification * value_error + 1e-12,
                "degree {n}: bound {error}"
            );
            assert!(table.amplification < 2f64.powi(n as i32), "degree {n}");
            // And the search finds the first root from them.
            let (found, _) = first_root_of_bernstein(
                &b,
                error,
                1e-12,
                10_000,
                false,
                &mut RootScratch::default(),
            );
            match found {
                FirstRoot::At(s) => {
                    assert!(
                        (s - roots[0]).abs() < 1e-9,
                        "degree {n}: {s} vs {}",
                        roots[0]
                    )
                }
                // Where the values are within their bound of zero; still
                // no root missed before it, and close.
                FirstRoot::Near(s) => {
                    assert!(
                        s <= roots[0] && roots[0] - s < 1e-3,
                        "degree {n}: near {s} vs {}",
                        roots[0]
                    )
                }
                other => panic!("degree {n}: {other:?}"),
            }
        }
    }

    #[test]
    fn finds_the_smallest_of_several_roots() {
        for roots in [
            vec![0.3, 0.7],
            vec![0.9, 0.2, 0.55],
            vec![-0.5, 1.5, 0.61, 0.62, 0.95],
            vec![0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 0.999],
        ] {
            let want = roots
                .iter()
                .copied()
                .filter(|r| (0.0..=1.0).contains(r))
                .fold(f64::INFINITY, f64::min);
            match first(&expand(&roots, -3.0)) {
                FirstRoot::At(s) | FirstRoot::Near(s) => {
                    assert!((s - want).abs() < 1e-9, "{roots:?}: {s} vs {want}")
                }
                other => panic!("{roots:?}: {other:?}"),
            }
        }
    }

    /// The refinement ends within its tolerance of the one root in its
    /// bracket, from a secant guess on either side, for steep and flat
    /// roots and tolerances down to a few units of the last place.
    #[test]
    fn the_bracketed_newton_refinement_ends_within_its_tolerance() {
        let mut next = crate::testing::uniform(0x2545_f491_4f6c_dd1du64);
        for k in 0..3000 {
            let root = 0.001 + 0.998 * next();
            // Other roots outside [0, 1], some close to it (a flat root).
            let mut roots = vec![root];
            for _ in 0..(k % 6) {
                let r = next();
                roots.push(if r < 0.5 {
                    -0.02 - 2.0 * r
                } else {
                    1.02 + 2.0 * r
                });
            }
            let power = expand(&roots, if k % 2 == 0 { 1.0 } else { -7.0 });
            let at = |s: f64| power.iter().rev().fold(0.0, |acc, &a| acc * s + a);
            let tolerance = 10f64.powi(-3 - k % 12);
            let found = newton_in_bracket(&power, at(0.0), at(1.0), tolerance);
            assert!(
                (found - root).abs() <= tolerance.max(1e-15),
                "{roots:?}: {found} vs {root}, tolerance {tolerance}"
            );
        }
    }

    /// Near a singular point of Taubin's heart the polynomial is within
    /// its error of zero just past the root; the refinement must stay in
    /// its bracket rather than stop there (it used to return a point
    /// 2.4e-5 past the root). The coefficients are those of one ray.
    #[test]
    fn a_flat_root_is_refined_inside_its_bracket() {
        let c = [
            0.00022390025162120705,
            -0.03565436593994105,
            1.9356412594566272,
            -38.059544491625566,
            124.13615534640441,
            -146.67358326526568,
            59.06108323573238,
        ];
        let length = 8.534054616310284 - 7.00046961302279;
        let want = (7.029766190793571 - 7.00046961302279) / length;
        let tolerance = 1e-6 / length;
        let (found, _) = first_root(
            &c,
            1.234274187197758e-10,
            tolerance,
            20_000,
            false,
            &mut RootScratch::default(),
        );
        match found {
            FirstRoot::At(s) | FirstRoot::Near(s) => {
                assert!((s - want).abs() < tolerance, "{s} vs {want}")
            }
            other => panic!("{other:?}"),
        }
    }

    /// Along some lines a polynomial drops to degree 1 or 0 (a ray along a
    /// level direction): the search still answers, without panicking.
    #[test]
    fn low_degrees_along_a_line() {
        assert_eq!(first(&[1.0]), FirstRoot::None);
        assert!(matches!(first(&[0.0]), FirstRoot::Near(s) if s == 0.0));
        match first(&[-1.0, 2.0]) {
            FirstRoot::At(s) | FirstRoot::Near(s) => assert!((s - 0.5).abs() < 1e-9, "{s}"),
            other => panic!("{other:?}"),
        }
        assert_eq!(first(&[1.0, 0.5]), FirstRoot::None);
        // Non-finite coefficients are no root (the caller falls back).
        assert_eq!(first(&[f64::NAN, 1.0, 2.0]), FirstRoot::None);
    }

    #[test]
    fn a_double_root_is_a_touching_hit_and_a_near_miss_is_not() {
        // (s - 0.4)^2: touches zero at 0.4.
        match first(&expand(&[0.4, 0.4], 1.0)) {
            FirstRoot::At(s) | FirstRoot::Near(s) => assert!((s - 0.4).abs() < 1e-6, "{s}"),
            other => panic!("{other:?}"),
        }
        // (s - 0.4)^2 + 1e-6: never zero.
        let mut p = expand(&[0.4, 0.4], 1.0);
        p[0] += 1e-6;
        assert_eq!(first(&p), FirstRoot::None);
        // No roots at all, and roots only outside [0, 1].
        assert_eq!(first(&expand(&[-1.0, 2.0, 3.0], 1.0)), FirstRoot::None);
    }

    /// A bracket one of whose ends lies next to the root (where a secant
    /// step lands) is settled in a step or two, not by bisecting the far
    /// end down to the tolerance; and a huge far end (an overflowing
    /// power) still gets the root.
    #[test]
    fn a_bracket_with_an_end_beside_the_root_settles_at_once() {
        let root = 17.386504132;
        let f = |t: f64| (t - root).sin() + 0.3 * (t - root).powi(2);
        for (a, b) in [(root - 1e-13, root + 1.0), (root - 1.0, root + 1e-13)] {
            let mut calls = 0;
            let got = illinois(a, b, f(a), f(b), 1e-6, |t| {
                calls += 1;
                f(t)
            });
            let Refined::Root(t) = got else {
                panic!("{got:?}")
            };
            assert!((t - root).abs() <= 1e-6, "{t}");
            assert!(calls <= 2, "{calls} evaluations from [{a}, {b}]");
        }
        let power = |t: f64| (t - 0.5) * (1.0 + t.powi(60));
        let got = illinois(0.0, 3.0, power(0.0), power(3.0), 1e-9, power);
        assert!(
            matches!(got, Refined::Root(t) if (t - 0.5).abs() <= 1e-9),
            "{got:?}"
        );
    }
}
