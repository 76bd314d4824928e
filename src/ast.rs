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
    pub items: Vec<Item>,
}

#[derive(Debug, Clone, PartialEq)]
pub enum Item {
    Let(LetItem),
    Shape(ShapeItem),
    Object(ObjectItem),
    Directive(Directive),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Ident {
    pub name: String,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct LetItem {
    pub name: Ident,
    pub value: Expr,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ShapeItem {
    pub name: Ident,
    pub params: Vec<Param>,
    pub body: Expr,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    pub name: Ident,
    /// The declared kind (`positive`, `vector`, ...), if any.
    pub kind: Option<Ident>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ObjectItem {
    pub solid: Solid,
    pub properties: Vec<Property>,
    pub span: Span,
}

/// The words that open an item other than a directive.
pub const ITEM_KEYWORDS: [&str; 3] = ["let", "shape", "object"];

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
    pub name: Ident,
    pub value: Option<Expr>,
    pub block: Option<Block>,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    pub properties: Vec<Property>,
    pub span: Span,
}

/// `name value [about axis]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Property {
    pub name: Ident,
    pub value: Expr,
    pub about: Option<Expr>,
    pub span: Span,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CsgOp {
    Union,
    Intersection,
    Difference,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TransformOp {
    Translate,
    Rotate,
    Scale,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Transform {
    pub op: TransformOp,
    pub value: Expr,
    pub about: Option<Expr>,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Solid {
    pub kind: SolidKind,
    /// Applied in the order written, after the solid itself is built.
    pub transforms: Vec<Transform>,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub enum SolidKind {
    /// A shape by name; `args` is `None` when no parentheses were written.
    Shape {
        name: Ident,
        args: Option<Vec<Expr>>,
    },
    Csg {
        op: CsgOp,
        children: Vec<Solid>,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinaryOp {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub enum ExprKind {
    Number(f64),
    /// An sRGB colour literal, `#rrggbb`.
    Colour([u8; 3]),
    Variable(String),
    Call {
        name: Ident,
        args: Vec<Expr>,
    },
    Tuple(Vec<Expr>),
    Neg(Box<Expr>),
    Binary(BinaryOp, Box<Expr>, Box<Expr>),
    /// `.x`, `.y` or `.z` (0, 1, 2) of a vector.
    Component(Box<Expr>, usize),
}
