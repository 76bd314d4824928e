//! Interval evaluation encloses the point value: for every builtin and
//! operator, at random boxes and random points inside them, the value at
//! the point (where it is defined) lies in the interval computed for the
//! box. Boxes include ones that straddle discontinuities and domain edges
//! (sign, abs, min/max, atan2, tan's poles, sqrt and ln at 0, 1/x at 0).

use glam::DVec3;
use nes::expr::{Dual, Implicit, Interval, IntervalLanes};
use proptest::prelude::*;

mod common;

/// Beyond the builtins: discontinuities and domain edges.
const EDGES: &[&str] = &[
    "x / y",
    "1 / (x - 0.25)",
    "x^2 * y^4",
    "pow(x, y)",
    "pow(abs(x), 0.5)",
    "pow(abs(x), 2.5) + pow(abs(y), 3.5)",
    "pow(abs(x) + 0.01, -1.5) * y",
    "tan(2*x + y)",
    "asin(x)",
    "acos(y*z)",
    "atan2(y, x)",
    "cos(1.5 * atan2(y, x)) + z",
    "z - 2 * atan2(y - 0.5, x + 0.25) + sin(atan2(x, y))",
    "ln(x)",
    "sqrt(x)",
    "sign(x - 0.5) * y",
    "(x^2 + 9/4*y^2 + z^2 - 1)^3 - x^2*z^3 - 9/80*y^2*z^3",
    // A member that overflows beside one that does not: min(inf, v) is v,
    // and its slope is v's.
    "min(x^1000 - 1, y)",
    "max(1 - exp(400 * x^2), z - 2)",
];

thread_local! {
    /// Every builtin's case and every edge, compiled once per thread.
    static FUNCTIONS: Vec<(&'static str, Implicit)> = common::CASES
        .iter()
        .chain(EDGES)
        .map(|&e| (e, common::compile(e)))
        .collect();
}

/// A box corner, a size from tiny to large, and fractions placing the
/// point inside it.
fn box_and_point() -> impl Strategy<Value = (DVec3, DVec3, DVec3)> {
    let coord = -3.0..3.0f64;
    let size = prop_oneof![0.0..1e-6f64, 0.0..0.1f64, 0.0..4.0f64];
    let frac = 0.0..=1.0f64;
    (
        (coord.clone(), coord.clone(), coord),
        (size.clone(), size.clone(), size),
        (frac.clone(), frac.clone(), frac),
    )
        .prop_map(|((x, y, z), (a, b, c), (u, v, w))| {
            (
                DVec3::new(x, y, z),
                DVec3::new(x + a, y + b, z + c),
                DVec3::new(u, v, w),
            )
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, .. ProptestConfig::default() })]

    #[test]
    fn interval_evaluation_encloses_every_point_value((lo, hi, frac) in box_and_point()) {
        FUNCTIONS.with(|functions| {
            let mut points = Vec::new();
            let mut intervals = Vec::new();
            // The box's corners and centre, and the random point.
            let mut samples = vec![lo + (hi - lo) * frac, 0.5 * (lo + hi)];
            for corner in 0..8 {
                let pick = |bit: u32, a: f64, b: f64| if corner & (1 << bit) == 0 { a } else { b };
                samples.push(DVec3::new(pick(0, lo.x, hi.x), pick(1, lo.y, hi.y), pick(2, lo.z, hi.z)));
            }
            for (expr, f) in functions {
                let range: Interval = f.interval(lo, hi, &mut intervals);
                for &p in &samples {
                    let v = f.value(p, &mut points);
                    // Division by exactly 0 is undefined in intervals, as
                    // in IEEE 1788 (empty), where f64 gives an infinity.
                    if v.is_nan() || *expr == "x / y" && p.y == 0.0 {
                        continue;
                    }
                    prop_assert!(
                        range.lo <= v && v <= range.hi,
                        "{}: f({}) = {} outside [{}, {}] for the box {} .. {}",
                        expr, p, v, range.lo, range.hi, lo, hi
                    );
                }
            }
            Ok(())
        })?;
    }
}

/// A line (start, unit direction), a piece `[a, b]` of its parameter and
/// fractions placing points in the piece.
fn line_and_piece() -> impl Strategy<Value = (DVec3, DVec3, f64, f64, [f64; 4])> {
    let coord = -3.0..3.0f64;
    let length = prop_oneof![0.0..1e-6f64, 0.0..0.1f64, 0.0..4.0f64];
    let frac = 0.0..=1.0f64;
    (
        (coord.clone(), coord.clone(), coord.clone()),
        (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64),
        coord,
        length,
        [frac.clone(), frac.clone(), frac.clone(), frac],
    )
        .prop_filter_map("a direction", |((x, y, z), (dx, dy, dz), a, len, fr)| {
            let d = DVec3::new(dx, dy, dz).try_normalize()?;
            Some((DVec3::new(x, y, z), d, a, a + len, fr))
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, .. ProptestConfig::default() })]

    /// Along a line, evaluation in the line's parameter (what root
    /// isolation does on straight segments) encloses the point values at
    /// the line's points, in every interval type: one interval, eight in
    /// lanes, and a dual number whose slope encloses the slopes there.
    #[test]
    fn evaluation_along_a_line_encloses_every_point_value(
        (start, dir, a, b, fracs) in line_and_piece()
    ) {
        FUNCTIONS.with(|functions| {
            let (mut points, mut forms) = (Vec::new(), Vec::new());
            let piece = Interval::new(a, b);
            let mut ts = vec![a, b, 0.5 * (a + b)];
            ts.extend(fracs.iter().map(|f| a + (b - a) * f));
            // Lane k holds the k-th eighth of the piece.
            let eighth = |k: usize| Interval::new(a + (b - a) * k as f64 / 8.0, a + (b - a) * (k + 1) as f64 / 8.0);
            for (expr, f) in functions {
                f.value_tape.line_forms(start, dir, a.abs().max(b.abs()) * (1.0 + 1e-12), &mut forms);
                let range: Interval = f.value_tape.eval_on_line(&forms, piece, &mut Vec::new());
                let dual: Dual<Interval> =
                    f.value_tape.eval_on_line(&forms, Dual::variable(piece), &mut Vec::new());
                let lanes: IntervalLanes<8> =
                    f.value_tape.eval_on_line(&forms, IntervalLanes::from_fn(eighth), &mut Vec::new());
                for &t in &ts {
                    let p = start + t * dir;
                    let v = f.value(p, &mut points);
                    if v.is_nan() {
                        continue;
                    }
                    for (what, r) in [("interval", range), ("dual value", dual.v)] {
                        prop_assert!(
                            r.lo <= v && v <= r.hi,
                            "{}: {} f({}) = {} outside [{}, {}] on {} + [{}, {}] {}",
                            expr, what, p, v, r.lo, r.hi, start, a, b, dir
                        );
                    }
                    for k in 0..8 {
                        let lane = lanes.lane(k);
                        if eighth(k).contains(t) {
                            prop_assert!(
                                lane.lo <= v && v <= lane.hi,
                                "{}: lane {} f({}) = {} outside [{}, {}]", expr, k, p, v, lane.lo, lane.hi
                            );
                        }
                    }
                    // The slope where the function is smooth at this point:
                    // two difference quotients agree.
                    let h = 1e-6 * (1.0 + t.abs());
                    let slope = |h: f64, points: &mut Vec<f64>| {
                        (f.value(start + (t + h) * dir, points) - f.value(start + (t - h) * dir, points)) / (2.0 * h)
                    };
                    let (s1, s2) = (slope(h, &mut points), slope(2.0 * h, &mut points));
                    let inside = t - 2.0 * h >= a && t + 2.0 * h <= b;
                    if inside && s1.is_finite() && s2.is_finite() && (s1 - s2).abs() <= 1e-4 * (1.0 + s1.abs()) {
                        let tol = 1e-3 * (1.0 + s1.abs());
                        prop_assert!(
                            dual.d.lo - tol <= s1 && s1 <= dual.d.hi + tol,
                            "{}: slope {} at {} outside [{}, {}]", expr, s1, p, dual.d.lo, dual.d.hi
                        );
                    }
                }
            }
            Ok(())
        })?;
    }
}
