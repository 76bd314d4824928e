//! The checked, compiled scene: every value validated, every shape turned
//! into an [`Implicit`] function. This is what the tracer renders; a render
//! is a pure function of a `Scene` and its [`RenderSettings`].

use glam::DVec3;

use crate::camera::Camera;
use crate::expr::Implicit;
use crate::space::{Aabb, Placement, Space, SpaceKind};

/// A compiled scene: everything [`crate::render()`] needs, produced by
/// [`crate::compile_source`] from a scene file plus the prelude.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The `camera` directive, with its frame and image size resolved.
    pub camera: Camera,
    /// What to draw, in the order the `object` items are written; a
    /// [`crate::trace::Hit`]'s `object` indexes this list.
    pub objects: Vec<Object>,
    /// The `light` directives in the order written; may be empty (Lambert
    /// shading then shows ambient light alone).
    pub lights: Vec<Light>,
    /// Fraction of an object's colour seen without direct light.
    pub ambient: f64,
    /// Linear RGB.
    pub background: DVec3,
    /// The `space` directive (Euclidean by default), with its parameters
    /// checked; [`Scene::build_space`] turns it into something that walks rays.
    pub space: SpaceKind,
    /// The `render` block, or its defaults.
    pub settings: RenderSettings,
    /// Whether the scene reads `time` or `frame`: if not, every frame of an
    /// animation is the same image.
    pub animated: bool,
    /// What in the file is likely not what its writer meant (codes
    /// `W....`), in source order; the scene renders anyway.
    pub warnings: Vec<crate::diagnostic::Diagnostic>,
    /// The files the scene imports, as their paths were resolved (for
    /// `nes watch`, which renders again when one changes).
    pub imports: Vec<std::path::PathBuf>,
}

impl Scene {
    /// The scene's space, ready to walk rays in: `method ode` integrates
    /// the paths where the space can.
    pub fn build_space(&self) -> Box<dyn Space> {
        let integrate = (self.settings.method == Method::Ode).then_some(self.settings.tolerance);
        self.space
            .build(self.camera.forward, integrate, self.settings.tolerance)
    }

    /// The space in words, for `nes explain`.
    pub fn space_description(&self) -> String {
        let integrate = (self.settings.method == Method::Ode).then_some(self.settings.tolerance);
        self.space.description(integrate, self.settings.tolerance)
    }
}

/// The moment a scene is compiled at: `frame` and `time` (seconds, frame
/// divided by the frames per second) are names any expression may use, so
/// a camera, an object or a space can move. A still render is frame 0.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Clock {
    /// The frame number, from 0.
    pub frame: u32,
    /// Seconds since frame 0: `frame / fps`.
    pub time: f64,
}

impl Clock {
    /// Frame `frame` of an animation shown at `fps` frames per second; `fps`
    /// should be positive (it is not checked here).
    pub fn at_frame(frame: u32, fps: f64) -> Clock {
        Clock {
            frame,
            time: frame as f64 / fps,
        }
    }
}

/// How shadow rays travel to the lights.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShadowPaths {
    /// Straight lines in ordinary space, whatever the scene's space (the
    /// seed report's choice).
    Euclidean,
    /// Along the space's own shortest path to the light (in the torus, to
    /// the nearest image of the light).
    Geodesic,
}

/// One object to draw: an `object` item compiled.
#[derive(Debug, Clone)]
pub struct Object {
    /// The solid as written, for messages and `nes explain`.
    pub label: String,
    /// Where the solid is written, for warnings.
    pub span: crate::diagnostic::Span,
    /// In S3 and H3, what `function` uses that compiles to the space's
    /// internal operations, as written: geometric builtins
    /// (`geodesic_distance`, `plane_distance`, `busemann`), the prelude
    /// shapes built on them (`horosphere`, `equidistant`), and
    /// `translate` for a translated part of a combination. Messages about
    /// the formula name these instead of the operations.
    pub curved_uses: Vec<String>,
    /// `f(x, y, z)` in the space's coordinates, with the object's transforms
    /// folded in: the surface is `f = 0`, the inside `f < 0`.
    pub function: Implicit,
    /// What the surface's outer side (facing where `f > 0`) is painted with.
    pub colour: Paint,
    /// What its other side, facing where `f < 0` (seen through an opening
    /// a `clip` or a jump leaves), is painted with, when the object says
    /// `inside ...`; otherwise the inside is painted as the outside.
    pub inside: Option<Paint>,
    /// The `clip` formula, in the same coordinates as `function`: the
    /// surface is drawn only where it is negative or zero, open where it
    /// is cut (not capped).
    pub clip: Option<Implicit>,
    /// Whether the searches must honour `clip`: false when no point of
    /// `bound` (shrunk by epsilon, whose faces cut to epsilon already)
    /// where the clip is positive can be on the surface, and paths are
    /// straight (cut to the bound exactly); searches then pass it over,
    /// and check only a hit within epsilon of the bound's faces.
    pub clip_cuts: bool,
    /// A box that holds every point of the surface that a ray can reach;
    /// `None` when there is none (the object can never be hit).
    pub bound: Option<Aabb>,
    /// Which cells of a grid over the bound may hold surface: straight
    /// paths search only between the first and last such cell they cross.
    pub cells: Option<CellGrid>,
    /// Shorter formulas per cell, where the function has choices a cell
    /// can decide and deciding them pays (see [`PrunedCells`]).
    pub pruned: Option<std::sync::Arc<PrunedCells>>,
    /// Where the function is a union of parts (see
    /// [`Implicit::union`](crate::expr::Implicit::union)), what each
    /// part's search needs, in order; empty otherwise.
    pub parts: Vec<Part>,
    /// How far the function's values may be off in `bound`, for the
    /// polynomial route along straight paths.
    pub value_errors: Option<crate::expr::ValueErrors>,
    /// In S3 and H3, the rigid motions that place the object: `function`,
    /// `clip` and `bound` are then in normal coordinates about its own
    /// centre. Empty in the flat spaces, where transforms are folded into
    /// `function`.
    pub placement: Placement,
}

/// What the search of one part of a union needs (see [`Object::parts`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// A box within the object's bound holding the part's surface, or
    /// `None` where it has none there: a path searches only the parts
    /// whose boxes it meets.
    pub bound: Option<Aabb>,
    /// How far the part's values may be off in its box, for the
    /// polynomial route (see [`Object::value_errors`]).
    pub value_errors: Option<crate::expr::ValueErrors>,
}

impl Object {
    /// The clip the searches must honour: `clip`, unless it cuts no
    /// surface within the bound shrunk by epsilon (see
    /// [`Object::clip_cuts`]).
    pub fn cutting_clip(&self) -> Option<&Implicit> {
        self.clip.as_ref().filter(|_| self.clip_cuts)
    }

    /// The function to evaluate near `local` (object coordinates): the
    /// cell's shorter formula there, where the object has them.
    pub fn function_at(&self, local: DVec3) -> &Implicit {
        self.pruned
            .as_ref()
            .and_then(|p| p.function_at(local))
            .unwrap_or(&self.function)
    }
}

/// How one object's hits are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Route {
    /// Closed form: the object is a plane or a quadric.
    Closed,
    /// The object is a polynomial of degree 3 or more: along a straight
    /// segment, its coefficients in the segment's parameter are computed
    /// in one pass and its first root isolated exactly (Bernstein
    /// subdivision); curved segments fall back to interval isolation.
    Polynomial,
    /// The object is a union (`min`) of a few parts each met in closed
    /// form or by the polynomial route (see
    /// [`Implicit::union`](crate::expr::Implicit::union)): along a
    /// straight segment from outside every part, each part's first root
    /// is found by its own route and the first of them taken; elsewhere,
    /// interval isolation.
    Union,
    /// Guaranteed interval root isolation.
    Interval,
    /// The seed's fixed-step marching.
    March,
    /// The seed's adaptive marching.
    Adaptive,
}

impl Route {
    /// The route `method` gives `object`, in a space whose paths are
    /// `straight` or not (polynomials are solved along lines; on curved
    /// paths they are isolated like any other function).
    pub fn for_object(object: &Object, method: Method, straight: bool) -> Route {
        let closed = object.function.quadric.is_some();
        let polynomial = straight && object.function.degree.is_some();
        let union = straight && object.function.union.is_some();
        match method {
            Method::Auto | Method::Exact if closed => Route::Closed,
            Method::Auto | Method::Exact if polynomial => Route::Polynomial,
            Method::Auto | Method::Exact if union => Route::Union,
            Method::Auto | Method::Exact | Method::Interval | Method::Ode => Route::Interval,
            Method::March => Route::March,
            Method::Adaptive => Route::Adaptive,
        }
    }

    /// The route for a cell's shorter formula (see [`PrunedCells`]) of an
    /// object on the interval route: the closed form or the polynomial
    /// route where the formula there is a quadric or a polynomial.
    pub fn for_cell(f: &Implicit) -> Route {
        if f.quadric.is_some() {
            Route::Closed
        } else if f.degree.is_some() {
            Route::Polynomial
        } else if f.union.is_some() {
            Route::Union
        } else {
            Route::Interval
        }
    }

    /// The route in words.
    pub fn name(self) -> &'static str {
        match self {
            Route::Closed => "closed form",
            Route::Polynomial => "exact polynomial roots",
            Route::Union => "each part's exact roots",
            Route::Interval => "interval root isolation",
            Route::March => "fixed-step march",
            Route::Adaptive => "adaptive march",
        }
    }

    /// Whether the route searches its range piece by piece, so that a
    /// loose bound costs it work; the closed form and the polynomial route
    /// solve a whole range at once, whatever its length.
    pub fn searches(self) -> bool {
        !matches!(self, Route::Closed | Route::Polynomial | Route::Union)
    }
}

/// A regular grid of `n^3` cells over a box, marking the cells where an
/// object's function may vanish (interval arithmetic over each cell,
/// slightly enlarged so that rounding in a path's traversal cannot skip
/// surface that lies on a cell face).
#[derive(Debug, Clone, PartialEq)]
pub struct CellGrid {
    /// The box the grid covers: the object's bound.
    pub bound: Aabb,
    /// Cells along each axis (16 for compiled objects); the grid has `n^3`.
    pub n: usize,
    /// A cell's size, and its reciprocal (NaN or infinite for a flat
    /// bound, which is never narrowed).
    size: DVec3,
    inv_size: DVec3,
    occupied: Vec<bool>,
}

impl CellGrid {
    /// The grid with cell `i + n (j + n k)` marked where `occupied` says,
    /// each tested over its [`CellGrid::cell_box`].
    pub fn from_occupied(bound: Aabb, n: usize, occupied: Vec<bool>) -> CellGrid {
        assert_eq!(occupied.len(), n * n * n, "one mark per cell");
        let size = (bound.max - bound.min) / n as f64;
        CellGrid {
            bound,
            n,
            size,
            inv_size: size.recip(),
            occupied,
        }
    }

    /// The box a cell `index` (`i + n (j + n k)`) of an `n^3` grid over
    /// `bound` is tested on: the cell enlarged by 2% of its size on every
    /// side, so the traversal's rounding near a face cannot skip surface.
    pub fn cell_box(bound: Aabb, n: usize, index: usize) -> (DVec3, DVec3) {
        let size = (bound.max - bound.min) / n as f64;
        let margin = size * 0.02;
        let (i, j, k) = (index % n, index / n % n, index / (n * n));
        let lo = bound.min + DVec3::new(i as f64, j as f64, k as f64) * size;
        (lo - margin, lo + size + margin)
    }

    /// How many of the `n^3` cells may hold surface.
    pub fn occupied_count(&self) -> usize {
        self.occupied.iter().filter(|&&o| o).count()
    }

    /// Whether cell `(i, j, k)` may hold surface.
    pub fn cell_occupied(&self, i: usize, j: usize, k: usize) -> bool {
        self.occupied[i + self.n * (j + self.n * k)]
    }

    fn is_occupied(&self, c: [i64; 3]) -> bool {
        let n = self.n as i64;
        self.occupied[(c[0] + n * (c[1] + n * c[2])) as usize]
    }

    /// The part of `[a, b]` of the line `start + t d` between entering the
    /// first occupied cell and leaving the last, or `None` when the line
    /// crosses no occupied cell there. `[a, b]` should lie in the bound;
    /// `inv` is `1 / d`. The first cell is sought from `a` forwards and
    /// the last from `b` backwards, so a line that meets the surface walks
    /// only the empty cells at either end.
    pub fn narrow(&self, start: DVec3, d: DVec3, inv: DVec3, a: f64, b: f64) -> Option<(f64, f64)> {
        // A flat or degenerate bound (or NaN): nothing to narrow.
        let smallest = self.size.min_element();
        if smallest.is_nan() || smallest <= 0.0 {
            return Some((a, b));
        }
        let length = b - a;
        let origin = self.bound.min;
        let front = self.first_occupied(start + d * a - origin, d, inv, length)?;
        let back = self
            .first_occupied(start + d * b - origin, -d, -inv, length)
            .unwrap_or(0.0);
        let (first, last) = (a + front, b - back);
        // Slack for the traversal's rounding (the cells were enlarged when
        // marked, so no surface lies outside the occupied run).
        let pad = 1e-9 * (1.0 + length.abs() + start.abs().max_element());
        Some(((first - pad).max(a), (last + pad).min(b).max(first)))
    }

    /// How far along `d` from `p` (relative to the grid's corner) the walk
    /// enters its first occupied cell, within `length`: a 3D DDA.
    #[inline]
    fn first_occupied(&self, p: DVec3, d: DVec3, inv: DVec3, length: f64) -> Option<f64> {
        let mut walk = CellWalk::new(self.n, self.size, self.inv_size, p, d, inv)?;
        // A line crosses at most 3n cells of an n^3 grid.
        for _ in 0..3 * self.n + 3 {
            if self.is_occupied(walk.cell) {
                return Some(walk.entered);
            }
            if !walk.advance(length) {
                return None;
            }
        }
        None
    }
}

/// A 3D DDA: the cells of an `n^3` grid a line crosses, in order, from
/// the point `p` (relative to the grid's corner) along `d` (`inv` is
/// `1 / d`).
struct CellWalk {
    n: i64,
    /// The current cell, and the distance at which the line entered it.
    cell: [i64; 3],
    entered: f64,
    step: [i64; 3],
    /// The distance at which the line leaves the current cell's slab
    /// along each axis, and a slab's width in distance.
    next: [f64; 3],
    delta: [f64; 3],
}

impl CellWalk {
    /// `None` when `p` is not finite in cell units.
    fn new(n: usize, size: DVec3, inv_size: DVec3, p: DVec3, d: DVec3, inv: DVec3) -> Option<Self> {
        let n = n as i64;
        let mut walk = CellWalk {
            n,
            cell: [0; 3],
            entered: 0.0,
            step: [0; 3],
            next: [f64::INFINITY; 3],
            delta: [f64::INFINITY; 3],
        };
        for axis in 0..3 {
            let c = p[axis] * inv_size[axis];
            if !c.is_finite() {
                return None;
            }
            let c = (c.floor() as i64).clamp(0, n - 1);
            walk.cell[axis] = c;
            if d[axis] > 0.0 {
                walk.step[axis] = 1;
                walk.delta[axis] = size[axis] * inv[axis];
                walk.next[axis] = ((c + 1) as f64 * size[axis] - p[axis]) * inv[axis];
            } else if d[axis] < 0.0 {
                walk.step[axis] = -1;
                walk.delta[axis] = -size[axis] * inv[axis];
                walk.next[axis] = (c as f64 * size[axis] - p[axis]) * inv[axis];
            }
        }
        Some(walk)
    }

    /// The current cell's index in an x-fastest array.
    fn index(&self) -> usize {
        let [i, j, k] = self.cell;
        (i + self.n * (j + self.n * k)) as usize
    }

    /// Into the next cell; false when the line leaves the grid or passes
    /// `length` first.
    fn advance(&mut self, length: f64) -> bool {
        let next = self.next;
        let axis = if next[0] <= next[1] && next[0] <= next[2] {
            0
        } else if next[1] <= next[2] {
            1
        } else {
            2
        };
        if next[axis] >= length {
            return false;
        }
        self.entered = next[axis];
        self.cell[axis] += self.step[axis];
        if self.cell[axis] < 0 || self.cell[axis] >= self.n {
            return false;
        }
        self.next[axis] += self.delta[axis];
        true
    }
}

/// Shorter formulas for the cells of a grid over an object's bound: in
/// each cell where the surface may lie, the object's function with the
/// `min`, `max` and `smin` choices interval arithmetic proves there
/// already made (see [`crate::expr::prune`]). **A cell's formula equals
/// the object's function everywhere in the cell**, enlarged by a margin
/// for the traversal's rounding; so searches and normals may use it
/// there. Cells with the same choices share one formula.
#[derive(Debug, Clone)]
pub struct PrunedCells {
    bound: Aabb,
    n: usize,
    size: DVec3,
    inv_size: DVec3,
    /// Per cell, the index of its formula in `functions`, or
    /// [`PrunedCells::EMPTY`] where no surface lies.
    cells: Vec<u32>,
    /// The distinct formulas.
    pub functions: Vec<Implicit>,
    /// Coarser grids over the same bound, finest first, as (blocks per
    /// axis, per block the index of its formula or
    /// [`PrunedCells::EMPTY`]): a block's formula serves its whole box.
    pub blocks: Vec<(usize, Vec<u32>)>,
}

impl PrunedCells {
    /// A cell that holds no surface.
    pub const EMPTY: u32 = u32::MAX;

    /// The grid of `n^3` cells over `bound` with each cell's formula.
    pub fn new(bound: Aabb, n: usize, cells: Vec<u32>, functions: Vec<Implicit>) -> PrunedCells {
        let size = (bound.max - bound.min) / n as f64;
        PrunedCells {
            bound,
            n,
            size,
            inv_size: size.recip(),
            cells,
            functions,
            blocks: Vec::new(),
        }
    }

    /// A cell's size along each axis.
    pub fn cell_size(&self) -> DVec3 {
        self.size
    }

    /// Cells along each axis.
    pub fn n(&self) -> usize {
        self.n
    }

    /// How many cells hold surface.
    pub fn occupied_count(&self) -> usize {
        self.cells.iter().filter(|&&c| c != Self::EMPTY).count()
    }

    /// The mean number of value-tape operations over the cells that hold
    /// surface: what a search there evaluates.
    pub fn mean_operations(&self) -> f64 {
        let (mut sum, mut count) = (0usize, 0usize);
        for &k in &self.cells {
            if let Some(f) = self.functions.get(k as usize) {
                sum += f.value_tape.operations();
                count += 1;
            }
        }
        sum as f64 / count.max(1) as f64
    }

    /// The formula of the cell holding `p` (clamped into the grid), if
    /// that cell holds surface.
    pub fn function_at(&self, p: DVec3) -> Option<&Implicit> {
        let n = self.n as i64;
        let c = self.cell_of(p, self.n)?;
        let k = self.cells[(c[0] + n * (c[1] + n * c[2])) as usize];
        self.functions.get(k as usize)
    }

    /// The formula that serves the whole box from `min` to `max`: every
    /// cell it touches (within the grid) holds no surface, or all that do
    /// share one formula. [`OverBox::Mixed`] where they differ, or where
    /// the box spans more than [`PrunedCells::MOST_CELLS_OVER`] cells
    /// (not worth counting: the full formula serves).
    pub fn formula_over(&self, min: DVec3, max: DVec3) -> OverBox<'_> {
        let levels = std::iter::once((self.n, &self.cells))
            .chain(self.blocks.iter().map(|(m, index)| (*m, index)));
        for (n, index) in levels {
            match self.formula_over_grid(n, index, min, max) {
                OverBox::Mixed => {}
                found => return found,
            }
        }
        OverBox::Mixed
    }

    /// [`PrunedCells::formula_over`] on the grid of `n^3` cells with
    /// formulas `index`.
    fn formula_over_grid(&self, n: usize, index: &[u32], min: DVec3, max: DVec3) -> OverBox<'_> {
        let (Some(lo), Some(hi)) = (self.cell_of(min, n), self.cell_of(max, n)) else {
            return OverBox::Mixed;
        };
        let n = n as i64;
        let count: i64 = (0..3).map(|i| hi[i] - lo[i] + 1).product();
        if count > Self::MOST_CELLS_OVER {
            return OverBox::Mixed;
        }
        let mut shared = Self::EMPTY;
        for k in lo[2]..=hi[2] {
            for j in lo[1]..=hi[1] {
                for i in lo[0]..=hi[0] {
                    let c = index[(i + n * (j + n * k)) as usize];
                    if c == Self::EMPTY || c == shared {
                        continue;
                    }
                    if shared != Self::EMPTY {
                        return OverBox::Mixed;
                    }
                    shared = c;
                }
            }
        }
        match self.functions.get(shared as usize) {
            Some(f) => OverBox::One(f),
            None => OverBox::Empty,
        }
    }

    /// The cell of the grid of `n^3` over the bound that holds `p`,
    /// clamped into the grid; `None` for a point that is not finite (a
    /// box reaching it is served by the full formula).
    fn cell_of(&self, p: DVec3, n: usize) -> Option<[i64; 3]> {
        let scale = self.inv_size / (self.n / n) as f64;
        let c = ((p - self.bound.min) * scale).to_array();
        let last = (n - 1) as f64;
        c.iter()
            .all(|v| v.is_finite())
            .then(|| c.map(|v| v.floor().clamp(0.0, last) as i64))
    }

    /// The most cells [`PrunedCells::formula_over`] looks at.
    pub const MOST_CELLS_OVER: i64 = 64;

    /// The runs of cells the line `start + t d` crosses within `[a, b]`
    /// (inside the bound; `inv` is `1 / d`), in order, each run cells of
    /// one formula and empty cells left out: `visit(from, to, f)` for each
    /// until it returns something. Runs are padded for the traversal's
    /// rounding, so a root on a cell face lies in both runs beside it.
    pub fn first_in_runs<T>(
        &self,
        start: DVec3,
        d: DVec3,
        inv: DVec3,
        a: f64,
        b: f64,
        mut visit: impl FnMut(f64, f64, &Implicit) -> Option<T>,
    ) -> Option<T> {
        let length = b - a;
        let p = start + d * a - self.bound.min;
        let pad = 1e-9 * (1.0 + length.abs() + start.abs().max_element());
        let mut walk = CellWalk::new(self.n, self.size, self.inv_size, p, d, inv)?;
        let mut visit_run = |(k, from): (u32, f64), to: f64| -> Option<T> {
            let f = &self.functions[k as usize];
            visit(a + (from - pad).max(0.0), a + (to + pad).min(length), f)
        };
        let mut run: Option<(u32, f64)> = None;
        // A line crosses at most 3n cells of an n^3 grid.
        for _ in 0..3 * self.n + 3 {
            let k = self.cells[walk.index()];
            if run.map(|r| r.0) != Some(k) {
                if let Some(found) = run.and_then(|r| visit_run(r, walk.entered)) {
                    return Some(found);
                }
                run = (k != Self::EMPTY).then_some((k, walk.entered));
            }
            if !walk.advance(length) {
                break;
            }
        }
        run.and_then(|r| visit_run(r, length))
    }
}

/// What serves a box, by [`PrunedCells::formula_over`].
#[derive(Debug, Clone, Copy)]
pub enum OverBox<'a> {
    /// No surface lies in the box.
    Empty,
    /// This formula serves the whole box.
    One(&'a Implicit),
    /// The box's cells need different formulas (or too many to look at).
    Mixed,
}

/// A point light without falloff: the `light` directive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Where the light is, in the space's coordinates. In the torus it is not
    /// repeated: it is where it is written.
    pub position: DVec3,
    /// Linear RGB.
    pub colour: DVec3,
    /// Scales the light's colour (0 to 1e6; 1, the default, is full strength).
    pub intensity: f64,
    /// How the light weakens with distance.
    pub falloff: Falloff,
}

/// How a light weakens with the distance `d` along its path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Falloff {
    /// Not at all (the seed's lights, and the default).
    #[default]
    None,
    /// As the area of the geodesic sphere of radius `d` grows: `1 / d^2`
    /// in flat space, `1 / (R sin(d/R))^2` in S3 (summed over both arcs),
    /// `1 / (R sinh(d/R))^2` in H3.
    Physical,
}

impl Falloff {
    /// Every falloff by name, as scene files write them.
    pub const NAMES: &'static [&'static str] = &["none", "physical"];
}

/// How hits are searched for: the `method` property of the `render` block
/// (or `--method`); [`crate::trace::Route::for_object`] turns it into each
/// object's route.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Closed form where the object allows it, otherwise interval root
    /// isolation.
    Auto,
    /// Closed form only where available (others fall back to `Auto`).
    Exact,
    /// The seed's fixed step with halving on a sign change.
    March,
    /// The seed's adaptive step.
    Adaptive,
    /// Interval root isolation for every object, quadrics included.
    Interval,
    /// The sphere space's rays integrated with DOPRI5 (the seed's route).
    Ode,
}

impl Method {
    /// The names `method` accepts, in the order of the variants.
    pub const NAMES: &'static [&'static str] =
        &["auto", "exact", "march", "adaptive", "interval", "ode"];

    /// The method a name stands for; `None` for a name not in
    /// [`Method::NAMES`].
    pub fn from_name(name: &str) -> Option<Method> {
        Some(match name {
            "auto" => Method::Auto,
            "exact" => Method::Exact,
            "march" => Method::March,
            "adaptive" => Method::Adaptive,
            "interval" => Method::Interval,
            "ode" => Method::Ode,
            _ => return None,
        })
    }

    /// The method's name as a scene writes it; the inverse of
    /// [`Method::from_name`].
    pub fn name(self) -> &'static str {
        match self {
            Method::Auto => "auto",
            Method::Exact => "exact",
            Method::March => "march",
            Method::Adaptive => "adaptive",
            Method::Interval => "interval",
            Method::Ode => "ode",
        }
    }
}

/// How a hit is coloured: the `shading` property of the `render` block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shading {
    /// Ambient plus Lambert diffuse from each light.
    Lambert,
    /// The seed report's look: flat colour, divided by 4 in shadow.
    Flat,
}

/// The `render { ... }` block: how rays are traced and pixels shaded. The
/// [`Default`] is what a scene without the block gets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// How hits are searched for (`auto` by default).
    pub method: Method,
    /// Hits are located to within this distance along the ray.
    pub epsilon: f64,
    /// Marching step length.
    pub step: f64,
    /// How far rays travel, as distance along their path (an arc length in the
    /// sphere space); positive, 100 by default.
    pub max_distance: f64,
    /// The most steps (march, adaptive) or pieces (interval isolation) the
    /// searches of one object along one ray may take together, over every
    /// piece of its path (torus wraps) and every image of the object. A
    /// search that runs out reports no hit, and the pixel is counted as
    /// out of steps.
    pub max_steps: u64,
    /// Samples per pixel, on a stratified grid (rounded up to a square).
    pub samples: u32,
    /// How hits are coloured.
    pub shading: Shading,
    /// Whether shadow rays are cast at all (`shadows off` turns them off).
    pub shadows: bool,
    /// Which paths shadow rays follow, when `shadows` is on.
    pub shadow_paths: ShadowPaths,
    /// Relative tolerance of the DOPRI5 integrator (method `ode`).
    pub tolerance: f64,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            method: Method::Auto,
            epsilon: 1e-6,
            step: 0.01,
            max_distance: 100.0,
            max_steps: 20_000,
            samples: 1,
            shading: Shading::Lambert,
            shadows: true,
            shadow_paths: ShadowPaths::Euclidean,
            tolerance: 1e-8,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against sampling: on random lines through a grid with random cells
    /// marked, the narrowed range holds every sample point of the line
    /// that lies in a marked cell, and is empty exactly when none does.
    #[test]
    fn narrowing_keeps_every_marked_cell_the_line_crosses() {
        let mut seed = 12345u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let bound = Aabb {
            min: DVec3::new(-1.0, -2.0, 0.5),
            max: DVec3::new(2.0, 1.0, 1.5),
        };
        let n = 8;
        for _ in 0..20 {
            let density = 0.02 + 0.1 * next();
            let marks: Vec<bool> = (0..n * n * n).map(|_| next() < density).collect();
            let grid = CellGrid::from_occupied(bound, n, marks.clone());
            let cell_of = |p: DVec3| {
                let c = ((p - bound.min) / (bound.max - bound.min) * n as f64).floor();
                let i = |x: f64| (x as usize).min(n - 1);
                (i(c.x), i(c.y), i(c.z))
            };
            for _ in 0..200 {
                let inside = |r: f64, lo: f64, hi: f64| lo + r * (hi - lo);
                let p = DVec3::new(
                    inside(next(), bound.min.x, bound.max.x),
                    inside(next(), bound.min.y, bound.max.y),
                    inside(next(), bound.min.z, bound.max.z),
                );
                let Some(d) = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5).try_normalize()
                else {
                    continue;
                };
                // The line through p, clipped to the bound.
                let start = p - 5.0 * d;
                let Some((a, b)) = bound.clip(start, d.recip(), 0.0, 10.0) else {
                    continue;
                };
                let narrowed = grid.narrow(start, d, d.recip(), a, b);
                let mut any = false;
                for i in 0..=2000 {
                    let t = a + (b - a) * i as f64 / 2000.0;
                    let (x, y, z) = cell_of(start + t * d);
                    if marks[x + n * (y + n * z)] {
                        any = true;
                        let (lo, hi) = narrowed.expect("a marked cell is crossed");
                        assert!(lo <= t && t <= hi, "t = {t} outside [{lo}, {hi}]");
                    }
                }
                if !any {
                    // Sampling can miss a corner the line only clips, so
                    // only a range that holds no sample is allowed.
                    if let Some((lo, hi)) = narrowed {
                        assert!(hi - lo <= 2.0 * (b - a) / 2000.0 + 1e-9, "[{lo}, {hi}]");
                    }
                }
            }
        }
    }
}

/// How one side of a surface is coloured.
#[derive(Debug, Clone)]
pub enum Paint {
    /// One linear colour everywhere.
    Flat(DVec3),
    /// A colour that varies over the surface (boxed: its tapes are large
    /// beside one colour).
    Field(Box<ColourField>),
}

impl Paint {
    /// One linear colour for the whole side: the colour itself, or a
    /// field's at a representative point (for tools that draw one colour
    /// per object, such as ray diagrams).
    pub fn flat(&self) -> DVec3 {
        match self {
            Paint::Flat(c) => *c,
            Paint::Field(f) => f.flat,
        }
    }

    /// The linear colour at the surface point `p` of `function` (in its
    /// coordinates). `slots` is scratch space for point evaluations.
    /// The linear colour at `p`, and whether a colour formula was not a
    /// number there (its component then counts as 0).
    pub fn at(
        &self,
        function: &crate::expr::Implicit,
        p: DVec3,
        slots: &mut Vec<f64>,
    ) -> (DVec3, bool) {
        match self {
            Paint::Flat(c) => (*c, false),
            Paint::Field(f) => {
                let (_, gradient) = function.value_and_gradient(p, slots);
                f.linear_colour_checked(p, gradient.normalize_or_zero(), slots)
            }
        }
    }
}

impl Object {
    /// The paint of the side a ray sees: its inside or its outside.
    pub fn paint(&self, inside: bool) -> &Paint {
        match (&self.inside, inside) {
            (Some(p), true) => p,
            _ => &self.colour,
        }
    }
}

/// A colour written as a formula: sRGB components from the point (input
/// slots 0 to 2), the outward unit normal (3 to 5), the mean curvature (6)
/// and the Gaussian curvature (7).
#[derive(Debug, Clone)]
pub struct ColourField {
    /// The three sRGB components.
    pub tape: crate::expr::Tape,
    /// Its linear colour at the origin with the normal along z and no
    /// curvature: [`Paint::flat`].
    pub flat: DVec3,
    /// `f`'s gradient and Hessian ([`crate::expr::Implicit::second_derivatives`]),
    /// when the field reads a curvature.
    pub second_derivatives: Option<crate::expr::Tape>,
}

impl ColourField {
    /// The linear colour at the surface point `p` (in the coordinates of
    /// `function`, the object's) with outward unit normal `normal`. A
    /// component that is not a number, or outside 0 to 1, is clamped (NaN
    /// to 0), so no pixel is poisoned.
    pub fn linear_colour(&self, p: DVec3, normal: DVec3, slots: &mut Vec<f64>) -> DVec3 {
        self.linear_colour_checked(p, normal, slots).0
    }

    /// [`ColourField::linear_colour`], and whether a component was not a
    /// number (the render counts such pixels).
    pub fn linear_colour_checked(
        &self,
        p: DVec3,
        normal: DVec3,
        slots: &mut Vec<f64>,
    ) -> (DVec3, bool) {
        // Where a curvature is undefined, so is a colour that reads it.
        let (mean, gauss) = self.curvatures(p, slots).unwrap_or((f64::NAN, f64::NAN));
        self.evaluate_checked(
            [p.x, p.y, p.z, normal.x, normal.y, normal.z, mean, gauss],
            slots,
        )
    }

    /// A field of `tape`; its second derivatives are added with
    /// [`ColourField::reads_curvature`] known, by the compiler.
    pub fn new(tape: crate::expr::Tape) -> ColourField {
        let mut field = ColourField {
            tape,
            flat: DVec3::ZERO,
            second_derivatives: None,
        };
        field.flat = field.evaluate([0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0], &mut Vec::new());
        field
    }

    /// Whether the field reads the mean or the Gaussian curvature.
    pub fn reads_curvature(&self) -> bool {
        self.tape.reads_input(6) || self.tape.reads_input(7)
    }

    fn evaluate(&self, inputs: [f64; 8], slots: &mut Vec<f64>) -> DVec3 {
        self.evaluate_checked(inputs, slots).0
    }

    fn evaluate_checked(&self, inputs: [f64; 8], slots: &mut Vec<f64>) -> (DVec3, bool) {
        let mut out = [0.0; 3];
        self.tape.eval_into(&inputs, slots, &mut out);
        let undefined = out.iter().any(|c| c.is_nan());
        let clamp = |c: f64| if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
        (
            out.map(|c| crate::shade::srgb_to_linear(clamp(c))).into(),
            undefined,
        )
    }

    /// The mean and Gaussian curvatures of the surface through `p`, with
    /// the sign convention that a sphere of radius r (negative inside) has
    /// mean curvature 1/r and Gaussian curvature 1/r^2 (Goldman, "Curvature
    /// formulas for implicit curves and surfaces", 2005). `None` when the
    /// field reads neither, or the gradient vanishes or is not finite there.
    pub fn curvatures(&self, p: DVec3, slots: &mut Vec<f64>) -> Option<(f64, f64)> {
        let tape = self.second_derivatives.as_ref()?;
        let mut d = [0.0; 9];
        tape.eval_into(&[p.x, p.y, p.z], slots, &mut d);
        // Both curvatures are the same for c f as for f: dividing by the
        // gradient's size keeps the products below from overflowing or
        // underflowing for formulas scaled by 1e100 or 1e-100.
        let scale = DVec3::new(d[0], d[1], d[2]).abs().max_element();
        if !(scale > 0.0 && scale.is_finite()) {
            return None;
        }
        let d = d.map(|v| v / scale);
        let g = DVec3::new(d[0], d[1], d[2]);
        let [xx, yy, zz, xy, xz, yz] = [d[3], d[4], d[5], d[6], d[7], d[8]];
        let h = glam::DMat3::from_cols(
            DVec3::new(xx, xy, xz),
            DVec3::new(xy, yy, yz),
            DVec3::new(xz, yz, zz),
        );
        let g2 = g.length_squared();
        // The adjugate of the symmetric Hessian, for the Gaussian curvature.
        let adj = glam::DMat3::from_cols(
            DVec3::new(yy * zz - yz * yz, xz * yz - xy * zz, xy * yz - xz * yy),
            DVec3::new(xz * yz - xy * zz, xx * zz - xz * xz, xy * xz - xx * yz),
            DVec3::new(xy * yz - xz * yy, xy * xz - xx * yz, xx * yy - xy * xy),
        );
        let gauss = g.dot(adj * g) / (g2 * g2);
        let mean = (g2 * (xx + yy + zz) - g.dot(h * g)) / (2.0 * g2 * g2.sqrt());
        (mean.is_finite() && gauss.is_finite()).then_some((mean, gauss))
    }
}
