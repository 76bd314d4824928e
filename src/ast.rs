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
