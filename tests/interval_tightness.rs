//! Interval extensions are tight: over random small boxes, the width of
//! each builtin's interval stays within a stated factor of the range its
//! values sampled on a grid over the box actually cover. Enclosure (never
//! too narrow) is tests/interval_enclosure.rs; this is the other side:
//! a loose extension makes bounds and root isolation slow without making
//! them wrong, so only a test like this one catches it. The factors are
//! what each extension achieves now, with a little room; a builtin whose
//! extension regresses fails here.

use glam::DVec3;

mod common;

/// A builtin, the region its boxes are drawn from (where it is defined
/// and away from its discontinuities), and the largest width ratio allowed.
struct Case {
    /// A `space` directive, or "" for Euclidean space.
    space: &'static str,
    expr: &'static str,
    lo: [f64; 3],
    hi: [f64; 3],
    factor: f64,
}

const CASES: &[Case] = &[
    Case {
        space: "",
        expr: "x^2 + y",
        lo: [-2.0, 0.0, 0.0],
        hi: [2.0, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "x * y",
        lo: [-2.0, -2.0, 0.0],
        hi: [2.0, 2.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "x / y",
        lo: [-2.0, 0.5, 0.0],
        hi: [2.0, 2.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "abs(x) + y",
        lo: [-2.0, 0.0, 0.0],
        hi: [2.0, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "sqrt(x) + y",
        lo: [0.01, 0.0, 0.0],
        hi: [4.0, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "exp(x) + y",
        lo: [-3.0, 0.0, 0.0],
        hi: [3.0, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "ln(x) + y",
        lo: [0.01, 0.0, 0.0],
        hi: [4.0, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "sin(x) + y",
        lo: [-7.0, 0.0, 0.0],
        hi: [7.0, 1.0, 1.0],
        factor: 1.2,
    },
    Case {
        space: "",
        expr: "cos(x) + y",
        lo: [-7.0, 0.0, 0.0],
        hi: [7.0, 1.0, 1.0],
        factor: 1.2,
    },
    Case {
        space: "",
        expr: "sin(40 * x) + y",
        lo: [-7.0, 0.0, 0.0],
        hi: [7.0, 1.0, 1.0],
        factor: 1.2,
    },
    Case {
        space: "",
        expr: "tan(x) + y",
        lo: [-1.4, 0.0, 0.0],
        hi: [1.4, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "asin(x) + y",
        lo: [-0.95, 0.0, 0.0],
        hi: [0.95, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "acos(x) + y",
        lo: [-0.95, 0.0, 0.0],
        hi: [0.95, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "atan(x) + y",
        lo: [-3.0, 0.0, 0.0],
        hi: [3.0, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "sinh(x) + y",
        lo: [-3.0, 0.0, 0.0],
        hi: [3.0, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "cosh(x) + y",
        lo: [-3.0, 0.0, 0.0],
        hi: [3.0, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "tanh(x) + y",
        lo: [-3.0, 0.0, 0.0],
        hi: [3.0, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "pow(x, 2.5) + y",
        lo: [0.1, 0.0, 0.0],
        hi: [3.0, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "pow(x, y)",
        lo: [0.1, -2.0, 0.0],
        hi: [3.0, 2.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "min(x, y)",
        lo: [-2.0, -2.0, 0.0],
        hi: [2.0, 2.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "max(x, y)",
        lo: [-2.0, -2.0, 0.0],
        hi: [2.0, 2.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "clamp(x, -0.5, 0.5) + y",
        lo: [-2.0, 0.0, 0.0],
        hi: [2.0, 1.0, 1.0],
        factor: 1.1,
    },
    Case {
        space: "",
        expr: "smin(x, y, 0.5)",
        lo: [-2.0, -2.0, 0.0],
        hi: [2.0, 2.0, 1.0],
        factor: 1.1,
    },
    // atan2 in each open half-plane: right, upper, lower.
    Case {
        space: "",
        expr: "atan2(y, x)",
        lo: [0.1, -2.0, 0.0],
        hi: [2.0, 2.0, 1.0],
        factor: 1.2,
    },
    Case {
        space: "",
        expr: "atan2(y, x)",
        lo: [-2.0, 0.1, 0.0],
        hi: [2.0, 2.0, 1.0],
        factor: 1.2,
    },
    Case {
        space: "",
        expr: "atan2(y, x)",
        lo: [-2.0, -2.0, 0.0],
        hi: [2.0, -0.1, 1.0],
        factor: 1.2,
    },
    // The geometric builtins of the curved spaces, written with their maps
    // from normal coordinates (shc, chc): compositions, so looser than one
    // operation; the factors keep them from getting worse.
    Case {
        space: "space h3 { radius 2 }",
        expr: "plane_distance((0, 0.6, 0.8))",
        lo: [-1.5, -1.5, -1.5],
        hi: [1.5, 1.5, 1.5],
        factor: 1.25,
    },
    Case {
        space: "space s3 { radius 2 }",
        expr: "plane_distance((0, 0.6, 0.8))",
        lo: [-1.5, -1.5, -1.5],
        hi: [1.5, 1.5, 1.5],
        factor: 2.3,
    },
    Case {
        space: "space h3 { radius 2 }",
        expr: "busemann((1, 0, 0))",
        lo: [-1.5, -1.5, -1.5],
        hi: [1.5, 1.5, 1.5],
        factor: 4.0,
    },
    Case {
        space: "space h3 { radius 2 }",
        expr: "geodesic_distance((1, 0.5, 0))",
        lo: [-1.5, -1.5, -1.5],
        hi: [1.5, 1.5, 1.5],
        factor: 10.0,
    },
    Case {
        space: "space s3 { radius 2 }",
        expr: "geodesic_distance((1, 0.5, 0))",
        lo: [-1.5, -1.5, -1.5],
        hi: [1.5, 1.5, 1.5],
        factor: 12.0,
    },
    Case {
        space: "",
        expr: "floor(x) + y",
        lo: [0.05, 0.0, 0.0],
        hi: [0.95, 1.0, 1.0],
        factor: 1.2,
    },
    Case {
        space: "",
        expr: "fract(x) + y",
        lo: [1.05, 0.0, 0.0],
        hi: [1.95, 1.0, 1.0],
        factor: 1.2,
    },
    Case {
        space: "",
        expr: "mod(x, 0.5) + y",
        lo: [0.51, 0.0, 0.0],
        hi: [0.99, 1.0, 1.0],
        factor: 1.2,
    },
    Case {
        space: "",
        expr: "smoothstep(-1, 1, x) + y",
        lo: [-1.50, 0.0, 0.0],
        hi: [1.50, 1.0, 1.0],
        factor: 1.2,
    },
    Case {
        space: "",
        expr: "mix(x, y, 0.3) + z",
        lo: [-1.0, -1.0, -1.0],
        hi: [1.0, 1.0, 1.0],
        factor: 1.2,
    },
    Case {
        space: "",
        expr: "step(0.5, x) + y",
        lo: [0.60, 0.0, 0.0],
        hi: [2.0, 1.0, 1.0],
        factor: 1.2,
    },
    Case {
        space: "",
        // Across its boundary an `if` is the hull of both branches over
        // the whole box, each taken where it is not used.
        expr: "(if x > 0 then x*x + y else y - x)",
        lo: [-1.0, 0.0, 0.0],
        hi: [1.0, 1.0, 1.0],
        factor: 1.5,
    },
    // Across the branch cut (boxes on both sides of the negative x axis),
    // wrapped where the formula is continuous: each side's values are
    // followed on their own (the whole [-pi, pi] made this [-1, 1]).
    Case {
        space: "",
        expr: "cos(1.5 * atan2(y, x))",
        lo: [-2.0, -0.5, 0.0],
        hi: [-0.5, 0.5, 1.0],
        factor: 1.5,
    },
];

/// A deterministic generator (splitmix64), so failures reproduce.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[test]
fn every_builtin_interval_is_within_its_factor_of_the_sampled_range() {
    const GRID: usize = 9;
    let mut rng = Rng(2026);
    for case in CASES {
        let f = common::compile_in(case.space, case.expr);
        let (mut slots, mut points) = (Vec::new(), Vec::new());
        let mut worst: f64 = 0.0;
        for _ in 0..300 {
            // Small boxes, from 1e-4 to 0.1 on a side, inside the region.
            let size = 10f64.powf(-4.0 + 3.0 * rng.next());
            let lo = DVec3::from_array(std::array::from_fn(|a| {
                let span = case.hi[a] - case.lo[a] - size;
                case.lo[a] + span.max(0.0) * rng.next()
            }));
            let hi = lo + DVec3::splat(size).min(DVec3::from(case.hi) - lo);
            let interval = f.interval(lo, hi, &mut slots);
            let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
            for i in 0..GRID {
                for j in 0..GRID {
                    for k in 0..GRID {
                        let t = DVec3::new(i as f64, j as f64, k as f64) / (GRID - 1) as f64;
                        let v = f.value(lo + (hi - lo) * t, &mut points);
                        low = low.min(v);
                        high = high.max(v);
                    }
                }
            }
            let sampled = high - low;
            let width = interval.hi - interval.lo;
            // Rounding outward adds a few ulps, which matter only when
            // the sampled range is itself that small.
            let slack = 1e-12 * (1.0 + low.abs().max(high.abs()));
            let ratio = (width - slack).max(0.0) / sampled.max(1e-300);
            assert!(
                width <= case.factor * sampled + slack,
                "{}: over {lo} .. {hi} the interval {interval:?} is {ratio:.2} times \
                 the sampled range [{low}, {high}] (at most {} allowed)",
                case.expr,
                case.factor
            );
            worst = worst.max(ratio);
        }
        eprintln!(
            "{:<14} {:<28} worst ratio {worst:.3}",
            case.space, case.expr
        );
    }
}

/// Gradient noise's extension is first-order tight: over a box of side
/// `s` (in lattice cells) its width is at most a fixed multiple of `s`
/// (9.1 at worst on these boxes).
/// A ratio to the sampled range, as above, cannot hold for it: near the
/// noise's extremes the range shrinks with `s` squared, and the corner
/// sum of a cell (whose eight weights are not independent) only with
/// `s`. A mean-value form would be second order, and was measured to
/// double render times for no fewer evaluations.
#[test]
fn noise_intervals_shrink_with_the_box() {
    let f = common::compile("noise(p)");
    let mut rng = Rng(77);
    let mut slots = Vec::new();
    let mut worst: f64 = 0.0;
    for _ in 0..2000 {
        let size = 10f64.powf(-5.0 + 4.5 * rng.next());
        let lo = DVec3::new(rng.next(), rng.next(), rng.next()) * 40.0 - DVec3::splat(20.0);
        let interval = f.interval(lo, lo + DVec3::splat(size), &mut slots);
        let per_side = (interval.hi - interval.lo) / size;
        worst = worst.max(per_side);
        assert!(
            per_side <= 10.0,
            "over a box of side {size} at {lo} the interval {interval:?} is {per_side:.2} times the side"
        );
    }
    eprintln!("noise: worst width per side {worst:.3}");
}
