//! A compact, linear form of an expression graph for fast evaluation.
//!
//! Each instruction writes one slot; operands refer to earlier slots. The
//! tape holds only nodes reachable from its outputs, in dependency order,
//! so shared subexpressions are computed once per evaluation.

use super::graph::{Binary, Graph, Node, NodeId, Unary};
use super::number::Number;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Instr {
    Const(f64),
    Input(u8),
    Unary(Unary, u32),
    Binary(Binary, u32, u32),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Tape {
    instrs: Vec<Instr>,
    outputs: Vec<u32>,
}

impl Tape {
    /// A tape computing `roots` (in order) from `graph`.
    pub fn new(graph: &Graph, roots: &[NodeId]) -> Tape {
        let mut slot_of: Vec<Option<u32>> = vec![None; graph.len()];
        let mut instrs = Vec::new();
        // Iterative post-order walk, so that deep expressions cannot
        // overflow the stack.
        for &root in roots {
            let mut stack = vec![(root, false)];
            while let Some((id, expanded)) = stack.pop() {
                if slot_of[id.0 as usize].is_some() {
                    continue;
                }
                let node = graph.node(id);
                if !expanded {
                    stack.push((id, true));
                    match node {
                        Node::Unary(_, a) => stack.push((a, false)),
                        Node::Binary(_, a, b) => {
                            stack.push((b, false));
                            stack.push((a, false));
                        }
                        _ => {}
                    }
                    continue;
                }
                let slot = |n: NodeId| slot_of[n.0 as usize].expect("operand before use");
                let instr = match node {
                    Node::Const(bits) => Instr::Const(f64::from_bits(bits)),
                    Node::Input(i) => Instr::Input(i),
                    Node::Unary(op, a) => Instr::Unary(op, slot(a)),
                    Node::Binary(op, a, b) => Instr::Binary(op, slot(a), slot(b)),
                };
                slot_of[id.0 as usize] = Some(instrs.len() as u32);
                instrs.push(instr);
            }
        }
        let outputs = roots
            .iter()
            .map(|r| slot_of[r.0 as usize].unwrap())
            .collect();
        Tape { instrs, outputs }
    }

    /// The number of instructions: the work of one evaluation.
    pub fn len(&self) -> usize {
        self.instrs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.instrs.is_empty()
    }

    pub fn output_count(&self) -> usize {
        self.outputs.len()
    }

    /// Evaluate at `inputs` (x, y, z, ...), writing each output to `out`.
    /// `slots` is scratch space, reused between calls to avoid allocation.
    #[inline]
    pub fn eval_into<N: Number>(&self, inputs: &[N], slots: &mut Vec<N>, out: &mut [N]) {
        slots.clear();
        slots.reserve(self.instrs.len());
        for instr in &self.instrs {
            let v = match *instr {
                Instr::Const(c) => N::constant(c),
                Instr::Input(i) => inputs
                    .get(i as usize)
                    .copied()
                    .unwrap_or(N::constant(f64::NAN)),
                Instr::Unary(op, a) => unary(op, slots[a as usize]),
                Instr::Binary(op, a, b) => binary(op, slots[a as usize], slots[b as usize]),
            };
            slots.push(v);
        }
        for (o, &s) in out.iter_mut().zip(&self.outputs) {
            *o = slots[s as usize];
        }
    }

    /// Evaluate the first output.
    #[inline]
    pub fn eval<N: Number>(&self, inputs: &[N], slots: &mut Vec<N>) -> N {
        let mut out = [N::constant(0.0)];
        self.eval_into(inputs, slots, &mut out);
        out[0]
    }
}

#[inline]
fn unary<N: Number>(op: Unary, a: N) -> N {
    match op {
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

#[inline]
fn binary<N: Number>(op: Binary, a: N, b: N) -> N {
    match op {
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

/// Constant folding uses exactly the evaluator's arithmetic.
pub(crate) fn apply_unary(op: Unary, a: f64) -> f64 {
    unary(op, a)
}

pub(crate) fn apply_binary(op: Binary, a: f64, b: f64) -> f64 {
    binary(op, a, b)
}
