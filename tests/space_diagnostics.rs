//! Diagnostics for bad space parameters, with their spans.

fn codes_and_spans(name: &str, src: &str) -> Vec<(String, String)> {
    let err = nes::compile_source("s.nes", src).expect_err("should fail");
    insta::assert_snapshot!(name, err.render_plain());
    err.diagnostics
        .iter()
        .map(|d| {
            let s = d.span().unwrap();
            (d.code.as_str().to_string(), src[s.start..s.end].to_string())
        })
        .collect()
}

const CAMERA: &str = "camera { position (0, 0, 0) look_at (1, 0, 0) }\n";

#[test]
fn an_empty_torus_cell() {
    let got = codes_and_spans(
        "an_empty_torus_cell",
        &format!("{CAMERA}space torus {{ min (0, 0, 0) max (1, -1, 1) }}\n"),
    );
    assert_eq!(got, [("E0301".to_string(), "(1, -1, 1)".to_string())]);
}

#[test]
fn a_negative_wrap_count_and_unknown_torus_property() {
    let got = codes_and_spans(
        "a_negative_wrap_count_and_unknown_torus_property",
        &format!("{CAMERA}space torus {{ wraps -3 sizes 4 }}\n"),
    );
    assert_eq!(
        got,
        [
            ("E0301".to_string(), "-3".to_string()),
            ("E0104".to_string(), "sizes".to_string())
        ]
    );
}

#[test]
fn a_sphere_space_radius_that_is_not_positive() {
    let got = codes_and_spans(
        "a_sphere_space_radius_that_is_not_positive",
        &format!("{CAMERA}space sphere {{ radius 0 }}\n"),
    );
    assert_eq!(got, [("E0301".to_string(), "0".to_string())]);
}

#[test]
fn the_ode_method_outside_the_sphere_space() {
    let got = codes_and_spans(
        "the_ode_method_outside_the_sphere_space",
        &format!("{CAMERA}space torus\nrender {{ method ode }}\n"),
    );
    assert_eq!(got, [("E0301".to_string(), "ode".to_string())]);
}

#[test]
fn an_unknown_space() {
    let got = codes_and_spans("an_unknown_space", &format!("{CAMERA}space hyperbolic\n"));
    assert_eq!(got, [("E0101".to_string(), "hyperbolic".to_string())]);
}

#[test]
fn curved_space_radius_and_loops_out_of_range() {
    let got = codes_and_spans(
        "curved_space_radius_and_loops_out_of_range",
        &format!("{CAMERA}space s3 {{ radius -1 loops 0 }}\n"),
    );
    assert_eq!(
        got,
        [
            ("E0301".to_string(), "-1".to_string()),
            ("E0301".to_string(), "0".to_string())
        ]
    );
}

#[test]
fn a_scale_after_a_translate_in_a_curved_space() {
    let got = codes_and_spans(
        "a_scale_after_a_translate_in_a_curved_space",
        &format!("{CAMERA}space h3\nobject sphere(1) {{ translate (2, 0, 0) scale 2 }}\n"),
    );
    assert_eq!(got, [("E0301".to_string(), "scale 2".to_string())]);
}

#[test]
fn a_horosphere_in_s3() {
    let got = codes_and_spans(
        "a_horosphere_in_s3",
        &format!("{CAMERA}space s3\nobject horosphere((1, 0, 0), 2)\n"),
    );
    assert_eq!(
        got,
        [("E0202".to_string(), "horosphere((1, 0, 0), 2)".to_string())]
    );
}

/// `method ode` in S3 or H3 says what their paths are (exact geodesics
/// in closed form, nothing to integrate), not that they are straight.
#[test]
fn the_ode_method_in_curved_spaces() {
    let got = codes_and_spans(
        "the_ode_method_in_s3",
        &format!("{CAMERA}space s3\nrender {{ method ode }}\n"),
    );
    assert_eq!(got, [("E0301".to_string(), "ode".to_string())]);
    let got = codes_and_spans(
        "the_ode_method_in_h3",
        &format!("{CAMERA}space h3\nrender {{ method ode }}\n"),
    );
    assert_eq!(got, [("E0301".to_string(), "ode".to_string())]);
}

/// docs/errors.md lists the curved spaces' diagnostics, each with the
/// code nes gives it.
#[test]
fn the_curved_space_diagnostics_are_documented() {
    let doc =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/errors.md")).unwrap();
    let section = doc
        .split("## In curved spaces")
        .nth(1)
        .expect("a section on curved spaces");
    let cases = [
        ("space s3 { radius -1 }\n", "`radius`"),
        ("space s3 { loops 0 }\n", "`loops`"),
        ("space h3 { loops 2 }\n", "`loops` in `space h3`"),
        (
            "space h3\nobject sphere(1) { translate (2, 0, 0) scale 2 }\n",
            "`scale` after a `translate`",
        ),
        (
            "space s3\nobject horosphere((1, 0, 0), 2)\n",
            "`horosphere` or `busemann` in S3",
        ),
        (
            "space h3\nobject horosphere((0, 0, 0), 2)\n",
            "the direction (0, 0, 0)",
        ),
        ("space h3\nlet a = busemann((1, 0, 0))\n", "outside a shape"),
        (
            "space s3\nrender { method ode }\n",
            "`render { method ode }`",
        ),
    ];
    for (src, row) in cases {
        let err = nes::compile_source("s.nes", &format!("{CAMERA}{src}")).expect_err(src);
        let code = err.diagnostics[0].code.as_str();
        let line = section
            .lines()
            .find(|l| l.contains(row))
            .unwrap_or_else(|| panic!("no row for {row}"));
        assert!(
            line.starts_with(&format!("| {code} |")),
            "{src}: {code}, but {line}"
        );
    }
}

/// In the file a space is named in lower case, as every word is; a name
/// in another case is refused with the lower-case one suggested.
#[test]
fn a_space_named_in_upper_case() {
    let got = codes_and_spans(
        "a_space_named_in_upper_case",
        &format!("{CAMERA}space S3\n"),
    );
    assert_eq!(got, [("E0101".to_string(), "S3".to_string())]);
    let err = nes::compile_source("s.nes", &format!("{CAMERA}space S3\n")).unwrap_err();
    assert!(err.render_plain().contains("did you mean `s3`?"));
}

#[test]
fn a_metric_that_is_not_symmetric() {
    let got = codes_and_spans(
        "a_metric_that_is_not_symmetric",
        &format!("{CAMERA}space metric {{ g [(1, x, 0), (0, 1, 0), (0, 0, 1)] }}\n"),
    );
    assert_eq!(
        got,
        [("E0301".to_string(), "x".to_string())],
        "the label on the first entry of the pair"
    );
}

#[test]
fn a_metric_that_is_not_positive_definite_at_the_camera() {
    let got = codes_and_spans(
        "a_metric_that_is_not_positive_definite_at_the_camera",
        &format!("{CAMERA}space metric {{ g diag(1, x - 1, 1) }}\n"),
    );
    assert_eq!(
        got,
        [("E0301".to_string(), "diag(1, x - 1, 1)".to_string())]
    );
}

#[test]
fn a_camera_outside_the_metric_domain() {
    let got = codes_and_spans(
        "a_camera_outside_the_metric_domain",
        &format!("{CAMERA}space metric {{ g conformal(1 / z)  domain z > 0 }}\n"),
    );
    assert_eq!(got, [("E0301".to_string(), "z > 0".to_string())]);
}

#[test]
fn a_metric_entry_with_an_unknown_name_and_a_missing_metric() {
    let got = codes_and_spans(
        "a_metric_entry_with_an_unknown_name",
        &format!("{CAMERA}space metric {{ g diag(1, 1 + w^2, 1) }}\n"),
    );
    assert_eq!(got, [("E0101".to_string(), "w".to_string())]);
    let got = codes_and_spans(
        "a_metric_space_without_a_metric",
        &format!("{CAMERA}space metric {{ domain z > 0 }}\n"),
    );
    assert_eq!(got[0].0, "E0105");
    let got = codes_and_spans(
        "a_metric_that_is_not_a_matrix",
        &format!("{CAMERA}space metric {{ g [(1, 0), (0, 1)] }}\n"),
    );
    assert_eq!(got, [("E0202".to_string(), "[(1, 0), (0, 1)]".to_string())]);
}

#[test]
fn a_condition_as_a_metric_entry_and_a_formula_as_its_domain() {
    let got = codes_and_spans(
        "a_condition_as_a_metric_entry",
        &format!("{CAMERA}space metric {{ g diag(1, z > 0, 1) }}\n"),
    );
    assert_eq!(got, [("E0202".to_string(), "z > 0".to_string())]);
    let got = codes_and_spans(
        "a_formula_as_a_metric_domain",
        &format!("{CAMERA}space metric {{ g diag(1, 1, 1)  domain z }}\n"),
    );
    assert_eq!(got, [("E0202".to_string(), "z".to_string())]);
}

#[test]
fn a_metric_that_is_not_finite_at_the_camera() {
    let got = codes_and_spans(
        "a_metric_that_is_not_finite_at_the_camera",
        &format!("{CAMERA}space metric {{ g diag(1, sqrt(-1 - x^2), 1) }}\n"),
    );
    assert_eq!(
        got,
        [(
            "E0301".to_string(),
            "diag(1, sqrt(-1 - x^2), 1)".to_string()
        )]
    );
}
