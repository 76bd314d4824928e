//! The first real root of a polynomial in one variable on `[0, 1]`, by
//! subdivision of its Bernstein form, with the coefficients' rounding
//! error taken into account.
//!
//! Input: the power-form coefficients `a_k` of `p(s) = sum a_k s^k` and a
//! bound on the sum of their errors. Output: the smallest root in `[0, 1]`
//! to a tolerance, none, or "out of steps".
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

/// Reused buffers for [`first_root`].
#[derive(Debug, Default, Clone)]
pub struct RootScratch {
    stack: Vec<f64>,
    work: Vec<f64>,
}

/// The smallest root of `p(s) = sum power[k] s^k` in `[0, 1]`, to within
/// `tolerance` in `s`, where `error` bounds the sum of the errors of the
/// `power` coefficients.
/// Cuts pieces at most `max_pieces` times; returns the number of cuts
/// made. With `any`, a piece proven to hold exactly one root is not
/// refined: its middle is returned (enough to know a path is blocked).
pub fn first_root(
    power: &[f64],
    error: f64,
    tolerance: f64,
    max_pieces: u64,
    any: bool,
    scratch: &mut RootScratch,
) -> (FirstRoot, u64) {
    let n = power.len() - 1;
    let stride = n + 3;
    let RootScratch { stack, work } = scratch;
    stack.clear();
    work.clear();
    work.resize(2 * (n + 1), 0.0);
    // Bernstein coefficients: b_i = sum_k C(i, k) / C(n, k) a_k, the
    // binomial transform of a_k / C(n, k), as n passes of adjacent sums.
    // The weights lie in [0, 1], so each b_i is off by at most `error`.
    stack.extend([0.0, 1.0]);
    let base = stack.len();
    stack.extend_from_slice(power);
    let mut binomial = 1.0;
    for k in 0..=n {
        stack[base + k] /= binomial;
        binomial = binomial * (n - k) as f64 / (k + 1) as f64;
    }
    for pass in 1..=n {
        for i in (pass..=n).rev() {
            stack[base + i] += stack[base + i - 1];
        }
    }
    let largest = stack[base..].iter().fold(0.0f64, |m, b| m.max(b.abs()));
    if !largest.is_finite() {
        return (FirstRoot::None, 0);
    }
    // The conversion's own rounding (n sums of at most `largest` each),
    // and that of every later halving (averages never grow the values),
    // to a generous depth.
    let uncertainty = error + 4.0 * (n as f64 + 64.0) * f64::EPSILON * largest + f64::MIN_POSITIVE;

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
        let sign = b[0].signum();
        let q0 = sign * b[0] - uncertainty;
        let mut steepest = 0.0f64;
        let mut lowest = q0;
        for (i, &bi) in b.iter().enumerate().skip(1) {
            let qi = sign * bi - uncertainty;
            lowest = lowest.min(qi);
            steepest = steepest.max((q0 - qi) * n as f64 / i as f64);
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
        // refined on the power form.
        let certain = b.iter().all(|v| v.abs() > uncertainty);
        if certain
            && b.windows(2)
                .filter(|w| (w[0] < 0.0) != (w[1] < 0.0))
                .count()
                == 1
        {
            if any {
                return (FirstRoot::At(0.5 * (lo + hi)), steps);
            }
            return (refine(power, lo, hi, tolerance), steps);
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

/// The root of `p` in `[lo, hi]`, where `p(lo)` and `p(hi)` differ in
/// sign, refined on the power form. A value within the coefficients'
/// error of zero still has the computed polynomial's sign, and following
/// it stays inside the bracket (stopping there could pass the root by the
/// error's width, where the surface is flat).
fn refine(power: &[f64], lo: f64, hi: f64, tolerance: f64) -> FirstRoot {
    let p = |s: f64| power.iter().rev().fold(0.0, |acc, &a| acc * s + a);
    let (Refined::Root(s) | Refined::Unsettled(s) | Refined::Undefined(s)) =
        illinois(lo, hi, p(lo), p(hi), tolerance, p);
    FirstRoot::At(s)
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
    for _ in 0..MOST_STEPS {
        if b - a <= tolerance {
            return Refined::Root(0.5 * (a + b));
        }
        let (small, large) = (fa.abs().min(fb.abs()), fa.abs().max(fb.abs()));
        let mut m = if large > 1e8 * small {
            0.5 * (a + b)
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

    fn first(p: &[f64]) -> FirstRoot {
        let error = p.iter().map(|c| c.abs() * 1e-15).sum();
        first_root(p, error, 1e-12, 10_000, false, &mut RootScratch::default()).0
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
}
