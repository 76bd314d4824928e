//! A compact, linear form of an expression graph for fast evaluation.
//!
//! Each instruction writes one slot; operands refer to earlier slots. The
//! tape holds only nodes reachable from its outputs, in dependency order,
//! so shared subexpressions are computed once per evaluation.

use super::graph::{Graph, Node, NodeId};
use super::op::{Binary, Noise, Unary};
use glam::DVec3;

use super::number::{LineForm, Number};

/// One operation: its opcode and operand slots. Constants and inputs are
/// not operations: they occupy the first slots, loaded before the first
/// operation runs, so the loop dispatches on operations alone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Step {
    pub(super) op: Op,
    pub(super) a: u32,
    pub(super) b: u32,
}

/// Every operation in one flat enum, so that evaluating a step is a
/// single jump: dispatch mispredictions are most of an interpreter's cost,
/// and a nested enum doubles them. Each arm only dispatches: what an
/// operation computes is defined once, in `op.rs`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Op {
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
    Shc,
    Chc,
    ShcSlope,
    Floor,
    Fract,
    SmoothStep,
    IntegerJumps,
    ZeroJumps,
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    Min,
    Max,
    Atan2,
    SmoothMin,
    When,
    Unless,
    /// The language's `if`: `When(c, a) + Unless(c, b)` fused into one
    /// step, `a` the condition's slot and `b` an index into
    /// `Tape::branches`, so that over an interval across the condition's
    /// boundary it gives the hull of the two branches (each half alone
    /// would add 0 to it).
    Select,
    /// `cx x + cy y + cz z + c0`, the coefficients at `affine[a]`: a whole
    /// linear subexpression (a transform folded into a shape) in one step.
    Affine,
    /// Gradient noise, its operation and three argument slots at
    /// `Tape::noise[a]`.
    Noise,
}

/// One term of an affine step, as every evaluator (and the description)
/// sums them: in order, the first starting the sum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum AffineTerm {
    /// Coordinate `i` (0, 1, 2: x, y, z) with coefficient one.
    Coordinate(usize),
    /// Coordinate `i` times a coefficient.
    Scaled(f64, usize),
    /// The constant.
    Constant(f64),
}

/// The terms of the affine form `[cx, cy, cz, c0]`: each coordinate whose
/// coefficient is not zero (not multiplied where it is one), then the
/// constant where it is not zero or nothing came before it; never empty.
/// One rule for the compiled code and the printed formula; the
/// interpreter writes it out (see `Tape::eval_into`), and a test holds the
/// compiled code to the interpreter's bits.
#[inline]
pub(super) fn affine_terms(form: [f64; 4]) -> impl Iterator<Item = AffineTerm> {
    let [cx, cy, cz, c0] = form;
    let any = cx != 0.0 || cy != 0.0 || cz != 0.0;
    [cx, cy, cz]
        .into_iter()
        .enumerate()
        .filter(|&(_, c)| c != 0.0)
        .map(|(i, c)| {
            if c == 1.0 {
                AffineTerm::Coordinate(i)
            } else {
                AffineTerm::Scaled(c, i)
            }
        })
        .chain((c0 != 0.0 || !any).then_some(AffineTerm::Constant(c0)))
}

/// Every one-operand operation (the compiled tapes' call codes index it).
pub(super) const UNARY_OPS: [Unary; 24] = [
    Unary::Neg,
    Unary::Square,
    Unary::Abs,
    Unary::Sign,
    Unary::Sqrt,
    Unary::Exp,
    Unary::Ln,
    Unary::Sin,
    Unary::Cos,
    Unary::Tan,
    Unary::Asin,
    Unary::Acos,
    Unary::Atan,
    Unary::Sinh,
    Unary::Cosh,
    Unary::Tanh,
    Unary::Shc,
    Unary::Chc,
    Unary::ShcSlope,
    Unary::Floor,
    Unary::Fract,
    Unary::SmoothStep,
    Unary::IntegerJumps,
    Unary::ZeroJumps,
];

/// Every two-operand operation (the compiled tapes' call codes index it).
pub(super) const BINARY_OPS: [Binary; 11] = [
    Binary::Add,
    Binary::Sub,
    Binary::Mul,
    Binary::Div,
    Binary::Pow,
    Binary::Min,
    Binary::Max,
    Binary::Atan2,
    Binary::SmoothMin,
    Binary::When,
    Binary::Unless,
];

impl Op {
    /// Whether the operation reads two operands.
    fn is_binary(self) -> bool {
        matches!(
            self,
            Op::Add
                | Op::Sub
                | Op::Mul
                | Op::Div
                | Op::Pow
                | Op::Min
                | Op::Max
                | Op::Atan2
                | Op::SmoothMin
                | Op::When
                | Op::Unless
        )
    }

    /// The builtin's name, for one-operand operations.
    fn name(self) -> &'static str {
        match self {
            Op::Abs => "abs",
            Op::Sign => "sign",
            Op::Sqrt => "sqrt",
            Op::Exp => "exp",
            Op::Ln => "ln",
            Op::Sin => "sin",
            Op::Cos => "cos",
            Op::Tan => "tan",
            Op::Asin => "asin",
            Op::Acos => "acos",
            Op::Atan => "atan",
            Op::Sinh => "sinh",
            Op::Cosh => "cosh",
            Op::Tanh => "tanh",
            Op::Shc => "shc",
            Op::Chc => "chc",
            Op::ShcSlope => "shc'",
            Op::Floor => "floor",
            Op::Fract => "fract",
            Op::SmoothStep => "smoothstep",
            Op::IntegerJumps => "jumps",
            Op::ZeroJumps => "jumps",
            _ => "?",
        }
    }

    fn unary(op: Unary) -> Op {
        match op {
            Unary::Neg => Op::Neg,
            Unary::Square => Op::Square,
            Unary::Abs => Op::Abs,
            Unary::Sign => Op::Sign,
            Unary::Sqrt => Op::Sqrt,
            Unary::Exp => Op::Exp,
            Unary::Ln => Op::Ln,
            Unary::Sin => Op::Sin,
            Unary::Cos => Op::Cos,
            Unary::Tan => Op::Tan,
            Unary::Asin => Op::Asin,
            Unary::Acos => Op::Acos,
            Unary::Atan => Op::Atan,
            Unary::Sinh => Op::Sinh,
            Unary::Cosh => Op::Cosh,
            Unary::Tanh => Op::Tanh,
            Unary::Shc => Op::Shc,
            Unary::Chc => Op::Chc,
            Unary::ShcSlope => Op::ShcSlope,
            Unary::Floor => Op::Floor,
            Unary::Fract => Op::Fract,
            Unary::SmoothStep => Op::SmoothStep,
            Unary::IntegerJumps => Op::IntegerJumps,
            Unary::ZeroJumps => Op::ZeroJumps,
        }
    }

    /// A one-operand operation's index in [`UNARY_OPS`], the compiled
    /// code's call code for it.
    pub(super) fn unary_code(self) -> Option<usize> {
        UNARY_OPS.iter().position(|&u| Op::unary(u) == self)
    }

    /// A two-operand operation's index in [`BINARY_OPS`].
    pub(super) fn binary_code(self) -> Option<usize> {
        BINARY_OPS.iter().position(|&b| Op::binary(b) == self)
    }

    fn binary(op: Binary) -> Op {
        match op {
            Binary::Add => Op::Add,
            Binary::Sub => Op::Sub,
            Binary::Mul => Op::Mul,
            Binary::Div => Op::Div,
            Binary::Pow => Op::Pow,
            Binary::Min => Op::Min,
            Binary::Max => Op::Max,
            Binary::Atan2 => Op::Atan2,
            Binary::SmoothMin => Op::SmoothMin,
            Binary::When => Op::When,
            Binary::Unless => Op::Unless,
        }
    }
}

/// A graph's expressions flattened into a list of instructions, evaluated
/// in any [`Number`] type: constants and inputs fill the first slots, then
/// each step writes one slot from earlier ones. Built by [`Tape::new`] from
/// the nodes reachable from its outputs; immutable and shared across threads.
#[derive(Debug, Clone, PartialEq)]
pub struct Tape {
    /// Slots `0..constants.len()`.
    pub(super) constants: Vec<f64>,
    /// Coefficients `[cx, cy, cz, c0]` of the affine steps.
    pub(super) affine: Vec<[f64; 4]>,
    /// The two branch slots of each [`Op::Select`] step.
    pub(super) branches: Vec<[u32; 2]>,
    /// The operation and argument slots of each [`Op::Noise`] step.
    pub(super) noise: Vec<(Noise, [u32; 3])>,
    /// Slots after the constants: which input each holds.
    pub(super) inputs: Vec<u8>,
    pub(super) steps: Vec<Step>,
    pub(super) outputs: Vec<u32>,
}

/// `order` with each cosine whose argument's sine is also computed moved
/// to just after that sine (its argument comes before both), so that one
/// step computes the pair: the gyroid's `sin(x) cos(y) + sin(y) cos(z) +
/// sin(z) cos(x)` reduces each coordinate once, not twice.
fn with_sines_beside_cosines(graph: &Graph, order: Vec<NodeId>) -> Vec<NodeId> {
    use std::collections::{HashMap, HashSet};
    let (mut sine_of, mut cosine_of) = (HashMap::new(), HashMap::new());
    for &id in &order {
        match graph.node(id) {
            Node::Unary(Unary::Sin, a) => sine_of.insert(a, id),
            Node::Unary(Unary::Cos, a) => cosine_of.insert(a, id),
            _ => None,
        };
    }
    let paired = |a: &NodeId| sine_of.contains_key(a) && cosine_of.contains_key(a);
    if !sine_of.keys().any(paired) {
        return order;
    }
    // The pair goes where the first of the two was: both read only their
    // argument, which comes before either.
    let mut placed = HashSet::new();
    let mut out = Vec::with_capacity(order.len());
    for id in order {
        match graph.node(id) {
            Node::Unary(Unary::Sin | Unary::Cos, a) if paired(&a) => {
                if placed.insert(a) {
                    out.push(sine_of[&a]);
                    out.push(cosine_of[&a]);
                }
            }
            _ => out.push(id),
        }
    }
    out
}

impl Tape {
    /// A tape computing `roots` (in order) from `graph`.
    pub fn new(graph: &Graph, roots: &[NodeId]) -> Tape {
        // Reachable nodes in dependency order, by an iterative post-order
        // walk, so that deep expressions cannot overflow the stack.
        let mut seen = vec![false; graph.len()];
        let mut order = Vec::new();
        for &root in roots {
            let mut stack = vec![(root, false)];
            while let Some((id, expanded)) = stack.pop() {
                if seen[id.0 as usize] && !expanded {
                    continue;
                }
                let node = graph.node(id);
                if !expanded {
                    seen[id.0 as usize] = true;
                    stack.push((id, true));
                    // Reversed, so the first operand is laid out first.
                    stack.extend(node.operands().rev().map(|a| (a, false)));
                    continue;
                }
                order.push(id);
            }
        }
        // Linear subexpressions of x, y, z become single affine steps; only
        // nodes that a non-linear node (or an output) uses get a slot.
        let linear = linear_forms(graph, &order);
        let is_affine = |id: NodeId| {
            linear[id.0 as usize].is_some()
                && matches!(graph.node(id), Node::Unary(..) | Node::Binary(..))
        };
        // `When(c, a) + Unless(c, b)`, the language's `if`, is one step.
        let select = |id: NodeId| -> Option<[NodeId; 3]> {
            let Node::Binary(Binary::Add, l, r) = graph.node(id) else {
                return None;
            };
            let halves = |w: NodeId, u: NodeId| match (graph.node(w), graph.node(u)) {
                (Node::Binary(Binary::When, c, a), Node::Binary(Binary::Unless, d, b))
                    if c == d =>
                {
                    Some([c, a, b])
                }
                _ => None,
            };
            halves(l, r).or_else(|| halves(r, l))
        };
        let mut needed = vec![false; graph.len()];
        for &r in roots {
            needed[r.0 as usize] = true;
        }
        for &id in order.iter().rev() {
            if !needed[id.0 as usize] || is_affine(id) {
                continue;
            }
            if let Some(operands) = select(id) {
                for n in operands {
                    needed[n.0 as usize] = true;
                }
                continue;
            }
            for a in graph.node(id).operands() {
                needed[a.0 as usize] = true;
            }
        }
        let order: Vec<NodeId> = order
            .into_iter()
            .filter(|id| needed[id.0 as usize])
            .collect();
        let order = with_sines_beside_cosines(graph, order);
        let mut affine = Vec::new();
        let mut branches = Vec::new();
        let mut noise = Vec::new();

        let mut slot_of: Vec<u32> = vec![u32::MAX; graph.len()];
        let mut constants = Vec::new();
        let mut inputs = Vec::new();
        for &id in &order {
            if let Node::Const(bits) = graph.node(id) {
                slot_of[id.0 as usize] = constants.len() as u32;
                constants.push(f64::from_bits(bits));
            }
        }
        for &id in &order {
            if let Node::Input(i) = graph.node(id) {
                slot_of[id.0 as usize] = (constants.len() + inputs.len()) as u32;
                inputs.push(i);
            }
        }
        let mut steps = Vec::new();
        let first = (constants.len() + inputs.len()) as u32;
        for (order_index, &id) in order.iter().enumerate() {
            let slot = |n: NodeId| {
                let s = slot_of[n.0 as usize];
                debug_assert!(s != u32::MAX, "operand before use");
                s
            };
            if is_affine(id) {
                let form = linear[id.0 as usize].expect("linear");
                slot_of[id.0 as usize] = first + steps.len() as u32;
                steps.push(Step {
                    op: Op::Affine,
                    a: affine.len() as u32,
                    b: 0,
                });
                affine.push(form);
                continue;
            }
            if let Some([c, a, b]) = select(id) {
                let step = Step {
                    op: Op::Select,
                    a: slot(c),
                    b: branches.len() as u32,
                };
                branches.push([slot(a), slot(b)]);
                slot_of[id.0 as usize] = first + steps.len() as u32;
                steps.push(step);
                continue;
            }
            let step = match graph.node(id) {
                // A sine followed by the cosine of its argument: one
                // step computes both (see `with_sines_beside_cosines`).
                Node::Unary(op @ (Unary::Sin | Unary::Cos), a) => {
                    let paired = |k: usize, want: Unary| {
                        order
                            .get(k)
                            .is_some_and(|&n| graph.node(n) == Node::Unary(want, a))
                    };
                    let at = order_index;
                    let pair = match op {
                        Unary::Sin => paired(at + 1, Unary::Cos),
                        _ => at > 0 && paired(at - 1, Unary::Sin),
                    };
                    Step {
                        op: Op::unary(op),
                        a: slot(a),
                        b: pair as u32,
                    }
                }
                Node::Unary(op, a) => Step {
                    op: Op::unary(op),
                    a: slot(a),
                    b: 0,
                },
                Node::Binary(op, a, b) => Step {
                    op: Op::binary(op),
                    a: slot(a),
                    b: slot(b),
                },
                Node::Noise(op, args) => {
                    noise.push((op, args.map(slot)));
                    Step {
                        op: Op::Noise,
                        a: (noise.len() - 1) as u32,
                        b: 0,
                    }
                }
                _ => continue,
            };
            slot_of[id.0 as usize] = first + steps.len() as u32;
            steps.push(step);
        }
        let outputs = roots.iter().map(|r| slot_of[r.0 as usize]).collect();
        Tape {
            constants,
            affine,
            branches,
            noise,
            inputs,
            steps,
            outputs,
        }
    }

    /// The numbers the tape uses, after constant folding.
    pub fn constants(&self) -> &[f64] {
        &self.constants
    }

    /// The number of instructions (constants, inputs and operations): the
    /// work of one evaluation.
    pub fn len(&self) -> usize {
        self.constants.len() + self.inputs.len() + self.steps.len()
    }

    /// The number of operations alone.
    pub fn operations(&self) -> usize {
        self.steps.len()
    }

    /// The slots holding operations' results, in order: after an
    /// evaluation into `slots`, `slots[k]` for these `k` is each
    /// operation's value (constants and inputs come first).
    pub fn operation_slots(&self) -> std::ops::Range<usize> {
        let first = self.constants.len() + self.inputs.len();
        first..first + self.steps.len()
    }

    /// The slots an operation's slot reads (none for an affine step, which
    /// reads the coordinates directly).
    pub fn operands(&self, slot: usize) -> Vec<usize> {
        let first = self.constants.len() + self.inputs.len();
        let Some(step) = slot.checked_sub(first).and_then(|k| self.steps.get(k)) else {
            return Vec::new();
        };
        match step.op {
            Op::Affine => Vec::new(),
            Op::Noise => self.noise[step.a as usize].1.map(|s| s as usize).to_vec(),
            Op::Select => {
                let [a, b] = self.branches[step.b as usize];
                vec![step.a as usize, a as usize, b as usize]
            }
            op if op.is_binary() => vec![step.a as usize, step.b as usize],
            _ => vec![step.a as usize],
        }
    }

    /// The first operation that is not a finite number at `inputs` though
    /// its operands are: where a formula's NaN or infinity comes from (a
    /// square root of a negative number, a division by zero), written out
    /// as [`Tape::describe`] does, with its value.
    pub fn first_not_finite(&self, inputs: &[f64], limit: usize) -> Option<(String, f64)> {
        let mut slots = Vec::new();
        let mut out = vec![0.0; self.output_count()];
        self.eval_into(inputs, &mut slots, &mut out);
        self.operation_slots().find_map(|slot| {
            let v = slots[slot];
            let from_finite = self.operands(slot).iter().all(|&a| slots[a].is_finite());
            (!v.is_finite() && from_finite).then(|| (self.describe(slot, limit), v))
        })
    }

    /// Whether the tape reads input `slot` (x, y, z are 0, 1, 2).
    pub fn reads_input(&self, slot: u8) -> bool {
        self.inputs.contains(&slot)
            || (slot < 3 && self.affine.iter().any(|a| a[slot as usize] != 0.0))
    }

    /// The argument slots of each `noise` operation.
    pub fn noise_arguments(&self) -> Vec<[usize; 3]> {
        self.noise
            .iter()
            .map(|(_, a)| a.map(|s| s as usize))
            .collect()
    }

    /// Whether the expression a slot computes reads an operation no scene
    /// file can write (`shc`, `chc`, `shc'`): the curved spaces' builtins
    /// and the moves of a translated part compile to them, so
    /// [`Tape::describe`] of such a slot names functions a user never
    /// wrote.
    pub fn uses_internal_ops(&self, slot: usize) -> bool {
        let first = self.constants.len() + self.inputs.len();
        let mut seen = vec![false; self.steps.len()];
        let mut stack = vec![slot];
        while let Some(s) = stack.pop() {
            let Some(k) = s.checked_sub(first).filter(|&k| k < self.steps.len()) else {
                continue;
            };
            if std::mem::replace(&mut seen[k], true) {
                continue;
            }
            if matches!(self.steps[k].op, Op::Shc | Op::Chc | Op::ShcSlope) {
                return true;
            }
            stack.extend(self.operands(s));
        }
        false
    }

    /// The expression a slot computes, written in the scene language (with
    /// the object's transforms folded in, so x, y and z are the scene's
    /// coordinates), cut short with `...` past about `limit` characters.
    pub fn describe(&self, slot: usize, limit: usize) -> String {
        let mut out = String::new();
        self.write_slot(slot, limit, &mut out);
        without_outer_parentheses(&out).to_string()
    }

    /// The expression output `k` computes, as [`Tape::describe`] writes it.
    pub fn describe_output(&self, k: usize, limit: usize) -> String {
        self.describe(self.outputs[k] as usize, limit)
    }

    fn write_slot(&self, slot: usize, limit: usize, out: &mut String) {
        use std::fmt::Write;
        if out.len() > limit {
            out.push_str("...");
            return;
        }
        let number = |c: f64| {
            let t = format!("{c}");
            if t.len() > 8 {
                format!("{c:.4}")
            } else {
                t
            }
        };
        let first = self.constants.len() + self.inputs.len();
        if slot < self.constants.len() {
            out.push_str(&number(self.constants[slot]));
            return;
        }
        if slot < first {
            let i = self.inputs[slot - self.constants.len()];
            out.push_str(["x", "y", "z"].get(i as usize).unwrap_or(&"?"));
            return;
        }
        let Some(step) = self.steps.get(slot - first) else {
            out.push('?');
            return;
        };
        let (a, b) = (step.a as usize, step.b as usize);
        let infix = |out: &mut String, sign: &str| {
            out.push('(');
            self.write_slot(a, limit, out);
            out.push_str(sign);
            self.write_slot(b, limit, out);
            out.push(')');
        };
        let call = |out: &mut String, name: &str, args: &[usize]| {
            out.push_str(name);
            out.push('(');
            for (k, &x) in args.iter().enumerate() {
                if k > 0 {
                    out.push_str(", ");
                }
                let mut arg = String::new();
                self.write_slot(x, limit.saturating_sub(out.len()), &mut arg);
                out.push_str(without_outer_parentheses(&arg));
            }
            out.push(')');
        };
        match step.op {
            Op::Affine => {
                const NAMES: [&str; 3] = ["x", "y", "z"];
                out.push('(');
                for (k, term) in affine_terms(self.affine[step.a as usize]).enumerate() {
                    let term = match term {
                        AffineTerm::Coordinate(i) => NAMES[i].to_string(),
                        AffineTerm::Scaled(c, i) => format!("{}*{}", number(c), NAMES[i]),
                        AffineTerm::Constant(c) => number(c),
                    };
                    // `- 1`, not `+ -1`.
                    match (k, term.strip_prefix('-')) {
                        (0, _) => out.push_str(&term),
                        (_, Some(positive)) => write!(out, " - {positive}").unwrap_or(()),
                        (_, None) => write!(out, " + {term}").unwrap_or(()),
                    }
                }
                out.push(')');
            }
            Op::Neg => {
                out.push('-');
                self.write_slot(a, limit, out);
            }
            Op::Square => {
                // Infix steps and calls bring their own parentheses.
                let atom = a < first || !matches!(self.steps[a - first].op, Op::Neg | Op::Square);
                if !atom {
                    out.push('(');
                }
                self.write_slot(a, limit, out);
                if !atom {
                    out.push(')');
                }
                out.push_str("^2");
            }
            Op::Add => infix(out, " + "),
            Op::Sub => infix(out, " - "),
            Op::Mul => infix(out, "*"),
            Op::Div => infix(out, "/"),
            Op::Pow => infix(out, "^"),
            Op::Min => call(out, "min", &[a, b]),
            Op::Max => call(out, "max", &[a, b]),
            Op::Atan2 => call(out, "atan2", &[a, b]),
            Op::When => call(out, "when", &[a, b]),
            Op::Unless => call(out, "unless", &[a, b]),
            Op::Select => {
                let [t, e] = self.branches[b];
                out.push_str("(if ");
                self.write_slot(a, limit, out);
                out.push_str(" > 0 then ");
                self.write_slot(t as usize, limit, out);
                out.push_str(" else ");
                self.write_slot(e as usize, limit, out);
                out.push(')');
            }
            Op::SmoothMin => {
                call(out, "smin", &[a, b]);
                out.insert_str(out.len() - 1, ", 1");
            }
            Op::Noise => {
                let (op, args) = self.noise[a];
                // A partial derivative is written d[i,j,k]noise: the
                // gradient tape holds them, no scene file does.
                let name = match op.partial {
                    [0, 0, 0] => "noise".to_string(),
                    [i, j, k] => format!("d[{i},{j},{k}]noise"),
                };
                call(out, &name, &args.map(|s| s as usize));
            }
            op => call(out, op.name(), &[a]),
        }
    }

    /// Whether any operation may jump (`floor`, `fract`, `sign`, `if`): a
    /// change of sign of such a function need not be a root.
    pub fn has_jumps(&self) -> bool {
        self.steps.iter().any(|s| {
            matches!(
                s.op,
                Op::Floor | Op::Fract | Op::Sign | Op::When | Op::Unless | Op::Select
            )
        })
    }

    /// Whether the function may jump where only an unbounded slope shows
    /// it: across `atan2`'s branch cut (the negative x axis), or across a
    /// pole (a division, `tan`, a power, `ln`) under a function that
    /// bounds it (`atan(y / x)` at x = 0), where its range stays bounded.
    pub fn has_slope_jumps(&self) -> bool {
        self.steps
            .iter()
            .any(|s| matches!(s.op, Op::Atan2 | Op::Div | Op::Tan | Op::Pow | Op::Ln))
    }

    /// Whether the tape has a `min`, `max` or `smin` step.
    pub fn has_choices(&self) -> bool {
        self.steps
            .iter()
            .any(|s| matches!(s.op, Op::Min | Op::Max | Op::SmoothMin))
    }

    /// Whether the tape has no instruction at all.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// How many values one evaluation produces: the number of roots it was
    /// built from (1 for a value tape, 4 for a gradient tape).
    pub fn output_count(&self) -> usize {
        self.outputs.len()
    }

    /// Evaluate at `inputs` (x, y, z, ...), writing each output to `out`.
    /// `slots` is scratch space, reused between calls to avoid allocation.
    #[inline]
    pub fn eval_into<N: Number>(&self, inputs: &[N], slots: &mut Vec<N>, out: &mut [N]) {
        let coordinate = |i: usize| inputs.get(i).copied().unwrap_or(N::constant(f64::NAN));
        let slots = self.run(
            slots,
            |j| coordinate(self.inputs[j] as usize),
            |k| {
                // `affine_terms`'s rule written out: on this hot path the
                // iterator form cost 16% more instructions on
                // examples/implicit.nes (callgrind, 349 M -> 404 M).
                let [cx, cy, cz, c0] = self.affine[k];
                let mut sum: Option<N> = None;
                for (i, c) in [cx, cy, cz].into_iter().enumerate() {
                    if c != 0.0 {
                        let term = if c == 1.0 {
                            coordinate(i)
                        } else {
                            N::constant(c) * coordinate(i)
                        };
                        sum = Some(match sum {
                            Some(s) => s + term,
                            None => term,
                        });
                    }
                }
                match sum {
                    Some(s) if c0 != 0.0 => s + N::constant(c0),
                    Some(s) => s,
                    None => N::constant(c0),
                }
            },
        );
        for (o, &s) in out.iter_mut().zip(&self.outputs) {
            *o = slots[s as usize];
        }
    }

    /// What each coordinate the tape reads, and each of its affine steps,
    /// is along the line `start + u direction` for `|u| <= reach`: a
    /// linear function of `u` (see [`LineForm`]), written to `forms` in
    /// the order [`Tape::eval_on_line`] reads them. Computed once per
    /// line, it turns every affine step into one multiply-add, and keeps
    /// interval evaluation over a stretch of the line free of the
    /// overestimate that treating x, y and z as independent ranges adds.
    pub fn line_forms(
        &self,
        start: DVec3,
        direction: DVec3,
        reach: f64,
        forms: &mut Vec<LineForm>,
    ) {
        self.near_line_forms(start, direction, reach, DVec3::ZERO, DVec3::ZERO, forms);
    }

    /// [`Tape::line_forms`] for a path that stays within `deviation`
    /// (per coordinate) of the line `start + u direction` for `|u| <=
    /// reach`, its velocity within `slope_deviation` of `direction`: a
    /// curved path's tangent line over a short piece.
    pub fn near_line_forms(
        &self,
        start: DVec3,
        direction: DVec3,
        reach: f64,
        deviation: DVec3,
        slope_deviation: DVec3,
        forms: &mut Vec<LineForm>,
    ) {
        // Generous: covers computing alpha and beta, the rounding of the
        // points `start + u direction` that point evaluations use, and
        // that of `alpha + beta u` and of moving it outward.
        const SLACK: f64 = 8.0 * f64::EPSILON;
        let (o, d) = (start.to_array(), direction.to_array());
        let (e, se) = (deviation.to_array(), slope_deviation.to_array());
        let form = |c: [f64; 4]| {
            let (mut alpha, mut beta) = (c[3], 0.0);
            let (mut size_o, mut size_d) = (c[3].abs(), 0.0);
            let (mut off, mut slope_off) = (0.0, 0.0);
            for i in 0..3 {
                if c[i] != 0.0 {
                    alpha += c[i] * o[i];
                    beta += c[i] * d[i];
                    size_o += (c[i] * o[i]).abs();
                    size_d += (c[i] * d[i]).abs();
                    off += c[i].abs() * e[i];
                    slope_off += c[i].abs() * se[i];
                }
            }
            LineForm {
                alpha,
                beta,
                err: (size_o + size_d * reach) * SLACK + off * (1.0 + SLACK) + f64::MIN_POSITIVE,
                slope_err: size_d * SLACK + slope_off * (1.0 + SLACK) + f64::MIN_POSITIVE,
            }
        };
        forms.clear();
        forms.extend(self.inputs.iter().map(|&i| match i {
            0..=2 => {
                let mut c = [0.0; 4];
                c[i as usize] = 1.0;
                form(c)
            }
            _ => LineForm {
                alpha: f64::NAN,
                ..LineForm::default()
            },
        }));
        forms.extend(self.affine.iter().map(|&c| form(c)));
    }

    /// Evaluate the first output along a line, at the line's parameter
    /// `u`, with `forms` from [`Tape::line_forms`] for that line. The same
    /// arithmetic as [`Tape::eval`] at the line's points, but every affine
    /// step is `alpha + beta u`.
    #[inline]
    pub fn eval_on_line<N: Number>(&self, forms: &[LineForm], u: N, slots: &mut Vec<N>) -> N {
        let inputs = self.inputs.len();
        let slots = self.run(
            slots,
            |j| N::along(u, &forms[j]),
            |k| N::along(u, &forms[inputs + k]),
        );
        slots[self.outputs[0] as usize]
    }

    /// The first output with input slot `j` given by `input(i)`, where
    /// `i` is the input it holds (0, 1, 2 for x, y, z), and each affine
    /// step by `affine(c)` from its form `c = [cx, cy, cz, c0]`: for
    /// number types whose affine values are best made whole (a bound over
    /// a box takes an affine step's exact range there).
    pub(super) fn eval_with_forms<N: Number>(
        &self,
        slots: &mut Vec<N>,
        input: impl Fn(u8) -> N,
        affine: impl Fn(&[f64; 4]) -> N,
    ) -> N {
        let slots = self.run(
            slots,
            |j| input(self.inputs[j]),
            |k| affine(&self.affine[k]),
        );
        slots[self.outputs[0] as usize]
    }

    /// The evaluator: constants and inputs into the first slots, then one
    /// slot per step. `input(j)` is the tape's j-th input and `affine(k)`
    /// the value of its k-th affine form.
    #[inline(always)]
    fn run<'s, N: Number>(
        &self,
        slots: &'s mut Vec<N>,
        input: impl Fn(usize) -> N,
        affine: impl Fn(usize) -> N,
    ) -> &'s [N] {
        let base = self.constants.len() + self.inputs.len();
        let len = base + self.steps.len();
        // Every slot is written by index into a buffer sized once per
        // length (callers keep one buffer per tape kind): no capacity
        // check per step.
        if slots.len() != len {
            slots.clear();
            slots.resize(len, N::constant(0.0));
        }
        let slots = &mut slots[..];
        for (slot, &c) in slots.iter_mut().zip(&self.constants) {
            *slot = N::constant(c);
        }
        for (j, slot) in slots[self.constants.len()..base].iter_mut().enumerate() {
            *slot = input(j);
        }
        self.run_steps(0, slots, &affine);
        slots
    }

    /// Steps `from..` of [`Tape::run`], into `slots`.
    #[inline(always)]
    fn run_steps<N: Number>(&self, from: usize, slots: &mut [N], affine: &impl Fn(usize) -> N) {
        let base = self.constants.len() + self.inputs.len();
        for (k, step) in self.steps.iter().enumerate().skip(from) {
            let v = if step.op == Op::Affine {
                affine(step.a as usize)
            } else {
                let a = slots[step.a as usize];
                let b = || slots[step.b as usize];
                match step.op {
                    // A paired sine also writes the cosine's slot, next.
                    Op::Sin if step.b == 1 => {
                        let (sin, cos) = a.sin_and_cos();
                        slots[base + k + 1] = cos;
                        sin
                    }
                    Op::Cos if step.b == 1 => continue,
                    Op::Neg => Unary::Neg.apply(a),
                    Op::Square => Unary::Square.apply(a),
                    Op::Abs => Unary::Abs.apply(a),
                    Op::Sign => Unary::Sign.apply(a),
                    Op::Sqrt => Unary::Sqrt.apply(a),
                    Op::Exp => Unary::Exp.apply(a),
                    Op::Ln => Unary::Ln.apply(a),
                    Op::Sin => Unary::Sin.apply(a),
                    Op::Cos => Unary::Cos.apply(a),
                    Op::Tan => Unary::Tan.apply(a),
                    Op::Asin => Unary::Asin.apply(a),
                    Op::Acos => Unary::Acos.apply(a),
                    Op::Atan => Unary::Atan.apply(a),
                    Op::Sinh => Unary::Sinh.apply(a),
                    Op::Cosh => Unary::Cosh.apply(a),
                    Op::Tanh => Unary::Tanh.apply(a),
                    Op::Shc => Unary::Shc.apply(a),
                    Op::Chc => Unary::Chc.apply(a),
                    Op::ShcSlope => Unary::ShcSlope.apply(a),
                    Op::Floor => Unary::Floor.apply(a),
                    Op::Fract => Unary::Fract.apply(a),
                    Op::SmoothStep => Unary::SmoothStep.apply(a),
                    Op::IntegerJumps => Unary::IntegerJumps.apply(a),
                    Op::ZeroJumps => Unary::ZeroJumps.apply(a),
                    Op::Add => Binary::Add.apply(a, b()),
                    Op::Sub => Binary::Sub.apply(a, b()),
                    Op::Mul => Binary::Mul.apply(a, b()),
                    Op::Div => Binary::Div.apply(a, b()),
                    Op::Pow => Binary::Pow.apply(a, b()),
                    Op::Min => Binary::Min.apply(a, b()),
                    Op::Max => Binary::Max.apply(a, b()),
                    Op::Atan2 => {
                        let x = b();
                        if let Some(sides) = a.atan2_sides(x) {
                            self.fork(k, sides, slots, affine);
                            return;
                        }
                        Binary::Atan2.apply(a, x)
                    }
                    Op::SmoothMin => Binary::SmoothMin.apply(a, b()),
                    Op::When => Binary::When.apply(a, b()),
                    Op::Unless => Binary::Unless.apply(a, b()),
                    Op::Select => {
                        let [t, e] = self.branches[step.b as usize];
                        a.select(slots[t as usize], slots[e as usize])
                    }
                    Op::Noise => {
                        let (op, [x, y, z]) = self.noise[step.a as usize];
                        op.apply([slots[x as usize], slots[y as usize], slots[z as usize]])
                    }
                    Op::Affine => unreachable!("handled above"),
                }
            };
            slots[base + k] = v;
        }
    }

    /// The rest of the tape from step `k`, an atan2 across its branch
    /// cut, once with each side's values, every later slot the hull of
    /// both (see [`Number::atan2_sides`]).
    #[inline(never)]
    fn fork<N: Number>(
        &self,
        k: usize,
        (upper, lower): (N, N),
        slots: &mut [N],
        affine: &impl Fn(usize) -> N,
    ) {
        let at = self.constants.len() + self.inputs.len() + k;
        slots[at] = upper;
        self.run_steps(k + 1, slots, affine);
        let first: Vec<N> = slots[at..].to_vec();
        slots[at] = lower;
        self.run_steps(k + 1, slots, affine);
        for (slot, other) in slots[at..].iter_mut().zip(first) {
            *slot = slot.hull_with(other);
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

/// For each node of `order` (dependency order), its form `[cx, cy, cz, c0]`
/// if it is an affine function of x, y and z: sums, differences and
/// negations of such, and their products with or quotients by constants.
fn linear_forms(graph: &Graph, order: &[NodeId]) -> Vec<Option<[f64; 4]>> {
    let mut form: Vec<Option<[f64; 4]>> = vec![None; graph.len()];
    let constant = |f: [f64; 4]| (f[0] == 0.0 && f[1] == 0.0 && f[2] == 0.0).then_some(f[3]);
    let scale = |f: [f64; 4], k: f64| f.map(|c| c * k);
    for &id in order {
        let get = |n: NodeId| form[n.0 as usize];
        form[id.0 as usize] = match graph.node(id) {
            Node::Const(bits) => Some([0.0, 0.0, 0.0, f64::from_bits(bits)]),
            Node::Input(i) if i < 3 => {
                let mut f = [0.0; 4];
                f[i as usize] = 1.0;
                Some(f)
            }
            Node::Input(_) => None,
            Node::Unary(Unary::Neg, a) => get(a).map(|f| scale(f, -1.0)),
            Node::Unary(..) | Node::Noise(..) => None,
            Node::Binary(op, a, b) => match (op, get(a), get(b)) {
                (Binary::Add, Some(f), Some(g)) => Some(std::array::from_fn(|i| f[i] + g[i])),
                (Binary::Sub, Some(f), Some(g)) => Some(std::array::from_fn(|i| f[i] - g[i])),
                (Binary::Mul, Some(f), Some(g)) => match (constant(f), constant(g)) {
                    (Some(k), _) => Some(scale(g, k)),
                    (_, Some(k)) => Some(scale(f, k)),
                    _ => None,
                },
                (Binary::Div, Some(f), Some(g)) => constant(g)
                    .filter(|&k| k != 0.0 && k.is_finite())
                    .map(|k| scale(f, 1.0 / k)),
                _ => None,
            },
        }
        // Only finite coefficients: an infinite or NaN one would turn
        // 0 * x into NaN where the written expression did not.
        .filter(|f| f.iter().all(|c| c.is_finite()));
    }
    form
}

/// `text` without one pair of parentheses around the whole of it (a call's
/// argument or a whole expression needs none), else `text`.
pub fn without_outer_parentheses(text: &str) -> &str {
    let Some(inner) = text.strip_prefix('(').and_then(|t| t.strip_suffix(')')) else {
        return text;
    };
    let mut depth = 0usize;
    for c in inner.chars() {
        match c {
            '(' => depth += 1,
            ')' if depth == 0 => return text,
            ')' => depth -= 1,
            _ => {}
        }
    }
    inner
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::Interval;

    /// `(2x - y/4 + 3)^2 + sin(z)`: the linear part is one step, and the
    /// tape agrees with the formula in f64 and encloses it in intervals.
    #[test]
    fn linear_parts_become_one_affine_step() {
        let mut g = Graph::new();
        let (x, y, z) = (g.input(0), g.input(1), g.input(2));
        let two = g.constant(2.0);
        let four = g.constant(4.0);
        let three = g.constant(3.0);
        let a = g.binary(Binary::Mul, two, x);
        let b = g.binary(Binary::Div, y, four);
        let c = g.binary(Binary::Sub, a, b);
        let lin = g.binary(Binary::Add, c, three);
        let sq = g.unary(Unary::Square, lin);
        let s = g.unary(Unary::Sin, z);
        let f = g.binary(Binary::Add, sq, s);
        let tape = Tape::new(&g, &[f]);
        // affine, square, sin, add
        assert_eq!(tape.operations(), 4);
        let formula = |x: f64, y: f64, z: f64| (2.0 * x - y / 4.0 + 3.0).powi(2) + z.sin();
        let mut slots = Vec::new();
        for p in [[0.5, -1.0, 2.0], [-3.0, 0.25, 0.0], [1e3, -7.0, -1.0]] {
            let v = tape.eval(&p, &mut slots);
            let want = formula(p[0], p[1], p[2]);
            assert!(
                (v - want).abs() <= 1e-12 * want.abs().max(1.0),
                "{p:?}: {v} vs {want}"
            );
            let boxes = p.map(|c| Interval::new(c - 0.1, c + 0.1));
            let r = tape.eval(&boxes, &mut Vec::new());
            assert!(r.contains(want), "{p:?}: {want} outside {r:?}");
        }
    }
}
