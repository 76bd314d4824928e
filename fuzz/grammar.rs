//! Generator 2: scenes written from the grammar (`grammar/nes.pest`) and
//! the language reference (`docs/language.md`).
//!
//! Input: a [`Rng`] and how often to go wrong on purpose. Output: the text
//! of a scene: constants, shapes with random expression trees over every
//! builtin (and chains of shapes built from shapes), a camera, lights, a
//! space, render settings with ordinary, extreme and out-of-range values,
//! and objects (shapes, CSG, transforms, properties). With `wrong` at 0
//! the scene is meant to compile (a value may still be out of range);
//! above 0, each node has that chance of a deliberate mistake: a wrong
//! kind, an unknown name, a wrong number of arguments, a stray word.

use crate::mutate::{EXTREME_NUMBERS, WORDS};
use crate::rng::Rng;

/// What an expression evaluates to.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Ty {
    Num,
    Vec,
    Col,
}

/// A shape parameter's kind, as written.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Kind {
    Number,
    Positive,
    Vector,
    Direction,
}

impl Kind {
    fn word(self) -> &'static str {
        match self {
            Kind::Number => "number",
            Kind::Positive => "positive",
            Kind::Vector => "vector",
            Kind::Direction => "direction",
        }
    }
    fn ty(self) -> Ty {
        match self {
            Kind::Number | Kind::Positive => Ty::Num,
            Kind::Vector | Kind::Direction => Ty::Vec,
        }
    }
}

/// A shape that can be called: its name and its parameters' kinds.
#[derive(Clone, Debug)]
struct Sig {
    name: String,
    params: Vec<Kind>,
}

fn prelude() -> Vec<Sig> {
    use Kind::*;
    let s = |name: &str, params: &[Kind]| Sig {
        name: name.into(),
        params: params.to_vec(),
    };
    vec![
        s("sphere", &[Positive]),
        s("plane", &[Direction, Number]),
        s("ellipsoid", &[Positive, Positive, Positive]),
        s("box", &[Positive, Positive, Positive]),
        s("cube", &[Positive]),
        s("torus", &[Positive, Positive]),
        s("cylinder", &[Positive]),
        s("capped_cylinder", &[Positive, Positive]),
        s("cone", &[Positive]),
        s("superellipsoid", &[Positive]),
    ]
}

const UNARY: &[&str] = &[
    "sin", "cos", "tan", "asin", "acos", "atan", "sinh", "cosh", "tanh", "exp", "ln", "log",
    "sqrt", "abs", "sign",
];
const COLOURS: &[&str] = &[
    "black", "white", "grey", "gray", "silver", "red", "green", "blue", "yellow", "orange", "pink",
    "purple", "cyan", "magenta", "brown", "sky",
];
const METHODS: &[&str] = &["auto", "exact", "interval", "march", "adaptive", "ode"];

/// Where an expression is written: in a shape (x, y, z, p and the
/// parameters exist) or anywhere else (constants only).
struct Scope {
    in_shape: bool,
    params: Vec<(String, Ty)>,
}

/// The generator's state while writing one scene.
pub struct Gen<'r> {
    rng: &'r mut Rng,
    wrong: f64,
    /// The chance that a value meant to be ordinary is extreme instead.
    extreme: f64,
    /// Whether the scene is in the sphere space (where `method ode` is
    /// allowed).
    sphere_space: bool,
    lets: Vec<(String, Ty)>,
    shapes: Vec<Sig>,
}

impl<'r> Gen<'r> {
    /// A generator that makes a deliberate mistake with chance `wrong` at
    /// each node, and writes an extreme value instead of an ordinary one
    /// with chance `extreme`.
    pub fn new(rng: &'r mut Rng, wrong: f64, extreme: f64) -> Self {
        Gen {
            rng,
            wrong,
            extreme,
            sphere_space: false,
            lets: Vec::new(),
            shapes: prelude(),
        }
    }

    fn oops(&mut self) -> bool {
        self.wrong > 0.0 && self.rng.chance(self.wrong)
    }

    // ------------------------------------------------------------ numbers --

    /// A number literal: mostly ordinary, sometimes wide, rarely extreme.
    fn literal(&mut self) -> String {
        match self.rng.weighted(&[50, 25, 15, 6, 4]) {
            0 => self.rng.below(10).to_string(),
            1 => format!("{:.*}", self.rng.between(1, 3), self.rng.range(0.0, 5.0)),
            2 => {
                let v = 10f64.powf(self.rng.range(-6.0, 6.0));
                match self.rng.below(3) {
                    0 => format!("{v:e}"),
                    1 => format!("{v}"),
                    _ => format!("{v:.3}"),
                }
            }
            3 => {
                if self.rng.chance(self.extreme * 10.0) {
                    self.extreme()
                } else {
                    "1e6".into()
                }
            }
            _ => format!("{}.5", self.rng.below(1000)),
        }
    }

    /// A literal in `lo..hi` as a person would write it, or now and then
    /// an extreme value.
    fn value_in(&mut self, lo: f64, hi: f64) -> String {
        if self.rng.chance(self.extreme) {
            return self.extreme();
        }
        let v = self.rng.range(lo, hi);
        let text = if hi - lo < 0.1 {
            format!("{:.3e}", v.abs())
        } else {
            format!("{:.3}", v.abs())
        };
        if v < 0.0 {
            format!("-{text}")
        } else {
            text
        }
    }

    /// An extreme number; text that is no number (`NaN`, `0x10`) only when
    /// going wrong.
    fn extreme(&mut self) -> String {
        let n = *self.rng.pick(EXTREME_NUMBERS);
        let number_text = n.trim_start_matches('-').bytes().all(|b| {
            b.is_ascii_digit() || b == b'.' || b == b'e' || b == b'E' || b == b'+' || b == b'-'
        }) && n.parse::<f64>().is_ok();
        if number_text || self.wrong > 0.0 {
            n.to_string()
        } else {
            "0".into()
        }
    }

    fn whole_in(&mut self, lo: usize, hi: usize) -> String {
        if self.rng.chance(self.extreme) {
            return self.extreme();
        }
        self.rng.between(lo, hi).to_string()
    }

    // -------------------------------------------------------- expressions --

    /// `e` as an operand of an operator: bracketed unless it is a name, a
    /// number or a call, so that the tree written is the tree parsed.
    fn atom(e: String) -> String {
        let simple = e
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'.' || b == b'#');
        let call = e.ends_with(')') && !e.starts_with(['(', '-']) && !e.contains(' ');
        if simple && !e.starts_with('-') || call {
            e
        } else {
            format!("({e})")
        }
    }

    /// A name in scope of type `ty`, if there is one.
    fn name_of(&mut self, ty: Ty, scope: &Scope) -> Option<String> {
        let mut names: Vec<String> = self
            .lets
            .iter()
            .chain(scope.params.iter())
            .filter(|(_, t)| *t == ty)
            .map(|(n, _)| n.clone())
            .collect();
        if ty == Ty::Num {
            names.extend(["pi", "tau", "e"].map(String::from));
            if self.rng.chance(0.1) {
                names.push(self.rng.pick(&["frame", "time"]).to_string());
            }
            if scope.in_shape {
                names.extend(["x", "y", "z", "x", "y", "z"].map(String::from));
            }
        }
        if ty == Ty::Vec && scope.in_shape {
            names.push("p".into());
        }
        if ty == Ty::Col {
            names.extend(COLOURS.iter().map(|c| c.to_string()));
        }
        (!names.is_empty()).then(|| self.rng.pick(&names).clone())
    }

    /// A deliberate mistake where an expression of `ty` belongs.
    fn mistake(&mut self, ty: Ty, scope: &Scope, depth: u32) -> String {
        match self.rng.below(7) {
            0 => {
                let other = if ty == Ty::Num { Ty::Vec } else { Ty::Num };
                self.expr(other, scope, depth)
            }
            1 => format!("{}{}", self.rng.pick(UNARY), self.rng.pick(&["", "x", "_"])),
            2 => {
                let f = *self
                    .rng
                    .pick(&["min", "atan2", "clamp", "smin", "dot", "rgb", "sin"]);
                let n = self.rng.below(5);
                let args: Vec<String> = (0..n).map(|_| self.expr(Ty::Num, scope, 1)).collect();
                format!("{f}({})", args.join(", "))
            }
            3 => self.rng.pick(WORDS).to_string(),
            4 => "x".into(),
            5 => format!("({})", self.expr(ty, scope, depth).replace(',', "")),
            _ => {
                let sig = self.rng.pick(&self.shapes).clone();
                let args: Vec<String> = (0..self.rng.below(4))
                    .map(|_| self.expr(Ty::Num, scope, 1))
                    .collect();
                format!("{}({})", sig.name, args.join(", "))
            }
        }
    }

    /// An expression of type `ty`, at most `depth` levels deep.
    fn expr(&mut self, ty: Ty, scope: &Scope, depth: u32) -> String {
        if self.oops() {
            return self.mistake(ty, scope, depth.saturating_sub(1));
        }
        match ty {
            Ty::Num => self.num(scope, depth),
            Ty::Vec => self.vector(scope, depth),
            Ty::Col => self.colour(scope),
        }
    }

    fn num(&mut self, scope: &Scope, depth: u32) -> String {
        if depth == 0 || self.rng.chance(0.3) {
            return match self.name_of(Ty::Num, scope) {
                Some(n) if self.rng.chance(0.5) => n,
                _ => self.literal(),
            };
        }
        let d = depth - 1;
        match self
            .rng
            .weighted(&[30, 8, 5, 14, 4, 3, 4, 3, 3, 3, 4, 8, 3, 2])
        {
            0 => {
                let op = *self.rng.pick(&["+", "-", "*", "/", "+", "*"]);
                let (a, b) = (self.num(scope, d), self.num(scope, d));
                format!("{} {op} {}", Self::atom(a), Self::atom(b))
            }
            1 => {
                // Powers: mostly small whole exponents, as people write them.
                let e = if self.rng.chance(0.7) {
                    self.rng.between(0, 9).to_string()
                } else {
                    Self::atom(self.num(scope, d.min(1)))
                };
                format!("{}^{e}", Self::atom(self.num(scope, d)))
            }
            2 => format!("-{}", Self::atom(self.num(scope, d))),
            3 => format!("{}({})", self.rng.pick(UNARY), self.num(scope, d)),
            4 => format!("atan2({}, {})", self.num(scope, d), self.num(scope, d)),
            5 => format!("pow({}, {})", self.num(scope, d), self.num(scope, d)),
            6 => {
                let f = *self.rng.pick(&["min", "max"]);
                let n = self.rng.between(2, 4);
                let args: Vec<String> = (0..n).map(|_| self.num(scope, d)).collect();
                format!("{f}({})", args.join(", "))
            }
            7 => format!(
                "clamp({}, {}, {})",
                self.num(scope, d),
                self.num(scope, d),
                self.num(scope, d)
            ),
            8 => format!(
                "smin({}, {}, {})",
                self.num(scope, d),
                self.num(scope, d),
                self.value_in(0.05, 1.0)
            ),
            9 => format!("dot({}, {})", self.vector(scope, d), self.vector(scope, d)),
            10 => format!("length({})", self.vector(scope, d)),
            11 if scope.in_shape => self.call(scope, d),
            12 => format!(
                "({}).{}",
                self.vector(scope, d),
                self.rng.pick(&["x", "y", "z"])
            ),
            _ => format!("({})", self.num(scope, d)),
        }
    }

    /// A call of a shape in scope with arguments of the right kinds.
    fn call(&mut self, scope: &Scope, depth: u32) -> String {
        let sig = self.rng.pick(&self.shapes).clone();
        if sig.params.is_empty() && self.rng.chance(0.5) {
            return sig.name;
        }
        let args: Vec<String> = sig
            .params
            .iter()
            .map(|k| self.argument(*k, scope, depth))
            .collect();
        format!("{}({})", sig.name, args.join(", "))
    }

    /// An argument for a parameter of kind `k`: mostly a constant of the
    /// right sign.
    fn argument(&mut self, k: Kind, scope: &Scope, depth: u32) -> String {
        match k {
            Kind::Positive if self.rng.chance(0.8) => self.value_in(0.1, 3.0),
            Kind::Direction if self.rng.chance(0.8) => self.vector_literal(-1.0, 1.0),
            _ => self.expr(k.ty(), scope, depth),
        }
    }

    fn vector_literal(&mut self, lo: f64, hi: f64) -> String {
        format!(
            "({}, {}, {})",
            self.value_in(lo, hi),
            self.value_in(lo, hi),
            self.value_in(lo, hi)
        )
    }

    fn vector(&mut self, scope: &Scope, depth: u32) -> String {
        if depth == 0 || self.rng.chance(0.3) {
            return match self.name_of(Ty::Vec, scope) {
                Some(n) if self.rng.chance(0.5) => n,
                _ => self.vector_literal(-3.0, 3.0),
            };
        }
        let d = depth - 1;
        match self.rng.weighted(&[6, 4, 3, 3, 3, 2, 2, 4]) {
            0 => format!(
                "({}, {}, {})",
                self.num(scope, d),
                self.num(scope, d),
                self.num(scope, d)
            ),
            1 => {
                let op = *self.rng.pick(&["+", "-"]);
                let (a, b) = (self.vector(scope, d), self.vector(scope, d));
                format!("{} {op} {}", Self::atom(a), Self::atom(b))
            }
            2 => {
                let (a, b) = (self.num(scope, d), self.vector(scope, d));
                format!("{} * {}", Self::atom(a), Self::atom(b))
            }
            3 => {
                let (a, b) = (self.vector(scope, d), self.num(scope, d));
                format!("{} * {}", Self::atom(a), Self::atom(b))
            }
            4 => {
                let (a, b) = (self.vector(scope, d), self.num(scope, d));
                format!("{} / {}", Self::atom(a), Self::atom(b))
            }
            5 => format!(
                "cross({}, {})",
                self.vector(scope, d),
                self.vector(scope, d)
            ),
            6 => format!("normalize({})", self.vector(scope, d)),
            _ => format!("-{}", Self::atom(self.vector(scope, d))),
        }
    }

    fn colour(&mut self, scope: &Scope) -> String {
        match self.rng.below(5) {
            0 => format!("#{:06x}", self.rng.next_u64() & 0xff_ffff),
            1 => self.rng.pick(COLOURS).to_string(),
            2 => format!(
                "rgb({}, {}, {})",
                self.whole_in(0, 255),
                self.whole_in(0, 255),
                self.whole_in(0, 255)
            ),
            3 => self.vector_literal(0.0, 1.0),
            _ => self
                .name_of(Ty::Col, scope)
                .unwrap_or_else(|| "orange".into()),
        }
    }

    // -------------------------------------------------------------- items --

    fn constant(&mut self, i: usize) -> String {
        let ty = *self.rng.pick(&[Ty::Num, Ty::Num, Ty::Vec, Ty::Col]);
        let scope = Scope {
            in_shape: false,
            params: Vec::new(),
        };
        let value = self.expr(ty, &scope, 3);
        let name = format!("k{i}");
        self.lets.push((name.clone(), ty));
        format!("let {name} = {value}\n")
    }

    fn shape(&mut self, i: usize) -> String {
        let n = *self.rng.pick(&[0usize, 0, 1, 2, 3]);
        let kinds: Vec<Kind> = (0..n)
            .map(|_| {
                *self.rng.pick(&[
                    Kind::Number,
                    Kind::Positive,
                    Kind::Positive,
                    Kind::Vector,
                    Kind::Direction,
                ])
            })
            .collect();
        let params: Vec<(String, Ty)> = kinds
            .iter()
            .enumerate()
            .map(|(j, k)| (format!("a{j}"), k.ty()))
            .collect();
        let written: Vec<String> = kinds
            .iter()
            .enumerate()
            .map(|(j, k)| {
                if *k == Kind::Number && self.rng.chance(0.5) {
                    format!("a{j}")
                } else if self.oops() {
                    format!("a{j}: {}", self.rng.pick(WORDS))
                } else {
                    format!("a{j}: {}", k.word())
                }
            })
            .collect();
        let scope = Scope {
            in_shape: true,
            params,
        };
        let depth = self.rng.between(1, 5) as u32;
        let body = self.expr(Ty::Num, &scope, depth);
        let name = format!("s{i}");
        let head = if kinds.is_empty() && self.rng.chance(0.7) {
            name.clone()
        } else {
            format!("{name}({})", written.join(", "))
        };
        // A shape may not use itself; it is known from here on.
        self.shapes.push(Sig {
            name,
            params: kinds,
        });
        format!("shape {head} = {body}\n")
    }

    /// A chain of shapes, each built from the one before, and an object
    /// of the last. Long chains (around the compiler's nesting limit of
    /// 64) use the one before once; chains that use it twice (a naive
    /// inliner doubles its work at every link) are short, except rarely:
    /// past about 22 links such a chain takes `nes check` longer than the
    /// timeout (fuzz/regressions/shape-chain-doubling.nes), and a campaign
    /// would spend its time re-finding that.
    fn chain(&mut self) -> String {
        let mut out = String::from("shape c0 = x^2 + y^2 + z^2 - 1\n");
        let twice = self.rng.chance(0.6);
        let n = if !twice {
            *self.rng.pick(&[4usize, 16, 30, 62, 63, 64, 65, 100])
        } else if self.rng.chance(0.002) {
            *self.rng.pick(&[24usize, 30])
        } else {
            *self.rng.pick(&[2usize, 4, 8, 12, 16])
        };
        let pattern = self.rng.below(4);
        for i in 1..=n {
            let prev = format!("c{}", i - 1);
            let body = match (twice, pattern) {
                (true, 0) => format!("{prev} + {prev}"),
                (true, 1) => format!("min({prev}, {prev} - 0.1)"),
                (true, 2) => format!("smin({prev}, {prev}, 0.2)"),
                (true, _) => format!("{prev} + 0.01 * sin({prev})"),
                (false, 0) => format!("{prev} * 1.01"),
                (false, 1) => format!("{prev} - 0.01"),
                (false, 2) => format!("sin({prev})"),
                (false, _) => format!("min({prev}, x)"),
            };
            out += &format!("shape c{i} = {body}\n");
        }
        out += &format!("object c{n} {{ scale 0.5 }}\n");
        out
    }

    /// A chain of constants, each from the one before.
    fn let_chain(&mut self) -> String {
        let n = *self.rng.pick(&[8usize, 64, 200, 1000]);
        let mut out = String::from("let q0 = 1.5\n");
        let op = *self
            .rng
            .pick(&["Q * Q", "Q + Q", "Q * 10", "-Q", "sqrt(Q)", "Q ^ 2"]);
        for i in 1..=n {
            out += &format!("let q{i} = {}\n", op.replace('Q', &format!("q{}", i - 1)));
        }
        self.lets.push((format!("q{n}"), Ty::Num));
        out
    }

    fn camera(&mut self) -> String {
        let scope = Scope {
            in_shape: false,
            params: Vec::new(),
        };
        let mut props = Vec::new();
        let pos = if self.rng.chance(0.8) {
            format!(
                "({}, {}, {})",
                self.value_in(-9.0, -3.0),
                self.value_in(-3.0, 3.0),
                self.value_in(-1.0, 4.0)
            )
        } else {
            self.expr(Ty::Vec, &scope, 2)
        };
        if !self.oops() {
            props.push(format!("position {pos}"));
        }
        match self.rng.below(4) {
            0 | 1 => props.push(format!(
                "look_at {}",
                if self.rng.chance(0.7) {
                    "(0, 0, 0)".to_string()
                } else {
                    self.expr(Ty::Vec, &scope, 2)
                }
            )),
            2 => {
                props.push(format!("yaw {}", self.value_in(-180.0, 180.0)));
                props.push(format!("pitch {}", self.value_in(-90.0, 90.0)));
            }
            _ => {}
        }
        if self.rng.chance(0.2) {
            props.push(format!("up {}", self.vector_literal(-1.0, 1.0)));
        }
        if self.rng.chance(0.5) {
            props.push(format!("fov {}", self.value_in(1.0, 179.0)));
        }
        if self.rng.chance(0.5) {
            props.push(format!("width {}", self.whole_in(1, 64)));
        }
        if self.rng.chance(0.5) {
            props.push(format!("height {}", self.whole_in(1, 64)));
        }
        if self.rng.chance(0.2) {
            props.push(format!(
                "projection {}",
                self.rng.pick(&["rectilinear", "angular"])
            ));
        }
        if self.rng.chance(0.1) {
            props.push(format!("correction {}", self.rng.pick(&["on", "off"])));
        }
        self.block("camera", props)
    }

    /// `name { props }`, with the properties in the order given, each on
    /// one line or all on one, sometimes ended by `;`.
    fn block(&mut self, head: &str, props: Vec<String>) -> String {
        let sep = if self.rng.chance(0.5) { "\n  " } else { "  " };
        let semi = if self.rng.chance(0.1) { ";" } else { "" };
        let body: Vec<String> = props.into_iter().map(|p| format!("{p}{semi}")).collect();
        format!("{head} {{ {} }}\n", body.join(sep))
    }

    fn light(&mut self) -> String {
        let scope = Scope {
            in_shape: false,
            params: Vec::new(),
        };
        let mut props = vec![format!(
            "position {}",
            if self.rng.chance(0.8) {
                self.vector_literal(-8.0, 8.0)
            } else {
                self.expr(Ty::Vec, &scope, 2)
            }
        )];
        if self.rng.chance(0.3) {
            props.push(format!("colour {}", self.colour(&scope)));
        }
        if self.rng.chance(0.3) {
            props.push(format!("intensity {}", self.value_in(0.0, 3.0)));
        }
        self.block("light", props)
    }

    fn space(&mut self) -> String {
        match self.rng.below(4) {
            0 => "space euclidean\n".into(),
            1 | 2 => {
                let mut props = Vec::new();
                let (lo, hi) = if self.rng.chance(0.8) {
                    let h = self.value_in(2.0, 12.0);
                    (format!("-{h}"), h)
                } else {
                    (
                        self.vector_literal(-10.0, -1.0),
                        self.vector_literal(1.0, 10.0),
                    )
                };
                if self.rng.chance(0.9) {
                    props.push(format!("min {lo}"));
                }
                if self.rng.chance(0.9) {
                    props.push(format!("max {hi}"));
                }
                if self.rng.chance(0.6) {
                    props.push(format!("wraps {}", self.whole_in(0, 600)));
                }
                if self.rng.chance(0.2) {
                    props.push(format!("periodic {}", self.rng.pick(&["on", "off"])));
                }
                if props.is_empty() && self.rng.chance(0.5) {
                    "space torus\n".into()
                } else {
                    self.block("space torus", props)
                }
            }
            _ => {
                self.sphere_space = true;
                if self.rng.chance(0.3) {
                    "space sphere\n".into()
                } else {
                    let r = self.value_in(2.0, 50.0);
                    self.block("space sphere", vec![format!("radius {r}")])
                }
            }
        }
    }

    fn render(&mut self) -> String {
        let mut props = Vec::new();
        if self.rng.chance(0.6) {
            let mut method = *self.rng.pick(METHODS);
            if method == "ode" && !self.sphere_space && !self.oops() {
                method = "auto";
            }
            props.push(format!("method {method}"));
        }
        if self.rng.chance(0.2) {
            props.push(format!("epsilon {}", self.value_in(1e-8, 1e-3)));
        }
        if self.rng.chance(0.3) {
            props.push(format!("step {}", self.value_in(0.01, 0.5)));
        }
        if self.rng.chance(0.2) {
            props.push(format!("max_distance {}", self.value_in(1.0, 200.0)));
        }
        if self.rng.chance(0.2) {
            props.push(format!("max_steps {}", self.whole_in(1, 5000)));
        }
        if self.rng.chance(0.2) {
            props.push(format!("samples {}", self.whole_in(1, 9)));
        }
        if self.rng.chance(0.2) {
            props.push(format!("shading {}", self.rng.pick(&["lambert", "flat"])));
        }
        if self.rng.chance(0.2) {
            props.push(format!(
                "shadows {}",
                self.rng
                    .pick(&["on", "off", "true", "false", "euclidean", "geodesic"])
            ));
        }
        if self.rng.chance(0.1) {
            props.push(format!("tolerance {}", self.value_in(1e-10, 1e-4)));
        }
        self.block("render", props)
    }

    /// A solid: a shape, a CSG combination or a bracketed solid, then
    /// transforms.
    fn solid(&mut self, depth: u32) -> String {
        let scope = Scope {
            in_shape: false,
            params: Vec::new(),
        };
        let atom = if depth > 0 && self.rng.chance(0.3) {
            let op = *self.rng.pick(&["union", "intersection", "difference"]);
            let least = if self.oops() { 0 } else { 2 };
            let n = self.rng.between(least, 3);
            let parts: Vec<String> = (0..n).map(|_| self.solid(depth - 1)).collect();
            format!("{op}({})", parts.join(", "))
        } else if depth > 0 && self.rng.chance(0.1) {
            format!("({})", self.solid(depth - 1))
        } else {
            let sig = self.rng.pick(&self.shapes).clone();
            if sig.params.is_empty() && self.rng.chance(0.5) {
                sig.name
            } else {
                let args: Vec<String> = sig
                    .params
                    .iter()
                    .map(|k| self.argument(*k, &scope, 1))
                    .collect();
                format!("{}({})", sig.name, args.join(", "))
            }
        };
        let mut out = atom;
        for _ in 0..self.rng.below(3) {
            out += " ";
            out += &self.transform(&scope);
        }
        out
    }

    fn transform(&mut self, scope: &Scope) -> String {
        match self.rng.below(3) {
            0 => format!("translate {}", self.vector_literal(-3.0, 3.0)),
            1 => {
                let axis = match self.rng.below(4) {
                    0 => "x".to_string(),
                    1 => "y".to_string(),
                    2 => "z".to_string(),
                    _ => self.vector_literal(-1.0, 1.0),
                };
                format!("rotate {} about {axis}", self.value_in(-360.0, 360.0))
            }
            _ => {
                if self.rng.chance(0.7) {
                    format!("scale {}", self.value_in(0.2, 3.0))
                } else if self.rng.chance(0.9) {
                    format!("scale {}", self.vector_literal(0.2, 3.0))
                } else {
                    format!("scale {}", self.expr(Ty::Num, scope, 2))
                }
            }
        }
    }

    fn object(&mut self) -> String {
        let scope = Scope {
            in_shape: false,
            params: Vec::new(),
        };
        let depth = self.rng.between(0, 3) as u32;
        let solid = self.solid(depth);
        if self.rng.chance(0.2) {
            return format!("object {solid}\n");
        }
        let mut props = Vec::new();
        for _ in 0..self.rng.below(4) {
            props.push(self.transform(&scope));
        }
        if self.rng.chance(0.7) {
            let word = *self.rng.pick(&["colour", "color"]);
            props.push(format!("{word} {}", self.colour(&scope)));
        }
        self.block(&format!("object {solid}"), props)
    }

    /// A whole scene.
    pub fn scene(&mut self) -> String {
        let mut out = String::new();
        if self.rng.chance(0.3) {
            out += "// generated\n";
        }
        for i in 0..self.rng.below(4) {
            out += &self.constant(i);
        }
        if self.rng.chance(0.03) {
            out += &self.let_chain();
        }
        for i in 0..self.rng.below(5) {
            out += &self.shape(i);
        }
        let mut items = Vec::new();
        if !self.oops() {
            items.push(self.camera());
        }
        if self.oops() {
            items.push(self.camera());
        }
        for _ in 0..self.rng.below(4) {
            items.push(self.light());
        }
        if self.rng.chance(0.4) {
            items.push(self.space());
        }
        if self.rng.chance(0.5) {
            items.push(self.render());
        }
        if self.rng.chance(0.3) {
            items.push(format!("ambient {}\n", self.value_in(0.0, 1.0)));
        }
        if self.rng.chance(0.2) {
            let scope = Scope {
                in_shape: false,
                params: Vec::new(),
            };
            items.push(format!("background {}\n", self.colour(&scope)));
        }
        for _ in 0..self.rng.between(1, 5) {
            items.push(self.object());
        }
        if self.rng.chance(0.05) {
            items.push(self.chain());
        }
        // Items may come in any order; definitions above stay first
        // unless going wrong.
        for i in (1..items.len()).rev() {
            if self.rng.chance(0.5) {
                let j = self.rng.below(i + 1);
                items.swap(i, j);
            }
        }
        out += &items.concat();
        if self.oops() {
            // A definition moved after its use, or a name used twice.
            out = match self.rng.below(2) {
                0 => format!("{out}let k0 = 2\n"),
                _ => format!("{out}shape s0 = x\n"),
            };
        }
        out
    }
}
