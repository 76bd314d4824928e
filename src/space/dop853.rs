//! The Dormand-Prince 8(5,3) method (Hairer's DOP853) that metric spaces
//! integrate their geodesics with, and the quintic Hermite interpolant of
//! its accepted steps.
//!
//! Input: a state, its rates and a step size; output: the 8th-order
//! solution with its stage rates, the error estimate of the 5th- and
//! 3rd-order embedded solutions (Hairer's combination), and, for a
//! second-order system, the dense output between two states.
//!
//! Why not DOPRI5, which the sphere space's `ode` route uses: at the
//! tolerance metric spaces need (1e-8), DOP853 takes about a fifth of the
//! steps and a third of the rate evaluations along a Nil geodesic. Why a
//! quintic Hermite interpolant and not DOP853's own 7th-order one: that
//! costs three more rate evaluations per step, while positions, velocities
//! and accelerations at both ends are already known, and the quintic
//! through them is 6th-order accurate in the position.

// DOP853 coefficients (Hairer's dop853.f, as scipy tabulates them).
// The equations do not depend on t, so the nodes c_i are not needed.
pub(super) const A: [[f64; 12]; 12] = [
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [
        0.05260015195876773,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.0197250569845379,
        0.0591751709536137,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.02958758547680685,
        0.0,
        0.08876275643042054,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.2413651341592667,
        0.0,
        -0.8845494793282861,
        0.924834003261792,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.037037037037037035,
        0.0,
        0.0,
        0.17082860872947386,
        0.12546768756682242,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.037109375,
        0.0,
        0.0,
        0.17025221101954405,
        0.06021653898045596,
        -0.017578125,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.03709200011850479,
        0.0,
        0.0,
        0.17038392571223998,
        0.10726203044637328,
        -0.015319437748624402,
        0.008273789163814023,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.6241109587160757,
        0.0,
        0.0,
        -3.3608926294469414,
        -0.868219346841726,
        27.59209969944671,
        20.154067550477894,
        -43.48988418106996,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        0.47766253643826434,
        0.0,
        0.0,
        -2.4881146199716677,
        -0.590290826836843,
        21.230051448181193,
        15.279233632882423,
        -33.28821096898486,
        -0.020331201708508627,
        0.0,
        0.0,
        0.0,
    ],
    [
        -0.9371424300859873,
        0.0,
        0.0,
        5.186372428844064,
        1.0914373489967295,
        -8.149787010746927,
        -18.52006565999696,
        22.739487099350505,
        2.4936055526796523,
        -3.0467644718982196,
        0.0,
        0.0,
    ],
    [
        2.273310147516538,
        0.0,
        0.0,
        -10.53449546673725,
        -2.0008720582248625,
        -17.9589318631188,
        27.94888452941996,
        -2.8589982771350235,
        -8.87285693353063,
        12.360567175794303,
        0.6433927460157636,
        0.0,
    ],
];
/// The 8th-order weights (the last stage at the new state has none).
pub(super) const B: [f64; 12] = [
    0.054293734116568765,
    0.0,
    0.0,
    0.0,
    0.0,
    4.450312892752409,
    1.8915178993145003,
    -5.801203960010585,
    0.3111643669578199,
    -0.1521609496625161,
    0.20136540080403034,
    0.04471061572777259,
];
/// The 8th-order solution minus the embedded 5th-order one.
pub(super) const E5: [f64; 12] = [
    0.01312004499419488,
    0.0,
    0.0,
    0.0,
    0.0,
    -1.2251564463762044,
    -0.4957589496572502,
    1.6643771824549864,
    -0.35032884874997366,
    0.3341791187130175,
    0.08192320648511571,
    -0.022355307863886294,
];
/// The 8th-order solution minus the embedded 3rd-order one.
pub(super) const E3: [f64; 12] = [
    -0.18980075407240762,
    0.0,
    0.0,
    0.0,
    0.0,
    4.450312892752409,
    1.8915178993145003,
    -5.801203960010585,
    -0.4226823213237919,
    -0.1521609496625161,
    0.20136540080403034,
    0.02265179219836082,
];

/// One trial step of size `h` from `y`, whose rates there are `k1`: the
/// 8th-order solution and the twelve stage rates. The rates at the new
/// state (the next step's first, as the error estimate does not need
/// them) are left to the caller.
pub(super) fn trial<const N: usize>(
    y: &[f64; N],
    k1: [f64; N],
    h: f64,
    mut rates: impl FnMut(&[f64; N]) -> [f64; N],
) -> ([f64; N], [[f64; N]; 12]) {
    let mut k = [[0.0; N]; 12];
    k[0] = k1;
    // Stage by stage, the weighted sum of the earlier rates, summed in
    // the same order per component as row by row but a whole rate at a
    // time (so the components go together), skipping the tableau's zeros.
    let combine = |weights: &[f64], k: &[[f64; N]]| {
        let mut acc = [0.0; N];
        for (&w, kj) in weights.iter().zip(k) {
            if w != 0.0 {
                for (a, &r) in acc.iter_mut().zip(kj) {
                    *a += w * r;
                }
            }
        }
        let mut out = *y;
        for (o, a) in out.iter_mut().zip(acc) {
            *o += h * a;
        }
        out
    };
    for stage in 1..12 {
        let ys = combine(&A[stage][..stage], &k[..stage]);
        k[stage] = rates(&ys);
    }
    let y_new = combine(&B, &k);
    (y_new, k)
}

/// The error estimate of a trial step, scaled by `tolerance` relative to
/// `1 + |y|` per component (their root mean square, as in Hairer's
/// dop853): at most 1 to accept. Hairer's combination of the 5th- and 3rd-order estimates, whose
/// quotient behaves as an 8th-order error. Infinite where an estimate
/// overflows; the state and rates must be finite (callers check).
pub(super) fn error_norm<const N: usize>(
    y: &[f64; N],
    y_new: &[f64; N],
    k: &[[f64; N]; 12],
    h: f64,
    tolerance: f64,
) -> f64 {
    let (mut e5, mut e3) = ([0.0; N], [0.0; N]);
    for (j, kj) in k.iter().enumerate() {
        // Both rows are zero at the same stages (1 to 4).
        if E5[j] == 0.0 && E3[j] == 0.0 {
            continue;
        }
        for i in 0..N {
            e5[i] += E5[j] * kj[i];
            e3[i] += E3[j] * kj[i];
        }
    }
    // Callers pass finite states and rates: plain comparisons, not
    // `f64::max`'s NaN handling.
    let larger = |m: f64, x: f64| if x > m { x } else { m };
    let (mut err5, mut err3): (f64, f64) = (0.0, 0.0);
    for i in 0..N {
        let scale = tolerance * (1.0 + larger(y[i].abs(), y_new[i].abs()));
        err5 += (e5[i] / scale).powi(2);
        err3 += (e3[i] / scale).powi(2);
    }
    let (err5, err3) = ((err5 / N as f64).sqrt(), (err3 / N as f64).sqrt());
    if err5 == 0.0 && err3 == 0.0 {
        return 0.0;
    }
    let denominator = (err5 * err5 + 0.01 * err3 * err3).sqrt();
    (h * err5 * err5 / denominator).abs()
}

/// The step-size factor for an error estimate `err` (exponent 1/8, the
/// estimate's order plus one): grow at most `most`-fold, shrink at most
/// fivefold.
pub(super) fn step_factor(err: f64, most: f64) -> f64 {
    if err == 0.0 {
        most
    } else {
        // err^(-1/8) by three square roots: a tenth of `powf`'s cost.
        (0.9 / err.sqrt().sqrt().sqrt()).clamp(0.2, most)
    }
}

/// A first step for the state `y` whose rates are `k1`, at most `most`:
/// Hairer's estimate (`hinit` in dop853.f), from the sizes of the state
/// and its rates relative to the tolerance and one Euler step's change of
/// the rates. Never below 1e-6 of `most`, nor NaN.
pub(super) fn initial_step<const N: usize>(
    y: &[f64; N],
    k1: &[f64; N],
    tolerance: f64,
    most: f64,
    mut rates: impl FnMut(&[f64; N]) -> [f64; N],
) -> f64 {
    let scale = |i: usize| tolerance * (1.0 + y[i].abs());
    let norm = |v: &dyn Fn(usize) -> f64| (0..N).map(|i| (v(i) / scale(i)).powi(2)).sum::<f64>();
    let (dnf, dny) = (norm(&|i| k1[i]), norm(&|i| y[i]));
    let h = if dnf <= 1e-10 || dny <= 1e-10 {
        1e-6
    } else {
        (dny / dnf).sqrt() * 0.01
    }
    .min(most);
    let mut euler = *y;
    for (e, k) in euler.iter_mut().zip(k1) {
        *e += h * k;
    }
    let k2 = rates(&euler);
    let der2 = norm(&|i| k2[i] - k1[i]).sqrt() / h;
    let der12 = der2.max(dnf.sqrt());
    let h1 = if der12 <= 1e-15 {
        (h * 1e-3).max(1e-6)
    } else {
        (0.01 / der12).powf(1.0 / 8.0)
    };
    let h = (100.0 * h).min(h1).min(most);
    if h.is_nan() {
        most * 1e-6
    } else {
        h.max(most * 1e-6)
    }
}

/// The quintic Hermite interpolant of one coordinate over a step of size
/// `h`: the coefficients in `theta` (0 to 1) of the polynomial through
/// the position `p`, velocity `v` and acceleration `a` at both ends.
pub(super) fn quintic(p: [f64; 2], v: [f64; 2], a: [f64; 2], h: f64) -> [f64; 6] {
    let dp = p[1] - p[0];
    let (v0, v1) = (h * v[0], h * v[1]);
    let (a0, a1) = (h * h * a[0], h * h * a[1]);
    [
        p[0],
        v0,
        0.5 * a0,
        10.0 * dp - 6.0 * v0 - 4.0 * v1 - 0.5 * (3.0 * a0 - a1),
        -15.0 * dp + 8.0 * v0 + 7.0 * v1 + 0.5 * (3.0 * a0 - 2.0 * a1),
        6.0 * dp - 3.0 * v0 - 3.0 * v1 - 0.5 * (a0 - a1),
    ]
}

/// A box holding the curve whose coordinates are the quintics `c` for
/// `theta` in [0, 1]: the range of each one's Bernstein coefficients
/// (the curve lies in their convex hull), rounding not included.
pub(super) fn quintic_range(c: &[[f64; 6]; 3]) -> (glam::DVec3, glam::DVec3) {
    // b_i = sum_j C(i, j) / C(5, j) c_j.
    const W: [[f64; 6]; 6] = [
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [1.0, 0.2, 0.0, 0.0, 0.0, 0.0],
        [1.0, 0.4, 0.1, 0.0, 0.0, 0.0],
        [1.0, 0.6, 0.3, 0.1, 0.0, 0.0],
        [1.0, 0.8, 0.6, 0.4, 0.2, 0.0],
        [1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
    ];
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for (axis, ci) in c.iter().enumerate() {
        for w in &W {
            let b: f64 = w.iter().zip(ci).map(|(w, c)| w * c).sum();
            // Plain comparisons: a NaN coefficient leaves the box empty
            // (its step is refused before it is searched anyway).
            if b < lo[axis] {
                lo[axis] = b;
            }
            if b > hi[axis] {
                hi[axis] = b;
            }
        }
    }
    (glam::DVec3::from_array(lo), glam::DVec3::from_array(hi))
}

/// The value of the polynomial `c` at `theta`.
#[inline]
pub(super) fn quintic_value(c: &[f64; 6], theta: f64) -> f64 {
    c[0] + theta * (c[1] + theta * (c[2] + theta * (c[3] + theta * (c[4] + theta * c[5]))))
}

/// The value and the `theta`-derivative of the polynomial `c` at `theta`.
#[inline]
pub(super) fn quintic_at(c: &[f64; 6], theta: f64) -> (f64, f64) {
    let value = quintic_value(c, theta);
    let slope = c[1]
        + theta * (2.0 * c[2] + theta * (3.0 * c[3] + theta * (4.0 * c[4] + theta * 5.0 * c[5])));
    (value, slope)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rows of the tableau sum to the nodes, the weights to 1, and
    /// the error weights to 0 (each estimate is a difference of two
    /// consistent solutions).
    #[test]
    fn the_tableau_is_consistent() {
        let nodes = [
            0.0,
            0.052_600_151_958_767_73,
            0.078_900_227_938_151_6,
            0.118_350_341_907_227_4,
            0.281_649_658_092_772_6,
            1.0 / 3.0,
            0.25,
            4.0 / 13.0,
            127.0 / 195.0,
            0.6,
            6.0 / 7.0,
            1.0,
        ];
        for (row, c) in A.iter().zip(nodes) {
            assert!(
                (row.iter().sum::<f64>() - c).abs() < 1e-13,
                "{row:?} vs {c}"
            );
        }
        assert!((B.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        assert!(E5.iter().sum::<f64>().abs() < 1e-13);
        assert!(E3.iter().sum::<f64>().abs() < 1e-13);
    }

    /// One step along the unit circle (a second-order system) is good to
    /// the method's order: halving the step divides the error by about
    /// 2^9 (local error of an 8th-order method), and the estimate follows.
    #[test]
    fn a_step_along_a_circle_is_eighth_order() {
        let rates = |y: &[f64; 4]| [y[2], y[3], -y[0], -y[1]];
        let error = |h: f64| {
            let y = [1.0, 0.0, 0.0, 1.0];
            let (y_new, k) = trial(&y, rates(&y), h, rates);
            let exact = [h.cos(), h.sin(), -h.sin(), h.cos()];
            let e = (0..4)
                .map(|i| (y_new[i] - exact[i]).abs())
                .fold(0.0, f64::max);
            (e, error_norm(&y, &y_new, &k, h, 1.0))
        };
        let (e1, est1) = error(0.8);
        let (e2, est2) = error(0.4);
        assert!(e1 < 1e-8 && e1 / e2 > 2f64.powi(8), "{e1:e} {e2:e}");
        assert!(est1 > e1 && est1 / est2 > 2f64.powi(6), "{est1:e} {est2:e}");
    }

    /// The Bernstein box holds the curve, and is tight at its ends.
    #[test]
    fn the_bernstein_box_holds_the_curve() {
        let h: f64 = 1.3;
        let c = [
            quintic([1.0, h.cos()], [0.0, -h.sin()], [-1.0, -h.cos()], h),
            quintic([0.0, h.sin()], [1.0, h.cos()], [0.0, -h.sin()], h),
            quintic([5.0, 5.0 + h], [1.0, 1.0], [0.0, 0.0], h),
        ];
        let (lo, hi) = quintic_range(&c);
        for i in 0..=200 {
            let theta = i as f64 / 200.0;
            let p = glam::DVec3::new(
                quintic_value(&c[0], theta),
                quintic_value(&c[1], theta),
                quintic_value(&c[2], theta),
            );
            assert!(
                p.cmpge(lo - 1e-12).all() && p.cmple(hi + 1e-12).all(),
                "{p} {lo} {hi}"
            );
        }
        assert!((lo.z - 5.0).abs() < 1e-12 && (hi.z - 5.0 - h).abs() < 1e-12);
        assert!(hi.y < 1.0 + 1e-9 && lo.x > h.cos() - 0.05, "{lo} {hi}");
    }

    /// The quintic through both ends' positions, velocities and
    /// accelerations meets them, and between is 6th-order accurate.
    #[test]
    fn the_quintic_meets_its_ends_and_follows_the_curve() {
        let h: f64 = 0.5;
        let c = quintic([0.0, h.sin()], [1.0, h.cos()], [0.0, -h.sin()], h);
        let (p0, v0) = quintic_at(&c, 0.0);
        let (p1, v1) = quintic_at(&c, 1.0);
        assert_eq!((p0, v0), (0.0, h));
        assert!((p1 - h.sin()).abs() < 1e-16 && (v1 / h - h.cos()).abs() < 1e-15);
        let worst = (1..100)
            .map(|i| {
                let theta = i as f64 / 100.0;
                (quintic_at(&c, theta).0 - (theta * h).sin()).abs()
            })
            .fold(0.0, f64::max);
        // |sin^(6)| <= 1: the bound h^6 / 46080.
        assert!(worst > 0.0 && worst <= h.powi(6) / 46080.0, "{worst:e}");
    }
}
