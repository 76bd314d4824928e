//! The expression graph: a DAG of operations with shared subexpressions.
//!
//! Nodes are hash-consed, so building the same subexpression twice yields
//! the same node. With simplification on, every constructor folds constants
//! and applies algebraic identities as the node is made, so derivatives and
//! substitutions built through the same constructors come out simplified.

use super::op::{Binary, Noise, Unary};

/// The hash map of graph building: nodes and node ids are hashed millions
/// of times when a large formula is compiled (a union of a hundred capsules
/// pruned per cell), where the standard SipHash cost a third of the
/// compile. foldhash is several times faster and still seeded per map.
pub type HashMap<K, V> = std::collections::HashMap<K, V, foldhash::fast::RandomState>;

/// A node of one [`Graph`]: an index into it, meaningless in any other graph.
/// Ids grow in creation order, so a node's operands have smaller ids.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(pub(crate) u32);

/// One operation of the expression DAG; operands are nodes of the same graph.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Node {
    /// The bits of an f64, so that nodes can be hashed.
    Const(u64),
    /// Input slot: 0, 1, 2 are x, y, z.
    Input(u8),
    /// `op(a)`.
    Unary(Unary, NodeId),
    /// `op(a, b)`, left operand first.
    Binary(Binary, NodeId, NodeId),
    /// Gradient noise (or a partial derivative of it) at `(a, b, c)`.
    Noise(Noise, [NodeId; 3]),
}

impl Node {
    /// The node's operands, in order (none for constants and inputs).
    pub fn operands(self) -> impl DoubleEndedIterator<Item = NodeId> {
        let (ids, n) = match self {
            Node::Const(_) | Node::Input(_) => ([NodeId(0); 3], 0),
            Node::Unary(_, a) => ([a, a, a], 1),
            Node::Binary(_, a, b) => ([a, b, b], 2),
            Node::Noise(_, args) => (args, 3),
        };
        ids.into_iter().take(n)
    }
}

/// Largest integer exponent compiled as a product chain.
const MAX_PRODUCT_POWER: i64 = 64;

/// An expression DAG of [`Node`]s, hash-consed so that equal subexpressions
/// are one node. The compiler builds each object's function here (as
/// written, [`Graph::unsimplified`]); [`crate::expr::Implicit::new`] copies it
/// into a simplifying graph, adds the symbolic gradient and compiles tapes.
#[derive(Debug, Clone)]
pub struct Graph {
    nodes: Vec<Node>,
    index: HashMap<Node, NodeId>,
    simplify: bool,
}

impl Default for Graph {
    fn default() -> Self {
        Graph::new()
    }
}

impl Graph {
    /// A graph whose constructors simplify.
    pub fn new() -> Self {
        Graph {
            nodes: Vec::new(),
            index: HashMap::default(),
            simplify: true,
        }
    }

    /// A graph that records operations exactly as written (to measure what
    /// simplification saves).
    pub fn unsimplified() -> Self {
        Graph {
            simplify: false,
            ..Graph::new()
        }
    }

    /// The node `id` stands for; panics if `id` is not from this graph.
    pub fn node(&self, id: NodeId) -> Node {
        self.nodes[id.0 as usize]
    }

    /// The number of distinct nodes made so far, constants and inputs included
    /// (not only those reachable from one root).
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether no node has been made yet.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    fn intern(&mut self, node: Node) -> NodeId {
        if let Some(&id) = self.index.get(&node) {
            return id;
        }
        let id = NodeId(self.nodes.len() as u32);
        self.nodes.push(node);
        self.index.insert(node, id);
        id
    }

    /// The constant `c` (a `-0.0` becomes `0.0`, so all zeros are one node).
    pub fn constant(&mut self, c: f64) -> NodeId {
        // One zero, so that `x - x` and `0` share a node.
        let c = if c == 0.0 { 0.0 } else { c };
        self.intern(Node::Const(c.to_bits()))
    }

    /// Input `slot`: 0, 1, 2 are x, y, z.
    pub fn input(&mut self, slot: u8) -> NodeId {
        self.intern(Node::Input(slot))
    }

    /// The value of `id` if it is a constant node; unlike
    /// [`Graph::constant_value`], it does not fold operations.
    pub fn as_const(&self, id: NodeId) -> Option<f64> {
        match self.node(id) {
            Node::Const(bits) => Some(f64::from_bits(bits)),
            _ => None,
        }
    }

    /// The value of `id` if it depends on no input, folding whatever
    /// operations lead to it (in an unsimplified graph they are not folded
    /// as they are built).
    pub fn constant_value(&self, id: NodeId) -> Option<f64> {
        match self.node(id) {
            Node::Const(bits) => Some(f64::from_bits(bits)),
            Node::Input(_) => None,
            Node::Unary(op, a) => Some(op.apply(self.constant_value(a)?)),
            Node::Binary(op, a, b) => {
                Some(op.apply(self.constant_value(a)?, self.constant_value(b)?))
            }
            Node::Noise(op, [a, b, c]) => Some(op.apply([
                self.constant_value(a)?,
                self.constant_value(b)?,
                self.constant_value(c)?,
            ])),
        }
    }

    /// Whether `id` is nonnegative as written, wherever it is a number: a
    /// square, an absolute value, an even power, a sum or product of
    /// nonnegative terms, a quotient of one by a positive constant, a
    /// nonnegative constant.
    pub fn nonnegative_as_written(&self, id: NodeId) -> bool {
        self.nonnegative_within(id, 64)
    }

    fn nonnegative_within(&self, id: NodeId, depth: usize) -> bool {
        if depth == 0 {
            return false;
        }
        let non = |a: NodeId| self.nonnegative_within(a, depth - 1);
        match self.node(id) {
            Node::Const(bits) => f64::from_bits(bits) >= 0.0,
            Node::Unary(Unary::Square | Unary::Abs, _) => true,
            Node::Binary(Binary::Add, a, b) => non(a) && non(b),
            Node::Binary(Binary::Mul, a, b) => a == b || (non(a) && non(b)),
            Node::Binary(Binary::Div, a, b) => self.as_const(b).is_some_and(|c| c > 0.0) && non(a),
            Node::Binary(Binary::Pow, a, b) => self
                .as_const(b)
                .is_some_and(|k| k.fract() == 0.0 && (k as i64) % 2 == 0 || non(a)),
            _ => false,
        }
    }

    fn is_const(&self, id: NodeId, c: f64) -> bool {
        self.as_const(id) == Some(c)
    }

    /// Whether the value at `id` depends on any input.
    pub fn depends_on_input(&self, id: NodeId) -> bool {
        self.depends_on_slots(id, |_| true)
    }

    /// Whether the value at `id` depends on an input whose slot `counts`.
    pub fn depends_on_slots(&self, id: NodeId, counts: impl Fn(u8) -> bool + Copy) -> bool {
        let mut memo = HashMap::default();
        self.depends_memo(id, counts, &mut memo)
    }

    fn depends_memo(
        &self,
        id: NodeId,
        counts: impl Fn(u8) -> bool + Copy,
        memo: &mut HashMap<NodeId, bool>,
    ) -> bool {
        if let Some(&d) = memo.get(&id) {
            return d;
        }
        let d = match self.node(id) {
            Node::Const(_) => false,
            Node::Input(slot) => counts(slot),
            node => node.operands().any(|a| self.depends_memo(a, counts, memo)),
        };
        memo.insert(id, d);
        d
    }

    /// `op(a)`. When the graph simplifies, a constant operand is folded and
    /// identities are applied: `--a = a`, `|a²| = a²`, `||a|| = |a|`,
    /// `|-a| = |a|`, `(-a)² = a²`, `|a|² = a²`, and `sqrt(a)² = a` for an
    /// `a` nonnegative as written.
    pub fn unary(&mut self, op: Unary, a: NodeId) -> NodeId {
        if self.simplify {
            if let Some(c) = self.as_const(a) {
                return self.constant(op.apply(c));
            }
            match (op, self.node(a)) {
                (Unary::Neg, Node::Unary(Unary::Neg, inner)) => return inner,
                (Unary::Abs, Node::Unary(Unary::Abs | Unary::Square, _)) => return a,
                (Unary::Abs | Unary::Square, Node::Unary(Unary::Neg, inner)) => {
                    return self.unary(op, inner)
                }
                (Unary::Square, Node::Unary(Unary::Abs, inner)) => {
                    return self.unary(Unary::Square, inner)
                }
                // `length(p - c)^2`, as metaballs are often written: the
                // square root of a quantity never negative, squared, is that
                // quantity (NaN where it is NaN), and a polynomial stays one.
                (Unary::Square, Node::Unary(Unary::Sqrt, inner))
                    if self.nonnegative_as_written(inner) =>
                {
                    return inner
                }
                _ => {}
            }
        }
        self.intern(Node::Unary(op, a))
    }

    /// `op(a, b)`. When the graph simplifies: constants are folded, operands of
    /// commutative operations are put in one order, and identities applied,
    /// among them `0 + a = a`, `a + a = 2a`, `a - a = 0`, `0 * a = 0`,
    /// `1 * a = a`, `a * a = a²`, `0 / a = 0`, `a / c = (1/c) a`,
    /// `a^0.5 = sqrt(a)`, whole constant powers up to 64 as products
    /// ([`Graph::powi`]), `min(a, a) = a`. Like any such simplification,
    /// `0 * a`, `a - a` and `0 / a` drop a NaN or infinity `a` would have given.
    pub fn binary(&mut self, op: Binary, a: NodeId, b: NodeId) -> NodeId {
        if !self.simplify {
            return self.intern(Node::Binary(op, a, b));
        }
        if let (Some(x), Some(y)) = (self.as_const(a), self.as_const(b)) {
            return self.constant(op.apply(x, y));
        }
        // Constants first for commutative operations, otherwise by id, so
        // that `a + b` and `b + a` are one node.
        let (a, b) = if op.commutative() && self.order_key(b) < self.order_key(a) {
            (b, a)
        } else {
            (a, b)
        };
        match op {
            Binary::Add => {
                if self.is_const(a, 0.0) {
                    return b;
                }
                if a == b {
                    let two = self.constant(2.0);
                    return self.binary(Binary::Mul, two, a);
                }
                if let Node::Unary(Unary::Neg, nb) = self.node(b) {
                    return self.binary(Binary::Sub, a, nb);
                }
                if let Node::Unary(Unary::Neg, na) = self.node(a) {
                    return self.binary(Binary::Sub, b, na);
                }
                if let (Some(c1), Node::Binary(Binary::Add, c, rest)) =
                    (self.as_const(a), self.node(b))
                {
                    if let Some(c2) = self.as_const(c) {
                        let c = self.constant(c1 + c2);
                        return self.binary(Binary::Add, c, rest);
                    }
                }
            }
            Binary::Sub => {
                if self.is_const(b, 0.0) {
                    return a;
                }
                if self.is_const(a, 0.0) {
                    return self.unary(Unary::Neg, b);
                }
                if a == b {
                    return self.constant(0.0);
                }
                if let Node::Unary(Unary::Neg, nb) = self.node(b) {
                    return self.binary(Binary::Add, a, nb);
                }
                if let Some(c) = self.as_const(b) {
                    let c = self.constant(-c);
                    return self.binary(Binary::Add, c, a);
                }
            }
            Binary::Mul => {
                if self.is_const(a, 0.0) {
                    return a;
                }
                if self.is_const(a, 1.0) {
                    return b;
                }
                if self.is_const(a, -1.0) {
                    return self.unary(Unary::Neg, b);
                }
                if a == b {
                    return self.unary(Unary::Square, a);
                }
                if let Some(c1) = self.as_const(a) {
                    match self.node(b) {
                        Node::Binary(Binary::Mul, c, rest) if self.as_const(c).is_some() => {
                            let c = self.constant(c1 * self.as_const(c).unwrap());
                            return self.binary(Binary::Mul, c, rest);
                        }
                        Node::Unary(Unary::Neg, inner) => {
                            let c = self.constant(-c1);
                            return self.binary(Binary::Mul, c, inner);
                        }
                        _ => {}
                    }
                }
            }
            Binary::Div => {
                if self.is_const(b, 1.0) {
                    return a;
                }
                if self.is_const(a, 0.0) {
                    return a;
                }
                if let Some(c) = self.as_const(b) {
                    if c != 0.0 {
                        let r = self.constant(1.0 / c);
                        return self.binary(Binary::Mul, r, a);
                    }
                }
            }
            Binary::Pow => {
                if let Some(e) = self.as_const(b) {
                    if e == 0.5 {
                        return self.unary(Unary::Sqrt, a);
                    }
                    if e.fract() == 0.0 && e.abs() <= MAX_PRODUCT_POWER as f64 {
                        return self.powi(a, e as i64);
                    }
                }
            }
            Binary::Min | Binary::Max => {
                if a == b {
                    return a;
                }
            }
            Binary::Atan2 => {}
            Binary::SmoothMin => {}
            Binary::When | Binary::Unless => {
                // A constant condition takes one branch for good.
                if let Some(c) = self.as_const(a) {
                    let zero = self.constant(0.0);
                    let taken = (c > 0.0) == (op == Binary::When);
                    return if c.is_nan() {
                        self.constant(f64::NAN)
                    } else if taken {
                        b
                    } else {
                        zero
                    };
                }
            }
        }
        self.intern(Node::Binary(op, a, b))
    }

    fn order_key(&self, id: NodeId) -> (bool, NodeId) {
        (self.as_const(id).is_none(), id)
    }

    /// `a^n` as a chain of squares and products.
    pub fn powi(&mut self, a: NodeId, n: i64) -> NodeId {
        match n {
            0 => self.constant(1.0),
            1 => a,
            n if n < 0 => {
                let one = self.constant(1.0);
                let p = self.powi(a, -n);
                self.binary(Binary::Div, one, p)
            }
            n if n % 2 == 0 => {
                let h = self.powi(a, n / 2);
                self.unary(Unary::Square, h)
            }
            n => {
                let p = self.powi(a, n - 1);
                self.binary(Binary::Mul, a, p)
            }
        }
    }

    // Short names for building derivatives and library code.
    /// `a + b`, simplified as [`Graph::binary`].
    pub fn add(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.binary(Binary::Add, a, b)
    }
    /// `a - b`, simplified as [`Graph::binary`].
    pub fn sub(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.binary(Binary::Sub, a, b)
    }
    /// `a * b`, simplified as [`Graph::binary`].
    pub fn mul(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.binary(Binary::Mul, a, b)
    }
    /// `a / b`, simplified as [`Graph::binary`].
    pub fn div(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.binary(Binary::Div, a, b)
    }
    /// `-a`, simplified as [`Graph::unary`].
    pub fn neg(&mut self, a: NodeId) -> NodeId {
        self.unary(Unary::Neg, a)
    }
    /// `min(a, b)`, simplified as [`Graph::binary`].
    pub fn min(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.binary(Binary::Min, a, b)
    }
    /// `max(a, b)`, simplified as [`Graph::binary`].
    pub fn max(&mut self, a: NodeId, b: NodeId) -> NodeId {
        self.binary(Binary::Max, a, b)
    }
    /// `a` where `c > 0`, else `b` (NaN where `c` is NaN): the sum of
    /// `when` and `unless`, which tapes compute as one step.
    pub fn select(&mut self, c: NodeId, a: NodeId, b: NodeId) -> NodeId {
        let taken = self.binary(Binary::When, c, a);
        let other = self.binary(Binary::Unless, c, b);
        self.add(taken, other)
    }
    /// `c * a`.
    pub fn scaled(&mut self, c: f64, a: NodeId) -> NodeId {
        let c = self.constant(c);
        self.mul(c, a)
    }

    /// Copy the expression at `root` of `from` into this graph, replacing
    /// input slot `i` by `inputs[i]`. With simplification on, this is also
    /// the simplify pass.
    pub fn import(&mut self, from: &Graph, root: NodeId, inputs: &[NodeId]) -> NodeId {
        let mut memo: HashMap<NodeId, NodeId> = HashMap::default();
        self.import_memo(from, root, inputs, &mut memo)
    }

    fn import_memo(
        &mut self,
        from: &Graph,
        id: NodeId,
        inputs: &[NodeId],
        memo: &mut HashMap<NodeId, NodeId>,
    ) -> NodeId {
        if let Some(&m) = memo.get(&id) {
            return m;
        }
        let out = match from.node(id) {
            Node::Const(bits) => self.constant(f64::from_bits(bits)),
            Node::Input(slot) => match inputs.get(slot as usize) {
                Some(&n) => n,
                None => self.input(slot),
            },
            Node::Unary(op, a) => {
                let a = self.import_memo(from, a, inputs, memo);
                self.unary(op, a)
            }
            Node::Binary(op, a, b) => {
                let a = self.import_memo(from, a, inputs, memo);
                let b = self.import_memo(from, b, inputs, memo);
                self.binary(op, a, b)
            }
            Node::Noise(op, args) => {
                let args = args.map(|a| self.import_memo(from, a, inputs, memo));
                self.noise(op, args)
            }
        };
        memo.insert(id, out);
        out
    }

    /// `op(a, b, c)`: gradient noise or one of its partial derivatives.
    /// When the graph simplifies, constant arguments are folded and a
    /// partial that vanishes identically is 0.
    pub fn noise(&mut self, op: Noise, args: [NodeId; 3]) -> NodeId {
        if self.simplify {
            if op.vanishes() {
                return self.constant(0.0);
            }
            if let [Some(a), Some(b), Some(c)] = args.map(|n| self.as_const(n)) {
                return self.constant(op.apply([a, b, c]));
            }
        }
        self.intern(Node::Noise(op, args))
    }

    /// The partial derivative of `root` with respect to input `slot`,
    /// built symbolically in this graph.
    pub fn derivative(&mut self, root: NodeId, slot: u8) -> NodeId {
        let mut memo = HashMap::default();
        self.derive(root, slot, &mut memo)
    }

    fn derive(&mut self, id: NodeId, slot: u8, memo: &mut HashMap<NodeId, NodeId>) -> NodeId {
        if let Some(&d) = memo.get(&id) {
            return d;
        }
        let d = match self.node(id) {
            Node::Const(_) => self.constant(0.0),
            Node::Input(s) => self.constant(if s == slot { 1.0 } else { 0.0 }),
            Node::Unary(op, a) => {
                let da = self.derive(a, slot, memo);
                if self.is_const(da, 0.0) {
                    da
                } else {
                    let outer = self.unary_derivative(op, a, id);
                    let slope = self.mul(outer, da);
                    if matches!(op, Unary::Sqrt | Unary::Asin | Unary::Acos | Unary::Ln) {
                        self.flat_where_still(slope, outer, da)
                    } else {
                        slope
                    }
                }
            }
            Node::Binary(op, a, b) => {
                let da = self.derive(a, slot, memo);
                let db = self.derive(b, slot, memo);
                self.binary_derivative(op, a, b, id, da, db)
            }
            Node::Noise(op, args) => {
                // The chain rule over the three arguments.
                let mut sum = self.constant(0.0);
                for (axis, &a) in args.iter().enumerate() {
                    let da = self.derive(a, slot, memo);
                    if !self.is_const(da, 0.0) {
                        let partial = self.noise(op.differentiated(axis), args);
                        let term = self.mul(partial, da);
                        sum = self.add(sum, term);
                    }
                }
                sum
            }
        };
        memo.insert(id, d);
        d
    }

    /// The chain rule's `slope = f'(a) * da`, but 0 where `da` is 0: for
    /// the operations whose `f'` is infinite at an end of their domain
    /// (`sqrt` at 0, `acos` at 1, ...), where `a` is often held by a clamp
    /// or a `max` whose slope is 0 there (`sqrt(max(0, u))`,
    /// `acos(clamp(u, -1, 1))`): 0 times infinity would be NaN, where the
    /// function is flat.
    /// The test is `|da| + |1 / f'| > 0`, which fails only where `f'` is
    /// infinite too: where `da` merely crosses 0 (a torus's `2z` at `z =
    /// 0`) the guard is inert, so second derivatives keep their terms.
    fn flat_where_still(&mut self, slope: NodeId, outer: NodeId, da: NodeId) -> NodeId {
        let moving = self.unary(Unary::Abs, da);
        let one = self.constant(1.0);
        let finite = self.div(one, outer);
        let finite = self.unary(Unary::Abs, finite);
        let test = self.add(moving, finite);
        self.binary(Binary::When, test, slope)
    }

    /// d op(a) / da, where `node` is op(a) itself.
    fn unary_derivative(&mut self, op: Unary, a: NodeId, node: NodeId) -> NodeId {
        let one = self.constant(1.0);
        match op {
            Unary::Neg => self.constant(-1.0),
            Unary::Square => self.scaled(2.0, a),
            Unary::Abs => self.unary(Unary::Sign, a),
            Unary::Sign => self.unary(Unary::ZeroJumps, a),
            Unary::Floor => self.unary(Unary::IntegerJumps, a),
            Unary::Fract => {
                let j = self.unary(Unary::IntegerJumps, a);
                self.add(one, j)
            }
            Unary::SmoothStep => {
                // 6 t (1 - t) with t clamped to [0, 1].
                let zero = self.constant(0.0);
                let t = self.max(a, zero);
                let t = self.min(t, one);
                let rest = self.sub(one, t);
                let p = self.mul(t, rest);
                self.scaled(6.0, p)
            }
            // Slopes of jumps: flat wherever they can be evaluated at all.
            Unary::IntegerJumps | Unary::ZeroJumps => self.constant(0.0),
            Unary::Sqrt => {
                let two_root = self.scaled(2.0, node);
                self.div(one, two_root)
            }
            Unary::Exp => node,
            Unary::Ln => self.div(one, a),
            Unary::Sin => self.unary(Unary::Cos, a),
            Unary::Cos => {
                let s = self.unary(Unary::Sin, a);
                self.neg(s)
            }
            Unary::Tan => {
                let t2 = self.unary(Unary::Square, node);
                self.add(one, t2)
            }
            Unary::Asin | Unary::Acos => {
                let a2 = self.unary(Unary::Square, a);
                let r = self.sub(one, a2);
                let r = self.unary(Unary::Sqrt, r);
                let d = self.div(one, r);
                if op == Unary::Acos {
                    self.neg(d)
                } else {
                    d
                }
            }
            Unary::Atan => {
                let a2 = self.unary(Unary::Square, a);
                let r = self.add(one, a2);
                self.div(one, r)
            }
            Unary::Sinh => self.unary(Unary::Cosh, a),
            Unary::Cosh => self.unary(Unary::Sinh, a),
            Unary::Tanh => {
                let t2 = self.unary(Unary::Square, node);
                self.sub(one, t2)
            }
            Unary::Shc => self.unary(Unary::ShcSlope, a),
            Unary::Chc => {
                let s = self.unary(Unary::Shc, a);
                self.scaled(0.5, s)
            }
            // Second derivatives are never taken: only value tapes are
            // differentiated, and they never hold this operation.
            Unary::ShcSlope => self.constant(f64::NAN),
        }
    }

    fn binary_derivative(
        &mut self,
        op: Binary,
        a: NodeId,
        b: NodeId,
        node: NodeId,
        da: NodeId,
        db: NodeId,
    ) -> NodeId {
        match op {
            Binary::Add => self.add(da, db),
            Binary::Sub => self.sub(da, db),
            Binary::Mul => {
                let l = self.mul(da, b);
                let r = self.mul(a, db);
                self.add(l, r)
            }
            Binary::Div => {
                // (a/b)' = a'/b - (a/b) b'/b
                let l = self.div(da, b);
                let r = self.mul(node, db);
                let r = self.div(r, b);
                self.sub(l, r)
            }
            Binary::Pow => {
                if let Some(e) = self.as_const(b) {
                    let e1 = self.constant(e - 1.0);
                    let p = self.binary(Binary::Pow, a, e1);
                    let p = self.scaled(e, p);
                    let slope = self.mul(p, da);
                    if e < 1.0 {
                        self.flat_where_still(slope, p, da)
                    } else {
                        slope
                    }
                } else if let Some(c) = self.as_const(a) {
                    // A constant base: (c^b)' = c^b ln(c) b'. Zero for
                    // c = 0, where 0^b is constant on each side of b = 0
                    // (the general rule's 0 * ln 0 is NaN, and a NaN slope
                    // hid `sphere(1) + 0.2 * 0^(x + 10)` from the search).
                    if c == 0.0 {
                        self.constant(0.0)
                    } else {
                        let ln_c = self.constant(c.ln());
                        let l = self.mul(db, ln_c);
                        self.mul(node, l)
                    }
                } else {
                    // (a^b)' = a^b (b' ln a + b a'/a)
                    let ln_a = self.unary(Unary::Ln, a);
                    let l = self.mul(db, ln_a);
                    let r = self.mul(b, da);
                    let r = self.div(r, a);
                    let s = self.add(l, r);
                    self.mul(node, s)
                }
            }
            Binary::Min | Binary::Max => {
                if da == db {
                    return da;
                }
                // The derivative picks da or db by the sign of a - b, and
                // averages them where a = b. By selection, not as the
                // algebraic (da + db)/2 -+ sign(a - b)(da - db)/2: where
                // the side not taken overflows (a union beside x^1000),
                // that gives inf - inf, and the sum lost the other side.
                let (first, second) = if op == Binary::Min {
                    (db, da)
                } else {
                    (da, db)
                };
                let a_minus_b = self.sub(a, b);
                let b_minus_a = self.neg(a_minus_b);
                let sum = self.add(da, db);
                let mean = self.scaled(0.5, sum);
                let otherwise = self.select(b_minus_a, second, mean);
                self.select(a_minus_b, first, otherwise)
            }
            Binary::SmoothMin => {
                // h a' + (1 - h) b' = b' + h (a' - b'), h = clamp(1/2 + (b - a)/2, 0, 1)
                let half = self.constant(0.5);
                let zero = self.constant(0.0);
                let one = self.constant(1.0);
                let d = self.sub(b, a);
                let d = self.mul(half, d);
                let h = self.add(half, d);
                let h = self.max(h, zero);
                let h = self.min(h, one);
                let diff = self.sub(da, db);
                let blend = self.mul(h, diff);
                self.add(db, blend)
            }
            Binary::When | Binary::Unless => {
                // The taken branch's slope, and the condition's jump.
                let branch = self.binary(op, a, db);
                let jump = self.unary(Unary::ZeroJumps, a);
                let jump = self.mul(jump, da);
                self.add(branch, jump)
            }
            Binary::Atan2 => {
                // atan2(a, b)' = (b a' - a b') / (a^2 + b^2), plus the jump
                // across the branch cut (a through 0 where b < 0): 0 at
                // points, unbounded over an interval there, so that a
                // search does not take the jump from pi to -pi for a root.
                let l = self.mul(b, da);
                let r = self.mul(a, db);
                let num = self.sub(l, r);
                let a2 = self.unary(Unary::Square, a);
                let b2 = self.unary(Unary::Square, b);
                let den = self.add(a2, b2);
                let smooth = self.div(num, den);
                let at_cut = self.unary(Unary::ZeroJumps, a);
                let negative_b = self.unary(Unary::Neg, b);
                let zero = self.constant(0.0);
                let left = self.binary(Binary::Max, negative_b, zero);
                let cut = self.mul(at_cut, left);
                let jump = self.mul(cut, da);
                self.add(smooth, jump)
            }
        }
    }

    /// The number of distinct operations reachable from `roots`.
    pub fn reachable_count(&self, roots: &[NodeId]) -> usize {
        let mut seen = vec![false; self.nodes.len()];
        let mut stack: Vec<NodeId> = roots.to_vec();
        let mut count = 0;
        while let Some(id) = stack.pop() {
            if std::mem::replace(&mut seen[id.0 as usize], true) {
                continue;
            }
            count += 1;
            stack.extend(self.node(id).operands());
        }
        count
    }
}
