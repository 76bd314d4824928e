//! Shorter formulas for small boxes: over a box, interval arithmetic may
//! prove which operand a `min`, `max` or `smin` takes everywhere in it;
//! the formula with those choices made is equal to the whole one there,
//! in every number type, and often far shorter (a union of a hundred
//! capsules is one or two capsules near any point of it). The idea is
//! fidget's tape simplification, applied per cell of a grid when an
//! object is compiled.
//!
//! Input: an [`Implicit`], a box, and the [`Pruned`] formula of a box
//! holding it. Output: whether its surface may lie in the box, and the
//! box's own shorter formula, from which [`Implicit::from_pruned`] builds
//! the function a cell's searches evaluate.

use std::sync::Arc;

use glam::DVec3;

use super::graph::{Graph, Node, NodeId};
use super::interval::Interval;
use super::op::{Binary, Unary};
use super::Implicit;

/// A formula with some choices made, as the steps of the object's graph
/// it still evaluates, in dependency order (the last is its value): each
/// step's operands are earlier steps. A box's formula is its parent's
/// with the box's choices made, so deciding a box costs one pass over
/// its parent's steps, with no walk of the graph. Two boxes whose
/// formulas are the same have equal steps (every formula's steps keep the
/// whole formula's order), which is how cells share one.
#[derive(Debug, Clone)]
pub struct Pruned {
    steps: Vec<Step>,
    /// Per step, the level only whose side matters (see [`levels`]), or
    /// NaN: a property of the formula, so computed once for all the boxes
    /// decided with it.
    levels: Vec<f64>,
    /// A hash of the steps, computed where the formula is made (in
    /// parallel): telling a grid's formulas apart then hashes none.
    fingerprint: u64,
}

impl PartialEq for Pruned {
    fn eq(&self, other: &Self) -> bool {
        self.fingerprint == other.fingerprint && self.steps == other.steps
    }
}

impl Eq for Pruned {}

impl std::hash::Hash for Pruned {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        state.write_u64(self.fingerprint);
    }
}

/// One step of a [`Pruned`] formula: a node of the object's graph, and
/// the steps that stand for its operands (a chosen operand stands for the
/// choice it replaced).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct Step {
    node: Node,
    args: [u32; 3],
}

impl Pruned {
    fn new(steps: Vec<Step>, s: &mut PruneScratch) -> Pruned {
        use std::hash::BuildHasher;
        let levels = levels(&steps, s);
        let fingerprint = foldhash::fast::FixedState::default().hash_one(&steps);
        Pruned {
            steps,
            levels,
            fingerprint,
        }
    }

    /// How many steps the formula has.
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    /// Whether the formula has no steps (never, for one built from a root).
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }
}

/// What a box shows of a function.
#[derive(Debug, Clone, PartialEq)]
pub enum OnBox {
    /// Its interval over the box excludes zero: no surface there.
    Empty,
    /// The surface may be there; this formula, with the choices that hold
    /// over the box made, equals it near its zeros there (the parent's own
    /// when the box decides nothing new).
    Kept(Arc<Pruned>),
}

/// Reused buffers for [`Implicit::on_box`].
#[derive(Debug, Default)]
pub struct PruneScratch {
    values: Vec<Interval>,
    /// Per step, the operand a choice takes (0 or 1), or [`UNCHOSEN`].
    picks: Vec<u32>,
    /// Per step, the step that stands for it once choices are made.
    stands_for: Vec<u32>,
    /// Per step, its index in the shorter formula, or [`UNCHOSEN`].
    index: Vec<u32>,
    users: Vec<u32>,
    /// The last formulas made, with the formula and the choices each was
    /// made from: a box's siblings mostly make the same choices (a tube
    /// of capsules' cells made 30 000 formulas, 1 600 of them distinct).
    recent: Vec<(Arc<Pruned>, Vec<u32>, Arc<Pruned>)>,
    /// The steps of all the formulas [`Implicit::on_box`] has made with
    /// this scratch (not those it found made already).
    pub made_steps: usize,
}

/// How many formulas [`PruneScratch`] remembers: a box's children.
const RECENT: usize = 8;

impl Implicit {
    /// Whether `f` has a `min`, `max` or `smin` a box could decide.
    pub fn has_choices(&self) -> bool {
        self.value_tape.has_choices()
    }

    /// `f` as a [`Pruned`] formula with no choice made: what
    /// [`Implicit::on_box`] decides the largest box with.
    pub fn unpruned(&self) -> Arc<Pruned> {
        let graph = &*self.graph;
        let mut order = Vec::new();
        let mut seen = vec![false; graph.len()];
        let mut stack = vec![(self.root, false)];
        // A depth-first walk that places a node once its operands are
        // placed: dependency order without a sort.
        while let Some((id, operands_placed)) = stack.pop() {
            if operands_placed {
                order.push(id);
                continue;
            }
            if std::mem::replace(&mut seen[id.0 as usize], true) {
                continue;
            }
            stack.push((id, true));
            for a in graph.node(id).operands() {
                if !seen[a.0 as usize] {
                    stack.push((a, false));
                }
            }
        }
        let mut index = vec![0u32; graph.len()];
        let steps = order
            .iter()
            .enumerate()
            .map(|(k, &id)| {
                index[id.0 as usize] = k as u32;
                let node = graph.node(id);
                let mut args = [0; 3];
                for (slot, a) in args.iter_mut().zip(node.operands()) {
                    *slot = index[a.0 as usize];
                }
                Step { node, args }
            })
            .collect();
        Arc::new(Pruned::new(steps, &mut PruneScratch::default()))
    }

    /// The surface over the box `[lo, hi]`, decided with `parent`'s
    /// formula (proven over a box holding this one): whether it may lie
    /// there, and the shorter formula that holds there.
    pub fn on_box(
        &self,
        lo: DVec3,
        hi: DVec3,
        parent: &Arc<Pruned>,
        s: &mut PruneScratch,
    ) -> OnBox {
        let (steps, levels) = (&parent.steps, &parent.levels);
        let n = steps.len();
        if n == 0 {
            return OnBox::Empty;
        }
        let box_ = [
            Interval::new(lo.x, hi.x),
            Interval::new(lo.y, hi.y),
            Interval::new(lo.z, hi.z),
        ];
        s.values.clear();
        s.picks.clear();
        s.picks.resize(n, UNCHOSEN);
        let mut decided = false;
        for (k, step) in steps.iter().enumerate() {
            let [a, b, c] = step.args.map(|a| a as usize);
            let v = match step.node {
                Node::Const(bits) => Interval::point(f64::from_bits(bits)),
                Node::Input(slot) => box_.get(slot as usize).copied().unwrap_or(Interval::EMPTY),
                Node::Unary(op, _) => op.apply(s.values[a]),
                Node::Binary(op, _, _) => {
                    let (va, vb) = (s.values[a], s.values[b]);
                    let pick =
                        decide(op, va, vb).or_else(|| decide_at_level(op, va, vb, levels[k]));
                    if let Some(first) = pick {
                        s.picks[k] = if first { 0 } else { 1 };
                        decided = true;
                    }
                    op.apply(va, vb)
                }
                Node::Noise(op, _) => op.apply([s.values[a], s.values[b], s.values[c]]),
            };
            s.values.push(v);
        }
        if !s.values[n - 1].contains(0.0) {
            return OnBox::Empty;
        }
        if !decided {
            return OnBox::Kept(parent.clone());
        }
        let same = |(from, picks, _): &(Arc<Pruned>, Vec<u32>, Arc<Pruned>)| {
            Arc::ptr_eq(from, parent) && *picks == s.picks
        };
        if let Some((_, _, made)) = s.recent.iter().find(|r| same(r)) {
            return OnBox::Kept(made.clone());
        }
        let Some(made) = shorter(steps, s) else {
            return OnBox::Kept(parent.clone());
        };
        s.made_steps += made.len();
        let made = Arc::new(made);
        if s.recent.len() == RECENT {
            s.recent.remove(0);
        }
        s.recent
            .push((parent.clone(), s.picks.clone(), made.clone()));
        OnBox::Kept(made)
    }

    /// The function a [`Pruned`] formula of `f` computes: on the same
    /// side of zero as `f` over the box it was made for, and equal to it
    /// near its zeros; without a gradient tape (see
    /// [`Implicit::value_only`]).
    pub fn from_pruned(&self, p: &Pruned) -> Implicit {
        let mut g = Graph::new();
        let mut ids: Vec<NodeId> = Vec::with_capacity(p.steps.len());
        for step in &p.steps {
            let arg = |k: usize| ids[step.args[k] as usize];
            let id = match step.node {
                Node::Const(bits) => g.constant(f64::from_bits(bits)),
                Node::Input(slot) => g.input(slot),
                Node::Unary(op, _) => g.unary(op, arg(0)),
                Node::Binary(op, _, _) => g.binary(op, arg(0), arg(1)),
                Node::Noise(op, _) => g.noise(op, [arg(0), arg(1), arg(2)]),
            };
            ids.push(id);
        }
        Implicit::value_only(&g, *ids.last().expect("a formula has a step"))
    }
}

/// `steps` with the choices in `s.picks` made: each chosen step stands
/// for the operand it takes, and only the steps the value still reaches
/// are kept, in the same order; `None` where that would keep nine
/// tenths or more of a long formula (see [`SHORTER_FROM`]).
fn shorter(steps: &[Step], s: &mut PruneScratch) -> Option<Pruned> {
    let n = steps.len();
    s.stands_for.clear();
    for (k, step) in steps.iter().enumerate() {
        let by = match s.picks[k] {
            UNCHOSEN => k as u32,
            pick => s.stands_for[step.args[pick as usize] as usize],
        };
        s.stands_for.push(by);
    }
    // Reached from the value, through the steps that stand for operands.
    s.index.clear();
    s.index.resize(n, UNCHOSEN);
    s.index[s.stands_for[n - 1] as usize] = 0;
    for k in (0..n).rev() {
        if s.index[k] == UNCHOSEN {
            continue;
        }
        for &a in &steps[k].args[..arity(steps[k].node)] {
            s.index[s.stands_for[a as usize] as usize] = 0;
        }
    }
    let count = s.index.iter().filter(|&&i| i != UNCHOSEN).count();
    if n >= SHORTER_FROM && count * 10 > n * 9 {
        return None;
    }
    let mut kept = Vec::with_capacity(count);
    for (k, step) in steps.iter().enumerate() {
        if s.index[k] == UNCHOSEN {
            continue;
        }
        s.index[k] = kept.len() as u32;
        let mut args = [0; 3];
        for (to, &a) in args.iter_mut().zip(&step.args[..arity(step.node)]) {
            *to = s.index[s.stands_for[a as usize] as usize];
        }
        kept.push(Step {
            node: step.node,
            args,
        });
    }
    Some(Pruned::new(kept, s))
}

/// Formulas of at least this many steps are made shorter only by a
/// tenth or more: a box that decides one ball of a thousand keeps its
/// parent's (a union of a thousand balls moved in H3, each dozens of
/// operations, held gigabytes in near copies of the whole formula).
const SHORTER_FROM: usize = 1000;

/// How many operands a node has.
fn arity(node: Node) -> usize {
    match node {
        Node::Const(_) | Node::Input(_) => 0,
        Node::Unary(..) => 1,
        Node::Binary(..) => 2,
        Node::Noise(..) => 3,
    }
}

/// No choice made at a node.
const UNCHOSEN: u32 = u32::MAX;

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

/// For each step, the level `c` such that only the side of `c` the step
/// is on matters to the sign of `f` (and, near `f = 0`, only its value
/// near `c`), or NaN when its exact value matters: `f` itself has level
/// 0, and a level passes down through a step's only use when that use is
/// `min`, `max`, a shift or a scaling by a constant, or a negation (which
/// side is which does not matter, only that it is kept).
fn levels(steps: &[Step], s: &mut PruneScratch) -> Vec<f64> {
    let n = steps.len();
    let mut levels = vec![f64::NAN; n];
    if n == 0 {
        return levels;
    }
    s.users.clear();
    s.users.resize(n, 0);
    for step in steps {
        for &a in &step.args[..arity(step.node)] {
            s.users[a as usize] += 1;
        }
    }
    levels[n - 1] = 0.0;
    let constant = |k: u32| match steps[k as usize].node {
        Node::Const(bits) => Some(f64::from_bits(bits)),
        _ => None,
    };
    for k in (0..n).rev() {
        let level = levels[k];
        if level.is_nan() {
            continue;
        }
        let [a, b, _] = steps[k].args;
        // A one-operand rule names its operand twice.
        let (to, child_level) = match steps[k].node {
            Node::Unary(Unary::Neg, _) => ([a, a], -level),
            Node::Binary(Binary::Min | Binary::Max, _, _) => ([a, b], level),
            Node::Binary(op @ (Binary::Add | Binary::Sub | Binary::Mul | Binary::Div), _, _) => {
                let usable = |c: f64| c.is_finite() && c != 0.0;
                match (op, constant(a), constant(b)) {
                    (Binary::Add, Some(c), None) => ([b, b], level - c),
                    (Binary::Sub, Some(c), None) => ([b, b], c - level),
                    (Binary::Add, None, Some(c)) => ([a, a], level - c),
                    (Binary::Sub, None, Some(c)) => ([a, a], level + c),
                    (Binary::Mul, Some(c), None) if usable(c) => ([b, b], level / c),
                    (Binary::Mul, None, Some(c)) if usable(c) => ([a, a], level / c),
                    (Binary::Div, None, Some(c)) if usable(c) => ([a, a], level * c),
                    _ => continue,
                }
            }
            _ => continue,
        };
        if !child_level.is_finite() {
            continue;
        }
        for a in to {
            if s.users[a as usize] == 1 {
                levels[a as usize] = child_level;
            }
        }
    }
    levels
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ring of 40 balls as a `min`, compiled as a scene compiles it.
    fn ring() -> Implicit {
        let src = "camera { position (0, -9, 4) }\n\
                   shape s = min(k in 0..40, length((x - 2.5 * cos(k * tau / 40), y, \
                   z - 2.5 * sin(k * tau / 40))) - 0.3)\nobject s";
        let scene = crate::compile_source("ring.nes", src).expect("compiles");
        scene.objects[0].function.clone()
    }

    #[test]
    fn a_box_around_one_ball_keeps_that_ball_alone() {
        let f = ring();
        let whole = f.unpruned();
        let mut s = PruneScratch::default();
        // The ball at k = 0 has its centre at (2.5, 0, 0); its neighbours'
        // are 0.39 away, so a box of half-width 0.05 about a point on its
        // surface facing away from them is closer to it by far.
        let at = DVec3::new(2.8, 0.0, 0.0);
        let (lo, hi) = (at - DVec3::splat(0.05), at + DVec3::splat(0.05));
        let OnBox::Kept(near) = f.on_box(lo, hi, &whole, &mut s) else {
            panic!("the surface passes through the box");
        };
        assert!(
            near.len() * 10 < whole.len(),
            "{} steps of {}",
            near.len(),
            whole.len()
        );
        // Equal to the whole function throughout the box.
        let g = f.from_pruned(&near);
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for k in 0..125 {
            let u = DVec3::new((k % 5) as f64, (k / 5 % 5) as f64, (k / 25) as f64) / 4.0;
            let p = lo + (hi - lo) * u;
            let (fp, gp) = (f.value(p, &mut a), g.value(p, &mut b));
            assert!((fp - gp).abs() < 1e-12, "at {p}: {fp} vs {gp}");
        }
        // A box far from every ball holds no surface.
        let far = DVec3::new(0.0, 0.0, 0.0);
        let empty = f.on_box(
            far - DVec3::splat(0.1),
            far + DVec3::splat(0.1),
            &whole,
            &mut s,
        );
        assert_eq!(empty, OnBox::Empty);
    }

    #[test]
    fn boxes_that_make_the_same_choices_share_one_formula() {
        let f = ring();
        let whole = f.unpruned();
        let mut s = PruneScratch::default();
        let box_at = |p: DVec3| (p - DVec3::splat(0.02), p + DVec3::splat(0.02));
        let (lo, hi) = box_at(DVec3::new(2.8, 0.0, 0.0));
        let (lo2, hi2) = box_at(DVec3::new(2.8, 0.0, 0.01));
        let (OnBox::Kept(a), OnBox::Kept(b)) = (
            f.on_box(lo, hi, &whole, &mut s),
            f.on_box(lo2, hi2, &whole, &mut s),
        ) else {
            panic!("the surface passes through both boxes");
        };
        assert!(Arc::ptr_eq(&a, &b), "one allocation for one formula");
        // Made again from scratch, the formula is equal, and hashes equal.
        let c = match f.on_box(lo, hi, &whole, &mut PruneScratch::default()) {
            OnBox::Kept(c) => c,
            OnBox::Empty => panic!("the surface passes through the box"),
        };
        assert!(!Arc::ptr_eq(&a, &c));
        assert_eq!(*a, *c);
        // A box that decides nothing keeps its parent's formula.
        let (big_lo, big_hi) = (DVec3::splat(-4.0), DVec3::splat(4.0));
        match f.on_box(big_lo, big_hi, &whole, &mut s) {
            OnBox::Kept(same) => assert!(Arc::ptr_eq(&same, &whole)),
            OnBox::Empty => panic!("the surface is in the box"),
        }
    }
}
