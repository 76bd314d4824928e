//! Every builtin's symbolic derivative agrees with central differences at
//! random points. Points where the function is not differentiable (or not
//! defined) are skipped: there, central differences at two step sizes
//! disagree with each other.

use glam::DVec3;

mod common;

use common::{compile, CASES};

/// A small deterministic generator, so failures reproduce.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }

    /// A point in the cube [-1.5, 1.5]^3.
    fn point(&mut self) -> DVec3 {
        DVec3::new(self.next(), self.next(), self.next()) * 1.5
    }
}

#[test]
fn symbolic_gradients_match_central_differences() {
    let mut rng = Lcg(7);
    let mut slots = Vec::new();
    for expr in CASES {
        let f = compile(expr);
        let mut checked = 0;
        for _ in 0..200 {
            let p = rng.point();
            let (v, grad) = f.value_and_gradient(p, &mut slots);
            assert!(
                v.is_nan() || (v - f.value(p, &mut slots)).abs() <= 1e-12 * v.abs().max(1.0),
                "{expr}: the gradient tape's value differs from the value tape"
            );
            if !v.is_finite() {
                continue;
            }
            let mut smooth = true;
            let mut numeric = [0.0; 3];
            for (axis, slot) in numeric.iter_mut().enumerate() {
                let e = DVec3::AXES[axis];
                let diff = |h: f64, slots: &mut Vec<f64>| {
                    (f.value(p + e * h, slots) - f.value(p - e * h, slots)) / (2.0 * h)
                };
                let (a, b) = (diff(1e-5, &mut slots), diff(2e-5, &mut slots));
                if !a.is_finite() || !b.is_finite() || (a - b).abs() > 1e-6 * (1.0 + a.abs()) {
                    smooth = false;
                }
                *slot = a;
            }
            if !smooth {
                continue;
            }
            checked += 1;
            for axis in 0..3 {
                let (s, n) = (grad[axis], numeric[axis]);
                assert!(
                    (s - n).abs() <= 1e-5 * (1.0 + n.abs()),
                    "{expr} at {p}: d/d{} symbolic {s} vs numeric {n}",
                    ["x", "y", "z"][axis]
                );
            }
        }
        assert!(
            checked >= 50,
            "{expr}: only {checked} smooth points checked"
        );
    }
}

/// Simplification removes identities, folds constants and shares
/// repeated subexpressions.
#[test]
fn simplification_shrinks_what_was_written() {
    let f = compile("(x*1 + 0) * (x*1 + 0) + y^1 - 0*z + (2 + 3)*sin(y)*sin(y)");
    // What is left is x^2 + y + 5 sin(y)^2: x, x^2, y, sin y, its square,
    // 5, a product and two sums.
    assert!(
        f.size_simplified < f.size_written,
        "{} vs {}",
        f.size_simplified,
        f.size_written
    );
    assert_eq!(f.size_simplified, 9);
    let mut slots = Vec::new();
    let p = DVec3::new(0.3, -0.7, 2.0);
    let want = 0.09 - 0.7 + 5.0 * (-0.7f64).sin().powi(2);
    assert!((f.value(p, &mut slots) - want).abs() < 1e-12);
}

/// Integer powers become products: x^8 is three squarings.
#[test]
fn integer_powers_compile_to_products() {
    let f = compile("x^8 - 1");
    // x, square, square, square, -1, add: six instructions.
    assert_eq!(f.value_tape.len(), 6, "{:?}", f.value_tape);
}

/// Along a line, the dual-number pass in the line's parameter gives the
/// value the point evaluator gives at the line's point, and the slope
/// that the symbolic gradient dotted with the direction gives: the two
/// evaluators the tracer mixes agree for every builtin.
#[test]
fn dual_slopes_along_lines_match_the_symbolic_gradient() {
    use nes::expr::Dual;
    let mut rng = Lcg(11);
    let (mut slots, mut duals, mut forms) = (Vec::new(), Vec::new(), Vec::new());
    for expr in CASES {
        let f = compile(expr);
        let mut checked = 0;
        for _ in 0..200 {
            let start = DVec3::new(rng.next(), rng.next(), rng.next()) * 1.5;
            let Some(dir) = DVec3::new(rng.next(), rng.next(), rng.next()).try_normalize() else {
                continue;
            };
            let u = rng.next();
            f.value_tape.line_forms(start, dir, u.abs(), &mut forms);
            let p = start + u * dir;
            let (v, grad) = f.value_and_gradient(p, &mut slots);
            let on_line: f64 = f.value_tape.eval_on_line(&forms, u, &mut Vec::new());
            let dual: Dual<f64> = f
                .value_tape
                .eval_on_line(&forms, Dual::variable(u), &mut duals);
            if !v.is_finite() || !grad.is_finite() {
                continue;
            }
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()));
            assert!(
                close(on_line, v),
                "{expr} at {p}: on the line {on_line}, at the point {v}"
            );
            assert!(
                close(dual.v, v),
                "{expr} at {p}: dual value {} vs {v}",
                dual.v
            );
            let slope = grad.dot(dir);
            assert!(
                close(dual.d, slope),
                "{expr} at {p} along {dir}: dual slope {} vs gradient . direction {slope}",
                dual.d
            );
            checked += 1;
        }
        assert!(checked >= 50, "{expr}: only {checked} points checked");
    }
}

/// The symbolic Hessian (what curvature colours read) agrees with central
/// differences of the symbolic gradient, for every shared case.
#[test]
fn symbolic_hessians_match_differences_of_the_gradient() {
    let mut rng = Lcg(11);
    let mut slots = Vec::new();
    for expr in CASES {
        let src = format!(
            "shape f = {expr}\ncamera {{ position (-5, 0, 0) }}\nobject f {{ colour viridis(mean_curvature) }}"
        );
        let scene = nes::compile_source("hessian.nes", &src)
            .unwrap_or_else(|e| panic!("{expr}: {}", e.render_plain()));
        let object = &scene.objects[0];
        let nes::scene::Paint::Field(field) = &object.colour else {
            panic!("{expr}: a colour that varies is a field");
        };
        let hessian = field
            .second_derivatives
            .as_ref()
            .expect("a colour reading a curvature builds the Hessian");
        let f = &object.function;
        let mut checked = 0;
        for _ in 0..200 {
            let p = rng.point();
            let mut d = [0.0; 9];
            hessian.eval_into(&[p.x, p.y, p.z], &mut slots, &mut d);
            let (_, grad) = f.value_and_gradient(p, &mut slots);
            if d.iter().any(|v| !v.is_finite()) || !grad.is_finite() {
                continue;
            }
            for axis in 0..3 {
                assert!(
                    (d[axis] - grad[axis]).abs() <= 1e-12 * (1.0 + grad[axis].abs()),
                    "{expr}: gradients differ"
                );
            }
            // Column j of the Hessian: the gradient's change along axis j.
            let column = |j: usize, h: f64, slots: &mut Vec<f64>| {
                let e = DVec3::AXES[j];
                (f.value_and_gradient(p + e * h, slots).1
                    - f.value_and_gradient(p - e * h, slots).1)
                    / (2.0 * h)
            };
            let numeric: Vec<DVec3> = (0..3).map(|j| column(j, 1e-5, &mut slots)).collect();
            let coarse: Vec<DVec3> = (0..3).map(|j| column(j, 2e-5, &mut slots)).collect();
            if numeric.iter().zip(&coarse).any(|(a, b)| {
                !a.is_finite()
                    || (*a - *b).abs().max_element() > 1e-6 * (1.0 + a.abs().max_element())
            }) {
                continue;
            }
            checked += 1;
            let symbolic = [[d[3], d[6], d[7]], [d[6], d[4], d[8]], [d[7], d[8], d[5]]];
            for i in 0..3 {
                for j in 0..3 {
                    let (s, n) = (symbolic[i][j], numeric[j][i]);
                    assert!(
                        (s - n).abs() <= 1e-5 * (1.0 + n.abs()),
                        "{expr} at {p}: d2/d{}d{} symbolic {s} vs numeric {n}",
                        ["x", "y", "z"][i],
                        ["x", "y", "z"][j]
                    );
                }
            }
        }
        assert!(
            checked >= 40,
            "{expr}: only {checked} smooth points checked"
        );
    }
}

/// Where a clamp or a `max` holds the argument of `sqrt`, `acos`, `asin`,
/// `ln` or a fractional power at the end of its domain, the function is
/// flat, and its gradient is the flat part's, not 0 times infinity (NaN).
#[test]
fn a_clamped_argument_is_flat_not_nan() {
    let mut slots = Vec::new();
    for (expr, at, want) in [
        (
            "z - 0.5 * acos(clamp(x / 2, -1, 1))",
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::Z,
        ),
        (
            "z - 0.5 * acos(clamp(x / 2, -1, 1))",
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.25, 0.0, 1.0),
        ),
        ("z - asin(min(1, x))", DVec3::new(2.0, 1.0, 0.0), DVec3::Z),
        (
            "z - sqrt(max(0, 1 - x^2 - y^2))",
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::Z,
        ),
        ("z - max(0, x)^(1/3)", DVec3::new(-1.0, 0.0, 0.0), DVec3::Z),
    ] {
        let f = compile(expr);
        let (_, grad) = f.value_and_gradient(at, &mut slots);
        assert!(
            (grad - want).length() < 1e-12,
            "{expr} at {at}: gradient {grad:?}, want {want}"
        );
    }
}

#[test]
fn forward_gradients_of_a_value_only_formula_match_the_symbolic_ones() {
    // A cell's shorter formula has no gradient tape (see
    // `Implicit::value_only`): its normals come from forward
    // differentiation of the value tape, which must agree.
    let mut rng = Lcg(11);
    let mut slots = Vec::new();
    for expr in CASES {
        let f = compile(expr);
        let forward = f.from_pruned(&f.unpruned());
        assert_eq!(forward.gradient_tape.output_count(), 0, "{expr}");
        let mut checked = 0;
        for _ in 0..100 {
            let p = rng.point();
            let (v, g) = f.value_and_gradient(p, &mut slots);
            let (fv, fg) = forward.value_and_gradient(p, &mut slots);
            if !(v.is_finite() && g.is_finite()) {
                continue;
            }
            let scale = 1e-9 * (1.0 + g.abs().max_element());
            assert!(
                (v - fv).abs() <= 1e-12 * v.abs().max(1.0),
                "{expr} at {p}: {v} vs {fv}"
            );
            assert!(
                (g - fg).abs().max_element() <= scale,
                "{expr} at {p}: {g} vs {fg}"
            );
            checked += 1;
        }
        assert!(checked > 0, "{expr}: no point checked");
    }
}
