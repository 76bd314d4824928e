//! Finding the first root of `f(o + t d)` on `[t0, t1]`, by each route.
//!
//! Every function returns the smallest `t` in the range where the ray
//! meets the surface (within the route's tolerance), or `None`.

use glam::DVec3;

use crate::expr::{Implicit, Interval, Quadric};

/// Scratch space reused across evaluations on one thread.
#[derive(Default)]
pub struct Scratch {
    pub points: Vec<f64>,
    pub intervals: Vec<Interval>,
    /// Evaluations of `f` (point or interval) made, for statistics.
    pub evaluations: u64,
}

/// The ray `o + t d` meets the quadric where `a t^2 + b t + c = 0`.
pub fn quadric(q: &Quadric, o: DVec3, d: DVec3, t0: f64, t1: f64) -> Option<f64> {
    let md = q.m * d;
    let a = d.dot(md);
    let b = 2.0 * o.dot(md) + q.b.dot(d);
    let c = q.value(o);
    let scale = a.abs().max(b.abs()).max(c.abs());
    if scale == 0.0 || !scale.is_finite() {
        return None;
    }
    let in_range = |t: f64| t >= t0 && t <= t1;
    // Relative to the other coefficients, a vanishing `a` is a linear
    // equation (a plane, or a ray parallel to a cylinder's axis).
    if a.abs() <= 1e-14 * scale {
        if b == 0.0 {
            return None;
        }
        let t = -c / b;
        return in_range(t).then_some(t);
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return None;
    }
    // The numerically stable pair of roots.
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    let (mut r0, mut r1) = (q / a, if q != 0.0 { c / q } else { q / a });
    if r0 > r1 {
        std::mem::swap(&mut r0, &mut r1);
    }
    if in_range(r0) {
        Some(r0)
    } else if in_range(r1) {
        Some(r1)
    } else {
        None
    }
}

fn sign(v: f64) -> i8 {
    if v > 0.0 {
        1
    } else if v < 0.0 {
        -1
    } else {
        0
    }
}

/// The seed's algorithm 2: fixed steps; on a change of sign, halve the step
/// and retry from the last point before it, until the step is below `eps`.
/// Points where `f` is not finite carry no sign and are stepped over.
#[allow(clippy::too_many_arguments)]
pub fn march(
    f: &Implicit,
    o: DVec3,
    d: DVec3,
    t0: f64,
    t1: f64,
    step: f64,
    eps: f64,
    max_steps: u64,
    s: &mut Scratch,
) -> Option<f64> {
    let mut t = t0;
    let v0 = f.value(o + t0 * d, &mut s.points);
    s.evaluations += 1;
    let mut start_sign = if v0.is_finite() { sign(v0) } else { 0 };
    let mut h = step;
    let mut steps = 0;
    while t < t1 && steps < max_steps {
        let tn = (t + h).min(t1);
        let v = f.value(o + tn * d, &mut s.points);
        s.evaluations += 1;
        steps += 1;
        let sg = if v.is_finite() { sign(v) } else { 0 };
        if start_sign == 0 {
            // No sign yet (the start was on the surface or undefined).
            start_sign = sg;
            t = tn;
            continue;
        }
        if sg != 0 && sg != start_sign {
            if h < eps {
                return Some(tn);
            }
            h *= 0.5;
            continue;
        }
        if sg == 0 && v == 0.0 {
            return Some(tn);
        }
        t = tn;
    }
    None
}

/// The seed's adaptive marching (report 9.1): the step doubles while |f|
/// falls; when |f| rises again after falling, the stretch around the
/// minimum is searched again at the base step, since a root may hide there.
#[allow(clippy::too_many_arguments)]
pub fn adaptive(
    f: &Implicit,
    o: DVec3,
    d: DVec3,
    t0: f64,
    t1: f64,
    step: f64,
    eps: f64,
    max_steps: u64,
    s: &mut Scratch,
) -> Option<f64> {
    let max_step = step * 64.0;
    let mut t = t0;
    let mut v = f.value(o + t * d, &mut s.points);
    s.evaluations += 1;
    let mut h = step;
    let mut falling = false;
    let mut t_before = t0;
    let mut steps = 0;
    while t < t1 && steps < max_steps {
        let tn = (t + h).min(t1);
        let vn = f.value(o + tn * d, &mut s.points);
        s.evaluations += 1;
        steps += 1;
        if v.is_finite() && vn.is_finite() && sign(vn) != sign(v) {
            return march(f, o, d, t, tn, h * 0.5, eps, max_steps, s);
        }
        if vn.is_finite() && v.is_finite() && vn.abs() > v.abs() && falling {
            // Passed a minimum of |f| between t_before and tn.
            if let Some(hit) = march(f, o, d, t_before, tn, step, eps, max_steps, s) {
                return Some(hit);
            }
            falling = false;
            h = step;
        } else if vn.is_finite() && v.is_finite() && vn.abs() < v.abs() {
            falling = true;
            h = (h * 2.0).min(max_step);
        }
        t_before = t;
        t = tn;
        v = vn;
    }
    None
}

/// The box holding the ray's points for `t` in `[a, b]`, rounded outward.
fn segment_box(o: DVec3, d: DVec3, a: f64, b: f64) -> [Interval; 3] {
    let pa = o + a * d;
    let pb = o + b * d;
    [0, 1, 2].map(|i| {
        let (lo, hi) = (pa[i].min(pb[i]), pa[i].max(pb[i]));
        Interval::new(lo.next_down(), hi.next_up())
    })
}

/// Guaranteed root isolation: split `[t0, t1]`, drop pieces where the
/// interval of `f` excludes zero, and refine a piece once `f` is provably
/// monotone on it and changes sign. A piece that cannot be split below
/// `eps` and may still hold a zero, with `f` near zero to first order, is a
/// touching (double) root, and counts as a hit.
#[allow(clippy::too_many_arguments)]
pub fn isolate(
    f: &Implicit,
    o: DVec3,
    d: DVec3,
    t0: f64,
    t1: f64,
    eps: f64,
    max_steps: u64,
    s: &mut Scratch,
) -> Option<f64> {
    let mut stack: Vec<(f64, f64)> = vec![(t0, t1)];
    let mut budget = max_steps;
    let mut grad_out = [Interval::point(0.0); 4];
    while let Some((a, b)) = stack.pop() {
        if budget == 0 {
            return None;
        }
        budget -= 1;
        let bx = segment_box(o, d, a, b);
        s.evaluations += 1;
        let range = f.value.eval(&bx, &mut s.intervals);
        if !range.contains(0.0) {
            continue;
        }
        if b - a <= eps {
            let m = 0.5 * (a + b);
            let (v, g) = f.value_and_gradient(o + m * d, &mut s.points);
            // A first-order estimate of the distance to the surface.
            if v.abs() <= 4.0 * eps * g.length() || v == 0.0 {
                return Some(m);
            }
            continue;
        }
        let fa = f.value(o + a * d, &mut s.points);
        let fb = f.value(o + b * d, &mut s.points);
        s.evaluations += 3;
        // Where f is provably monotone along the piece, it holds a root
        // exactly when the ends differ in sign.
        f.with_gradient
            .eval_into(&bx, &mut s.intervals, &mut grad_out);
        let slope = grad_out[1] * Interval::point(d.x)
            + grad_out[2] * Interval::point(d.y)
            + grad_out[3] * Interval::point(d.z);
        if !slope.contains(0.0) && !slope.is_empty() && fa.is_finite() && fb.is_finite() {
            if sign(fa) * sign(fb) <= 0 {
                return Some(refine(f, o, d, a, b, fa, eps, s));
            }
            continue;
        }
        let mid = 0.5 * (a + b);
        stack.push((mid, b));
        stack.push((a, mid));
    }
    None
}

/// Illinois (modified regula falsi) on a bracket with one root.
#[allow(clippy::too_many_arguments)]
fn refine(
    f: &Implicit,
    o: DVec3,
    d: DVec3,
    mut a: f64,
    mut b: f64,
    fa: f64,
    eps: f64,
    s: &mut Scratch,
) -> f64 {
    let mut fa = fa;
    let mut fb = f.value(o + b * d, &mut s.points);
    let mut side = 0;
    for _ in 0..200 {
        if b - a <= eps {
            break;
        }
        let mut m = (a * fb - b * fa) / (fb - fa);
        if !(m > a && m < b) {
            m = 0.5 * (a + b);
        }
        let fm = f.value(o + m * d, &mut s.points);
        s.evaluations += 1;
        if !fm.is_finite() {
            // Fall back to bisection over an undefined point.
            m = 0.5 * (a + b);
        }
        if fm == 0.0 {
            return m;
        }
        if sign(fm) == sign(fa) {
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
    0.5 * (a + b)
}
