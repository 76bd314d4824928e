//! Shared by the test files: the expressions that exercise every builtin,
//! and compiling one expression as a scene's only object.

#![allow(dead_code)] // each test file uses a part

use nes::expr::Implicit;

/// One expression per builtin (and operator), each mixing the three
/// coordinates so that every partial derivative is exercised.
pub const CASES: &[&str] = &[
    "x + 2*y - z/3",
    "x*y*z",
    "x / (1.5 + y*y)",
    "(x + y)^3 - z^2",
    "(x*x + 1)^(y/3)",
    "-(x - y)^2 + z",
    "sin(x*y + z)",
    // Sine and cosine of one argument: the tape computes them in one step.
    "sin(x*y - z) * cos(x*y - z) + cos(y) - sin(0.5*y)",
    "cos(x - 2*z) * y",
    "tan(0.3*x + 0.2*y - 0.1*z)",
    "asin(0.3*x + 0.2*y*z)",
    "acos(0.25*x - 0.2*z + 0.1*y)",
    "atan(x*z - y)",
    "atan2(y + 0.1, x - z)",
    "sinh(x - y*z)",
    "cosh(y + 0.5*x) - z",
    "tanh(x*y - z)",
    "exp(0.5*x - y + z*z)",
    "ln(x*x + y*y + 0.5) * z",
    "log(1 + x*x + z*z) - y",
    "sqrt(x*x + 2*y*y + z*z + 0.1)",
    "abs(x - y) + z",
    "sign(x) * y + z",
    "min(x, y*z) + max(y, x - z)",
    "min(x, y, z, 0.2)",
    "max(x*y, z)",
    "clamp(x + y, -0.5, 0.5) * z",
    "pow(x*x + 0.5, z) + y",
    "smin(x, y, 0.4) + z",
    "length((x, y, z) - (0.1, 0.2, 0.3))",
    "dot(normalize((1, 2, 3)), p) + x*z",
    "length(cross(p, (0.3, -1, 0.5)))",
    "sphere(1) + torus(1, 0.3)*y",
    "box(0.5, 0.4, 0.3) * (1 + x)",
    "floor(2*x + y) * 0.5 + z",
    "fract(x + 0.3*y) - z",
    "mod(x*y, 0.7) + z",
    "ceil(x - z) + round(y)",
    "step(0.2, x) * y + z",
    "smoothstep(-0.5, 0.5, x + y) * z",
    "mix(x, y, z)",
    "if x > y then x*z else sin(y) + z",
    "if x < 0 and y > 0 then sqrt(-x) + z else sqrt(x*x + y*y) - z",
    "if not (x < 0 or z > 0.5) then y else y*y",
    "sum(i in 0..3, (x - i*0.3)^2) - y*z",
    "noise(2.5*p + (0.3, -0.1, 0.2)) + 0.1*z",
    "fbm((x*y, z, x), 3) - y",
    "product(c in [0.5, -0.25], x - c) + y",
    "let r = x*x + y*y in r - z",
    "sphere(0.5) at (x - 0.2, 2*y, z)",
    "smin(sphere(0.5) translate (0.3, 0, 0), box(0.3, 0.3, 0.3) rotate 30 about z, 0.2)",
    "sphere(0.4) rotate 20*z about (0, 0, 1) scale (1, 2, 1)",
];

/// The function of the scene whose only object is the shape `expr`.
pub fn compile(expr: &str) -> Implicit {
    compile_in("", expr)
}

/// [`compile`] in the space a `space` directive (or "") names.
#[allow(dead_code)]
pub fn compile_in(space: &str, expr: &str) -> Implicit {
    let src = format!("{space}\nshape f = {expr}\ncamera {{ position (-5, 0, 0) }}\nobject f");
    let scene = nes::compile_source("case.nes", &src)
        .unwrap_or_else(|e| panic!("{expr}: {}", e.render_plain()));
    scene.objects[0].function.clone()
}

/// How many pixels of two renders of one size differ by more than `by` in
/// some linear channel.
pub fn pixels_differing(a: &nes::render::Image, b: &nes::render::Image, by: f64) -> usize {
    assert_eq!(
        (a.width, a.height),
        (b.width, b.height),
        "renders of one size"
    );
    a.pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| (**p - **q).abs().max_element() > by)
        .count()
}

/// A folder of its own under the system's temporary folder for one test,
/// emptied when made and removed when dropped, unless the test panicked:
/// then it stays for a look at what the test left.
pub struct Scratch(std::path::PathBuf);

impl Scratch {
    /// `nes-NAME-PID` under the temporary folder.
    pub fn new(name: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!("nes-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
}

impl std::ops::Deref for Scratch {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::path::Path> for Scratch {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

impl AsRef<std::ffi::OsStr> for Scratch {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.0.as_os_str()
    }
}
