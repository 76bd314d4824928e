//! Object bounds, computed once at compile time: the region rays can reach
//! is subdivided into cells, cells where the interval of `f` excludes zero
//! are dropped, and the box around the remaining cells bounds the surface.
//! Rays that miss the box skip the object.

use glam::DVec3;

use std::collections::HashMap;
use std::sync::Arc;

use rayon::prelude::*;

use crate::expr::prune::{OnBox, PruneScratch, Pruned};
use crate::expr::univariate::MOST_INTERPOLATED_DEGREE;
use crate::expr::{Implicit, Interval, SplitScratch, ValueErrors};
use crate::scene::{CellGrid, Part, PrunedCells, Scene, ShadowPaths};
use crate::space::{Aabb, Euclidean, Placement, Space};

/// Cells per axis of an object's occupancy grid.
const GRID_CELLS: usize = 16;
/// The most tape operations the occupancy grid takes (about a tenth of a
/// second, in interval arithmetic).
const GRID_OPERATIONS: usize = 20_000_000;

/// The coarse subdivision stops when this many cells remain (or at a
/// depth no float range needs: halving 1e308 down to 1e-308 takes 2046
/// levels): a compact object in a huge region keeps few cells per level
/// until the cells reach its size, so the depth it takes is about
/// log2(region / object), 200 for a torus of radius 2 under `max_distance
/// 1e60` (64 levels, the limit before, left its box at 2.8e15).
const MAX_DEPTH: u32 = 2100;
const MAX_CELLS: usize = 1024;
/// The most tape operations the subdivision takes, in interval
/// arithmetic (about a third of a second): a long tape (a sum of
/// thousands of terms) stops it at a coarser level, with a looser box.
const DESCENT_OPERATIONS: usize = 60_000_000;
/// The most tape operations the slabs of [`shrink_faces`] take: fewer
/// bisections for a long tape.
const SHRINK_OPERATIONS: usize = 30_000_000;

/// Each face of the coarse box is then pushed in to within this fraction
/// of the box's size, by a best-first search of at most
/// [`FACE_SEARCH_CELLS`] cells per face (fewer for a long tape, see
/// [`face_search_cells`]).
const FACE_RESOLUTION: f64 = 1.0 / 256.0;
const FACE_SEARCH_CELLS: usize = 4096;

/// The most tape operations the six faces' searches take together, in
/// interval arithmetic: about a fifth of a second. A long tape (a sum of
/// hundreds of terms) gets fewer cells per face, and a looser face.
const FACE_SEARCH_OPERATIONS: usize = 30_000_000;

/// Cells per face for a value tape of `len` operations: [`FACE_SEARCH_CELLS`]
/// within [`FACE_SEARCH_OPERATIONS`], and at least 64.
fn face_search_cells(len: usize) -> usize {
    (FACE_SEARCH_OPERATIONS / (6 * len.max(1))).clamp(64, FACE_SEARCH_CELLS)
}

/// The box that holds every point, in object coordinates, that a primary
/// ray or a shadow ray can reach: what the space says a path from the
/// camera can reach, and its shadow paths from there to each light (in a
/// torus these stay in the cell, however far away a light is written).
pub fn reachable_region(scene: &Scene) -> Aabb {
    let space = scene.build_space();
    let seen = space.reach(scene.camera.position, scene.settings.max_distance);
    let straight =
        scene.settings.shadow_paths == ShadowPaths::Euclidean && !scene.space.places_objects();
    let shadow_space: &dyn Space = if straight { &Euclidean } else { space.as_ref() };
    let mut region = seen;
    for l in &scene.lights {
        let lit = shadow_space.light_reach(seen, l.position);
        region.min = region.min.min(lit.min);
        region.max = region.max.max(lit.max);
    }
    region
}

/// `region` (in the scene's coordinates) in the coordinates of an object
/// placed by `placement`: itself in the flat spaces.
pub fn local_region(scene: &Scene, region: Aabb, placement: &Placement) -> Aabb {
    scene.build_space().local_region(region, placement)
}

/// Recompute every object's bound, after the scene's space, camera or
/// settings changed.
pub fn compute_bounds(scene: &mut Scene) {
    let region = reachable_region(scene);
    let space = scene.build_space();
    let straight = space.straight_paths();
    for o in &mut scene.objects {
        let local = space.local_region(region, &o.placement);
        (o.bound, o.cells, o.pruned) = search_aids(&o.function, o.clip.as_ref(), local, straight);
        o.value_errors = value_errors(&o.function, o.bound);
        o.clip_cuts = clip_cuts(
            &o.function,
            o.clip.as_ref(),
            o.bound,
            scene.settings.epsilon,
            straight,
        );
    }
}

/// Whether the searches must honour `clip` (see [`Object::clip_cuts`]):
/// whether it may cut the surface of `f` within `bound` shrunk by
/// `epsilon`. The bound's faces are a cut already, located to `epsilon`
/// like every hit: a clip that cuts only within `epsilon` of them (`clip
/// cube(3.2)`, which the bound equals) cuts nothing they do not. Only
/// along `straight` paths, which are cut to the bound exactly: a curved
/// path is searched over pieces (or a ball) that reach past it. A
/// surface lying along a face within `epsilon` is not cut by it, so the
/// tracer checks a hit within `epsilon` of the faces against the clip
/// (`cos(x)`, the planes its own bound's faces hold, in a ball).
///
/// [`Object::clip_cuts`]: crate::scene::Object::clip_cuts
pub fn clip_cuts(
    f: &Implicit,
    clip: Option<&Implicit>,
    bound: Option<Aabb>,
    epsilon: f64,
    straight: bool,
) -> bool {
    let (Some(c), Some(b)) = (clip, bound) else {
        return clip.is_some();
    };
    let inner = b.shrunk(epsilon);
    !straight || inner.is_empty() || clip_cuts_within(f, c, inner)
}

/// Whether `clip` may cut the surface of `f` within `region`: some box
/// in it may hold a point where the clip is positive (or undefined) and
/// `f` vanishes. False only where a descent proves there is none; out of
/// budget, true.
pub fn clip_cuts_within(f: &Implicit, clip: &Implicit, region: Aabb) -> bool {
    bound_where(
        region,
        f.value_tape.len() + clip.value_tape.len(),
        (),
        |lo, hi, &(), slots: &mut Vec<Interval>| {
            let kept = clip.interval(lo, hi, slots);
            ((kept.is_empty() || kept.hi > 0.0) && f.interval(lo, hi, slots).contains(0.0))
                .then_some(())
        },
    )
    .is_some()
}

/// What narrows an object's searches within `region`: its bound, the
/// grid of cells where its surface may lie, and its shorter formulas per
/// cell (each `None` where there is none). Where paths curve (`straight`
/// false), formulas for blocks of cells too: a curved piece that crosses
/// a cell face is searched with its block's (see
/// [`PrunedCells::formula_over`]).
pub fn search_aids(
    f: &Implicit,
    clip: Option<&Implicit>,
    region: Aabb,
    straight: bool,
) -> (Option<Aabb>, Option<CellGrid>, Option<Arc<PrunedCells>>) {
    let bound = object_bound(f, clip, region);
    // A quadric is met in closed form: its cells would serve only a
    // forced interval search, and cost 4096 evaluations per object.
    let (cells, descent) = match bound.filter(|_| f.quadric.is_none()) {
        Some(b) => {
            let (cells, descent) = compute_cells(f, clip, b);
            (Some(cells), descent)
        }
        None => (None, None),
    };
    // Along curves a formula must be long for its cells to pay (see
    // `compute_pruned`), and deciding them is most of a short one's
    // compile: a smooth union of 16 balls (31 operations) spent 0.8 G
    // instructions on cells it then dropped.
    // A union met part by part along straight paths (see `Route::Union`)
    // gets its cells' formulas too: `--method interval`, which the scene
    // may be given after it is compiled, searches with them.
    let pruned = cells
        .as_ref()
        .filter(|_| straight || f.value_tape.operations() >= CURVED_PRUNE_OPERATIONS)
        .and_then(|c| compute_pruned(f, c, descent, !straight));
    (bound, cells, pruned)
}

/// What each part's search needs, where `f` is a union (see
/// [`Implicit::union`]): a box within `bound` holding its surface, and
/// its values' errors there. Empty otherwise.
pub fn parts(f: &Implicit, bound: Option<Aabb>) -> Vec<Part> {
    match (f.union.as_deref(), bound) {
        (Some(parts), Some(bound)) => parts
            .iter()
            .map(|p| {
                let bound = compute_bound(p, bound);
                Part {
                    bound,
                    value_errors: value_errors(p, bound),
                }
            })
            .collect(),
        _ => Vec::new(),
    }
}

/// How far `f`'s values may be off anywhere in `bound`, for an object
/// whose route interpolates a polynomial along straight paths (see
/// [`ValueErrors`]).
pub fn value_errors(f: &Implicit, bound: Option<Aabb>) -> Option<ValueErrors> {
    let degree = f.degree?;
    let b = bound?;
    (degree <= MOST_INTERPOLATED_DEGREE)
        .then(|| ValueErrors::over_box(f.solved_tape(), b.min, b.max))
        .flatten()
}

/// An object's bound: where `f` may vanish within `region`, and within
/// the part of it where `clip` may be negative or zero, if it has one (an
/// explicit bound: it only ever shrinks the box rays search).
pub fn object_bound(f: &Implicit, clip: Option<&Implicit>, region: Aabb) -> Option<Aabb> {
    let region = match clip {
        Some(c) => {
            let kept = bound_where(
                region,
                c.value_tape.len(),
                (),
                |lo, hi, &(), slots: &mut Vec<Interval>| {
                    (c.interval(lo, hi, slots).lo <= 0.0).then_some(())
                },
            )?;
            Aabb {
                min: region.min.max(kept.min),
                max: region.max.min(kept.max),
            }
        }
        None => region,
    };
    if region.is_empty() {
        return None;
    }
    compute_bound(f, region)
}

/// Along curved paths, formulas shorter than this are not worth pruning
/// per cell (a cell's search must evaluate a quarter of the formula or
/// less, and one holds a few parts of ten operations or so).
const CURVED_PRUNE_OPERATIONS: usize = 128;

/// Formulas shorter than this are not worth pruning per cell.
const SHORT_TAPE: usize = 24;

/// Whether `f` is worth deciding box by box with its choices made (see
/// [`Implicit::on_box`]): it has choices, and enough operations that
/// skipping the untaken ones pays for the bookkeeping.
fn prunes(f: &Implicit) -> bool {
    f.has_choices() && f.value_tape.len() >= SHORT_TAPE
}

/// A box holding every point of `region` where `f` may be zero, or `None`
/// when `f` is provably non-zero throughout the region.
pub fn compute_bound(f: &Implicit, region: Aabb) -> Option<Aabb> {
    // An ellipsoid's box is known in closed form: ten thousand small
    // balls once took 18 s of searches to bound.
    if let Some(ellipsoid) = f.quadric.as_ref().and_then(|q| q.ellipsoid_box()) {
        let (min, max) = ellipsoid?;
        let (min, max) = (min.max(region.min), max.min(region.max));
        return min.cmple(max).all().then_some(Aabb { min, max });
    }
    let len = f.value_tape.len();
    if prunes(f) {
        // Each cell is decided with its parent's choices made: deep in
        // the descent a union of a hundred parts is one or two there.
        let budget = FormulaBudget::default();
        bound_where(
            region,
            len,
            f.unpruned(),
            |lo, hi, parent, scratch: &mut PruneScratch| {
                let made = scratch.made_steps;
                match f.on_box(lo, hi, parent, scratch) {
                    OnBox::Empty => None,
                    OnBox::Kept(formula) => {
                        Some(budget.admit(formula, parent, scratch.made_steps - made))
                    }
                }
            },
        )
    } else {
        let coarse = bound_where(region, len, (), |lo, hi, &(), slots: &mut Vec<Interval>| {
            f.interval(lo, hi, slots).contains(0.0).then_some(())
        })?;
        // Where `f` is a sum with a polynomial part in one coordinate, the
        // box is searched again with that part's exact range (and within
        // the plain interval too, so it is never looser): intervals leave
        // Chmutov's octic bounded at 1.9 per axis, where its surface ends
        // at 1.014. The descent above stays plain: it may need hundreds of
        // levels, and the sharper test costs more.
        let Some(split) = f.split_sum(0.5 * (coarse.min + coarse.max)) else {
            return Some(coarse);
        };
        bound_where(
            coarse,
            len + SPLIT_COST,
            (),
            |lo, hi, &(), s: &mut SplitScratch| {
                let plain = f.interval(lo, hi, &mut s.intervals);
                (plain.contains(0.0) && split.interval(lo, hi, s).contains(0.0)).then_some(())
            },
        )
    }
}

/// What a [`SplitSum`](crate::expr::SplitSum)'s enclosure is charged, in
/// tape operations, in the budgets of the second search: a part's range
/// is a shift, a conversion and a branch and bound, some thousands of
/// operations. At 20 000 that search adds about 10 ms to Chmutov's
/// compile (at 2 000, 30 ms), and still finds its box to 1.014.
const SPLIT_COST: usize = 20000;

/// A box holding every point of `region` that `keep` keeps, found with
/// work in proportion to `tape_len`, the length of the tape `keep`
/// evaluates (see the budgets above). `keep` tests
/// a box given what its parent's test found (`root` for the region) and
/// returns what it finds there, or `None` to drop the box; what it finds
/// must hold over every box inside.
fn bound_where<K: Clone + Send + Sync, S: Default + Send>(
    region: Aabb,
    tape_len: usize,
    root: K,
    keep: impl Fn(DVec3, DVec3, &K, &mut S) -> Option<K> + Sync,
) -> Option<Aabb> {
    let cells_per_face = face_search_cells(tape_len);
    let root = keep(region.min, region.max, &root, &mut S::default())?;
    let mut cells = vec![(region.min, region.max, root.clone())];
    let mut tested = 1;
    for _ in 0..MAX_DEPTH {
        if (tested + 8 * cells.len()) * tape_len.max(1) > DESCENT_OPERATIONS {
            break;
        }
        tested += 8 * cells.len();
        // Each level's cells are tested in parallel: a long formula's
        // descent is most of its compile time.
        let next: Vec<(DVec3, DVec3, K)> = cells
            .par_iter()
            .map_init(S::default, |scratch, (lo, hi, found)| {
                let (lo, hi) = (*lo, *hi);
                let mid = (lo + hi) * 0.5;
                let mut kept = Vec::new();
                for octant in 0..8 {
                    let pick = |bit: u32, a: f64, m: f64, b: f64| {
                        if octant & (1 << bit) == 0 {
                            (a, m)
                        } else {
                            (m, b)
                        }
                    };
                    let (x0, x1) = pick(0, lo.x, mid.x, hi.x);
                    let (y0, y1) = pick(1, lo.y, mid.y, hi.y);
                    let (z0, z1) = pick(2, lo.z, mid.z, hi.z);
                    let (clo, chi) = (DVec3::new(x0, y0, z0), DVec3::new(x1, y1, z1));
                    if let Some(k) = keep(clo, chi, found, scratch) {
                        kept.push((clo, chi, k));
                    }
                }
                kept
            })
            .flatten()
            .collect();
        if next.is_empty() {
            return None;
        }
        cells = next;
        if cells.len() > MAX_CELLS {
            break;
        }
    }
    let mut b = Aabb {
        min: DVec3::INFINITY,
        max: DVec3::NEG_INFINITY,
    };
    for (lo, hi, _) in &cells {
        b.min = b.min.min(*lo);
        b.max = b.max.max(*hi);
    }
    // The faces' searches and slabs lie in the region: what its own test
    // found holds there.
    let b = refine_faces(b, cells_per_face, &root, &keep);
    let bisections = (SHRINK_OPERATIONS / (12 * tape_len.max(1))).clamp(8, 64);
    let b = shrink_faces(b, bisections, |lo, hi, scratch: &mut S| {
        keep(lo, hi, &root, scratch).is_some()
    });
    // A contracted box can be as thin as the surface (a plane's slab); a
    // margin keeps roots that rounding puts a hair outside it. A point's
    // coordinate along a path rounds relative to that coordinate, so each
    // axis takes its own: a surface within 0.1 of z = 0 under `max_distance
    // 1e60` keeps a slab 0.1 thick, where one margin for all axes made it
    // 1e51 and every path to the sky searched it.
    let scale = b.min.abs().max(b.max.abs());
    let margin = 1e-9 * (DVec3::ONE + scale);
    Some(Aabb {
        min: b.min - margin,
        max: b.max + margin,
    })
}

/// Pushes each face of `b` in to the extreme of the cells, as small as
/// [`FACE_RESOLUTION`] of the box, where `f` may vanish. The coarse cells
/// stop where their number grows, at an eighth or so of the object's
/// size, and on wide cells the interval of a high-degree polynomial is
/// loose (the dependency problem), so their box can be several times the
/// surface's. For the upper x face, say: cells are taken highest upper x
/// first; one where `f` cannot vanish is dropped, a larger one is split
/// in eight, and the first small one that may hold surface gives the
/// face (every cell left has a lower upper x). A search that runs out of
/// cells keeps the highest face still in its queue, which is as safe.
fn refine_faces<K: Clone + Send + Sync, S: Default + Send>(
    b: Aabb,
    cells_per_face: usize,
    root: &K,
    keep: &(impl Fn(DVec3, DVec3, &K, &mut S) -> Option<K> + Sync),
) -> Aabb {
    use std::cmp::Ordering;
    use std::collections::BinaryHeap;
    // A cell carries what its parent's test found.
    struct Cell<K> {
        key: f64,
        lo: DVec3,
        hi: DVec3,
        parent: K,
    }
    impl<K> PartialEq for Cell<K> {
        fn eq(&self, o: &Self) -> bool {
            self.key.total_cmp(&o.key) == Ordering::Equal
        }
    }
    impl<K> Eq for Cell<K> {}
    impl<K> PartialOrd for Cell<K> {
        fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
            Some(self.cmp(o))
        }
    }
    impl<K> Ord for Cell<K> {
        fn cmp(&self, o: &Self) -> Ordering {
            self.key.total_cmp(&o.key)
        }
    }
    let size = b.max - b.min;
    if !size.is_finite() {
        return b;
    }
    let resolution = size * FACE_RESOLUTION;
    // The six faces' searches are independent: one task each.
    let faces: Vec<(usize, bool, Option<f64>)> = (0..6)
        .into_par_iter()
        .map(|face| {
            let (axis, upper) = (face / 2, face % 2 == 1);
            let mut scratch = S::default();
            // The key orders cells by how far out their face lies.
            let key = |lo: DVec3, hi: DVec3| if upper { hi[axis] } else { -lo[axis] };
            let mut queue = BinaryHeap::new();
            queue.push(Cell {
                key: key(b.min, b.max),
                lo: b.min,
                hi: b.max,
                parent: root.clone(),
            });
            let mut face = None;
            for _ in 0..cells_per_face {
                let Some(cell) = queue.pop() else {
                    break;
                };
                let Some(found) = keep(cell.lo, cell.hi, &cell.parent, &mut scratch) else {
                    continue;
                };
                let extent = cell.hi - cell.lo;
                if extent.cmple(resolution).all() {
                    face = Some(cell.key);
                    break;
                }
                let mid = (cell.lo + cell.hi) * 0.5;
                for octant in 0..8 {
                    let mut lo = cell.lo;
                    let mut hi = cell.hi;
                    for a in 0..3 {
                        // Halve only the axes still wider than the resolution.
                        if extent[a] <= resolution[a] {
                            continue;
                        }
                        if octant & (1 << a) == 0 {
                            hi[a] = mid[a];
                        } else {
                            lo[a] = mid[a];
                        }
                    }
                    if (0..3).any(|a| extent[a] <= resolution[a] && octant & (1 << a) != 0) {
                        continue;
                    }
                    queue.push(Cell {
                        key: key(lo, hi),
                        lo,
                        hi,
                        parent: found.clone(),
                    });
                }
            }
            // Out of cells before a small one: the farthest face queued
            // still holds every cell left.
            (axis, upper, face.or_else(|| queue.peek().map(|c| c.key)))
        })
        .collect();
    let mut out = b;
    for (axis, upper, face) in faces {
        match (face, upper) {
            (Some(k), true) => out.max[axis] = k.min(b.max[axis]),
            (Some(k), false) => out.min[axis] = (-k).max(b.min[axis]),
            // Nothing left anywhere: the caller's cells said otherwise;
            // keep the face.
            (None, _) => {}
        }
    }
    if out.min.cmple(out.max).all() {
        out
    } else {
        b
    }
}

/// Rounds of [`shrink_faces`] at most. A slab is measured from a face and
/// resolved to 2^-30 of the coordinates there, so one round brings a face
/// about nine decades closer to a surface near the origin: a surface
/// within 0.1 of z = 0 in a box reaching 1e300 takes some thirty-five
/// rounds; most boxes settle in one or two.
const ROUNDS: usize = 40;

/// Moves each face of `b` inwards past every slab where `f` provably has
/// no zero. The cells stop at a fixed depth, so the box they make can be
/// loose by a cell's size (for a plane across a large region, a whole unit
/// of empty space that every grazing path would search); this contracts
/// it to the surface. Inclusion-monotone interval arithmetic makes the
/// test monotone in the slab's thickness, so bisection finds the largest
/// empty slab.
fn shrink_faces<S: Default>(
    mut b: Aabb,
    bisections: usize,
    may_vanish: impl Fn(DVec3, DVec3, &mut S) -> bool + Sync,
) -> Aabb {
    // A round that moves no face by this fraction of its width leaves
    // nothing for another round to gain.
    const SETTLED: f64 = 1.0 / 64.0;
    // The largest empty slab at one face of `b`.
    let empty_slab = |b: Aabb, axis: usize, upper: bool| {
        let slab = |d: f64| {
            let (mut lo, mut hi) = (b.min, b.max);
            if upper {
                lo[axis] = b.max[axis] - d;
            } else {
                hi[axis] = b.min[axis] + d;
            }
            (lo, hi)
        };
        // Largest empty thickness found, and smallest known not empty.
        let (mut empty, mut full) = (0.0, b.max[axis] - b.min[axis]);
        let mut scratch = S::default();
        // Finer than the bound's margin (1e-9 of the coordinates) is
        // no use.
        let enough = 2f64.powi(-30) * (b.min[axis].abs().max(b.max[axis].abs()) + full);
        for _ in 0..bisections {
            if full - empty <= enough {
                break;
            }
            let d = 0.5 * (empty + full);
            let (lo, hi) = slab(d);
            if may_vanish(lo, hi, &mut scratch) {
                full = d;
            } else {
                empty = d;
            }
        }
        empty
    };
    for _ in 0..ROUNDS {
        let mut settled = true;
        for axis in 0..3 {
            let width = b.max[axis] - b.min[axis];
            // The upper face is searched in the box the lower one leaves:
            // searched at once, two slabs near half a box of 1e51 each
            // rounded to cover it, and neither face moved.
            let below = empty_slab(b, axis, false);
            if below >= width {
                // An empty slab covering the box: the descent kept a cell
                // the slab's tighter intervals clear; keep the axis as it
                // is rather than trust it.
                continue;
            }
            let mut moved = b;
            moved.min[axis] += below;
            let above = empty_slab(moved, axis, true);
            if above >= moved.max[axis] - moved.min[axis] {
                continue;
            }
            moved.max[axis] -= above;
            b = moved;
            settled &= below.max(above) <= width * SETTLED;
        }
        if settled {
            break;
        }
    }
    b
}

/// The cells of a grid over `bound` where `f` may vanish (and `clip`,
/// if given, may be negative or zero), and for a formula with choices,
/// the descent that found them (see [`Descent`]).
pub fn compute_cells(
    f: &Implicit,
    clip: Option<&Implicit>,
    bound: Aabb,
) -> (CellGrid, Option<Descent>) {
    // A long tape gets a coarser grid, so its compile time stays bounded.
    let len = f.value_tape.len() + clip.map_or(0, |c| c.value_tape.len());
    let mut n = GRID_CELLS;
    while n > 1 && n * n * n * len.max(1) > GRID_OPERATIONS {
        n /= 2;
    }
    let clip_keeps = |lo: DVec3, hi: DVec3, slots: &mut Vec<Interval>| {
        clip.is_none_or(|c| c.interval(lo, hi, slots).lo <= 0.0)
    };
    if let Some(mut descent) = descend(f, bound, n) {
        // Decided with its parent's choices made, a cell of a union of a
        // hundred capsules evaluates one or two of them: a fifteenth of
        // the work of testing every cell with the whole formula.
        let mut slots = Vec::new();
        let mut occupied = vec![false; n * n * n];
        let last = &mut descent.levels.last_mut().expect("a level per halving").1;
        last.retain(|&(c, _)| {
            let index = c[0] + n * (c[1] + n * c[2]);
            let (lo, hi) = CellGrid::cell_box(bound, n, index);
            let kept = clip_keeps(lo, hi, &mut slots);
            occupied[index] = kept;
            kept
        });
        return (CellGrid::from_occupied(bound, n, occupied), Some(descent));
    }
    let occupied = (0..n * n * n)
        .into_par_iter()
        .map_init(Vec::new, |slots, index| {
            let (lo, hi) = CellGrid::cell_box(bound, n, index);
            f.interval(lo, hi, slots).contains(0.0) && clip_keeps(lo, hi, slots)
        })
        .collect();
    (CellGrid::from_occupied(bound, n, occupied), None)
}

/// The levels of an octree descent over an object's bound, each as its
/// cells per axis and the cells where the surface may lie, with the
/// shorter formula of each (decided with its parent's): from 2 cells a
/// side down to the occupancy grid's, whose cells are the grid's
/// occupied ones.
pub struct Descent {
    levels: Vec<(usize, Level)>,
}

/// The cells of one level of a descent where the surface may lie, each
/// with its shorter formula.
type Level = Vec<([usize; 3], Arc<Pruned>)>;

/// The descent over `bound` down to `n` cells a side, when `f` has
/// choices worth making (see [`prunes`]) and `n` is a power of two above
/// 1; `None` otherwise.
fn descend(f: &Implicit, bound: Aabb, n: usize) -> Option<Descent> {
    let size = bound.max - bound.min;
    let positive = size.min_element().partial_cmp(&0.0) == Some(std::cmp::Ordering::Greater);
    if !prunes(f) || n < 2 || !n.is_power_of_two() || !positive || !size.is_finite() {
        return None;
    }
    let mut level = vec![([0; 3], f.unpruned())];
    let mut levels = Vec::new();
    let budget = FormulaBudget::default();
    let mut m = 1;
    while m < n {
        m *= 2;
        level = split_level(f, bound, m, &level, &budget, |_| true);
        // Only the levels [`compute_pruned`] may keep as blocks (of 8
        // cells a side and less) and the last are kept.
        if m * 8 >= SPLIT * n || m == n {
            levels.push((m, level.clone()));
        }
        if budget.spent() {
            return None;
        }
    }
    Some(Descent { levels })
}

/// The steps of shorter formulas one descent may make (about 160 MB):
/// past them, boxes keep their parent's formula, and a descent for cells
/// gives up its shorter formulas. A union of a hundred balls moved in H3,
/// each ball dozens of operations, once held 1.8 GB in near copies of its
/// whole formula at the upper levels, where few choices are made.
const MOST_MADE_STEPS: usize = 4_000_000;

/// What one descent has spent of [`MOST_MADE_STEPS`], shared by the
/// threads deciding its boxes.
#[derive(Default)]
struct FormulaBudget(std::sync::atomic::AtomicUsize);

impl FormulaBudget {
    /// `formula` (found by [`Implicit::on_box`] from `parent`, with
    /// `new_steps` steps of formulas made for it) if the budget allows it,
    /// else `parent`.
    fn admit(&self, formula: Arc<Pruned>, parent: &Arc<Pruned>, new_steps: usize) -> Arc<Pruned> {
        let before = self
            .0
            .fetch_add(new_steps, std::sync::atomic::Ordering::Relaxed);
        match before + new_steps <= MOST_MADE_STEPS {
            true => formula,
            false => parent.clone(),
        }
    }

    /// Whether a formula was refused.
    fn spent(&self) -> bool {
        self.0.load(std::sync::atomic::Ordering::Relaxed) > MOST_MADE_STEPS
    }
}

/// The cells of the level of `m` cells a side whose parents are
/// `parents` (a level of `m / 2`), that `keep` keeps and where the
/// surface may lie, each with its shorter formula. A cell is enlarged as
/// the occupancy grid's are, for the traversal's rounding; a choice
/// proven over a parent holds over its children, which lie inside it.
fn split_level(
    f: &Implicit,
    bound: Aabb,
    m: usize,
    parents: &[([usize; 3], Arc<Pruned>)],
    budget: &FormulaBudget,
    keep: impl Fn([usize; 3]) -> bool + Sync,
) -> Level {
    let size = (bound.max - bound.min) / m as f64;
    let margin = size * 0.02;
    parents
        .par_iter()
        .map_init(PruneScratch::default, |scratch, (c, parent)| {
            let mut found = Vec::new();
            for child in 0..8 {
                let c = [
                    2 * c[0] + (child & 1),
                    2 * c[1] + (child >> 1 & 1),
                    2 * c[2] + (child >> 2),
                ];
                if !keep(c) {
                    continue;
                }
                let lo = bound.min + DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) * size;
                let made = scratch.made_steps;
                if let OnBox::Kept(formula) =
                    f.on_box(lo - margin, lo + size + margin, parent, scratch)
                {
                    let new_steps = scratch.made_steps - made;
                    found.push((c, budget.admit(formula, parent, new_steps)));
                }
            }
            found
        })
        .flatten()
        .collect()
}

/// Each occupied cell of the occupancy grid is split in this many along
/// each axis for its shorter formulas.
const SPLIT: usize = 4;

/// The most distinct shorter formulas an object keeps, and the most tape
/// steps they may have in all (about 40 MB): beyond either, the whole
/// function serves, so memory stays bounded.
const MOST_PRUNED_FUNCTIONS: usize = 8192;
const MOST_PRUNED_STEPS: usize = 2_500_000;

/// The most node visits the cells' decisions may take (about a second):
/// checked before each of the two levels starts, so compile time stays
/// bounded for huge formulas.
const MOST_PRUNE_WORK: usize = 300_000_000;

/// A grid of blocks per axis, and its blocks that may hold surface, each
/// as its index and the choices made there.
type BlockLevel = (usize, Vec<(usize, Arc<Pruned>)>);

/// Shorter formulas per cell of `f` (see [`PrunedCells`]), when `f` has
/// choices to make and making them shortens what the cells' searches
/// evaluate by a quarter or more. The cells are found by an octree from
/// the whole bound down to `SPLIT` times the occupancy grid's resolution,
/// each cell decided with its parent's choices made, so a decision costs
/// only its parent's shorter formula; the levels down to the occupancy
/// grid's are `descent`'s, when [`compute_cells`] made one. With
/// `blocks`, the blocks of 2, 4 and 8 cells a side get theirs too (see
/// [`PrunedCells::blocks`]).
pub fn compute_pruned(
    f: &Implicit,
    cells: &CellGrid,
    descent: Option<Descent>,
    blocks: bool,
) -> Option<Arc<PrunedCells>> {
    if !prunes(f) {
        return None;
    }
    let bound = cells.bound;
    let (coarse, n) = (cells.n, SPLIT * cells.n);
    let fine_size = (bound.max - bound.min) / n as f64;
    if fine_size.min_element().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
        || !fine_size.is_finite()
    {
        return None;
    }
    // From the occupancy grid's descent on (or the whole bound, without
    // one), each level's cells split in two along each axis and decided
    // with their parent's choices made, so each decision evaluates only
    // what its parent left; from the occupancy grid's size on, only cells
    // it marks occupied are kept.
    let whole = f.unpruned();
    let mut level: Level = vec![([0; 3], whole.clone())];
    // With `blocks`, the levels of blocks of 2, 4 and 8 cells a side.
    let mut block_levels: Vec<BlockLevel> = Vec::new();
    let budget = FormulaBudget::default();
    let mut m = 1;
    let keep_block = |m: usize| blocks && m < n && m >= n / 8;
    let block_level = |m: usize, level: &[([usize; 3], Arc<Pruned>)]| {
        let cells = level
            .iter()
            .map(|(c, formula)| (c[0] + m * (c[1] + m * c[2]), formula.clone()))
            .collect();
        (m, cells)
    };
    if let Some(descent) = descent.filter(|d| d.levels.last().is_some_and(|l| l.0 == coarse)) {
        for (at, cells) in descent.levels {
            if keep_block(at) {
                block_levels.push(block_level(at, &cells));
            }
            (m, level) = (at, cells);
        }
    }
    while m < n {
        let work: usize = level.iter().map(|c| c.1.len() * 8).sum();
        if work > MOST_PRUNE_WORK || !n.is_power_of_two() {
            return None;
        }
        m *= 2;
        let occupied = |c: [usize; 3]| {
            m < coarse || {
                let r = m / coarse;
                cells.cell_occupied(c[0] / r, c[1] / r, c[2] / r)
            }
        };
        level = split_level(f, bound, m, &level, &budget, occupied);
        if keep_block(m) {
            block_levels.push(block_level(m, &level));
        }
        if budget.spent() {
            return None;
        }
    }
    let leaves: Vec<(usize, Arc<Pruned>)> = level
        .into_iter()
        .map(|(c, formula)| (c[0] + n * (c[1] + n * c[2]), formula))
        .collect();
    let mut index = vec![PrunedCells::EMPTY; n * n * n];
    let mut distinct = Distinct::default();
    for (cell, formula) in &leaves {
        let id = distinct.id(formula);
        if distinct.formulas.len() > MOST_PRUNED_FUNCTIONS {
            return None;
        }
        index[*cell] = id;
    }
    // The blocks' formulas, finest first, unless they would pass the
    // limits (then curved pieces across cell faces take the full one).
    let leaf_count = distinct.formulas.len();
    let mut block_indexes: Vec<(usize, Vec<u32>)> = Vec::new();
    for (m, blocks) in &block_levels {
        let mut index = vec![PrunedCells::EMPTY; m * m * m];
        for (block, formula) in blocks {
            index[*block] = distinct.id(formula);
        }
        block_indexes.push((*m, index));
    }
    let mut distinct = distinct.formulas;
    if distinct.len() > MOST_PRUNED_FUNCTIONS {
        distinct.truncate(leaf_count);
        block_indexes.clear();
    }
    let functions: Vec<Implicit> = distinct
        .par_iter()
        .map(|&formula| {
            if *formula == *whole {
                f.clone()
            } else {
                f.from_pruned(formula)
            }
        })
        .collect();
    let steps =
        |functions: &[Implicit]| functions.iter().map(|g| g.value_tape.len()).sum::<usize>();
    let mut functions = functions;
    if steps(&functions) > MOST_PRUNED_STEPS {
        functions.truncate(leaf_count);
        block_indexes.clear();
    }
    if steps(&functions) > MOST_PRUNED_STEPS {
        return None;
    }
    let mut pruned = PrunedCells::new(bound, n, index, functions);
    pruned.blocks = block_indexes.into_iter().rev().collect();
    // Worth it only if a cell's search evaluates a good deal less: along
    // a curve, where pieces are cut at cells by their boxes, a quarter
    // (a smooth union of 16 balls, 17 operations a cell against 31, was
    // 25% slower in S3 with its cells).
    let share = if blocks { 0.25 } else { 0.75 };
    (pruned.mean_operations() <= f.value_tape.operations() as f64 * share).then(|| Arc::new(pruned))
}

/// The distinct formulas of a grid's cells, each with its index.
/// Formulas are told apart by their steps, each allocation once: cells
/// mostly share their formula's with their siblings, which its pointer
/// finds at once (hashing every cell's steps, with SipHash, was a quarter
/// of a tube of capsules' compile).
#[derive(Default)]
struct Distinct<'a> {
    by_pointer: HashMap<*const Pruned, u32, foldhash::fast::RandomState>,
    by_steps: HashMap<&'a Pruned, u32, foldhash::fast::RandomState>,
    formulas: Vec<&'a Pruned>,
}

impl<'a> Distinct<'a> {
    /// The index of `formula` among the distinct ones, added if new.
    fn id(&mut self, formula: &'a Arc<Pruned>) -> u32 {
        let (by_steps, formulas) = (&mut self.by_steps, &mut self.formulas);
        *self
            .by_pointer
            .entry(Arc::as_ptr(formula))
            .or_insert_with(|| {
                *by_steps.entry(formula).or_insert_with(|| {
                    formulas.push(formula);
                    formulas.len() as u32 - 1
                })
            })
    }
}

/// Cells per axis of the grid [`loose_bound`] samples a bound on.
const SAMPLE_CELLS: usize = 32;

/// A bound that sampling shows to be looser than its surface, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct LooseBound {
    /// The bound.
    pub bound: Aabb,
    /// The box of the sampling grid's cells where the function's sampled
    /// values change sign, grown by a cell: where the surface is seen.
    pub surface: Aabb,
    /// The box of the grid's cells whose intervals may hold zero: it holds
    /// all of the surface, also what lies between samples, so the `clip`
    /// suggested is this.
    pub holds: Aabb,
    /// The subexpression whose interval is the most too wide, over a cell
    /// the bound keeps away from the surface.
    pub culprit: Option<Culprit>,
}

/// The subexpression a [`LooseBound`] blames.
#[derive(Debug, Clone, PartialEq)]
pub struct Culprit {
    /// The subexpression, in the scene language (see [`crate::expr::Tape::describe`]).
    pub expr: String,
    /// How many times wider its interval is than the range of its sampled
    /// values over the cell; infinite when the interval is unbounded.
    pub ratio: f64,
    /// Whether it reads the curved spaces' internal operations (see
    /// [`crate::expr::Tape::uses_internal_ops`]): then `expr` is the space's model, not
    /// anything the user wrote.
    pub internal: bool,
}

impl Culprit {
    /// How much too wide the interval is, for a sentence: "is 12x wider
    /// than its values over a cell far from the surface", never an
    /// infinite or NaN ratio.
    fn width(&self) -> String {
        const CELL: &str = "over a cell far from the surface";
        if !self.ratio.is_finite() {
            format!("is unbounded {CELL}, where its values are finite")
        } else if self.ratio >= 1e6 {
            format!("is {:.0e} times wider than its values {CELL}", self.ratio)
        } else {
            format!("is {:.0}x wider than its values {CELL}", self.ratio)
        }
    }
}

/// `a`, `a` or `b`, `a`, `b` or `c`, each in backquotes.
fn either(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
    match quoted.split_last() {
        None => String::new(),
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
    }
}

impl LooseBound {
    /// What is loose and what to do, in a sentence; `clipped` when the
    /// object already has a clip (then only rewriting helps).
    /// `curved_uses` is [`crate::scene::Object::curved_uses`]: what to
    /// name when the culprit is made of the curved spaces' internal
    /// operations.
    pub fn describe(&self, clipped: bool, curved_uses: &[String]) -> String {
        let advice = self.advice(clipped, curved_uses);
        format!(
            "{}{}",
            self.finding(),
            if advice.is_empty() {
                String::new()
            } else {
                format!("; {advice}")
            }
        )
    }

    /// What sampling found: the bound, and where the surface lies.
    fn finding(&self) -> String {
        let v = |p: DVec3| format!("({:.3}, {:.3}, {:.3})", p.x, p.y, p.z);
        format!(
            "its bound {} .. {} is loose, which makes rays search empty space: sampled on a {n}^3 grid over the bound, its surface lies within {} .. {} (to a grid cell)",
            v(self.bound.min),
            v(self.bound.max),
            v(self.surface.min),
            v(self.surface.max),
            n = SAMPLE_CELLS
        )
    }

    /// A box formula that holds the sampled surface box, its sizes
    /// rounded up to two digits: `box(1.1, 1.1, 0.52)`, moved with `at`
    /// when the box is off the origin.
    fn clip_around(b: Aabb) -> String {
        let up = |v: f64| {
            if v.is_nan() || v <= 0.0 || v.is_infinite() {
                return "1".to_string();
            }
            let unit = 10f64.powf(v.log10().floor() - 1.0);
            let r = (v / unit).ceil() * unit;
            let t = format!("{r:.6}");
            t.trim_end_matches('0').trim_end_matches('.').to_string()
        };
        let near = |v: f64| {
            let t = format!("{v:.2}");
            t.trim_end_matches('0').trim_end_matches('.').to_string()
        };
        let (lo, hi) = (b.min, b.max);
        let centre = 0.5 * (lo + hi);
        let half = 0.5 * (hi - lo);
        if centre
            .abs()
            .cmple(0.05 * half.max(DVec3::splat(1e-300)))
            .all()
        {
            let r = lo.abs().max(hi.abs());
            return format!("box({}, {}, {})", up(r.x), up(r.y), up(r.z));
        }
        let moved = |axis: &str, c: f64| {
            if near(c) == "0" || near(c) == "-0" {
                axis.to_string()
            } else if c < 0.0 {
                format!("{axis} + {}", near(-c))
            } else {
                format!("{axis} - {}", near(c))
            }
        };
        // The half sizes allow for the centre's rounding to two decimals.
        let slack = 0.005;
        format!(
            "box({}, {}, {}) at ({}, {}, {})",
            up(half.x + slack),
            up(half.y + slack),
            up(half.z + slack),
            moved("x", centre.x),
            moved("y", centre.y),
            moved("z", centre.z)
        )
    }

    /// Why the bound is loose (the culprit, when one is found) and what
    /// to do, as one clause; empty when there is nothing to say (no
    /// culprit, and already clipped).
    pub fn advice(&self, clipped: bool, curved_uses: &[String]) -> String {
        // Where the cells whose intervals may hold zero fill the bound
        // (intervals loose everywhere, as a formula moved in S3 is), a box
        // of them would clip nothing: the advice is sampling's box, grown
        // by a quarter for what lies between samples (a trial was told
        // `clip box(32, 32, 32)` for a surface within 4 of the origin).
        let bound_size = self.bound.max - self.bound.min;
        let holds_size = self.holds.max - self.holds.min;
        let clip = if holds_size.cmpge(bound_size * 0.9).all() {
            let grow = (self.surface.max - self.surface.min) * 0.125;
            let around = Aabb {
                min: self.surface.min - grow,
                max: self.surface.max + grow,
            };
            format!(
                "give the object a `clip` around its surface, in its own coordinates: `clip {}` holds what sampling sees, with a margin of a quarter (a part finer than the {n}^3 sampling grid could lie beyond it)",
                Self::clip_around(around),
                n = SAMPLE_CELLS
            )
        } else {
            format!(
                "give the object a `clip` around its surface, in its own coordinates: `clip {}` holds all of it",
                Self::clip_around(self.holds)
            )
        };
        let clip = clip.as_str();
        match &self.culprit {
            Some(c) if c.internal => {
                let (why, mut advice) = curved_culprit(c, curved_uses, clipped);
                if !clipped {
                    advice.push(clip.to_string());
                }
                if advice.is_empty() {
                    why
                } else {
                    format!("{why}: {}", advice.join("; "))
                }
            }
            Some(c) => format!(
                "the interval of `{}` {}, so such cells cannot be ruled out: write that part another way (an expanded polynomial is loose on wide cells; factor it, or nest it in Horner form){}",
                c.expr,
                c.width(),
                if clipped { String::new() } else { format!(", or {clip}") }
            ),
            None if clipped => String::new(),
            None => clip.to_string(),
        }
    }
}

/// Whether `f`'s bound is looser than its surface: samples on a grid of
/// 32^3 cells over `bound` find where `f` changes sign; if
/// the bound is more than 1.5 times that box (grown by a cell) along some
/// axis, it is loose, and a cell it keeps away from the surface says why:
/// each operation's interval there against the range of its values at
/// 125 points of the cell, the culprit being the operation that widens
/// most beyond what its operands already did (the dependency problem
/// shows up at one operation, and everything above it inherits it).
/// `None` when the bound is tight, or when no sign change is sampled (a
/// surface thinner than the grid: sampling cannot tell).
pub fn loose_bound(f: &Implicit, bound: Aabb) -> Option<LooseBound> {
    match sample_bound(f, bound, 0.0) {
        Sampled::Loose(loose) => Some(loose),
        _ => None,
    }
}

/// The points [`sample_bound`] evaluates `f` at.
pub const SAMPLED_POINTS: usize = (SAMPLE_CELLS + 1).pow(3);

/// What sampling `f` over its bound shows (see [`loose_bound`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Sampled {
    /// The bound is looser than the surface.
    Loose(LooseBound),
    /// The surface's sign changes reach the bound's faces.
    Tight,
    /// No sign change anywhere on the grid: a formula that is never 0
    /// where intervals cannot show it, or a surface finer than the grid.
    NoSurface,
    /// Not sampled: a closed form, or a flat bound (a plane's slab).
    Unsampled,
}

/// Points per axis of the grid [`undefined_share`] samples.
const UNDEFINED_SAMPLES: usize = 17;
/// Points [`undefined_share`] samples (each one evaluation of the formula
/// and of its clip).
pub const UNDEFINED_POINTS: usize = UNDEFINED_SAMPLES * UNDEFINED_SAMPLES * UNDEFINED_SAMPLES;

/// Where a formula is not a number over part of its bound: the share of
/// the sampled points, and whether it has both signs at the others.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Undefined {
    /// The share of the points kept at which `f` is not a number.
    pub share: f64,
    /// Whether `f` has both signs where it is a number. Where it has one,
    /// its only zeros (its bound says it may vanish) are where it stops
    /// being defined, as in `sqrt(x^2 + y^2 + z^2 - 0.5)`.
    pub both_signs: bool,
}

/// Whether `f` is not a number at some of the points of a grid over
/// `bound` (where `clip`, if any, keeps them): a formula undefined over
/// part of the region its surface would cross (`sphere(1.5) + 0.1 *
/// sqrt(x)`, NaN where x < 0), where no surface is drawn. `None` where it
/// is defined everywhere sampled, or nowhere.
pub fn undefined_share(f: &Implicit, clip: Option<&Implicit>, bound: Aabb) -> Option<Undefined> {
    let n = UNDEFINED_SAMPLES;
    let size = (bound.max - bound.min) / (n - 1) as f64;
    if !size.is_finite() {
        return None;
    }
    // In parallel, a plane of points each: a long formula's samples were
    // a tenth of its compile, after everything else.
    let (kept, undefined, neg, pos) = (0..n)
        .into_par_iter()
        .map_init(Vec::new, |slots, i| {
            let (mut kept, mut undefined, mut neg, mut pos) = (0usize, 0usize, false, false);
            for j in 0..n {
                for k in 0..n {
                    let p = bound.min + size * DVec3::new(i as f64, j as f64, k as f64);
                    if clip.is_some_and(|c| c.value(p, slots) > 0.0) {
                        continue;
                    }
                    kept += 1;
                    let v = f.value(p, slots);
                    undefined += v.is_nan() as usize;
                    neg |= v < 0.0;
                    pos |= v > 0.0;
                }
            }
            (kept, undefined, neg, pos)
        })
        .reduce(
            || (0, 0, false, false),
            |a, b| (a.0 + b.0, a.1 + b.1, a.2 || b.2, a.3 || b.3),
        );
    if !(undefined > 0 && undefined < kept) {
        return None;
    }
    // One sign at the points is a claim about the whole bound only where
    // intervals over the cells between them show no other: a trumpet
    // `ln(x) + y^2 + z^2 - 1` is positive at every point of a grid over
    // a bound of 200 units, and negative where x < 1 between them.
    let mut intervals = Vec::new();
    let both_signs = (neg && pos)
        || (0..(n - 1).pow(3)).any(|index| {
            let cell = DVec3::new(
                (index / ((n - 1) * (n - 1))) as f64,
                ((index / (n - 1)) % (n - 1)) as f64,
                (index % (n - 1)) as f64,
            );
            let lo = bound.min + size * cell;
            let r = f.interval(lo, lo + size, &mut intervals);
            if pos {
                r.lo < 0.0
            } else {
                r.hi > 0.0
            }
        });
    Some(Undefined {
        share: undefined as f64 / kept as f64,
        both_signs,
    })
}

/// Samples `f` on the grid [`loose_bound`] describes. A bound at most
/// `worth_volume` times the sampled surface's box in volume counts as
/// tight: its looseness costs too little to say why, and the cells'
/// intervals that would say it (32^3 of them) are not evaluated.
pub fn sample_bound(f: &Implicit, bound: Aabb, worth_volume: f64) -> Sampled {
    let n = SAMPLE_CELLS;
    let size = (bound.max - bound.min) / n as f64;
    // A closed form does not search its bound; and a flat bound (a plane's
    // slab) has nothing to sample across.
    if f.quadric.is_some() || !size.is_finite() || size.min_element() <= 1e-6 * size.max_element() {
        return Sampled::Unsampled;
    }
    let corner =
        |i: usize, j: usize, k: usize| bound.min + size * DVec3::new(i as f64, j as f64, k as f64);
    let mut slots = Vec::new();
    let m = n + 1;
    let mut values = vec![0.0; m * m * m];
    for i in 0..m {
        for j in 0..m {
            for k in 0..m {
                values[(i * m + j) * m + k] = f.value(corner(i, j, k), &mut slots);
            }
        }
    }
    let at = |i: usize, j: usize, k: usize| values[(i * m + j) * m + k];
    let mut surface = Aabb {
        min: DVec3::INFINITY,
        max: DVec3::NEG_INFINITY,
    };
    let mut found = false;
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let (mut neg, mut pos) = (false, false);
                for c in 0..8 {
                    let v = at(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
                    neg |= v <= 0.0;
                    pos |= v >= 0.0;
                }
                if neg && pos {
                    found = true;
                    surface.min = surface.min.min(corner(i, j, k) - size);
                    surface.max = surface.max.max(corner(i + 1, j + 1, k + 1) + size);
                }
            }
        }
    }
    if !found {
        return Sampled::NoSurface;
    }
    let surface = Aabb {
        min: surface.min.max(bound.min),
        max: surface.max.min(bound.max),
    };
    let loose_around = |surface: Aabb| {
        (0..3).any(|a| bound.max[a] - bound.min[a] > 1.5 * (surface.max[a] - surface.min[a]))
    };
    let volume = |b: Aabb| (b.max - b.min).max(DVec3::splat(1e-300)).element_product();
    if !loose_around(surface) || volume(bound) <= worth_volume * volume(surface) {
        return Sampled::Tight;
    }
    // Points miss what lies between them (a wave whose crests fall
    // between samples 6 units apart): the `clip` suggested is the box of
    // the cells where intervals, over cells as small as the grid's, may
    // hold the surface. Where that box is the bound, the bound was right.
    let mut intervals = Vec::new();
    let mut holds = Aabb {
        min: DVec3::INFINITY,
        max: DVec3::NEG_INFINITY,
    };
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let (lo, hi) = (corner(i, j, k), corner(i + 1, j + 1, k + 1));
                if f.interval(lo, hi, &mut intervals).contains(0.0) {
                    holds.min = holds.min.min(lo);
                    holds.max = holds.max.max(hi);
                }
            }
        }
    }
    let narrower =
        (0..3).any(|a| holds.max[a] - holds.min[a] < 0.95 * (bound.max[a] - bound.min[a]));
    if holds.is_empty() {
        return Sampled::Tight;
    }
    // The widest gap between the surface's box and the bound's faces, as
    // a slab of the bound: its interval holds zero (else the bound would
    // have shrunk past it), and says which operation is loose there.
    let mut kept = None;
    let mut widest = 0.0;
    for axis in 0..3 {
        for upper in [false, true] {
            let (mut lo, mut hi) = (bound.min, bound.max);
            if upper {
                lo[axis] = surface.max[axis];
            } else {
                hi[axis] = surface.min[axis];
            }
            let gap = hi[axis] - lo[axis];
            if gap > widest && gap > size[axis] {
                widest = gap;
                kept = Some((lo, hi));
            }
        }
    }
    let culprit = kept.and_then(|(lo, hi)| culprit(f, lo, hi));
    // Intervals over small cells clearing no more than the bound did: the
    // samples missed part of the surface, unless an interval is unbounded
    // (`ln`, a horosphere's model) or the curved spaces' model is the
    // culprit, which no cell size tightens.
    if !narrower
        && culprit
            .as_ref()
            .is_none_or(|c| c.ratio.is_finite() && !c.internal)
    {
        return Sampled::Tight;
    }
    Sampled::Loose(LooseBound {
        bound,
        surface,
        holds,
        culprit,
    })
}

/// The operation of `f`'s value tape whose interval over the box widens
/// most beyond its operands', with how many times wider than its sampled
/// range the interval is.
fn culprit(f: &Implicit, lo: DVec3, hi: DVec3) -> Option<Culprit> {
    let tape = &f.value_tape;
    let mut intervals: Vec<Interval> = Vec::new();
    let mut out = [Interval::new(0.0, 0.0)];
    let boxed = [
        Interval::new(lo.x, hi.x),
        Interval::new(lo.y, hi.y),
        Interval::new(lo.z, hi.z),
    ];
    tape.eval_into(&boxed, &mut intervals, &mut out);
    let mut low = vec![f64::INFINITY; intervals.len()];
    let mut high = vec![f64::NEG_INFINITY; intervals.len()];
    let mut points: Vec<f64> = Vec::new();
    let mut single = [0.0];
    for c in 0..125 {
        let t = DVec3::new((c % 5) as f64, ((c / 5) % 5) as f64, (c / 25) as f64) * 0.25;
        let p = lo + (hi - lo) * t;
        tape.eval_into(&[p.x, p.y, p.z], &mut points, &mut single);
        for (s, &v) in points.iter().enumerate() {
            low[s] = low[s].min(v);
            high[s] = high[s].max(v);
        }
    }
    let ratio = |s: usize| {
        let width = intervals[s].hi - intervals[s].lo;
        let range = (high[s] - low[s]).max(1e-12 * (1.0 + low[s].abs().max(high[s].abs())));
        width / range
    };
    let mut best: Option<(usize, f64, f64)> = None;
    for s in tape.operation_slots() {
        let own = ratio(s);
        // NaN (an undefined value) is no culprit.
        if own.is_nan() || own <= 1.5 {
            continue;
        }
        let inherited = tape
            .operands(s)
            .into_iter()
            .map(ratio)
            .fold(1.0f64, f64::max);
        let created = if own.is_infinite() && inherited.is_infinite() {
            1.0
        } else {
            own / inherited
        };
        if best.is_none_or(|(_, c, _)| created > c) {
            best = Some((s, created, own));
        }
    }
    best.map(|(s, _, own)| Culprit {
        expr: tape.describe(s, 80),
        ratio: own,
        internal: tape.uses_internal_ops(s),
    })
}

/// For a culprit made of the curved spaces' internal operations: the
/// clause saying what is loose, naming what the user wrote
/// (`curved_uses`), and the advice for it, as clauses (a new `clip` is
/// the caller's to add; a tighter one is advised when `clipped`).
fn curved_culprit(c: &Culprit, curved_uses: &[String], clipped: bool) -> (String, Vec<String>) {
    let builtins: Vec<&str> = curved_uses
        .iter()
        .map(String::as_str)
        .filter(|u| *u != "translate")
        .collect();
    let moved = curved_uses.iter().any(|u| u == "translate");
    let what = match (builtins.is_empty(), moved) {
        (false, false) => format!("the interval of {}", either(&builtins)),
        (false, true) => format!(
            "the interval of {} or of a translated part of the combination",
            either(&builtins)
        ),
        (true, _) => "the interval of a translated part of the combination".to_string(),
    };
    let why = format!(
        "{what} (computed through the space's model) {}, so such cells cannot be ruled out",
        c.width()
    );
    let mut advice = Vec::new();
    if builtins.contains(&"geodesic_distance") {
        advice.push(
            "a ball is faster written as `sphere(r) translate c`, which is met in closed form"
                .to_string(),
        );
    }
    if moved {
        advice.push(
            "a part moved as a whole is faster as its own object, placed by `translate`"
                .to_string(),
        );
    }
    if clipped {
        advice.push("a tighter `clip` leaves fewer such cells".to_string());
    }
    (why, advice)
}
