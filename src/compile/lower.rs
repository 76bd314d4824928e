//! Lowering expressions: AST expressions to IR nodes, with names resolved
//! and kinds (number, vector, colour) checked.
//!
//! The same lowering serves shape bodies (where x, y, z exist) and constant
//! positions (let, properties, arguments of objects), where they do not; in
//! a constant position every node folds to a constant as it is built.

use std::collections::HashMap;

use glam::DVec3;

use super::Reported;
use crate::ast::{BinaryOp, Expr, ExprKind, Ident};
use crate::diagnostic::{suggest, Code, Diagnostic, Span};
use crate::expr::{Binary, Graph, NodeId, Noise, Unary};

/// A lowered value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Value {
    Num(NodeId),
    Vector([NodeId; 3]),
    /// sRGB components in [0, 1]; colours are always constant.
    Colour(DVec3),
    /// A condition (`x < 1`, `a and b`): a number positive exactly where
    /// it holds, so `and` is `min`, `or` is `max`, `not` is `-`, and as a
    /// region (a solid, a clip) it is that number negated.
    Cond(NodeId),
}

impl Value {
    pub(crate) fn kind_name(&self) -> &'static str {
        match self {
            Value::Num(_) => "a number",
            Value::Vector(_) => "a vector",
            Value::Colour(_) => "a colour",
            Value::Cond(_) => "a condition",
        }
    }

    /// The graph nodes the value is made of (none for a colour).
    fn nodes(&self) -> Vec<NodeId> {
        match self {
            Value::Num(n) | Value::Cond(n) => vec![*n],
            Value::Vector(c) => c.to_vec(),
            Value::Colour(_) => vec![],
        }
    }
}

/// The most terms one `sum`, `product`, `min` or `max` may have.
pub const MAX_TERMS: i64 = 100_000;

/// A constant value, as `let` binds it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Constant {
    Num(f64),
    Vector(DVec3),
    Colour(DVec3),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ParamKind {
    Number,
    Positive,
    Vector,
    Direction,
}

impl ParamKind {
    pub(crate) const NAMES: &'static [&'static str] =
        &["number", "positive", "vector", "direction"];

    pub(crate) fn from_name(name: &str) -> Option<ParamKind> {
        Some(match name {
            "number" => ParamKind::Number,
            "positive" => ParamKind::Positive,
            "vector" => ParamKind::Vector,
            "direction" => ParamKind::Direction,
            _ => return None,
        })
    }

    fn describe(self) -> &'static str {
        match self {
            ParamKind::Number => "a number",
            ParamKind::Positive => "a positive number",
            ParamKind::Vector => "a vector",
            ParamKind::Direction => "a direction (a non-zero vector)",
        }
    }

    fn is_vector(self) -> bool {
        matches!(self, ParamKind::Vector | ParamKind::Direction)
    }
}

#[derive(Debug, Clone)]
pub(crate) struct ShapeDef {
    pub name: Ident,
    pub params: Vec<(Ident, ParamKind)>,
    pub body: Expr,
    /// Written with `fn`: it may give a vector or a condition.
    pub function: bool,
    /// Defined by the prelude (not the scene file).
    pub prelude: bool,
}

/// Everything defined at the top level.
#[derive(Debug, Default)]
pub(crate) struct Globals {
    pub lets: HashMap<String, Constant>,
    /// Lists bound by `let NAME = [...]`.
    pub lists: HashMap<String, Vec<Constant>>,
    pub shapes: HashMap<String, ShapeDef>,
    /// The prelude's own shapes. A prelude body calls these, whatever the
    /// scene redefines: a scene's own `box` replaces `box`, not `cube`.
    pub prelude: HashMap<String, ShapeDef>,
    /// Shapes and constants whose definition has errors (already
    /// reported): uses of them fail quietly.
    pub broken_names: std::collections::HashSet<String>,
    /// The values of `time` and `frame` (for animations).
    pub clock: crate::scene::Clock,
    /// Whether anything read `time` or `frame`.
    pub read_clock: std::cell::Cell<bool>,
    /// Lowering steps taken so far in this compile, against
    /// [`MAX_EXPANSION_STEPS`].
    pub expansion_steps: std::cell::Cell<u64>,
    /// Whether the spent budget was reported (it is, once per compile).
    pub budget_reported: std::cell::Cell<bool>,
    /// In S3 and H3, the sign of the curvature (1, -1) and its radius: the
    /// geometric builtins (`geodesic_distance`, `plane_distance`,
    /// `busemann`) follow the space. `None` in the flat spaces.
    pub curvature: Option<(f64, f64)>,
    /// In S3 and H3, what the formula being lowered uses that compiles to
    /// the space's internal operations, as the user wrote it: a geometric
    /// builtin, the prelude shape built on one (`horosphere`), or
    /// `translate` for a translated part of a combination; in order of
    /// first use. Cleared and read by the compiler for each object, for
    /// messages about its formula.
    pub curved_uses: std::cell::RefCell<Vec<String>>,
}

impl Globals {
    /// Note a use for [`Globals::curved_uses`].
    pub(crate) fn note_curved_use(&self, name: &str) {
        let mut uses = self.curved_uses.borrow_mut();
        if !uses.iter().any(|u| u == name) {
            uses.push(name.to_string());
        }
    }
}

/// The most lowering steps (expression nodes visited, with every use of a
/// shape expanding its body again) one compile may take: about a second
/// of work. Shapes that use another shape twice, nested 30 deep, would
/// otherwise expand to 2^30 copies and take minutes and gigabytes.
pub const MAX_EXPANSION_STEPS: u64 = 4_000_000;
/// The message of the diagnostic for a compile past [`MAX_EXPANSION_STEPS`].
const TOO_BIG: &str = "expands past the compile budget";

/// The message of the diagnostic for `busemann` (and so `horosphere`) in
/// S3, which a shape's body checked on its own cannot show.
const NO_INFINITY: &str = "the 3-sphere has no points at infinity, so no horospheres";
const NO_INFINITY_HELP: &str = "busemann and horosphere exist in h3 and the flat spaces; in s3 use a geodesic ball, sphere(r) translate (...)";

/// Names no `let`, shape or parameter may take.
pub(crate) const RESERVED: &[&str] = &[
    "x",
    "y",
    "z",
    "p",
    "pi",
    "tau",
    "e",
    "time",
    "frame",
    "mean_curvature",
    "gauss_curvature",
];

/// The hint for a definition that takes a name of [`RESERVED`].
pub(crate) const RESERVED_HELP: &str = "x, y, z, p, pi, tau, e, time, frame, mean_curvature and gauss_curvature are built in; choose another name";

/// The names a colour formula may read besides x, y, z and p: the hit's
/// outward normal and curvatures. `normal` is not reserved (shapes take
/// parameters of that name); in a colour formula it is the hit's.
pub(crate) const COLOUR_FIELD_NAMES: [&str; 3] = ["normal", "mean_curvature", "gauss_curvature"];

pub(crate) const BUILTIN_FUNCTIONS: &[&str] = &[
    "sin",
    "cos",
    "tan",
    "asin",
    "acos",
    "atan",
    "atan2",
    "sinh",
    "cosh",
    "tanh",
    "exp",
    "ln",
    "log",
    "sqrt",
    "abs",
    "sign",
    "min",
    "max",
    "union",
    "intersection",
    "difference",
    "clamp",
    "pow",
    "smin",
    "floor",
    "ceil",
    "round",
    "fract",
    "mod",
    "step",
    "smoothstep",
    "mix",
    "dot",
    "cross",
    "length",
    "normalize",
    "noise",
    "geodesic_distance",
    "plane_distance",
    "busemann",
    "rgb",
];

/// Named colours, as sRGB bytes.
pub(crate) const NAMED_COLOURS: &[(&str, [u8; 3])] = &[
    ("black", [0, 0, 0]),
    ("white", [255, 255, 255]),
    ("grey", [128, 128, 128]),
    ("gray", [128, 128, 128]),
    ("silver", [192, 192, 192]),
    ("red", [220, 40, 40]),
    ("green", [40, 170, 70]),
    ("blue", [50, 100, 230]),
    ("yellow", [250, 210, 40]),
    ("orange", [255, 145, 71]),
    ("pink", [198, 91, 124]),
    ("purple", [130, 60, 180]),
    ("cyan", [40, 200, 220]),
    ("magenta", [220, 50, 200]),
    ("brown", [140, 90, 50]),
    ("sky", [79, 158, 245]),
];

pub(crate) fn named_colour(name: &str) -> Option<DVec3> {
    NAMED_COLOURS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, c)| srgb_bytes(*c))
}

pub(crate) fn srgb_bytes(c: [u8; 3]) -> DVec3 {
    DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) / 255.0
}

/// Where an expression is lowered: the values of parameters in scope, and
/// the point (x, y, z) if it exists here.
#[derive(Clone, Copy)]
pub(crate) struct Frame<'a> {
    pub params: Scope<'a>,
    pub point: Option<[NodeId; 3]>,
}

impl Frame<'_> {
    pub(crate) fn constant() -> Frame<'static> {
        Frame {
            params: Scope::EMPTY,
            point: None,
        }
    }
}

/// The local names in scope (a shape's parameters, `let`s, an aggregate's
/// variable), innermost first: a `let` adds one link to the scope it is
/// in instead of copying it (10 000 nested `let`s once copied 50 M names
/// and ran out of memory), and an inner name shadows an outer one.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Scope<'a> {
    names: &'a [(String, Value)],
    outer: Option<&'a Scope<'a>>,
}

impl<'a> Scope<'a> {
    /// No local names.
    pub(crate) const EMPTY: Scope<'static> = Scope {
        names: &[],
        outer: None,
    };

    /// A scope of `names` alone (a shape's body sees only its parameters).
    pub(crate) fn of(names: &'a [(String, Value)]) -> Scope<'a> {
        Scope { names, outer: None }
    }

    /// `names` inside this scope; a later name shadows an earlier one.
    pub(crate) fn inside(&'a self, names: &'a [(String, Value)]) -> Scope<'a> {
        Scope {
            names,
            outer: Some(self),
        }
    }

    /// The value of the innermost `name`.
    pub(crate) fn get(&self, name: &str) -> Option<Value> {
        let mut scope = Some(self);
        while let Some(s) = scope {
            if let Some((_, v)) = s.names.iter().rev().find(|(n, _)| n == name) {
                return Some(*v);
            }
            scope = s.outer;
        }
        None
    }

    /// Every name in scope, innermost first (shadowed ones included).
    pub(crate) fn names(&self) -> Vec<&'a str> {
        let mut out = Vec::new();
        let mut scope = Some(self);
        while let Some(s) = scope {
            out.extend(s.names.iter().rev().map(|(n, _)| n.as_str()));
            scope = s.outer;
        }
        out
    }
}

/// Deeper shape-in-shape nesting than this is an error (recursion is
/// caught before, so only absurd nesting reaches it).
const MAX_SHAPE_DEPTH: usize = 64;
/// The message of the diagnostic for shapes nested past [`MAX_SHAPE_DEPTH`].
const TOO_DEEP: &str = "shapes are nested too deeply";

pub(crate) struct Lowerer<'a> {
    pub globals: &'a Globals,
    pub graph: &'a mut Graph,
    pub diags: &'a mut Vec<Diagnostic>,
    depth: usize,
    /// Shape uses already expanded in this graph, by shape, arguments and
    /// point: the same use again is the same node (the graph shares equal
    /// nodes), so it is not expanded twice.
    expanded: HashMap<ExpansionKey, Value>,
    /// The outermost prelude shape being expanded, if any: the name the
    /// user wrote for what its body uses.
    prelude_shape: Option<String>,
    /// True while a shape's body is checked on its own, with its parameters
    /// as unknowns: a range whose end is a parameter is then checked with
    /// one symbolic term, since its length is only known at each use.
    pub(crate) parameters_unknown: bool,
}

#[derive(Hash, PartialEq, Eq)]
struct ExpansionKey {
    shape: String,
    /// Whether `shape` is the prelude's (a scene may define its own of
    /// the same name).
    prelude: bool,
    arguments: Vec<NodeId>,
    /// `None` for a function used where there is no point (a constant).
    point: Option<[NodeId; 3]>,
}

type Lowered = Result<Value, Reported>;

impl<'a> Lowerer<'a> {
    pub(crate) fn new(
        globals: &'a Globals,
        graph: &'a mut Graph,
        diags: &'a mut Vec<Diagnostic>,
    ) -> Self {
        Lowerer {
            globals,
            graph,
            diags,
            depth: 0,
            expanded: HashMap::new(),
            prelude_shape: None,
            parameters_unknown: false,
        }
    }

    /// Counts one step against the compile's budget; false once it is
    /// spent.
    fn within_budget(&self) -> bool {
        let steps = self.globals.expansion_steps.get() + 1;
        self.globals.expansion_steps.set(steps);
        steps <= MAX_EXPANSION_STEPS
    }

    fn error<T>(&mut self, d: Diagnostic) -> Result<T, Reported> {
        self.diags.push(d);
        Err(Reported)
    }

    pub(crate) fn lower(&mut self, e: &Expr, frame: Frame) -> Lowered {
        if !self.within_budget() {
            return self.over_budget(e.span, None);
        }
        match &e.kind {
            ExprKind::Number(n) if n.is_finite() => Ok(Value::Num(self.graph.constant(*n))),
            ExprKind::Number(_) => self.error(
                Diagnostic::new(Code::OutOfRange, "this number is too large")
                    .label(e.span, "beyond the largest number, about 1.8e308")
                    .help("write a number below 1e308; scale the formula down instead"),
            ),
            ExprKind::Colour(c) => Ok(Value::Colour(srgb_bytes(*c))),
            ExprKind::Variable(name) => self.variable(name, e.span, frame),
            ExprKind::Tuple(items) => {
                let mut nodes = Vec::new();
                let mut failed = false;
                for item in items {
                    match self.lower(item, frame) {
                        Ok(Value::Num(n)) => nodes.push(n),
                        Ok(v) => {
                            failed = true;
                            self.diags.push(
                                Diagnostic::new(
                                    Code::WrongKind,
                                    format!(
                                        "a vector's component must be a number, not {}",
                                        v.kind_name()
                                    ),
                                )
                                .label(item.span, format!("this is {}", v.kind_name()))
                                .help("vectors are written (x, y, z) with three numbers"),
                            );
                        }
                        Err(Reported) => failed = true,
                    }
                }
                if failed {
                    return Err(Reported);
                }
                if nodes.len() != 3 {
                    return self.error(
                        Diagnostic::new(
                            Code::WrongKind,
                            format!("a vector has 3 components, this has {}", nodes.len()),
                        )
                        .label(e.span, format!("{} components", nodes.len()))
                        .help("write all three coordinates, e.g. (1, 2, 0)"),
                    );
                }
                Ok(Value::Vector([nodes[0], nodes[1], nodes[2]]))
            }
            ExprKind::Neg(a) => match self.lower(a, frame)? {
                Value::Num(n) => Ok(Value::Num(self.graph.neg(n))),
                Value::Vector(v) => Ok(Value::Vector(v.map(|c| self.graph.neg(c)))),
                Value::Colour(_) => self.colour_misuse(a.span),
                Value::Cond(_) => self.condition_misuse(a.span),
            },
            ExprKind::Not(a) => match self.lower(a, frame)? {
                Value::Cond(c) => Ok(Value::Cond(self.graph.neg(c))),
                v => self.error(
                    Diagnostic::new(
                        Code::WrongKind,
                        format!("`not` needs a condition, not {}", v.kind_name()),
                    )
                    .label(a.span, format!("this is {}", v.kind_name()))
                    .help("conditions are comparisons like `x < 1`, joined with `and` and `or`"),
                ),
            },
            ExprKind::If {
                condition,
                then,
                otherwise,
            } => self.if_then_else(condition, then, otherwise, frame),
            ExprKind::Let { name, value, body } => {
                if RESERVED.contains(&name.name.as_str()) {
                    return self.error(
                        Diagnostic::new(
                            Code::DuplicateName,
                            format!("`{}` is built in and cannot be a local name", name.name),
                        )
                        .label(name.span, "reserved name")
                        .help(RESERVED_HELP),
                    );
                }
                let v = self.lower(value, frame)?;
                let link = [(name.name.clone(), v)];
                self.lower(
                    body,
                    Frame {
                        params: frame.params.inside(&link),
                        point: frame.point,
                    },
                )
            }
            ExprKind::At(body, point) => {
                let v = self.lower(point, frame)?;
                let point = self.expect_vector(v, point, "the point after `at`")?;
                self.lower(
                    body,
                    Frame {
                        params: frame.params,
                        point: Some(point),
                    },
                )
            }
            ExprKind::Moved(body, transforms) => {
                let Some(point) = frame.point else {
                    return self.error(
                        Diagnostic::new(
                            Code::NotConstant,
                            "a transform moves a formula of x, y, z, which has none here",
                        )
                        .label(transforms[0].span, "nothing to move")
                        .help("transforms inside formulas move shapes: `shape s = smin(sphere(1) translate (1, 0, 0), sphere(1), 0.3)`"),
                    );
                };
                let point = self.moved_point(transforms, point, frame)?;
                self.lower(
                    body,
                    Frame {
                        params: frame.params,
                        point: Some(point),
                    },
                )
            }
            ExprKind::List(_) => self.error(
                Diagnostic::new(Code::WrongKind, "a list is not a value here")
                    .label(e.span, "a list")
                    .help("a list is summed over (`sum(c in [...], ...)`), indexed (`list[0]`) or bound with a top-level `let`"),
            ),
            ExprKind::Index(list, index) => {
                let items = self.list_items(list, frame)?;
                let v = self.lower(index, frame)?;
                let i = self.expect_num(v, index, "a list index")?;
                let Some(i) = self.graph.constant_value(i) else {
                    return self.not_constant(index);
                };
                if i.fract() != 0.0 || i < 0.0 || i >= items.len() as f64 {
                    return self.error(
                        Diagnostic::new(
                            Code::OutOfRange,
                            if i.fract() != 0.0 && i.is_finite() {
                                format!("index {i} is not a whole number")
                            } else {
                                format!(
                                    "index {} is outside the list of {}",
                                    super::readable(i),
                                    items.len()
                                )
                            },
                        )
                        .label(index.span, "no such item")
                        .help(format!(
                            "items are counted from 0: give a whole number from 0 to {}",
                            items.len().saturating_sub(1)
                        )),
                    );
                }
                Ok(items[i as usize])
            }
            ExprKind::Aggregate {
                op,
                name,
                source,
                body,
            } => self.aggregate(*op, name, source, body, e.span, frame),
            ExprKind::Component(a, axis) => match self.lower(a, frame)? {
                Value::Vector(v) => Ok(Value::Num(v[*axis])),
                v => {
                    // A parameter declared without a kind is a number.
                    let parameter = match &a.kind {
                        ExprKind::Variable(n) if frame.params.get(n).is_some() => {
                            Some(n.clone())
                        }
                        _ => None,
                    };
                    let help = match parameter {
                        Some(n) => format!(
                            "a parameter is a number unless declared otherwise: write `{n}: vector` in the definition's parameters"
                        ),
                        None => "components are taken of vectors, like (1, 2, 3).x or a vector parameter".to_string(),
                    };
                    self.error(
                        Diagnostic::new(
                            Code::WrongKind,
                            format!(
                                "`.{}` needs a vector, not {}",
                                ["x", "y", "z"][*axis],
                                v.kind_name()
                            ),
                        )
                        .label(a.span, format!("this is {}", v.kind_name()))
                        .help(help),
                    )
                }
            },
            ExprKind::Binary(op, a, b) => {
                let va = self.lower(a, frame);
                let vb = self.lower(b, frame);
                let (va, vb) = (va?, vb?);
                self.binary(*op, va, vb, a.span, b.span)
            }
            ExprKind::Call { name, args } => self.call(name, args, e.span, frame),
        }
    }

    /// The budget is spent: reported once per compile, at the outermost
    /// shape use being expanded (passed up by [`Self::shape_call_at`]).
    fn over_budget(&mut self, span: Span, shape: Option<&str>) -> Lowered {
        // Inner lowerings report into a discarded list, passed up by
        // message; the outermost reports once for the whole compile.
        if self.depth == 0 && self.globals.budget_reported.replace(true) {
            return Err(Reported);
        }
        let what = match shape {
            Some(name) => format!("`{name}` {TOO_BIG}"),
            None => format!("this expression {TOO_BIG}"),
        };
        self.error(
            Diagnostic::new(Code::TooLarge, what)
                .label(span, format!("more than {MAX_EXPANSION_STEPS} steps to expand"))
                .help("every use of a shape copies its whole body: a shape that uses another twice, nested n deep, is 2^n copies; use each shape fewer times, or nest fewer levels"),
        )
    }

    /// `if c then a else b`: `When(c, a) + Unless(c, b)` per component,
    /// so the branch not taken adds exactly 0, whatever its value there.
    fn if_then_else(
        &mut self,
        condition: &Expr,
        then: &Expr,
        otherwise: &Expr,
        frame: Frame,
    ) -> Lowered {
        let c = self.lower(condition, frame);
        let a = self.lower(then, frame);
        let b = self.lower(otherwise, frame);
        let (c, a, b) = (c?, a?, b?);
        let c = match c {
            Value::Cond(c) => c,
            v => {
                return self.error(
                    Diagnostic::new(
                        Code::WrongKind,
                        format!("`if` needs a condition, not {}", v.kind_name()),
                    )
                    .label(condition.span, format!("this is {}", v.kind_name()))
                    .help(if matches!(v, Value::Num(_)) {
                        "compare it: `if x > 0 then ... else ...`"
                    } else {
                        "write a comparison like `x > 0`, joined with `and`, `or`, `not`"
                    }),
                )
            }
        };
        let constant_c = self.graph.constant_value(c);
        let (a, b) = match (self.as_components(a, b, constant_c.is_none()), constant_c) {
            ((Value::Colour(u), Value::Colour(v)), Some(k)) => {
                return Ok(Value::Colour(if k > 0.0 { u } else { v }))
            }
            (ab, _) => ab,
        };
        let g = &mut *self.graph;
        let mut pick = |x: NodeId, y: NodeId| {
            let l = g.binary(Binary::When, c, x);
            let r = g.binary(Binary::Unless, c, y);
            g.add(l, r)
        };
        match (a, b) {
            (Value::Num(x), Value::Num(y)) => Ok(Value::Num(pick(x, y))),
            (Value::Cond(x), Value::Cond(y)) => Ok(Value::Cond(pick(x, y))),
            (Value::Vector(u), Value::Vector(v)) => {
                Ok(Value::Vector([0, 1, 2].map(|i| pick(u[i], v[i]))))
            }
            (a, b) => self.error(
                Diagnostic::new(
                    Code::WrongKind,
                    format!(
                        "the two branches of `if` give {} and {}",
                        a.kind_name(),
                        b.kind_name()
                    ),
                )
                .label(then.span, format!("this is {}", a.kind_name()))
                .label(otherwise.span, format!("this is {}", b.kind_name()))
                .help(
                    "both branches must be of one kind: two numbers, two vectors or two conditions",
                ),
            ),
        }
    }

    /// The point a formula written with `transforms` after it sees: each
    /// transform undone, the last written first, as for a solid. Amounts
    /// known at compile time give the exact maps (in S3 and H3 a
    /// `translate` is the space's isometry); amounts that vary (a twist by
    /// `rotate 30 * z about z`) are built as formulas of the point.
    fn moved_point(
        &mut self,
        transforms: &[crate::ast::Transform],
        point: [NodeId; 3],
        frame: Frame,
    ) -> Result<[NodeId; 3], Reported> {
        use crate::ast::TransformOp;
        let mut q = point;
        for t in transforms.iter().rev() {
            if t.op != TransformOp::Rotate {
                if let Some(about) = &t.about {
                    self.diags.push(
                        Diagnostic::new(Code::UnknownSetting, "only `rotate` takes `about`")
                            .label(about.span, "not used here")
                            .help("write `rotate DEGREES about AXIS`"),
                    );
                    return Err(Reported);
                }
            }
            // `sphere(1) translate (0, 0, 1) + 0.1 * sin(10 * x)` reads the
            // rest of the formula as the amount: say so, not "vector plus
            // number".
            if let ExprKind::Binary(op, l, _) = &t.value.kind {
                let arithmetic = matches!(
                    op,
                    BinaryOp::Add | BinaryOp::Sub | BinaryOp::Mul | BinaryOp::Div
                );
                if arithmetic && matches!(l.kind, ExprKind::Tuple(_)) && t.op != TransformOp::Scale
                {
                    let before = self.diags.len();
                    let v = self.lower(&t.value, frame);
                    if v.is_err() {
                        self.diags.truncate(before);
                        return self.error(
                            Diagnostic::new(
                                Code::WrongKind,
                                "the amount of a transform runs to the end of the formula",
                            )
                            .label(t.value.span, "all of this was read as the amount")
                            .help("put the moved shape in brackets: `(sphere(1) translate (0, 0, 1)) + 0.1 * sin(10 * x)`"),
                        );
                    }
                }
            }
            let amount = self.lower(&t.value, frame)?;
            q = match t.op {
                TransformOp::Translate => {
                    let v = self.expect_vector(amount, &t.value, "translate")?;
                    let known = v.map(|c| self.graph.constant_value(c));
                    match (self.globals.curvature, known) {
                        (Some((sigma, radius)), [Some(a), Some(b), Some(c)]) => {
                            let k = if sigma > 0.0 {
                                crate::space::Curvature::spherical(radius)
                            } else {
                                crate::space::Curvature::hyperbolic(radius)
                            };
                            translated_back(self.graph, &k, q, DVec3::new(a, b, c))
                        }
                        _ => [0, 1, 2].map(|i| self.graph.sub(q[i], v[i])),
                    }
                }
                TransformOp::Scale => {
                    let factors = match amount {
                        Value::Num(s) => [s; 3],
                        Value::Vector(v) => v,
                        other => {
                            return self.error(
                                Diagnostic::new(
                                    Code::WrongKind,
                                    format!(
                                        "a scale must be a number or a vector, not {}",
                                        other.kind_name()
                                    ),
                                )
                                .label(t.value.span, format!("this is {}", other.kind_name()))
                                .help("write `scale 2` or `scale (1, 2, 1)`"),
                            )
                        }
                    };
                    if factors
                        .iter()
                        .any(|f| self.graph.constant_value(*f) == Some(0.0))
                    {
                        return self.error(
                            Diagnostic::new(Code::OutOfRange, "a scale factor must not be zero")
                                .label(t.value.span, "a zero factor")
                                .help("a zero scale flattens the shape to nothing; use a small positive factor"),
                        );
                    }
                    [0, 1, 2].map(|i| self.graph.div(q[i], factors[i]))
                }
                TransformOp::Rotate => {
                    let degrees =
                        self.expect_num(amount, &t.value, "a rotation angle (in degrees)")?;
                    let Some(about) = &t.about else {
                        if super::about_misspelt_after(self.diags, t.span) {
                            return Err(Reported);
                        }
                        return self.error(
                            Diagnostic::new(Code::MissingSetting, "a rotation needs an axis")
                                .label(t.span, "no axis given")
                                .help(
                                    "write e.g. `rotate 30 about z` or `rotate 45 about (1, 1, 0)`",
                                ),
                        );
                    };
                    let axis = self.rotation_axis(about, frame)?;
                    self.rotated_back(q, degrees, axis)
                }
            };
        }
        Ok(q)
    }

    /// The axis after `about`: x, y, z by name (not the point's
    /// coordinates), or a vector, made a unit one.
    fn rotation_axis(&mut self, e: &Expr, frame: Frame) -> Result<[NodeId; 3], Reported> {
        if let ExprKind::Variable(v) = &e.kind {
            let unit = match v.as_str() {
                "x" => Some(DVec3::X),
                "y" => Some(DVec3::Y),
                "z" => Some(DVec3::Z),
                _ => None,
            };
            if let Some(u) = unit {
                return Ok(u.to_array().map(|c| self.graph.constant(c)));
            }
        }
        let v = self.lower(e, frame)?;
        let v = self.expect_vector(v, e, "a rotation axis")?;
        let known = v.map(|c| self.graph.constant_value(c));
        if let [Some(a), Some(b), Some(c)] = known {
            let Some(u) = crate::camera::unit_vector(DVec3::new(a, b, c)) else {
                return self.error(
                    Diagnostic::new(Code::ZeroLength, "a rotation axis cannot be zero")
                        .label(e.span, "this vector has length zero")
                        .help("rotate about x, y, z or a non-zero vector like (1, 1, 0)"),
                );
            };
            return Ok(u.to_array().map(|c| self.graph.constant(c)));
        }
        let g = &mut *self.graph;
        let sq = v.map(|c| g.unary(Unary::Square, c));
        let s = g.add(sq[0], sq[1]);
        let s = g.add(s, sq[2]);
        let len = g.unary(Unary::Sqrt, s);
        Ok(v.map(|c| g.div(c, len)))
    }

    /// `q` turned by `-degrees` about the unit `axis` (Rodrigues' formula):
    /// the point a shape turned by `degrees` sees.
    fn rotated_back(&mut self, q: [NodeId; 3], degrees: NodeId, k: [NodeId; 3]) -> [NodeId; 3] {
        let g = &mut *self.graph;
        let (sin, cos) = match g.constant_value(degrees) {
            Some(d) => {
                let (s, c) = quarter_exact_sin_cos(-d);
                (g.constant(s), g.constant(c))
            }
            None => {
                let to_radians = g.constant(-std::f64::consts::PI / 180.0);
                let a = g.mul(to_radians, degrees);
                (g.unary(Unary::Sin, a), g.unary(Unary::Cos, a))
            }
        };
        let dot = {
            let t = [0, 1, 2].map(|i| g.mul(k[i], q[i]));
            let s = g.add(t[0], t[1]);
            g.add(s, t[2])
        };
        let cross = |g: &mut Graph, i: usize, j: usize| {
            let a = g.mul(k[i], q[j]);
            let b = g.mul(k[j], q[i]);
            g.sub(a, b)
        };
        let kxq = [cross(g, 1, 2), cross(g, 2, 0), cross(g, 0, 1)];
        // Split into the part along the axis, which the turn keeps, and
        // the part across it, which it turns: written as q cos + k (k.q)
        // (1 - cos), the part along the axis would hold cos twice, and
        // an interval over a varying angle (a twist, `rotate 60 * z
        // about z`) could not tell that z stays z. With a constant axis
        // both parts are constant projections of q.
        let constant_axis: Option<Vec<f64>> = k.iter().map(|&n| g.constant_value(n)).collect();
        let (along, across): ([NodeId; 3], [NodeId; 3]) = match constant_axis {
            Some(kc) => {
                let project = |g: &mut Graph, m: &dyn Fn(usize, usize) -> f64| {
                    [0, 1, 2].map(|i| {
                        let mut sum = g.constant(0.0);
                        for (j, &qj) in q.iter().enumerate() {
                            let c = m(i, j);
                            if c != 0.0 {
                                let term = g.scaled(c, qj);
                                sum = g.add(sum, term);
                            }
                        }
                        sum
                    })
                };
                let along = project(g, &|i, j| kc[i] * kc[j]);
                let across = project(g, &|i, j| if i == j { 1.0 } else { 0.0 } - kc[i] * kc[j]);
                (along, across)
            }
            None => {
                let along = k.map(|ki| g.mul(ki, dot));
                let across = [0, 1, 2].map(|i| g.sub(q[i], along[i]));
                (along, across)
            }
        };
        [0, 1, 2].map(|i| {
            let a = g.mul(across[i], cos);
            let b = g.mul(kxq[i], sin);
            let ab = g.add(a, b);
            g.add(along[i], ab)
        })
    }

    /// The items of a list written out or named by a top-level `let`.
    fn list_items(&mut self, list: &Expr, frame: Frame) -> Result<Vec<Value>, Reported> {
        match &list.kind {
            ExprKind::List(items) => {
                let mut out = Vec::new();
                let mut failed = false;
                for item in items {
                    match self.lower(item, frame) {
                        Ok(v) => out.push(v),
                        Err(Reported) => failed = true,
                    }
                }
                if failed {
                    Err(Reported)
                } else {
                    Ok(out)
                }
            }
            ExprKind::Variable(name) if self.globals.lists.contains_key(name) => {
                let items = self.globals.lists[name].clone();
                Ok(items.into_iter().map(|c| self.constant_node(c)).collect())
            }
            _ => {
                let what = match self.lower(list, frame) {
                    Ok(v) => v.kind_name(),
                    Err(Reported) => return Err(Reported),
                };
                self.diags.push(
                    Diagnostic::new(Code::WrongKind, format!("expected a list, found {what}"))
                        .label(list.span, format!("this is {what}"))
                        .help("write a list as [a, b, c], or name one with a top-level `let centres = [...]`"),
                );
                Err(Reported)
            }
        }
    }

    /// `sum(i in a..b, term)`, `product`, `min`, `max`: the term lowered
    /// once per number or item, combined as it goes.
    fn aggregate(
        &mut self,
        op: crate::ast::AggregateOp,
        name: &Ident,
        source: &crate::ast::Source,
        body: &Expr,
        span: Span,
        frame: Frame,
    ) -> Lowered {
        use crate::ast::Source;
        if RESERVED.contains(&name.name.as_str()) {
            return self.error(
                Diagnostic::new(
                    Code::DuplicateName,
                    format!("`{}` is built in and cannot name the terms", name.name),
                )
                .label(name.span, "reserved name")
                .help("use another name, like i, k or c"),
            );
        }
        let items: Vec<Value> = match source {
            Source::Range {
                from,
                to,
                inclusive,
            } => {
                let a = self.whole_number(from, frame);
                let b = self.whole_number(to, frame);
                let (Some(a), Some(b)) = (a?, b?) else {
                    // A parameter's range while the body is checked: one
                    // term with an unknown index (slot 255, which no tape
                    // reads) stands for all of them.
                    let index = Value::Num(self.graph.input(u8::MAX));
                    return self.aggregate_terms(op, name, vec![index], body, span, frame);
                };
                let end = if *inclusive { b + 1 } else { b };
                if end - a > MAX_TERMS {
                    return self.error(
                        Diagnostic::new(
                            Code::TooLarge,
                            format!("a range of {} numbers is too long", end - a),
                        )
                        .label(span, format!("more than {MAX_TERMS} terms"))
                        .help("each term is compiled into the formula; use fewer terms"),
                    );
                }
                (a..end)
                    .map(|i| Value::Num(self.graph.constant(i as f64)))
                    .collect()
            }
            Source::List(list) => self.list_items(list, frame)?,
        };
        self.aggregate_terms(op, name, items, body, span, frame)
    }

    /// The terms of an aggregate, one per item, combined as they come.
    fn aggregate_terms(
        &mut self,
        op: crate::ast::AggregateOp,
        name: &Ident,
        items: Vec<Value>,
        body: &Expr,
        span: Span,
        frame: Frame,
    ) -> Lowered {
        use crate::ast::AggregateOp;
        if items.is_empty() && matches!(op, AggregateOp::Min | AggregateOp::Max) {
            return self.error(
                Diagnostic::new(
                    Code::OutOfRange,
                    format!("`{}` over nothing has no value", op.name()),
                )
                .label(span, "no terms")
                .help("give the range or list at least one item"),
            );
        }
        let mut total: Option<Value> = None;
        for item in items {
            let link = [(name.name.clone(), item)];
            let term = self.lower(
                body,
                Frame {
                    params: frame.params.inside(&link),
                    point: frame.point,
                },
            )?;
            total = Some(match (total, term) {
                (None, t @ (Value::Num(_) | Value::Vector(_))) => {
                    if matches!(t, Value::Vector(_)) && op != AggregateOp::Sum {
                        return self.aggregate_kind_error(op, body, t);
                    }
                    t
                }
                (Some(Value::Num(acc)), Value::Num(t)) => {
                    let g = &mut *self.graph;
                    Value::Num(match op {
                        AggregateOp::Sum => g.add(acc, t),
                        AggregateOp::Product => g.mul(acc, t),
                        AggregateOp::Min => g.min(acc, t),
                        AggregateOp::Max => g.max(acc, t),
                    })
                }
                (Some(Value::Vector(acc)), Value::Vector(t)) => {
                    Value::Vector([0, 1, 2].map(|i| self.graph.add(acc[i], t[i])))
                }
                (_, t) => return self.aggregate_kind_error(op, body, t),
            });
        }
        Ok(total.unwrap_or_else(|| {
            Value::Num(
                self.graph
                    .constant(if op == AggregateOp::Product { 1.0 } else { 0.0 }),
            )
        }))
    }

    fn aggregate_kind_error(
        &mut self,
        op: crate::ast::AggregateOp,
        body: &Expr,
        t: Value,
    ) -> Lowered {
        self.error(
            Diagnostic::new(
                Code::WrongKind,
                format!("the terms of `{}` must be numbers{}, not {}", op.name(),
                    if op == crate::ast::AggregateOp::Sum { " or vectors (all of one kind)" } else { "" },
                    t.kind_name()),
            )
            .label(body.span, format!("this is {}", t.kind_name()))
            .help("for a condition, choose a number with `if`; for a vector, take its length or a component"),
        )
    }

    /// A range's end: a whole number known at compile time, or `None` for
    /// a parameter's value while a body is checked on its own.
    fn whole_number(&mut self, e: &Expr, frame: Frame) -> Result<Option<i64>, Reported> {
        let v = self.lower(e, frame)?;
        let n = self.expect_num(v, e, "a range's end")?;
        match self.graph.constant_value(n) {
            Some(k) if k.fract() == 0.0 && k.abs() <= 1e15 => Ok(Some(k as i64)),
            None if self.parameters_unknown && !self.graph.depends_on_slots(n, |s| s < 3) => {
                Ok(None)
            }
            Some(k) => {
                self.diags.push(
                    Diagnostic::new(Code::OutOfRange, format!("a range runs over whole numbers, not {k}"))
                        .label(e.span, "not a whole number")
                        .help("write the ends as whole numbers, like 0..5; scale the name inside the term instead"),
                );
                Err(Reported)
            }
            None => {
                self.diags.push(
                    Diagnostic::new(
                        Code::NotConstant,
                        "a range's ends must be known before rendering",
                    )
                    .label(e.span, "depends on x, y or z")
                    .help("use numbers, `let` constants and parameters here"),
                );
                Err(Reported)
            }
        }
    }

    /// Two values to choose or blend between: colours stay colours when
    /// the choice is constant; where it `varies`, or beside a vector, a
    /// colour is the vector of its sRGB components (a colour field's).
    fn as_components(&mut self, a: Value, b: Value, varies: bool) -> (Value, Value) {
        match (a, b) {
            (Value::Colour(_), Value::Colour(_)) if !varies => (a, b),
            (Value::Colour(_), Value::Colour(_) | Value::Vector(_))
            | (Value::Vector(_), Value::Colour(_)) => (self.components(a), self.components(b)),
            ab => ab,
        }
    }

    /// A colour as the vector of its sRGB components (a colour field's);
    /// any other value as it is.
    fn components(&mut self, v: Value) -> Value {
        match v {
            Value::Colour(c) => Value::Vector(c.to_array().map(|x| self.graph.constant(x))),
            v => v,
        }
    }

    fn condition_misuse(&mut self, span: Span) -> Lowered {
        self.error(
            Diagnostic::new(Code::WrongKind, "a condition is not a number")
                .label(span, "this is a condition")
                .help("choose between values with `if CONDITION then A else B`; `step(edge, x)` is 1 where x >= edge and 0 below"),
        )
    }

    fn colour_misuse(&mut self, span: Span) -> Lowered {
        self.error(
            Diagnostic::new(Code::WrongKind, "a colour cannot be used here")
                .label(span, "this is a colour")
                .help("colours add and subtract (`red + 0.2 * blue`), scale by a number (`0.5 * red`) and tint each other (`red * grey`); elsewhere they are for `colour` properties and `background`"),
        )
    }

    /// Colours added, subtracted, tinted by each other (component by
    /// component) and scaled by a number, in sRGB as `mix` blends them.
    /// A constant result stays a colour, clamped to 0..1 as a field's
    /// components are; by a number that varies it is a colour field's
    /// components.
    fn colour_arithmetic(
        &mut self,
        op: BinaryOp,
        a: Value,
        b: Value,
        sa: Span,
        sb: Span,
    ) -> Lowered {
        use Value::*;
        // A vector of constants is a colour written as fractions, as
        // wherever a colour goes.
        let constant = |g: &Graph, v: Value| match v {
            Colour(c) => Some(c),
            Num(n) => g.constant_value(n).map(DVec3::splat),
            Vector(v) => {
                let c: Option<Vec<f64>> = v.iter().map(|&n| g.constant_value(n)).collect();
                c.map(|c| DVec3::new(c[0], c[1], c[2]))
            }
            Cond(_) => None,
        };
        let both = (constant(self.graph, a), constant(self.graph, b));
        let folded = match (op, a, b, both) {
            (BinaryOp::Add, Colour(_) | Vector(_), Colour(_) | Vector(_), (Some(u), Some(v))) => {
                Some(u + v)
            }
            (BinaryOp::Sub, Colour(_) | Vector(_), Colour(_) | Vector(_), (Some(u), Some(v))) => {
                Some(u - v)
            }
            (BinaryOp::Mul, Colour(_) | Num(_), Colour(_) | Num(_), (Some(u), Some(v))) => {
                Some(u * v)
            }
            (BinaryOp::Div, Colour(_), Num(_), (Some(u), Some(s))) => Some(u / s),
            _ => None,
        };
        if let Some(c) = folded {
            return if c.is_finite() {
                Ok(Colour(c.clamp(DVec3::ZERO, DVec3::ONE)))
            } else {
                self.error(
                    Diagnostic::new(Code::OutOfRange, "this colour is not a number")
                        .label(sa.to(sb), "divided by zero, or overflowed")
                        .help("scale a colour by a finite number"),
                )
            };
        }
        match (op, a, b) {
            (BinaryOp::Add | BinaryOp::Sub, Colour(_) | Vector(_), Colour(_) | Vector(_))
            | (BinaryOp::Mul, Colour(_), Num(_))
            | (BinaryOp::Mul, Num(_), Colour(_))
            | (BinaryOp::Div, Colour(_), Num(_)) => {
                let (a, b) = (self.components(a), self.components(b));
                self.binary(op, a, b, sa, sb)
            }
            (BinaryOp::Mul, Colour(u), Vector(v)) | (BinaryOp::Mul, Vector(v), Colour(u)) => {
                let g = &mut *self.graph;
                Ok(Vector([0, 1, 2].map(|i| {
                    let c = g.constant(u[i]);
                    g.mul(c, v[i])
                })))
            }
            (_, Cond(_), _) => self.condition_misuse(sa),
            (_, _, Cond(_)) => self.condition_misuse(sb),
            _ => self.colour_misuse(if matches!(a, Colour(_)) { sa } else { sb }),
        }
    }

    fn binary(&mut self, op: BinaryOp, a: Value, b: Value, sa: Span, sb: Span) -> Lowered {
        use Value::*;
        let comparison = matches!(
            op,
            BinaryOp::Less
                | BinaryOp::LessOrEqual
                | BinaryOp::Greater
                | BinaryOp::GreaterOrEqual
                | BinaryOp::Equal
                | BinaryOp::NotEqual
        );
        let logical = matches!(op, BinaryOp::And | BinaryOp::Or);
        if matches!(op, BinaryOp::Equal | BinaryOp::NotEqual) {
            let sym = if op == BinaryOp::Equal { "==" } else { "!=" };
            return self.error(
                Diagnostic::new(Code::WrongKind, format!("nes has no `{sym}` for numbers"))
                    .label(sa.to(sb), "an exact comparison")
                    .help("computed numbers are seldom exactly equal, and a surface is already where its formula is 0: compare with a tolerance, `abs(a - b) < 0.001`, or use < and >"),
            );
        }
        if logical {
            return match (a, b) {
                (Cond(x), Cond(y)) => Ok(Cond(if op == BinaryOp::And {
                    self.graph.min(x, y)
                } else {
                    self.graph.max(x, y)
                })),
                (Cond(_), other) | (other, Cond(_)) | (other, _) => {
                    let culprit = if matches!(a, Cond(_)) { sb } else { sa };
                    self.error(
                        Diagnostic::new(
                            Code::WrongKind,
                            format!(
                                "`{}` joins conditions, not {}",
                                if op == BinaryOp::And { "and" } else { "or" },
                                other.kind_name()
                            ),
                        )
                        .label(culprit, format!("this is {}", other.kind_name()))
                        .help("write comparisons on both sides, e.g. `x > 0 and y < 1`"),
                    )
                }
            };
        }
        if comparison {
            return match (a, b) {
                (Num(x), Num(y)) => {
                    let g = &mut *self.graph;
                    Ok(Cond(match op {
                        BinaryOp::Less | BinaryOp::LessOrEqual => g.sub(y, x),
                        _ => g.sub(x, y),
                    }))
                }
                (Num(_), other) | (other, _) => {
                    let culprit = if matches!(a, Num(_)) { sb } else { sa };
                    self.error(
                        Diagnostic::new(
                            Code::WrongKind,
                            format!("comparisons are between numbers, not {}", other.kind_name()),
                        )
                        .label(culprit, format!("this is {}", other.kind_name()))
                        .help(if matches!(other, Cond(_)) {
                            "chain comparisons with `and`: `0 < x and x < 1`"
                        } else {
                            "compare lengths or components: `length(p) < 1`, `p.z > 0`"
                        }),
                    )
                }
            };
        }
        if matches!(a, Colour(_)) || matches!(b, Colour(_)) {
            return self.colour_arithmetic(op, a, b, sa, sb);
        }
        let g = &mut *self.graph;
        match (op, a, b) {
            (_, Cond(_), _) => self.condition_misuse(sa),
            (_, _, Cond(_)) => self.condition_misuse(sb),
            (BinaryOp::Add, Num(x), Num(y)) => Ok(Num(g.add(x, y))),
            (BinaryOp::Sub, Num(x), Num(y)) => Ok(Num(g.sub(x, y))),
            (BinaryOp::Mul, Num(x), Num(y)) => Ok(Num(g.mul(x, y))),
            (BinaryOp::Div, Num(x), Num(y)) => Ok(Num(g.div(x, y))),
            (BinaryOp::Pow, Num(x), Num(y)) => Ok(Num(g.binary(Binary::Pow, x, y))),
            (BinaryOp::Add, Vector(u), Vector(v)) => {
                Ok(Vector([0, 1, 2].map(|i| g.add(u[i], v[i]))))
            }
            (BinaryOp::Sub, Vector(u), Vector(v)) => {
                Ok(Vector([0, 1, 2].map(|i| g.sub(u[i], v[i]))))
            }
            (BinaryOp::Mul, Num(s), Vector(v)) | (BinaryOp::Mul, Vector(v), Num(s)) => {
                Ok(Vector(v.map(|c| g.mul(s, c))))
            }
            (BinaryOp::Div, Vector(v), Num(s)) => Ok(Vector(v.map(|c| g.div(c, s)))),
            (op, a, b) => {
                let (sym, hint) = match op {
                    BinaryOp::Add => ("+", "add numbers to numbers and vectors to vectors"),
                    BinaryOp::Sub => (
                        "-",
                        "subtract numbers from numbers and vectors from vectors",
                    ),
                    BinaryOp::Mul => ("*", "for two vectors use dot(a, b) or cross(a, b)"),
                    BinaryOp::Div => ("/", "only a vector divided by a number is defined"),
                    BinaryOp::Pow => (
                        "^",
                        "powers take numbers; for a vector's length use length(v)",
                    ),
                    _ => ("?", "check the operands' kinds"),
                };
                let (culprit, kind) = if matches!(a, Vector(_)) {
                    (sa, a.kind_name())
                } else {
                    (sb, b.kind_name())
                };
                self.error(
                    Diagnostic::new(
                        Code::WrongKind,
                        format!(
                            "`{sym}` is not defined for {} and {}",
                            a.kind_name(),
                            b.kind_name()
                        ),
                    )
                    .label(culprit, format!("this is {kind}"))
                    .help(hint),
                )
            }
        }
    }

    fn variable(&mut self, name: &str, span: Span, frame: Frame) -> Lowered {
        // x, y, z and p are reserved, so no local name hides them; they are
        // read before the scope, whose lookup walks every enclosing `let`.
        let is_point = matches!(name, "x" | "y" | "z" | "p");
        if !is_point {
            if let Some(v) = frame.params.get(name) {
                return Ok(v);
            }
        }
        let axis = match name {
            "x" => Some(0),
            "y" => Some(1),
            "z" => Some(2),
            _ => None,
        };
        if axis.is_some() || name == "p" {
            let Some(point) = frame.point else {
                return self.error(
                    Diagnostic::new(Code::NotConstant, format!("`{name}` has no value here"))
                        .label(span, "x, y, z and p exist only inside a shape")
                        .help(
                            "a `let` or a setting holds a constant: for what varies with the point, write the formula where it is used (`object ...`, `colour viridis(z)`), or define it with `shape NAME = ...` or `fn NAME(q: vector) = ...`",
                        ),
                );
            };
            return Ok(match axis {
                Some(i) => Value::Num(point[i]),
                None => Value::Vector(point),
            });
        }
        let constant = match name {
            "pi" => Some(std::f64::consts::PI),
            "tau" => Some(std::f64::consts::TAU),
            "e" => Some(std::f64::consts::E),
            "time" | "frame" => {
                self.globals.read_clock.set(true);
                Some(if name == "time" {
                    self.globals.clock.time
                } else {
                    self.globals.clock.frame as f64
                })
            }
            _ => None,
        };
        if let Some(c) = constant {
            return Ok(Value::Num(self.graph.constant(c)));
        }
        if let Some(c) = self.globals.lets.get(name).filter(|_| !self.in_prelude()) {
            return Ok(self.constant_node(*c));
        }
        if self.globals.lists.contains_key(name) && !self.in_prelude() {
            return self.error(
                Diagnostic::new(Code::WrongKind, format!("`{name}` is a list, not a value"))
                    .label(span, "a list")
                    .help(format!(
                        "sum over it with `sum(item in {name}, ...)` or take an item with `{name}[0]`"
                    )),
            );
        }
        if let Some(c) = named_colour(name) {
            return Ok(Value::Colour(c));
        }
        if self.shape_def(name).is_some() {
            let ident = Ident {
                name: name.to_string(),
                span,
            };
            return self.call(&ident, &[], span, frame);
        }
        if COLOUR_FIELD_NAMES.contains(&name) {
            return self.error(
                Diagnostic::new(
                    Code::NotConstant,
                    format!("`{name}` has a value only in a colour"),
                )
                .label(span, "the hit's, in `colour` and `inside` formulas")
                .help(format!(
                    "use it in an object's colour, as in `colour diverging({})`",
                    if name == "normal" { "normal.z" } else { name }
                )),
            );
        }
        if self.globals.broken_names.contains(name) {
            return Err(Reported);
        }
        let hint = self.did_you_mean(name, frame);
        self.error(
            Diagnostic::new(Code::UnknownName, format!("unknown name `{name}`"))
                .label(span, "not defined")
                .help(hint),
        )
    }

    pub(crate) fn constant_node(&mut self, c: Constant) -> Value {
        match c {
            Constant::Num(n) => Value::Num(self.graph.constant(n)),
            Constant::Vector(v) => Value::Vector(v.to_array().map(|c| self.graph.constant(c))),
            Constant::Colour(c) => Value::Colour(c),
        }
    }

    fn did_you_mean(&self, name: &str, frame: Frame) -> String {
        let mut candidates: Vec<&str> = Vec::new();
        candidates.extend(frame.params.names());
        candidates.extend(self.globals.lets.keys().map(|s| s.as_str()));
        candidates.extend(self.globals.shapes.keys().map(|s| s.as_str()));
        candidates.extend(BUILTIN_FUNCTIONS);
        candidates.extend(NAMED_COLOURS.iter().map(|(n, _)| *n));
        candidates.extend(["pi", "tau", "e", "time", "frame"]);
        if frame.point.is_some() {
            candidates.extend(["x", "y", "z", "p"]);
        }
        match suggest(name, candidates) {
            Some(s) => format!("did you mean `{s}`?"),
            // `lightblue`, `darkred`: a colour name nes does not know.
            None if NAMED_COLOURS.iter().any(|(n, _)| name.contains(n)) => format!(
                "the named colours are {}; any other is written #rrggbb, rgb(R, G, B) or (r, g, b), or named with `let`",
                NAMED_COLOURS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
            ),
            None => "define it with `let` or `shape` before using it".into(),
        }
    }

    fn call(&mut self, name: &Ident, args: &[Expr], span: Span, frame: Frame) -> Lowered {
        if BUILTIN_FUNCTIONS.contains(&name.name.as_str()) {
            return self.builtin(name, args, span, frame);
        }
        if self.shape_def(&name.name).is_some() {
            return self.shape_call(name, args, span, frame);
        }
        if matches!(name.name.as_str(), "sum" | "product") {
            return self.error(
                Diagnostic::new(
                    Code::Syntax,
                    format!("`{}` runs over a range or a list", name.name),
                )
                .label(span, "no `NAME in ...` here")
                .help(format!(
                    "write `{}(i in 0..5, term)` or `{}(c in [a, b], term)`",
                    name.name, name.name
                )),
            );
        }
        // Only names that take this many arguments are suggested: `mox(a,
        // b, t)` is `mix`, not `max` or `mod`.
        let n = args.len();
        let mut candidates: Vec<&str> = BUILTIN_FUNCTIONS
            .iter()
            .copied()
            .filter(|b| {
                let (lo, hi) = builtin_arity(b);
                (lo..=hi).contains(&n)
            })
            .collect();
        candidates.extend(
            self.globals
                .shapes
                .iter()
                .filter(|(_, d)| d.params.len() == n)
                .map(|(k, _)| k.as_str()),
        );
        let close = || {
            // Builtins come first in the list and win ties.
            candidates
                .iter()
                .enumerate()
                .map(|(i, c)| (strsim::levenshtein(&name.name, c), i, *c))
                .filter(|(d, _, _)| *d <= 1.max(name.name.len() / 3))
                .min()
                .map(|(_, _, c)| c.to_string())
        };
        let hint = match suggest(&name.name, candidates.iter().copied()).or_else(close) {
            Some(s) => format!("did you mean `{s}`?"),
            None => "define it with `fn` or `shape` before using it; docs/language.md lists the builtins".into(),
        };
        self.error(
            Diagnostic::new(
                Code::UnknownName,
                format!("unknown function or shape `{}`", name.name),
            )
            .label(name.span, "not defined")
            .help(hint),
        )
    }

    fn args(&mut self, args: &[Expr], frame: Frame) -> Result<Vec<Value>, Reported> {
        let mut out = Vec::new();
        let mut failed = false;
        for a in args {
            match self.lower(a, frame) {
                Ok(v) => out.push(v),
                Err(Reported) => failed = true,
            }
        }
        if failed {
            Err(Reported)
        } else {
            Ok(out)
        }
    }

    fn count_error(
        &mut self,
        name: &Ident,
        span: Span,
        expected: &str,
        got: usize,
        usage: &str,
    ) -> Lowered {
        self.error(
            Diagnostic::new(
                Code::ArgumentCount,
                format!(
                    "`{}` takes {expected}, but {got} {} given",
                    name.name,
                    if got == 1 { "was" } else { "were" }
                ),
            )
            .label(
                span,
                format!("{got} argument{}", if got == 1 { "" } else { "s" }),
            )
            .help(format!("write it as {usage}")),
        )
    }

    fn expect_num(&mut self, v: Value, e: &Expr, what: &str) -> Result<NodeId, Reported> {
        match v {
            Value::Num(n) => Ok(n),
            other => {
                self.diags.push(
                    Diagnostic::new(
                        Code::WrongKind,
                        format!("{what} must be a number, not {}", other.kind_name()),
                    )
                    .label(e.span, format!("this is {}", other.kind_name()))
                    .help(if matches!(other, Value::Vector(_)) {
                        "take a component with .x, .y or .z, or the length with length(v)"
                    } else {
                        "colours can only be used as colours"
                    }),
                );
                Err(Reported)
            }
        }
    }

    fn expect_vector(&mut self, v: Value, e: &Expr, what: &str) -> Result<[NodeId; 3], Reported> {
        match v {
            Value::Vector(n) => Ok(n),
            other => {
                self.diags.push(
                    Diagnostic::new(
                        Code::WrongKind,
                        format!("{what} must be a vector, not {}", other.kind_name()),
                    )
                    .label(e.span, format!("this is {}", other.kind_name()))
                    .help("write a vector as (x, y, z)"),
                );
                Err(Reported)
            }
        }
    }

    fn builtin(&mut self, name: &Ident, args: &[Expr], span: Span, frame: Frame) -> Lowered {
        let n = name.name.as_str();
        let vals = self.args(args, frame)?;
        let (lo, hi) = builtin_arity(n);
        let arity: (usize, usize, &str) = match n {
            "atan2" => (2, 2, "atan2(y, x)"),
            "pow" => (2, 2, "pow(base, exponent)"),
            "min" | "max" => (2, usize::MAX, "min(a, b, ...) with two or more numbers"),
            "union" | "intersection" | "difference" => {
                (1, usize::MAX, "union(a, b, ...) of solids or formulas")
            }
            "clamp" => (3, 3, "clamp(value, low, high)"),
            "smin" => (3, 3, "smin(a, b, k) with a smoothing radius k > 0"),
            "mod" => (2, 2, "mod(a, b), the remainder of a / b in [0, b)"),
            "step" => (2, 2, "step(edge, x): 0 below the edge, 1 from it on"),
            "smoothstep" => (3, 3, "smoothstep(edge0, edge1, x)"),
            "mix" => (3, 3, "mix(a, b, t) = a + (b - a) t"),
            "dot" => (2, 2, "dot(u, v)"),
            "cross" => (2, 2, "cross(u, v)"),
            "length" => (1, 1, "length(v)"),
            "normalize" => (1, 1, "normalize(v)"),
            "noise" => (1, 1, "noise(q) of a point q, as in noise(3 * p)"),
            "geodesic_distance" => (1, 1, "geodesic_distance(point)"),
            "plane_distance" => (1, 1, "plane_distance(normal)"),
            "busemann" => (1, 1, "busemann(direction)"),
            "rgb" => (3, 3, "rgb(red, green, blue) with values from 0 to 255"),
            _ => (1, 1, ""),
        };
        debug_assert_eq!((lo, hi), (arity.0, arity.1), "{n}");
        if vals.len() < arity.0 || vals.len() > arity.1 {
            let expected = if arity.1 == usize::MAX {
                format!("at least {} arguments", arity.0)
            } else if arity.0 == 1 {
                "1 argument".to_string()
            } else {
                format!("{} arguments", arity.0)
            };
            let usage = if arity.2.is_empty() {
                format!("{n}(value)")
            } else {
                arity.2.to_string()
            };
            return self.count_error(name, span, &expected, vals.len(), &usage);
        }
        let what = |i: usize| format!("argument {} of `{n}`", i + 1);
        match n {
            "mix" => {
                let t = self.expect_num(vals[2], &args[2], &what(2))?;
                let constant_t = self.graph.constant_value(t);
                let (a, b) = self.as_components(vals[0], vals[1], constant_t.is_none());
                let g = &mut *self.graph;
                let mix = |g: &mut Graph, a: NodeId, b: NodeId| {
                    let d = g.sub(b, a);
                    let d = g.mul(d, t);
                    g.add(a, d)
                };
                match (a, b) {
                    (Value::Num(a), Value::Num(b)) => Ok(Value::Num(mix(g, a, b))),
                    (Value::Vector(a), Value::Vector(b)) => {
                        Ok(Value::Vector([0, 1, 2].map(|i| mix(g, a[i], b[i]))))
                    }
                    (Value::Colour(a), Value::Colour(b)) => {
                        let t = constant_t.expect("colours that vary are components");
                        Ok(Value::Colour(a + (b - a) * t))
                    }
                    (a, b) => self.error(
                        Diagnostic::new(
                            Code::WrongKind,
                            format!(
                                "`mix` blends two values of one kind, not {} and {}",
                                a.kind_name(),
                                b.kind_name()
                            ),
                        )
                        .label(args[0].span.to(args[1].span), "these two")
                        .help("write mix(a, b, t) with two numbers, two vectors or two colours"),
                    ),
                }
            }
            "dot" | "cross" => {
                let u = self.expect_vector(vals[0], &args[0], &what(0));
                let v = self.expect_vector(vals[1], &args[1], &what(1));
                let (u, v) = (u?, v?);
                let g = &mut *self.graph;
                if n == "dot" {
                    let terms = [0, 1, 2].map(|i| g.mul(u[i], v[i]));
                    let s = g.add(terms[0], terms[1]);
                    Ok(Value::Num(g.add(s, terms[2])))
                } else {
                    let c = |g: &mut Graph, i: usize, j: usize| {
                        let a = g.mul(u[i], v[j]);
                        let b = g.mul(u[j], v[i]);
                        g.sub(a, b)
                    };
                    Ok(Value::Vector([c(g, 1, 2), c(g, 2, 0), c(g, 0, 1)]))
                }
            }
            "length" | "normalize" => {
                let v = self.expect_vector(vals[0], &args[0], &what(0))?;
                let g = &mut *self.graph;
                let sq = v.map(|c| g.unary(Unary::Square, c));
                let s = g.add(sq[0], sq[1]);
                let s = g.add(s, sq[2]);
                let len = g.unary(Unary::Sqrt, s);
                if n == "length" {
                    return Ok(Value::Num(len));
                }
                if g.constant_value(len) == Some(0.0) {
                    return self.error(
                        Diagnostic::new(
                            Code::ZeroLength,
                            "cannot normalize a vector of length zero",
                        )
                        .label(args[0].span, "this vector is (0, 0, 0)")
                        .help("give a direction with at least one non-zero component"),
                    );
                }
                Ok(Value::Vector(v.map(|c| g.div(c, len))))
            }
            "geodesic_distance" | "plane_distance" | "busemann" => {
                let v = self.expect_vector(vals[0], &args[0], &what(0))?;
                let Some(p) = frame.point else {
                    return self.error(
                        Diagnostic::new(Code::NotConstant, format!("`{n}` has no value here"))
                            .label(span, "a distance from the point (x, y, z), which exists only inside a shape")
                            .help("use it in a shape: `shape s = geodesic_distance((1, 0, 0)) - 0.5`"),
                    );
                };
                if n == "busemann" && matches!(self.globals.curvature, Some((k, _)) if k > 0.0) {
                    return self.error(
                        Diagnostic::new(Code::WrongKind, NO_INFINITY)
                            .label(span, "busemann needs a direction to infinity")
                            .help(NO_INFINITY_HELP),
                    );
                }
                if n != "geodesic_distance"
                    && v.iter().all(|c| self.graph.constant_value(*c) == Some(0.0))
                {
                    return self.error(
                        Diagnostic::new(
                            Code::ZeroLength,
                            format!("`{n}` needs a direction, not (0, 0, 0)"),
                        )
                        .label(args[0].span, "this vector is (0, 0, 0)")
                        .help("give a direction with at least one non-zero component"),
                    );
                }
                let curvature = self.globals.curvature;
                if curvature.is_some() {
                    self.globals
                        .note_curved_use(self.prelude_shape.as_deref().unwrap_or(n));
                }
                Ok(Value::Num(geometric(self.graph, n, p, v, curvature)))
            }
            "noise" => {
                let q = self.expect_vector(vals[0], &args[0], &what(0))?;
                Ok(Value::Num(self.graph.noise(Noise::VALUE, q)))
            }
            "rgb" => {
                let mut rgb = [0.0; 3];
                for i in 0..3 {
                    let node = self.expect_num(vals[i], &args[i], &what(i))?;
                    match self.graph.constant_value(node) {
                        // `rgb(1, 0.5, 0)`: fractions, which as bytes would
                        // be all but black.
                        Some(c) if c.fract() != 0.0 && (0.0..1.0).contains(&c) => return self.error(
                            Diagnostic::new(
                                Code::OutOfRange,
                                format!("rgb() takes whole bytes from 0 to 255, and {c} looks like a fraction"),
                            )
                            .label(args[i].span, "a fraction of a byte")
                            .help("for fractions from 0 to 1 write the vector (r, g, b), e.g. `(1, 0.5, 0)`; for bytes, `rgb(255, 128, 0)`"),
                        ),
                        Some(c) if (0.0..=255.0).contains(&c) => rgb[i] = c / 255.0,
                        Some(c) => return self.error(
                            Diagnostic::new(
                                Code::OutOfRange,
                                format!("colour component {c} is outside 0 to 255"),
                            )
                            .label(args[i].span, "out of range")
                            .help("rgb() takes bytes from 0 to 255; for fractions write (r, g, b)"),
                        ),
                        None => return self.not_constant(&args[i]),
                    }
                }
                Ok(Value::Colour(DVec3::from_array(rgb)))
            }
            _ => {
                let mut nums = Vec::new();
                let mut failed = false;
                for (i, v) in vals.iter().enumerate() {
                    match self.expect_num(*v, &args[i], &what(i)) {
                        Ok(x) => nums.push(x),
                        Err(Reported) => failed = true,
                    }
                }
                if failed {
                    return Err(Reported);
                }
                self.numeric_builtin(n, &nums, args)
            }
        }
    }

    fn not_constant(&mut self, e: &Expr) -> Lowered {
        self.error(
            Diagnostic::new(Code::NotConstant, "this value must be a constant")
                .label(e.span, "depends on x, y or z")
                .help("use numbers, `let` constants and parameters here, not the point"),
        )
    }

    fn numeric_builtin(&mut self, n: &str, a: &[NodeId], args: &[Expr]) -> Lowered {
        let g = &mut *self.graph;
        let v = match n {
            "sin" => g.unary(Unary::Sin, a[0]),
            "cos" => g.unary(Unary::Cos, a[0]),
            "tan" => g.unary(Unary::Tan, a[0]),
            "asin" => g.unary(Unary::Asin, a[0]),
            "acos" => g.unary(Unary::Acos, a[0]),
            "atan" => g.unary(Unary::Atan, a[0]),
            "sinh" => g.unary(Unary::Sinh, a[0]),
            "cosh" => g.unary(Unary::Cosh, a[0]),
            "tanh" => g.unary(Unary::Tanh, a[0]),
            "exp" => g.unary(Unary::Exp, a[0]),
            "ln" => g.unary(Unary::Ln, a[0]),
            "log" => {
                let l = g.unary(Unary::Ln, a[0]);
                let k = g.constant(std::f64::consts::LOG10_E);
                g.mul(k, l)
            }
            "sqrt" => g.unary(Unary::Sqrt, a[0]),
            "abs" => g.unary(Unary::Abs, a[0]),
            "sign" => g.unary(Unary::Sign, a[0]),
            "atan2" => g.binary(Binary::Atan2, a[0], a[1]),
            "pow" => g.binary(Binary::Pow, a[0], a[1]),
            "min" => a[1..].iter().fold(a[0], |acc, &x| g.min(acc, x)),
            "max" => a[1..].iter().fold(a[0], |acc, &x| g.max(acc, x)),
            // In a formula, as between solids: inside any, inside all,
            // inside the first and outside the rest.
            "union" => a[1..].iter().fold(a[0], |acc, &x| g.min(acc, x)),
            "intersection" => a[1..].iter().fold(a[0], |acc, &x| g.max(acc, x)),
            "difference" => a[1..].iter().fold(a[0], |acc, &x| {
                let outside = g.neg(x);
                g.max(acc, outside)
            }),
            "clamp" => {
                let lo = g.max(a[0], a[1]);
                g.min(lo, a[2])
            }
            "floor" => g.unary(Unary::Floor, a[0]),
            "ceil" => {
                let m = g.neg(a[0]);
                let f = g.unary(Unary::Floor, m);
                g.neg(f)
            }
            "round" => {
                let half = g.constant(0.5);
                let s = g.add(a[0], half);
                g.unary(Unary::Floor, s)
            }
            "fract" => g.unary(Unary::Fract, a[0]),
            "mod" => {
                if g.constant_value(a[1]) == Some(0.0) {
                    return self.error(
                        Diagnostic::new(Code::OutOfRange, "mod by zero has no value")
                            .label(args[1].span, "zero")
                            .help("mod(a, b) is the remainder of a / b: give a non-zero b, like mod(x, 2)"),
                    );
                }
                // b fract(a / b), in [0, b): GLSL's mod.
                let q = g.div(a[0], a[1]);
                let f = g.unary(Unary::Fract, q);
                g.mul(a[1], f)
            }
            "step" => {
                // 1 where x >= edge: 1 unless edge - x > 0.
                let c = g.sub(a[0], a[1]);
                let one = g.constant(1.0);
                g.binary(Binary::Unless, c, one)
            }
            "smoothstep" => {
                if let (Some(e0), Some(e1)) = (g.constant_value(a[0]), g.constant_value(a[1])) {
                    if e0 == e1 {
                        return self.error(
                            Diagnostic::new(Code::OutOfRange, "smoothstep's two edges are equal")
                                .label(args[0].span.to(args[1].span), format!("both {e0}"))
                                .help("smoothstep(edge0, edge1, x) rises from edge0 to edge1; for a sharp step use step(edge, x)"),
                        );
                    }
                }
                let d = g.sub(a[2], a[0]);
                let w = g.sub(a[1], a[0]);
                let t = g.div(d, w);
                g.unary(Unary::SmoothStep, t)
            }
            "smin" => {
                if let Some(k) = g.constant_value(a[2]) {
                    if k <= 0.0 || !k.is_finite() {
                        return self.error(
                            Diagnostic::new(Code::OutOfRange, format!("smin's smoothing radius must be positive, got {k}"))
                                .label(args[2].span, "not positive")
                                .help("the third argument of smin(a, b, k) is how far the blend reaches; try 0.2"),
                        );
                    }
                }
                // The polynomial smooth minimum of radius k is k times the
                // one of radius 1 at a / k, b / k: one operation, whose
                // interval is tight (see `Binary::SmoothMin`).
                let (x, y, k) = (a[0], a[1], a[2]);
                let xs = g.div(x, k);
                let ys = g.div(y, k);
                let s = g.binary(Binary::SmoothMin, xs, ys);
                g.mul(k, s)
            }
            other => unreachable!("builtin {other} has no lowering"),
        };
        Ok(Value::Num(v))
    }

    /// Whether a prelude shape's body is being lowered: its names are the
    /// prelude's, not the scene's.
    fn in_prelude(&self) -> bool {
        self.prelude_shape.is_some()
    }

    /// The shape `name` calls where it is written: in a prelude body the
    /// prelude's own, elsewhere the scene's (which may replace one).
    fn shape_def(&self, name: &str) -> Option<&'a ShapeDef> {
        let globals = self.globals;
        if self.in_prelude() {
            globals.prelude.get(name)
        } else {
            globals.shapes.get(name)
        }
    }

    fn shape_call(&mut self, name: &Ident, args: &[Expr], span: Span, frame: Frame) -> Lowered {
        self.shape_call_at(name, args, span, frame, frame.point)
    }

    fn shape_call_at(
        &mut self,
        name: &Ident,
        args: &[Expr],
        span: Span,
        frame: Frame,
        point: Option<[NodeId; 3]>,
    ) -> Lowered {
        let globals = self.globals;
        let prelude = self.in_prelude();
        let def = self.shape_def(&name.name).expect("called for a shape");
        // A function may be used where there is no point, as a constant
        // (`background viridis(0.3)`); if its body reads x, y or z, that
        // use is reported as such. A shape is a function of the point.
        if point.is_none() && !def.function {
            return self.error(
                Diagnostic::new(
                    Code::NotConstant,
                    format!("the shape `{}` has no value here", name.name),
                )
                .label(name.span, "a shape is a function of x, y, z")
                .help(format!(
                    "draw it with `object {}` or use it inside another shape",
                    name.name
                )),
            );
        }
        let vals = self.args(args, frame)?;
        if vals.len() != def.params.len() {
            let names: Vec<&str> = def.params.iter().map(|(p, _)| p.name.as_str()).collect();
            let expected = match names.len() {
                0 => "no arguments".to_string(),
                1 => "1 argument".to_string(),
                k => format!("{k} arguments"),
            };
            let usage = format!("{}({})", name.name, names.join(", "));
            return self.count_error(name, span, &expected, vals.len(), &usage);
        }
        if globals.broken_names.contains(&name.name) {
            return Err(Reported);
        }
        let mut bound = Vec::new();
        let mut failed = false;
        for (i, ((pname, kind), v)) in def.params.iter().zip(vals).enumerate() {
            match self.check_argument(name, &pname.name, *kind, v, &args[i]) {
                Ok(v) => bound.push((pname.name.clone(), v)),
                Err(Reported) => failed = true,
            }
        }
        if failed {
            return Err(Reported);
        }
        let key = ExpansionKey {
            shape: name.name.clone(),
            prelude,
            arguments: bound.iter().flat_map(|(_, v)| v.nodes()).collect(),
            point,
        };
        if let Some(&v) = self.expanded.get(&key) {
            return Ok(v);
        }
        if self.depth >= MAX_SHAPE_DEPTH {
            return self.error(
                Diagnostic::new(Code::RecursiveShape, TOO_DEEP)
                    .label(span, format!("more than {MAX_SHAPE_DEPTH} shapes deep"))
                    .help("flatten the definitions"),
            );
        }
        // The body was checked on its own; errors inside it are not
        // reported again for every use.
        let mut quiet = Vec::new();
        let mut inner = Lowerer {
            globals,
            graph: &mut *self.graph,
            diags: &mut quiet,
            depth: self.depth + 1,
            expanded: std::mem::take(&mut self.expanded),
            prelude_shape: self
                .prelude_shape
                .clone()
                .or_else(|| def.prelude.then(|| name.name.clone())),
            parameters_unknown: self.parameters_unknown,
        };
        let body_frame = Frame {
            params: Scope::of(&bound),
            point,
        };
        let lowered = inner.lower(&def.body, body_frame);
        self.expanded = std::mem::take(&mut inner.expanded);
        if lowered.is_err() && quiet.iter().any(|d| d.message.ends_with(TOO_BIG)) {
            return self.over_budget(span, Some(&name.name));
        }
        if lowered.is_err() {
            // Nesting too deep is no fault of the body, which was checked
            // on its own: pass that diagnostic up to be reported, once.
            if quiet.iter().any(|d| d.message == NO_INFINITY) {
                // The body is fine in the space it was checked in: say so
                // at this use.
                self.diags.push(
                    Diagnostic::new(Code::WrongKind, NO_INFINITY)
                        .label(span, format!("`{}` needs a point at infinity", name.name))
                        .help(NO_INFINITY_HELP),
                );
            }
            let special = |d: &Diagnostic| d.message == TOO_DEEP || d.message == NO_INFINITY;
            if let Some(d) = quiet.iter().find(|d| !special(d)) {
                // The body checked fine on its own, so what failed depends
                // on these arguments (a range's end, a constant the body
                // needs): say so at the use, and inside the body only when
                // the body is the user's (the prelude's text is not shown).
                let mut shown =
                    Diagnostic::new(d.code, format!("in `{}`: {}", name.name, d.message))
                        .label(span, format!("in this use of `{}`", name.name));
                if !def.prelude && self.prelude_shape.is_none() {
                    for l in &d.labels {
                        shown = shown.label(l.span, l.text.clone());
                    }
                }
                if let Some(h) = &d.help {
                    shown = shown.help(h.clone());
                }
                self.diags.push(shown);
            }
            let too_deep = quiet.into_iter().find(|d| d.message == TOO_DEEP);
            if let Some(d) = too_deep {
                if !self.diags.iter().any(|e| e.message == TOO_DEEP) {
                    self.diags.push(d);
                }
            }
        }
        let v = lowered?;
        self.expanded.insert(key, v);
        Ok(v)
    }

    fn check_argument(
        &mut self,
        shape: &Ident,
        param: &str,
        kind: ParamKind,
        v: Value,
        e: &Expr,
    ) -> Lowered {
        let wrong = |this: &mut Self, v: Value| {
            this.error(
                Diagnostic::new(
                    Code::WrongKind,
                    format!(
                        "`{param}` of `{}` must be {}, not {}",
                        shape.name,
                        kind.describe(),
                        v.kind_name()
                    ),
                )
                .label(e.span, format!("this is {}", v.kind_name()))
                .help(if kind.is_vector() {
                    "write a vector as (x, y, z)"
                } else {
                    "give a number here; take a vector's component with .x, .y or .z"
                }),
            )
        };
        match (kind, v) {
            (ParamKind::Number, Value::Num(_)) | (ParamKind::Vector, Value::Vector(_)) => Ok(v),
            (ParamKind::Positive, Value::Num(n)) => match self.graph.constant_value(n) {
                Some(c) if c <= 0.0 || c.is_nan() => self.error(
                    Diagnostic::new(
                        Code::OutOfRange,
                        format!("`{param}` of `{}` must be positive, got {c}", shape.name),
                    )
                    .label(e.span, "not positive")
                    .help(format!("give `{param}` a value greater than zero")),
                ),
                Some(c) if c.is_infinite() => self.error(
                    Diagnostic::new(
                        Code::OutOfRange,
                        format!(
                            "`{param}` of `{}` must be a finite number, got {c}",
                            shape.name
                        ),
                    )
                    .label(
                        e.span,
                        "infinite (a division by zero, or a number past 1.8e308)",
                    )
                    .help(format!("give `{param}` a finite value greater than zero")),
                ),
                _ => Ok(v),
            },
            (ParamKind::Direction, Value::Vector(c)) => {
                let consts = c.map(|n| self.graph.constant_value(n));
                if let [Some(a), Some(b), Some(d)] = consts {
                    let Some(u) = crate::camera::unit_vector(DVec3::new(a, b, d)) else {
                        return self.error(
                            Diagnostic::new(
                                Code::ZeroLength,
                                format!(
                                    "`{param}` of `{}` is a direction and cannot be zero",
                                    shape.name
                                ),
                            )
                            .label(e.span, "this vector has length zero")
                            .help("give a non-zero vector, e.g. (0, 0, 1) for straight up"),
                        );
                    };
                    return Ok(Value::Vector(u.to_array().map(|x| self.graph.constant(x))));
                }
                // A direction that depends on the point is normalised as
                // an expression.
                let g = &mut *self.graph;
                let sq = c.map(|n| g.unary(Unary::Square, n));
                let s = g.add(sq[0], sq[1]);
                let s = g.add(s, sq[2]);
                let len = g.unary(Unary::Sqrt, s);
                Ok(Value::Vector(c.map(|n| g.div(n, len))))
            }
            (_, v) => wrong(self, v),
        }
    }
}

/// The geometric builtins at the point `p` (normal coordinates about the
/// object's centre), for the vector argument `v`, in the space of
/// `curvature` (sign, radius; `None` flat). A point `q` is
/// `X = (R chc(k |q|^2 / R^2), q shc(k |q|^2 / R^2))` on the model, with
/// `k = -1` in S3 and `1` in H3: no division by `|q|`, so these are
/// smooth through the centre.
fn geometric(
    g: &mut Graph,
    name: &str,
    p: [NodeId; 3],
    v: [NodeId; 3],
    curvature: Option<(f64, f64)>,
) -> NodeId {
    let unit = |g: &mut Graph, v: [NodeId; 3]| {
        let l2 = dot(g, v, v);
        let l = g.unary(Unary::Sqrt, l2);
        v.map(|c| g.div(c, l))
    };
    let Some((sigma, r)) = curvature else {
        return match name {
            "geodesic_distance" => {
                let d = [0, 1, 2].map(|i| g.sub(p[i], v[i]));
                let d2 = dot(g, d, d);
                g.unary(Unary::Sqrt, d2)
            }
            "plane_distance" => {
                let n = unit(g, v);
                dot(g, n, p)
            }
            _ => {
                let u = unit(g, v);
                let d = dot(g, u, p);
                g.neg(d)
            }
        };
    };
    let (x0, xs, shc) = model_point(g, p, sigma, r);
    match name {
        "geodesic_distance" => {
            // C(d/R) = (X0 C0 + sigma... ) / R^2: cos(d/R) = (X0 C0 + Xs.Cs)
            // / R^2 in S3, cosh(d/R) = (X0 C0 - Xs.Cs) / R^2 in H3, each
            // term monotone in |p|^2 (no difference of two large model
            // points, whose intervals would cancel badly).
            let (c0, cs, _) = model_point(g, v, sigma, r);
            let along = dot(g, xs, cs);
            let first = g.mul(x0, c0);
            let u = if sigma > 0.0 {
                g.add(first, along)
            } else {
                g.sub(first, along)
            };
            let u = g.scaled(1.0 / (r * r), u);
            let angle = if sigma > 0.0 {
                let one = g.constant(1.0);
                let minus = g.constant(-1.0);
                let u = g.min(u, one);
                let u = g.max(u, minus);
                g.unary(Unary::Acos, u)
            } else {
                // acosh(u) = ln(u + sqrt(u^2 - 1)), u >= 1.
                let one = g.constant(1.0);
                let u = g.max(u, one);
                let u2 = g.unary(Unary::Square, u);
                let m = g.sub(u2, one);
                let zero = g.constant(0.0);
                let m = g.max(m, zero);
                let root = g.unary(Unary::Sqrt, m);
                let t = g.add(u, root);
                g.unary(Unary::Ln, t)
            };
            let d = g.scaled(r, angle);
            // The distance is at least |p| - |c| (|p| is the distance from
            // the centre): the same value, but its interval rules out far
            // cells that the model's large, cancelling terms cannot.
            let p2 = dot(g, p, p);
            let pl = g.unary(Unary::Sqrt, p2);
            let c2 = dot(g, v, v);
            let cl = g.unary(Unary::Sqrt, c2);
            let lower = g.sub(pl, cl);
            g.max(d, lower)
        }
        "plane_distance" => {
            let n = unit(g, v);
            let along = dot(g, n, p);
            let s = g.mul(along, shc);
            let s = g.scaled(1.0 / r, s);
            let angle = if sigma > 0.0 {
                let one = g.constant(1.0);
                let minus = g.constant(-1.0);
                let s = g.min(s, one);
                let s = g.max(s, minus);
                g.unary(Unary::Asin, s)
            } else {
                asinh(g, s)
            };
            g.scaled(r, angle)
        }
        _ => {
            // R ln((X0 - Xs . u) / R): 0 at the centre, falling by 1 per
            // unit towards the point at infinity in direction u.
            let u = unit(g, v);
            let along = dot(g, u, xs);
            let h = g.sub(x0, along);
            let h = g.scaled(1.0 / r, h);
            let l = g.unary(Unary::Ln, h);
            g.scaled(r, l)
        }
    }
}

/// `asinh(s) = sign(s) ln(|s| + sqrt(s^2 + 1))`, without the cancellation
/// of `ln(s + sqrt(s^2 + 1))` below zero.
fn asinh(g: &mut Graph, s: NodeId) -> NodeId {
    let a = g.unary(Unary::Abs, s);
    let s2 = g.unary(Unary::Square, s);
    let one = g.constant(1.0);
    let r = g.add(s2, one);
    let r = g.unary(Unary::Sqrt, r);
    let t = g.add(a, r);
    let l = g.unary(Unary::Ln, t);
    let sign = g.unary(Unary::Sign, s);
    g.mul(sign, l)
}

/// `a . b` as graph nodes.
fn dot(g: &mut Graph, a: [NodeId; 3], b: [NodeId; 3]) -> NodeId {
    let t = [0, 1, 2].map(|i| g.mul(a[i], b[i]));
    let s = g.add(t[0], t[1]);
    g.add(s, t[2])
}

/// The model point `(X0, Xs)` of normal coordinates `q` in the space of
/// curvature sign `sigma` and radius `r`: `X0 = R chc(-sigma |q|^2 / R^2)`,
/// `Xs = q shc(-sigma |q|^2 / R^2)` (no division by `|q|`); and that shc
/// factor.
pub(crate) fn model_point(
    g: &mut Graph,
    q: [NodeId; 3],
    sigma: f64,
    r: f64,
) -> (NodeId, [NodeId; 3], NodeId) {
    let q2 = dot(g, q, q);
    let arg = g.scaled(-sigma / (r * r), q2);
    let c = g.unary(Unary::Chc, arg);
    let sh = g.unary(Unary::Shc, arg);
    let x0 = g.scaled(r, c);
    (x0, q.map(|qi| g.mul(qi, sh)), sh)
}

/// The normal coordinates of the model point `(y0, ys)`: `ys / shc(-sigma
/// theta^2)` with `theta` the angle from the origin (`atan2(|ys|, y0)` in
/// S3, `asinh(|ys| / R)` in H3), which has length `R theta`.
pub(crate) fn normal_coordinates(
    g: &mut Graph,
    y0: NodeId,
    ys: [NodeId; 3],
    sigma: f64,
    r: f64,
) -> [NodeId; 3] {
    let n2 = dot(g, ys, ys);
    let n = g.unary(Unary::Sqrt, n2);
    let theta = if sigma > 0.0 {
        g.binary(Binary::Atan2, n, y0)
    } else {
        let ratio = g.scaled(1.0 / r, n);
        asinh(g, ratio)
    };
    let t2 = g.unary(Unary::Square, theta);
    let arg = g.scaled(-sigma, t2);
    let sh = g.unary(Unary::Shc, arg);
    ys.map(|c| g.div(c, sh))
}

/// The point `q` (normal coordinates) moved back by the translation `v`
/// of the space of curvature `k`: `log(T(-v) exp(q))`, in expressions.
/// How many arguments a builtin takes, at least and at most.
fn builtin_arity(name: &str) -> (usize, usize) {
    match name {
        "atan2" | "pow" | "dot" | "cross" | "mod" | "step" => (2, 2),
        "min" | "max" => (2, usize::MAX),
        "union" | "intersection" | "difference" => (1, usize::MAX),
        "clamp" | "smin" | "smoothstep" | "mix" | "rgb" => (3, 3),
        _ => (1, 1),
    }
}

/// `(sin, cos)` of an angle in degrees, exact at quarter turns (as solids'
/// rotations are).
fn quarter_exact_sin_cos(degrees: f64) -> (f64, f64) {
    match degrees.rem_euclid(360.0) {
        0.0 => (0.0, 1.0),
        90.0 => (1.0, 0.0),
        180.0 => (0.0, -1.0),
        270.0 => (-1.0, 0.0),
        _ => degrees.to_radians().sin_cos(),
    }
}

pub(crate) fn translated_back(
    g: &mut Graph,
    k: &crate::space::Curvature,
    q: [NodeId; 3],
    v: DVec3,
) -> [NodeId; 3] {
    let (sigma, r) = (k.sign(), k.radius());
    let (x0, xs, _) = model_point(g, q, sigma, r);
    let x = [x0, xs[0], xs[1], xs[2]];
    let m = k.translation_matrix(-v);
    let y: Vec<NodeId> = (0..4)
        .map(|i| {
            let row = m.row(i).to_array();
            let mut acc: Option<NodeId> = None;
            for j in 0..4 {
                if row[j] != 0.0 {
                    let term = g.scaled(row[j], x[j]);
                    acc = Some(match acc {
                        Some(a) => g.add(a, term),
                        None => term,
                    });
                }
            }
            acc.unwrap_or_else(|| g.constant(0.0))
        })
        .collect();
    normal_coordinates(g, y[0], [y[1], y[2], y[3]], sigma, r)
}
