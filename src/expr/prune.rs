//! Shorter formulas for small boxes: over a box, interval arithmetic may
//! prove which operand a `min`, `max` or `smin` takes everywhere in it;
//! the formula with those choices made is equal to the whole one there,
//! in every number type, and often far shorter (a union of a hundred
//! capsules is one or two capsules near any point of it). The idea is
//! fidget's tape simplification, applied per cell of a grid when an
//! object is compiled.
//!
//! Input: an [`Implicit`] and a box. Output: whether its surface may lie
//! in the box, and the choices that hold there, from which
//! [`Implicit::pruned`] builds the shorter function.

use glam::DVec3;

use super::graph::{Graph, HashMap, Node, NodeId};
use super::interval::Interval;
use super::op::{Binary, Unary};
use super::Implicit;

/// One proven choice: the node (of the object's graph) and the operand
/// it takes over the box.
pub type Choice = (NodeId, NodeId);

/// What a box shows of a function.
#[derive(Debug, Clone, PartialEq)]
pub enum OnBox {
    /// Its interval over the box excludes zero: no surface there.
    Empty,
    /// The surface may be there; these choices hold over the box (sorted
    /// by node, none when nothing could be decided).
    Choices(Vec<Choice>),
}

/// Reused buffers for [`Implicit::on_box`].
#[derive(Debug, Default)]
pub struct PruneScratch {
    values: Vec<Interval>,
    stack: Vec<NodeId>,
    /// [`live_nodes`]'s stack: a node, and whether its operands are placed.
    walk: Vec<(NodeId, bool)>,
    seen: Vec<bool>,
    order: Vec<NodeId>,
    /// Per node, the level only whose side matters (see [`levels`]), or NaN.
    levels: Vec<f64>,
    users: Vec<u32>,
    /// Per node, the operand a known choice takes, or [`UNCHOSEN`].
    redirect: Vec<u32>,
    /// Nodes of the last shorter formula [`Implicit::on_box`] found.
    live: usize,
}

impl PruneScratch {
    /// How many nodes the shorter formula of the last
    /// [`Implicit::on_box`] has (0 after [`OnBox::Empty`]).
    pub fn live_count(&self) -> usize {
        self.live
    }
}

impl Implicit {
    /// Whether `f` has a `min`, `max` or `smin` a box could decide.
    pub fn has_choices(&self) -> bool {
        self.value_tape.has_choices()
    }

    /// The surface over the box `[lo, hi]`, with the choices `known`
    /// (sorted by node, proven over a box holding this one) already made:
    /// only the part of `f` they leave is evaluated.
    pub fn on_box(&self, lo: DVec3, hi: DVec3, known: &[Choice], s: &mut PruneScratch) -> OnBox {
        // `known` as a table, for lookups in constant time; its entries
        // are undone after, so the table stays all-unchosen between calls.
        let mut redirect = std::mem::take(&mut s.redirect);
        if redirect.len() < self.graph.len() {
            redirect.resize(self.graph.len(), UNCHOSEN);
        }
        for &(node, pick) in known {
            redirect[node.0 as usize] = pick.0;
        }
        let out = self.on_box_with(lo, hi, known, &redirect, s);
        for &(node, _) in known {
            redirect[node.0 as usize] = UNCHOSEN;
        }
        s.redirect = redirect;
        out
    }

    fn on_box_with(
        &self,
        lo: DVec3,
        hi: DVec3,
        known: &[Choice],
        redirect: &[u32],
        s: &mut PruneScratch,
    ) -> OnBox {
        let graph = &*self.graph;
        let chosen = |id: NodeId| match redirect[id.0 as usize] {
            UNCHOSEN => id,
            pick => NodeId(pick),
        };
        live_nodes(graph, self.root, &chosen, s);
        if s.values.len() < graph.len() {
            s.values.resize(graph.len(), Interval::EMPTY);
        }
        let box_ = [
            Interval::new(lo.x, hi.x),
            Interval::new(lo.y, hi.y),
            Interval::new(lo.z, hi.z),
        ];
        levels(graph, resolve_id(self.root, &chosen), &chosen, s);
        let mut choices: Vec<Choice> = known.to_vec();
        for &id in &s.order {
            let v = match graph.node(id) {
                Node::Const(bits) => Interval::point(f64::from_bits(bits)),
                Node::Input(slot) => box_.get(slot as usize).copied().unwrap_or(Interval::EMPTY),
                Node::Unary(op, a) => op.apply(s.values[resolve(a, &chosen)]),
                Node::Binary(op, a, b) => {
                    let (a, b) = (resolve_id(a, &chosen), resolve_id(b, &chosen));
                    let (va, vb) = (s.values[a.0 as usize], s.values[b.0 as usize]);
                    let level = s.levels[id.0 as usize];
                    let pick = decide(op, va, vb).or_else(|| decide_at_level(op, va, vb, level));
                    if let Some(pick) = pick {
                        choices.push((id, if pick { a } else { b }));
                    }
                    op.apply(va, vb)
                }
                Node::Noise(op, args) => op.apply(args.map(|a| s.values[resolve(a, &chosen)])),
            };
            s.values[id.0 as usize] = v;
        }
        let root = resolve_id(self.root, &chosen);
        if !s.values[root.0 as usize].contains(0.0) {
            s.live = 0;
            return OnBox::Empty;
        }
        choices.sort_unstable_by_key(|c| c.0);
        choices.dedup_by_key(|c| c.0);
        // Only choices the shorter formula still meets matter: cells that
        // differ in the others share a formula.
        let met = met_choices(graph, self.root, &choices, s);
        let choices = choices
            .into_iter()
            .zip(met)
            .filter(|c| c.1)
            .map(|c| c.0)
            .collect();
        OnBox::Choices(choices)
    }

    /// `f` with `choices` made: on the same side of zero as `f` wherever
    /// they hold, and equal to it near its zeros; without a gradient tape
    /// (see [`Implicit::value_only`]).
    pub fn pruned(&self, choices: &[Choice]) -> Implicit {
        let subs: HashMap<NodeId, NodeId> = choices.iter().copied().collect();
        let mut g = Graph::new();
        let root = g.import_substituting(&self.graph, self.root, &subs);
        Implicit::value_only(&g, root)
    }
}

/// No choice made at a node.
const UNCHOSEN: u32 = u32::MAX;

/// A node with every choice `chosen` makes followed to the end.
fn resolve_id(mut id: NodeId, chosen: &impl Fn(NodeId) -> NodeId) -> NodeId {
    loop {
        let next = chosen(id);
        if next == id {
            return id;
        }
        id = next;
    }
}

fn resolve(id: NodeId, chosen: &impl Fn(NodeId) -> NodeId) -> usize {
    resolve_id(id, chosen).0 as usize
}

/// Which operand `op` takes over operand ranges `a` and `b`, if one: true
/// for `a`. A margin far above rounding keeps a choice made on intervals
/// the one every number type makes at points inside them.
fn decide(op: Binary, a: Interval, b: Interval) -> Option<bool> {
    if a.is_empty() || b.is_empty() {
        return None;
    }
    let margin = |x: f64, y: f64| 1e-9 * (1.0 + x.abs() + y.abs());
    let below = |a: Interval, b: Interval, gap: f64| {
        let (h, l) = (a.hi, b.lo);
        h.is_finite() && l.is_finite() && h + gap + margin(h, l) < l
    };
    match op {
        Binary::Min if below(a, b, 0.0) => Some(true),
        Binary::Min if below(b, a, 0.0) => Some(false),
        Binary::Max if below(b, a, 0.0) => Some(true),
        Binary::Max if below(a, b, 0.0) => Some(false),
        // The blend of radius 1 is the plain minimum where the operands
        // differ by 1 or more.
        Binary::SmoothMin if below(a, b, 1.0) => Some(true),
        Binary::SmoothMin if below(b, a, 1.0) => Some(false),
        _ => None,
    }
}

/// Which operand `op` takes at `level` (see [`levels`]): one that stays
/// on the far side of the level over the box can be dropped, since the
/// node is then on the same side as the other operand wherever that one
/// is, and equal to it near the level. `smin` lowers the smaller operand
/// by at most 1/4 where they are within 1 of each other, hence its gap.
fn decide_at_level(op: Binary, a: Interval, b: Interval, level: f64) -> Option<bool> {
    if !level.is_finite() || a.is_empty() || b.is_empty() {
        return None;
    }
    let margin =
        1e-9 * (1.0 + level.abs() + a.lo.abs().min(a.hi.abs()) + b.lo.abs().min(b.hi.abs()));
    let above = |v: Interval, gap: f64| v.lo.is_finite() && v.lo > level + gap + margin;
    let below = |v: Interval| v.hi.is_finite() && v.hi < level - margin;
    match op {
        Binary::Min if above(a, 0.0) => Some(false),
        Binary::Min if above(b, 0.0) => Some(true),
        Binary::Max if below(a) => Some(false),
        Binary::Max if below(b) => Some(true),
        Binary::SmoothMin if above(a, 1.25) => Some(false),
        Binary::SmoothMin if above(b, 1.25) => Some(true),
        _ => None,
    }
}

/// For each live node, the level `c` such that only the side of `c` the
/// node is on matters to the sign of `f` (and, near `f = 0`, only its
/// value near `c`), or NaN when its exact value matters: `f` itself has
/// level 0, and a level passes down through a node's only use when that
/// use is `min`, `max`, a shift or a scaling by a constant, or a negation
/// (which side is which does not matter, only that it is kept). Into `s.levels`, from `s.order`.
fn levels(graph: &Graph, root: NodeId, chosen: &impl Fn(NodeId) -> NodeId, s: &mut PruneScratch) {
    if s.levels.len() < graph.len() {
        s.levels.resize(graph.len(), f64::NAN);
        s.users.resize(graph.len(), 0);
    }
    // Only the live nodes' entries are read.
    for &id in &s.order {
        s.levels[id.0 as usize] = f64::NAN;
        s.users[id.0 as usize] = 0;
    }
    for &id in &s.order {
        for a in graph.node(id).operands() {
            s.users[resolve(a, chosen)] += 1;
        }
    }
    s.levels[root.0 as usize] = 0.0;
    let constant = |id: NodeId| match graph.node(id) {
        Node::Const(bits) => Some(f64::from_bits(bits)),
        _ => None,
    };
    for &id in s.order.iter().rev() {
        let level = s.levels[id.0 as usize];
        if level.is_nan() {
            continue;
        }
        let (to, child_level) = match graph.node(id) {
            Node::Unary(Unary::Neg, a) => (vec![a], -level),
            Node::Binary(Binary::Min | Binary::Max, a, b) => (vec![a, b], level),
            Node::Binary(op @ (Binary::Add | Binary::Sub | Binary::Mul | Binary::Div), a, b) => {
                let usable = |c: f64| c.is_finite() && c != 0.0;
                match (op, constant(a), constant(b)) {
                    (Binary::Add, Some(c), None) => (vec![b], level - c),
                    (Binary::Sub, Some(c), None) => (vec![b], c - level),
                    (Binary::Add, None, Some(c)) => (vec![a], level - c),
                    (Binary::Sub, None, Some(c)) => (vec![a], level + c),
                    (Binary::Mul, Some(c), None) if usable(c) => (vec![b], level / c),
                    (Binary::Mul, None, Some(c)) if usable(c) => (vec![a], level / c),
                    (Binary::Div, None, Some(c)) if usable(c) => (vec![a], level * c),
                    _ => continue,
                }
            }
            _ => continue,
        };
        for a in to {
            let a = resolve(a, chosen);
            if s.users[a] == 1 && child_level.is_finite() {
                s.levels[a] = child_level;
            }
        }
    }
}

/// Which of `choices` (sorted by node) the walk from `root` meets, as
/// [`live_nodes`] makes it; the number of nodes it reaches into `s.live`.
fn met_choices(graph: &Graph, root: NodeId, choices: &[Choice], s: &mut PruneScratch) -> Vec<bool> {
    let mut met = vec![false; choices.len()];
    walk(
        graph,
        root,
        |mut id| loop {
            match choices.binary_search_by_key(&id, |c| c.0) {
                Ok(k) => {
                    met[k] = true;
                    id = choices[k].1;
                }
                Err(_) => return id,
            }
        },
        s,
    );
    s.live = s.order.len();
    met
}

/// The nodes `root` reaches when `known`'s choices are followed, in
/// dependency order (a node after its operands), into `s.order`: a
/// depth-first walk that places a node once its operands are placed, so no
/// sort is needed (sorting by id cost a fifth of a large union's compile).
fn live_nodes(
    graph: &Graph,
    root: NodeId,
    chosen: &impl Fn(NodeId) -> NodeId,
    s: &mut PruneScratch,
) {
    s.order.clear();
    s.seen.resize(graph.len().max(s.seen.len()), false);
    let mut stack = std::mem::take(&mut s.walk);
    stack.clear();
    stack.push((resolve_id(root, chosen), false));
    while let Some((id, operands_placed)) = stack.pop() {
        if operands_placed {
            s.order.push(id);
            continue;
        }
        if s.seen[id.0 as usize] {
            continue;
        }
        s.seen[id.0 as usize] = true;
        stack.push((id, true));
        for a in graph.node(id).operands() {
            let a = resolve_id(a, chosen);
            if !s.seen[a.0 as usize] {
                stack.push((a, false));
            }
        }
    }
    s.walk = stack;
    clear_seen(s);
}

/// The nodes `root` reaches, each operand taken through `follow` (which
/// makes the choices), into `s.order` in no particular order.
fn walk(
    graph: &Graph,
    root: NodeId,
    mut follow: impl FnMut(NodeId) -> NodeId,
    s: &mut PruneScratch,
) {
    s.order.clear();
    s.stack.clear();
    s.seen.resize(graph.len().max(s.seen.len()), false);
    s.stack.push(follow(root));
    while let Some(id) = s.stack.pop() {
        if s.seen[id.0 as usize] {
            continue;
        }
        s.seen[id.0 as usize] = true;
        s.order.push(id);
        for a in graph.node(id).operands() {
            let a = follow(a);
            if !s.seen[a.0 as usize] {
                s.stack.push(a);
            }
        }
    }
    clear_seen(s);
}

/// `s.seen` all false again, in the time of the walk that set it: its
/// nodes are `s.order`.
fn clear_seen(s: &mut PruneScratch) {
    for &id in &s.order {
        s.seen[id.0 as usize] = false;
    }
}
