//! Interval evaluation encloses the point value: for every builtin and
//! operator, at random boxes and random points inside them, the value at
//! the point (where it is defined) lies in the interval computed for the
//! box. Boxes include ones that straddle discontinuities and domain edges
//! (sign, abs, min/max, atan2, tan's poles, sqrt and ln at 0, 1/x at 0).

use glam::DVec3;
use nes::expr::{Implicit, Interval};
use proptest::prelude::*;

mod common;

/// Beyond the builtins: discontinuities and domain edges.
const EDGES: &[&str] = &[
    "x / y",
    "1 / (x - 0.25)",
    "x^2 * y^4",
    "pow(x, y)",
    "pow(abs(x), 0.5)",
    "tan(2*x + y)",
    "asin(x)",
    "acos(y*z)",
    "atan2(y, x)",
    "ln(x)",
    "sqrt(x)",
    "sign(x - 0.5) * y",
    "(x^2 + 9/4*y^2 + z^2 - 1)^3 - x^2*z^3 - 9/80*y^2*z^3",
];

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
        thread_local! {
            static FUNCTIONS: Vec<(&'static str, Implicit)> = common::CASES
                .iter()
                .chain(EDGES)
                .map(|&e| (e, common::compile(e)))
                .collect();
        }
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
                    if v.is_nan() {
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
