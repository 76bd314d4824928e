//! The operations of the expression IR, each defined once.
//!
//! Input: an operation and its operands in any [`Number`] type. Output:
//! its value in that type. The graph folds constants with these
//! definitions and the tape evaluates with them, so **constant folding
//! and evaluation can never disagree**; a new operation is added here,
//! with its `Number` method, its derivative in `graph.rs` and its tape
//! opcode.

use super::number::Number;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Unary {
    Neg,
    Square,
    Abs,
    Sign,
    Sqrt,
    Exp,
    Ln,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Sinh,
    Cosh,
    Tanh,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Binary {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    Min,
    Max,
    Atan2,
}

impl Binary {
    /// Whether `a op b == b op a`, so operands may be put in one order.
    pub fn commutative(self) -> bool {
        matches!(self, Binary::Add | Binary::Mul | Binary::Min | Binary::Max)
    }
}

impl Unary {
    /// The operation in any number type: the one definition every
    /// evaluator (tapes, constant folding) uses.
    #[inline(always)]
    pub fn apply<N: Number>(self, a: N) -> N {
        match self {
            Unary::Neg => -a,
            Unary::Square => a.square(),
            Unary::Abs => a.abs(),
            Unary::Sign => a.sign(),
            Unary::Sqrt => a.sqrt(),
            Unary::Exp => a.exp(),
            Unary::Ln => a.ln(),
            Unary::Sin => a.sin(),
            Unary::Cos => a.cos(),
            Unary::Tan => a.tan(),
            Unary::Asin => a.asin(),
            Unary::Acos => a.acos(),
            Unary::Atan => a.atan(),
            Unary::Sinh => a.sinh(),
            Unary::Cosh => a.cosh(),
            Unary::Tanh => a.tanh(),
        }
    }
}

impl Binary {
    /// The operation in any number type: the one definition every
    /// evaluator (tapes, constant folding) uses.
    #[inline(always)]
    pub fn apply<N: Number>(self, a: N, b: N) -> N {
        match self {
            Binary::Add => a + b,
            Binary::Sub => a - b,
            Binary::Mul => a * b,
            Binary::Div => a / b,
            Binary::Pow => a.pow(b),
            Binary::Min => a.min(b),
            Binary::Max => a.max(b),
            Binary::Atan2 => a.atan2(b),
        }
    }
}
