//! The abstract syntax tree: what the user wrote, with a byte span on every
//! node, before any name is resolved or any value checked.
//!
//! Input: built by [`crate::syntax`] from source text.
//! Output: consumed by [`crate::compile`], which turns it into a checked
//! scene. Nothing here knows about pest.

use crate::diagnostic::Span;

/// A parsed scene file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct File {
    /// The top-level items in source order. Order matters only for `let`, whose
    /// value may use the constants defined before it; shapes may be used anywhere.
    pub items: Vec<Item>,
}

/// One top-level item: a definition, an object to draw or a directive.
#[derive(Debug, Clone, PartialEq)]
pub enum Item {
    /// `import "lib.nes"`: the definitions of another file.
    Import(ImportItem),
    /// `let r = 1.5`: a named constant.
    Let(LetItem),
    /// `shape ring(R, r) = ...`: a named implicit function of `x`, `y`, `z`.
    Shape(ShapeItem),
    /// `object sphere(1) { colour red }`: something to draw.
    Object(ObjectItem),
    /// Any other name at the top level: `camera { ... }`, `ambient 0.1`, ...
    Directive(Directive),
}

/// A name as written, with where it was written: the name of a definition,
/// parameter, property, directive or call.
#[derive(Debug, Clone, PartialEq)]
pub struct Ident {
    /// The name's text, exactly as in the source (case-sensitive).
    pub name: String,
    /// Where the name is, for diagnostics.
    pub span: Span,
}

/// `let NAME = VALUE`, e.g. `let centre = (2, 0, r)`.
#[derive(Debug, Clone, PartialEq)]
pub struct LetItem {
    /// The constant's name.
    pub name: Ident,
    /// The value: a number, vector or colour; it may use earlier constants but
    /// not `x`, `y`, `z` (the compiler checks).
    pub value: Expr,
    /// From `let` to the end of the value.
    pub span: Span,
}

/// `shape NAME(PARAMS) = BODY`, e.g. `shape ball(r: positive) = x^2 + y^2 +
/// z^2 - r^2`: the surface is where the body is zero, negative inside.
#[derive(Debug, Clone, PartialEq)]
pub struct ShapeItem {
    /// The shape's name; it replaces a prelude shape of the same name.
    pub name: Ident,
    /// The parameters in order; empty both for `shape s = ...` and for
    /// `shape s() = ...`.
    pub params: Vec<Param>,
    /// The body, an expression of `x`, `y`, `z`, `p` and the parameters.
    pub body: Expr,
    /// Written with `fn` rather than `shape`: the same definition, which
    /// may give a vector or a condition as well as a number.
    pub function: bool,
    /// From `shape` to the end of the body.
    pub span: Span,
}

/// One parameter of a shape: `r` or `r: positive`.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    /// The parameter's name, used as a variable in the body.
    pub name: Ident,
    /// The declared kind (`positive`, `vector`, ...), if any.
    pub kind: Option<Ident>,
}

/// `object SOLID { PROPERTIES }`, e.g.
/// `object sphere(1) translate (0, 0, 1) { colour red }`.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectItem {
    /// What to draw, with the transforms written right after it.
    pub solid: Solid,
    /// The block's properties in order (`colour`, `translate`, `rotate`,
    /// `scale`); empty when no block was written.
    pub properties: Vec<Property>,
    /// From `object` to the end of the block (or of the solid if none).
    pub span: Span,
}

/// The words that open an item other than a directive.
pub const ITEM_KEYWORDS: [&str; 5] = ["import", "let", "shape", "fn", "object"];

/// `import "lib.nes"`.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportItem {
    /// The path as written, without its quotes.
    pub path: String,
    /// The quoted path.
    pub path_span: Span,
    /// From `import` to the closing quote.
    pub span: Span,
}

/// What a directive is written with after its name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DirectiveForm {
    /// A block of properties: `camera { position (1, 2, 3) }`.
    Block,
    /// A value alone: `ambient 0.1`.
    Value,
    /// A value with an optional block: `space torus { wraps 9 }`.
    ValueAndBlock,
}

/// One directive the language has: **the one table** the parser's error
/// recovery and the compiler's checks (unknown, repeated, wrongly written,
/// missing a value) all read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DirectiveSpec {
    /// The directive's name.
    pub name: &'static str,
    /// What follows the name.
    pub form: DirectiveForm,
    /// Whether a scene may give it more than once.
    pub repeatable: bool,
    /// How it is written, for hints.
    pub example: &'static str,
}

/// Every directive, in the order the docs list them.
pub const DIRECTIVES: [DirectiveSpec; 6] = [
    DirectiveSpec {
        name: "camera",
        form: DirectiveForm::Block,
        repeatable: false,
        example: "camera { position (-6, 0, 2)  look_at (0, 0, 0) }",
    },
    DirectiveSpec {
        name: "light",
        form: DirectiveForm::Block,
        repeatable: true,
        example: "light { position (-4, -3, 5) }",
    },
    DirectiveSpec {
        name: "space",
        form: DirectiveForm::ValueAndBlock,
        repeatable: false,
        example: "space euclidean",
    },
    DirectiveSpec {
        name: "ambient",
        form: DirectiveForm::Value,
        repeatable: false,
        example: "ambient 0.1",
    },
    DirectiveSpec {
        name: "background",
        form: DirectiveForm::Value,
        repeatable: false,
        example: "background black",
    },
    DirectiveSpec {
        name: "render",
        form: DirectiveForm::Block,
        repeatable: false,
        example: "render { method auto }",
    },
];

/// The directive named `name`, if the language has one.
pub fn directive(name: &str) -> Option<&'static DirectiveSpec> {
    DIRECTIVES.iter().find(|d| d.name == name)
}

/// `name [value] [{ properties }]` at the top level.
#[derive(Debug, Clone, PartialEq)]
pub struct Directive {
    /// The directive's name; [`directive`] says whether it exists.
    pub name: Ident,
    /// The value after the name, as in `ambient 0.1` or `space torus`; `None`
    /// when none was written.
    pub value: Option<Expr>,
    /// The `{ ... }` block after the value, if one was written.
    pub block: Option<Block>,
    /// From the name to the end of the value or block.
    pub span: Span,
}

/// A `{ name value  name value ... }` block of a directive.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    /// The properties in the order written (a `;` may end each).
    pub properties: Vec<Property>,
    /// From `{` to `}`.
    pub span: Span,
}

/// `name value [about axis]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Property {
    /// The property's name, e.g. `position`; the compiler decides which exist.
    pub name: Ident,
    /// The value after the name.
    pub value: Expr,
    /// The axis after `about`, as in `rotate 30 about z`; only `rotate` may have
    /// one (the compiler reports it anywhere else).
    pub about: Option<Expr>,
    /// From the name to the end of the value (or of the axis).
    pub span: Span,
}

/// How a CSG solid combines its children.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CsgOp {
    /// `union(a, b, ...)`: inside any child (`min` of the functions).
    Union,
    /// `intersection(a, b, ...)`: inside every child (`max`).
    Intersection,
    /// `difference(a, b, ...)`: inside the first, outside the rest
    /// (`max(a, -b, ...)`).
    Difference,
}

/// Which transform a [`Transform`] applies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TransformOp {
    /// `translate V`: move by the vector V.
    Translate,
    /// `rotate DEGREES about AXIS`: rotate by an angle in degrees.
    Rotate,
    /// `scale S`: scale by a number or a vector of per-axis factors.
    Scale,
}

/// A transform written after a solid: `translate (0, 0, 1)`,
/// `rotate 30 about z`, `scale 2`.
#[derive(Debug, Clone, PartialEq)]
pub struct Transform {
    /// Which transform.
    pub op: TransformOp,
    /// The amount: a vector, an angle in degrees or a scale factor.
    pub value: Expr,
    /// The axis after `about`, as in `rotate 30 about z`; required by `rotate`
    /// and an error on the others (the compiler checks).
    pub about: Option<Expr>,
    /// From the transform's keyword to the end of its value (or axis).
    pub span: Span,
}

/// A solid: a shape or CSG combination with the transforms written after
/// it, e.g. `union(sphere(1), cube(0.8)) rotate 45 about z`.
#[derive(Debug, Clone, PartialEq)]
pub struct Solid {
    /// The shape or combination itself.
    pub kind: SolidKind,
    /// Applied in the order written, after the solid itself is built.
    pub transforms: Vec<Transform>,
    /// From the start of the solid to the end of its last transform.
    pub span: Span,
}

/// What a [`Solid`] is before its transforms.
#[derive(Debug, Clone, PartialEq)]
pub enum SolidKind {
    /// A shape by name; `args` is `None` when no parentheses were written.
    Shape {
        /// The shape's name, resolved by the compiler among the scene's shapes
        /// and the prelude's.
        name: Ident,
        /// The arguments, in order, between the parentheses.
        args: Option<Vec<Expr>>,
    },
    /// Any other formula of x, y, z drawn as it stands:
    /// `object sphere(1) + 0.1 * sin(9 * x)`.
    Formula(Expr),
    /// `union(...)`, `intersection(...)` or `difference(...)` of solids.
    Csg {
        /// Which combination.
        op: CsgOp,
        /// The combined solids in order (at least one; for `difference`, the
        /// first is kept and the rest cut away).
        children: Vec<Solid>,
    },
}

/// An infix operator. Precedence, lowest first: `+ -`, `* /`, unary `-`,
/// `^`, `.x`; all left-associative except `^`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinaryOp {
    /// `a + b`: numbers with numbers, vectors with vectors.
    Add,
    /// `a - b`: numbers with numbers, vectors with vectors.
    Sub,
    /// `a * b`: numbers, or a number and a vector in either order.
    Mul,
    /// `a / b`: numbers, or a vector divided by a number.
    Div,
    /// `a ^ b`: power, right-associative (`2^3^2` is `2^9`) and binding tighter
    /// than unary minus (`-x^2` is `-(x^2)`).
    Pow,
    /// `a < b`: a condition.
    Less,
    /// `a <= b`.
    LessOrEqual,
    /// `a > b`.
    Greater,
    /// `a >= b`.
    GreaterOrEqual,
    /// `a == b`: parsed so that its diagnostic can explain why nes has none.
    Equal,
    /// `a != b`: likewise.
    NotEqual,
    /// `a and b` of two conditions.
    And,
    /// `a or b` of two conditions.
    Or,
}

/// What an aggregate combines its terms with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AggregateOp {
    /// `sum(i in ..., term)`.
    Sum,
    /// `product(...)`.
    Product,
    /// `min(...)`: the union of shapes.
    Min,
    /// `max(...)`: their intersection.
    Max,
}

impl AggregateOp {
    /// The name as written.
    pub fn name(self) -> &'static str {
        match self {
            AggregateOp::Sum => "sum",
            AggregateOp::Product => "product",
            AggregateOp::Min => "min",
            AggregateOp::Max => "max",
        }
    }
}

/// What an aggregate's name runs over.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// `a..b` (without `b`) or `a..=b` (with it): whole numbers.
    Range {
        /// The first number.
        from: Box<Expr>,
        /// The end.
        to: Box<Expr>,
        /// Whether `to` itself is taken (`..=`).
        inclusive: bool,
    },
    /// A list, written out or named by a `let`.
    List(Box<Expr>),
}

/// An expression, with the span of its text.
#[derive(Debug, Clone, PartialEq)]
pub struct Expr {
    /// What the expression is.
    pub kind: ExprKind,
    /// The expression's text; a parenthesised expression keeps the span of its
    /// contents, without the parentheses.
    pub span: Span,
}

/// The forms an [`Expr`] takes.
#[derive(Debug, Clone, PartialEq)]
pub enum ExprKind {
    /// A number literal: `12`, `0.5`, `.5`, `1e-6`. A literal too large for an
    /// `f64` is infinite.
    Number(f64),
    /// An sRGB colour literal, `#rrggbb`.
    Colour([u8; 3]),
    /// A name used as a value: a `let` constant, a shape parameter, `x`, `y`,
    /// `z`, `p`, `pi`, `tau`, `e`, `time`, `frame` or a named colour such as
    /// `red`; a shape without parameters may also be used this way (`heart`).
    Variable(String),
    /// `name(args)`: a builtin function (`sin`, `min`, `rgb`, ...) or a shape
    /// evaluated at the current point (`sphere(1)`).
    Call {
        /// The function's or shape's name.
        name: Ident,
        /// The arguments in order (possibly none).
        args: Vec<Expr>,
    },
    /// `(a, b, c)`: a parenthesised list with at least one comma. The compiler
    /// accepts it only as a vector of three numbers.
    Tuple(Vec<Expr>),
    /// `-a`: negation.
    Neg(Box<Expr>),
    /// `a OP b`: the operator, then the left and right operands.
    Binary(BinaryOp, Box<Expr>, Box<Expr>),
    /// `.x`, `.y` or `.z` (0, 1, 2) of a vector.
    Component(Box<Expr>, usize),
    /// `not c` of a condition.
    Not(Box<Expr>),
    /// `if c then a else b`.
    If {
        /// The condition.
        condition: Box<Expr>,
        /// The value where it holds.
        then: Box<Expr>,
        /// The value elsewhere.
        otherwise: Box<Expr>,
    },
    /// `let name = value in body`.
    Let {
        /// The local name.
        name: Ident,
        /// Its value, lowered once.
        value: Box<Expr>,
        /// Where the name is in scope.
        body: Box<Expr>,
    },
    /// `e at point`: `e` with `x, y, z` (and `p`) taken from `point`.
    At(Box<Expr>, Box<Expr>),
    /// `e translate v rotate a about axis ...`: `e` moved as a solid is.
    Moved(Box<Expr>, Vec<Transform>),
    /// `[a, b, c]`.
    List(Vec<Expr>),
    /// `list[i]`.
    Index(Box<Expr>, Box<Expr>),
    /// `sum(i in 0..5, term)` and its kin.
    Aggregate {
        /// How the terms combine.
        op: AggregateOp,
        /// The name each term sees.
        name: Ident,
        /// What the name runs over.
        source: Source,
        /// The term.
        body: Box<Expr>,
    },
}

impl Expr {
    /// The expressions written directly inside this one, in source order:
    /// operands, arguments, a transform's amount and axis, a range's ends.
    /// Walks that care about scope (a `let` or a sum's name hides others
    /// in its body) match `Let` and `Aggregate` themselves.
    pub fn children(&self) -> Vec<&Expr> {
        match &self.kind {
            ExprKind::Number(_) | ExprKind::Colour(_) | ExprKind::Variable(_) => Vec::new(),
            ExprKind::Call { args, .. } => args.iter().collect(),
            ExprKind::Tuple(xs) | ExprKind::List(xs) => xs.iter().collect(),
            ExprKind::Neg(a) | ExprKind::Component(a, _) | ExprKind::Not(a) => vec![a],
            ExprKind::Binary(_, a, b) | ExprKind::At(a, b) | ExprKind::Index(a, b) => vec![a, b],
            ExprKind::If {
                condition,
                then,
                otherwise,
            } => vec![condition, then, otherwise],
            ExprKind::Let { value, body, .. } => vec![value, body],
            ExprKind::Moved(a, transforms) => std::iter::once(&**a)
                .chain(
                    transforms
                        .iter()
                        .flat_map(|t| std::iter::once(&t.value).chain(&t.about)),
                )
                .collect(),
            ExprKind::Aggregate { source, body, .. } => {
                let mut out: Vec<&Expr> = match source {
                    Source::Range { from, to, .. } => vec![from, to],
                    Source::List(l) => vec![l],
                };
                out.push(body);
                out
            }
        }
    }

    /// Calls `f` on this expression and every one inside it, outermost first.
    pub fn visit<'e>(&'e self, f: &mut impl FnMut(&'e Expr)) {
        f(self);
        for c in self.children() {
            c.visit(f);
        }
    }
}
