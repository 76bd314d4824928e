//! The Dormand-Prince 5(4) tables of the sphere space's `ode` route (the
//! seed's integrator; metric spaces use [`super::dop853`]).
//!
//! Input: none; output: the Butcher tableau, the embedded error weights
//! and Hairer's dense-output weights (contd5).

// Dormand-Prince 5(4) coefficients. The equations do not depend on t, so
// the nodes c_i are not needed.
pub(super) const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
/// The 5th-order solution minus the embedded 4th-order one.
pub(super) const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];
/// Dense output (Hairer's contd5).
pub(super) const D: [f64; 7] = [
    -12715105075.0 / 11282082432.0,
    0.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
];

/// One trial step of size `h` from `y`, whose rates there are `k1`: the
/// 5th-order solution and the seven stage rates (the last at the new
/// state, so it is the next step's first: FSAL). The equations do not
/// depend on `t`.
pub(super) fn trial<const N: usize>(
    y: &[f64; N],
    k1: [f64; N],
    h: f64,
    mut rates: impl FnMut(&[f64; N]) -> [f64; N],
) -> ([f64; N], [[f64; N]; 7]) {
    let mut k = [[0.0; N]; 7];
    k[0] = k1;
    let mut y_new = *y;
    for stage in 1..7 {
        let mut ys = *y;
        for (i, ysi) in ys.iter_mut().enumerate() {
            let mut acc = 0.0;
            for (j, kj) in k.iter().enumerate().take(stage) {
                acc += A[stage][j] * kj[i];
            }
            *ysi += h * acc;
        }
        k[stage] = rates(&ys);
        // The 5th-order solution is the last stage's argument.
        if stage == 6 {
            y_new = ys;
        }
    }
    (y_new, k)
}

/// The embedded error estimate of a trial step, scaled by `tolerance`
/// relative to `1 + |y|` per component: at most 1 to accept. Infinite
/// where a component's estimate overflows (the step is then shrunk); a NaN
/// component is not seen here (callers whose rates can be NaN check the
/// step for it).
pub(super) fn error_norm<const N: usize>(
    y: &[f64; N],
    y_new: &[f64; N],
    k: &[[f64; N]; 7],
    h: f64,
    tolerance: f64,
) -> f64 {
    let mut err: f64 = 0.0;
    for i in 0..N {
        let mut e = 0.0;
        for (j, kj) in k.iter().enumerate() {
            e += E[j] * kj[i];
        }
        let scale = tolerance * (1.0 + y[i].abs().max(y_new[i].abs()));
        err = err.max((h * e / scale).abs());
    }
    err
}

/// The dense output's coefficients of an accepted step (Hairer's
/// contd5), read by [`dense_state`].
pub(super) fn dense_coefficients<const N: usize>(
    y: &[f64; N],
    y_new: &[f64; N],
    k: &[[f64; N]; 7],
    h: f64,
) -> [[f64; N]; 5] {
    let mut c = [[0.0; N]; 5];
    for i in 0..N {
        let dy = y_new[i] - y[i];
        let bspl = h * k[0][i] - dy;
        c[0][i] = y[i];
        c[1][i] = dy;
        c[2][i] = bspl;
        c[3][i] = dy - h * k[6][i] - bspl;
        let mut acc = 0.0;
        for (j, kj) in k.iter().enumerate() {
            acc += D[j] * kj[i];
        }
        c[4][i] = h * acc;
    }
    c
}

/// The state at the fraction `theta` (0 to 1) of a step with dense
/// coefficients `c`.
#[inline]
pub(super) fn dense_state<const N: usize>(c: &[[f64; N]; 5], theta: f64) -> [f64; N] {
    let theta1 = 1.0 - theta;
    let mut y = [0.0; N];
    for (i, yi) in y.iter_mut().enumerate() {
        *yi =
            c[0][i] + theta * (c[1][i] + theta1 * (c[2][i] + theta * (c[3][i] + theta1 * c[4][i])));
    }
    y
}

/// The standard step-size factor for an error estimate `err`: grow at most
/// `most`-fold, shrink at most fivefold.
pub(super) fn step_factor(err: f64, most: f64) -> f64 {
    if err == 0.0 {
        most
    } else {
        (0.9 * err.powf(-0.2)).clamp(0.2, most)
    }
}
