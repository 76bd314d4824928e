//! Finding the first root of `f` along a path segment, by each route.
//!
//! Every function returns the smallest `t` in `[t0, t1]` where the path
//! meets the surface (within the route's tolerance), or `None`. They see a
//! path only through [`Segment`]'s points, directions and bounding boxes,
//! so they serve every space.

use crate::expr::univariate::{
    bernstein_value, first_root_of_bernstein, illinois, interpolation, power_to_bernstein,
    FirstRoot, Refined, RootScratch, MOST_INTERPOLATED_DEGREE,
};
use crate::expr::{
    Dual, F64Lanes, Implicit, Interval, IntervalLanes, LineForm, Magnitude, Taylor, ValueErrors,
};
use crate::space::{Aabb, Segment};

/// What a search is asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Query {
    /// The nearest hit, refined to the tolerance (view rays).
    Nearest,
    /// Whether there is any hit (shadow rays): interval isolation returns
    /// a point of the first piece proven to hold a root, unrefined.
    Any,
}

/// The limits every search of a render shares, from the scene's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// How close to the surface a hit must be located.
    pub epsilon: f64,
    /// The most steps (or pieces) one search may take: what is left of
    /// its ray's budget for the object.
    pub max_steps: u64,
    /// The marching step of the march and adaptive routes.
    pub step: f64,
}

/// One search for the first root of `f` along one segment: what every
/// route needs, in one place.
#[derive(Clone, Copy)]
pub struct Search<'a, 'p> {
    /// The object's function.
    pub f: &'a Implicit,
    /// The piece of path searched.
    pub seg: &'a Segment<'p>,
    /// The render's limits.
    pub limits: Limits,
    /// What is asked.
    pub query: Query,
    /// How far `f`'s values may be off in the object's bound (see
    /// [`ValueErrors`]): for `f` alone, so [`Search::with_formula`] drops it.
    pub value_errors: Option<&'a ValueErrors>,
    /// Where `f` is a union, what each part's search needs (see
    /// [`crate::scene::Object::parts`]), or nothing: for `f` alone, so
    /// [`Search::with_formula`] drops them.
    pub parts: &'a [crate::scene::Part],
}

/// Scratch space reused across evaluations on one thread.
#[derive(Default)]
pub struct Scratch {
    /// Slots for point values, and (kept apart, so that neither is
    /// resized for the other) for values with gradients.
    pub points: Vec<f64>,
    /// Slots for evaluating a gradient tape at a point.
    pub gradient_points: Vec<f64>,
    /// Slots for evaluating a value tape over a box.
    pub intervals: Vec<Interval>,
    /// Slots for evaluating [`LANES`] pieces or points at once.
    pub lane_points: Vec<F64Lanes<LANES>>,
    /// Slots for evaluating [`LANES`] pieces' interval enclosures at once.
    pub lane_intervals: Vec<IntervalLanes<LANES>>,
    /// Slots for a value with its slope along a straight path.
    pub dual_intervals: Vec<Dual<Interval>>,
    /// The searched object's affine forms along the current straight
    /// segment (see [`crate::expr::Tape::line_forms`]).
    pub line_forms: Vec<LineForm>,
    /// The forms of the tangent line of the curved piece being split or
    /// tested (see [`crate::space::NearLine`]).
    pub near_forms: Vec<LineForm>,
    /// The piece `(a, b)` of the current search's path whose forms
    /// `near_forms` holds, and its line's parameter origin: a piece is
    /// tested and then split, and each needs them (a tenth of a curved
    /// search's work).
    near_piece: Option<(f64, f64, f64)>,
    /// Root isolation's stack of pieces, kept to avoid an allocation per
    /// search.
    pieces: Vec<Piece>,
    /// The polynomial route's series slots, one buffer per capacity.
    series: SeriesSlots,
    /// The polynomial route's power-form coefficients (Taylor
    /// arithmetic's).
    power: Vec<f64>,
    /// The polynomial route's Bernstein coefficients, and a bound on each
    /// one's error.
    coefficients: Vec<f64>,
    coefficient_error: f64,
    /// The polynomial route's Bernstein pieces.
    roots: RootScratch,
    /// Evaluations of `f` (point or interval) made, for statistics.
    pub evaluations: u64,
    /// When set, what every search does is written down (`nes probe`,
    /// `nes rays`); renders leave it `None`.
    pub log: Option<SearchLog>,
    /// The object being searched, for `log` (set by the tracer).
    pub object: usize,
    /// What went wrong since the caller last cleared it (per pixel, in a
    /// render).
    pub trouble: Trouble,
    /// Steps (marching steps, isolation pieces) taken by all searches so
    /// far: the tracer charges each search's steps to its ray's budget.
    pub steps: u64,
    /// Per object, the steps the current ray's searches may still take.
    pub budgets: Vec<u64>,
    /// Per object, whether the current ray's path has left it behind for
    /// good (see [`crate::space::Segment::gone_past`]).
    pub gone: Vec<bool>,
}

/// Why a ray's result cannot be trusted. Set by the searches and the
/// normal, read and cleared per pixel by the render, which counts them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Trouble {
    /// A search used up `max_steps` before settling its range: a root
    /// there may have been missed.
    pub out_of_steps: bool,
    /// A hit could not be located to `epsilon`: the floating-point numbers
    /// at its distance are spaced wider than that.
    pub imprecise: bool,
    /// The object's value at a hit was not finite or its gradient was zero
    /// or not finite (the normal is a guess), or the colour was not.
    pub nonfinite: bool,
    /// The object's colour formula was not a number at the hit (drawn as
    /// 0 in that component).
    pub colour_undefined: bool,
    /// The object's values overflowed to infinities of opposite signs
    /// across a stretch of the ray: a surface may lie there undrawn.
    pub overflow: bool,
}

impl Trouble {
    /// Whether anything went wrong.
    pub fn any(&self) -> bool {
        self.out_of_steps
            || self.imprecise
            || self.nonfinite
            || self.colour_undefined
            || self.overflow
    }
}

/// Whether no float lies strictly between `a` and `b` besides a few:
/// the piece cannot be split any finer.
fn too_narrow_to_split(a: f64, b: f64) -> bool {
    let m = 0.5 * (a + b);
    // Eight pieces need nine distinct ends.
    let ulp = (a.abs().max(b.abs()) * f64::EPSILON).max(f64::MIN_POSITIVE);
    m <= a || m >= b || b - a <= 16.0 * ulp
}

/// What the searches along one path evaluated, in the order they did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SearchLog {
    /// A point value of an object's `f` at distance `t` along the path.
    pub samples: Vec<LoggedSample>,
    /// An interval enclosure of `f` over the piece `[a, b]` of the path.
    pub pieces: Vec<LoggedPiece>,
}

/// One point value a search computed: what `nes probe` and `nes rays`
/// draw as a dot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoggedSample {
    /// The object searched (an index into the scene's objects).
    pub object: usize,
    /// The distance along the path at which `f` was evaluated.
    pub t: f64,
    /// The object's `f` there (NaN or infinite where undefined).
    pub value: f64,
}

/// One interval enclosure a root isolation computed: what `nes probe`
/// draws as a box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoggedPiece {
    /// The object searched (an index into the scene's objects).
    pub object: usize,
    /// The distance along the path where the piece starts.
    pub a: f64,
    /// The distance along the path where the piece ends.
    pub b: f64,
    /// An enclosure of the object's `f` over the piece; if it excludes 0,
    /// the piece was dropped.
    pub range: Interval,
}

impl Scratch {
    /// Scratch space whose searches write down what they evaluate.
    pub fn logging() -> Scratch {
        Scratch {
            log: Some(SearchLog::default()),
            ..Scratch::default()
        }
    }

    #[inline]
    fn note(&mut self, t: f64, value: f64) {
        if let Some(log) = &mut self.log {
            log.samples.push(LoggedSample {
                object: self.object,
                t,
                value,
            });
        }
    }
}

fn sign(v: f64) -> i8 {
    if v > 0.0 {
        1
    } else if v < 0.0 {
        -1
    } else {
        0
    }
}

fn interval_box(b: &Aabb) -> [Interval; 3] {
    // One ulp outward covers the rounding of the box's corners.
    [0, 1, 2].map(|i| Interval::hull_of(b.min[i], b.max[i]))
}

/// Pieces a range is split into at once in root isolation, and evaluated
/// together (see [`crate::expr::lanes`]).
pub const LANES: usize = 8;

/// Where a split puts its ends, as fractions of the piece: equal pieces.
const EQUAL_SPLIT: [f64; LANES + 1] = split_fractions(1.0);

/// The first split of a whole range: each piece 1.25 times longer than
/// the one before. The nearest root is resolved first, and a shorter
/// nearest piece is likelier to pass the slope test at once (implicit.nes
/// at 300 px: 2.5% fewer instructions than equal pieces; ratios 1.2 to
/// 1.45 all gain, 2 loses).
const GRADED_SPLIT: [f64; LANES + 1] = split_fractions(1.25);

/// Fractions `0 = e_0 < e_1 < ... < e_LANES = 1` with piece lengths in
/// the ratio `ratio`.
const fn split_fractions(ratio: f64) -> [f64; LANES + 1] {
    let mut ends = [0.0; LANES + 1];
    let mut length = 1.0;
    let mut k = 1;
    while k <= LANES {
        ends[k] = ends[k - 1] + length;
        length *= ratio;
        k += 1;
    }
    let total = ends[LANES];
    let mut k = 1;
    while k <= LANES {
        ends[k] /= total;
        k += 1;
    }
    ends
}

/// A piece of the range that may hold a root, with `f` at its ends.
#[derive(Debug, Clone, Copy)]
struct Piece {
    a: f64,
    b: f64,
    fa: f64,
    fb: f64,
}

fn changes_sign(fa: f64, fb: f64) -> bool {
    fa.is_finite() && fb.is_finite() && sign(fa) * sign(fb) <= 0 && (fa != 0.0 || fb != 0.0)
}

/// How many places the polynomial route's coefficients cannot clear are
/// looked at again over a shorter stretch, per range, and how much
/// shorter (a fraction of the range left).
const MOST_ZOOMS: usize = 8;
const ZOOM: f64 = 64.0;

/// What one pass of the polynomial route found.
enum Solved {
    /// A root, located to epsilon.
    At(f64),
    /// No root before this point, where the coefficients cannot tell
    /// whether `f` vanishes.
    Near(f64),
    /// No root.
    None,
    /// The segment is not straight or the coefficients overflowed.
    Unsolvable,
}

/// A stretch of a straight segment the polynomial route solves on: the
/// points `line.start + (start + length s) line.direction`, `s` in
/// `[0, 1]`, with `|start|` and `|start + length|` within `reach`.
#[derive(Clone, Copy)]
struct Stretch {
    line: crate::space::Line,
    reach: f64,
    start: f64,
    length: f64,
}

/// Slots for evaluating a tape in [`Taylor`] series of each capacity the
/// polynomial route uses. A series is copied in and out of its slot at
/// every operation, so capacities follow the degrees users write
/// (Barth's decic, Sarti's dodecic) rather than powers of two: a degree
/// 10 tape in 17 coefficients spent a sixth of its render in `memcpy`.
#[derive(Default)]
struct SeriesSlots {
    up_to_4: Vec<Taylor<5>>,
    up_to_6: Vec<Taylor<7>>,
    up_to_8: Vec<Taylor<9>>,
    up_to_12: Vec<Taylor<13>>,
    up_to_16: Vec<Taylor<17>>,
    up_to_32: Vec<Taylor<33>>,
    /// The interpolation's error bounds.
    magnitudes: Vec<Magnitude>,
}

/// Whether the interpolated coefficients in `s` are certain enough to
/// search: their error bound is at most a millionth of the largest.
/// That is far above what rounding gives a formula that does not cancel
/// (Chmutov's octic about 1e-11; a Kummer surface moved 1e5 from the
/// origin about 1e-7, from its coordinates' own rounding), far below
/// what one that does gives (about 1e10 for `(x + 1e6)^2 - 1e12 - 2e6 x`).
fn precise_enough(s: &Scratch) -> bool {
    const LOOSEST: f64 = 1e-6;
    let largest = s.coefficients.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    s.coefficient_error <= LOOSEST * largest
}

impl<'a, 'p> Search<'a, 'p> {
    /// This search with `f` in place of the object's function (a cell's
    /// shorter formula), without what was known of the object's.
    pub fn with_formula(&self, f: &'a Implicit) -> Search<'a, 'p> {
        Search {
            f,
            value_errors: None,
            parts: &[],
            ..*self
        }
    }

    /// A sign change of `f` as written just after `t`, where the
    /// polynomial's coefficients place a root only to within their error
    /// (no root lies before `t`): bracketed from `t - epsilon` over
    /// widening steps to the right and refined.
    fn sign_change_after(&self, t: f64, t1: f64, s: &mut Scratch) -> Option<f64> {
        let eps = self.limits.epsilon;
        let a = t - eps;
        let fa = self.value_at(a, s);
        let mut width = 2.0 * eps;
        for _ in 0..8 {
            let b = (t + width).min(t1);
            let fb = self.value_at(b, s);
            if changes_sign(fa, fb) {
                return Some(self.refine(a, b, fa, fb, s));
            }
            if b >= t1 {
                break;
            }
            width *= 4.0;
        }
        None
    }

    /// The polynomial route: along a straight segment, `f` restricted to
    /// `[t0, t1]` is a polynomial in `s = (t - t0) / (t1 - t0)`; its
    /// coefficients come from one pass of the value tape in Taylor
    /// arithmetic, with rounding bounds, and its first root in `[0, 1]`
    /// from [`first_root_of_bernstein`], which misses none. Curved segments, and
    /// coefficients that overflow, are searched by [`Search::isolate`].
    pub fn polynomial(&self, t0: f64, t1: f64, s: &mut Scratch) -> Option<f64> {
        let t = self.polynomial_roots(t0, t1, s)?;
        // A rational function's numerator may vanish where its
        // denominator does, and `f` is undefined there: it keeps its sign
        // (x^2 / x^2 - 0.5) or jumps through infinity (z / z^2). A root
        // is kept where `f` changes sign across it and is no larger at it
        // than at either side (a pole is larger); anything else (a
        // touching hit too) is left to interval isolation.
        if self.f.proxy != crate::expr::Proxy::None {
            let eps = self.limits.epsilon;
            let (a, b) = ((t - eps).max(t0), (t + eps).min(t1));
            let mut at = |u: f64| self.f.value(self.seg.point(u), &mut s.points);
            let (fa, fm, fb) = (at(a), at(t), at(b));
            s.evaluations += 3;
            let crossing = fa.is_finite() && fb.is_finite() && fa * fb <= 0.0;
            if !(crossing && fm.abs() <= fa.abs().max(fb.abs())) {
                return self.isolate(t0, t1, s);
            }
        }
        Some(t)
    }

    fn polynomial_roots(&self, t0: f64, t1: f64, s: &mut Scratch) -> Option<f64> {
        // A place the coefficients cannot clear (their error, which grows
        // with the sizes of f's terms over the whole range, hides the
        // value) is looked at again over a short stretch from it, where
        // the terms are far smaller: a near miss (a ray passing close to
        // Sarti's dodecic, whose terms reach 1e15 along the ray) or the
        // surface a shadow ray leaves (Boy's surface in a loose bound) is
        // cleared there, and the search goes on past it. There the
        // coefficients come from Taylor arithmetic, whose bound follows
        // the coefficients' own sizes, which shrink with the stretch; the
        // interpolation's follows its terms', which do not (a double root
        // of a squared sphere took 40% more evaluations with it).
        let mut a = t0;
        let mut t1 = t1;
        let mut clipped = false;
        for _ in 0..MOST_ZOOMS {
            let solved = self.polynomial_once(a, t1, false, s);
            // Coefficients over a long range (a bound as large as the
            // reachable region, under `max_distance 1e6`) carry terms so
            // large that no value near the surface clears their error.
            // Every root lies within a bound of the polynomial's own
            // coefficients about the range's start, which are small there:
            // the range is cut to it once and solved again.
            if matches!(solved, Solved::Near(_) | Solved::Unsolvable) && !clipped {
                clipped = true;
                if let Some(end) = self.roots_end(a, t1, s) {
                    if end < a + 0.5 * (t1 - a) {
                        t1 = end;
                        continue;
                    }
                }
            }
            let t = match solved {
                Solved::At(t) => return Some(t),
                Solved::None => return None,
                Solved::Unsolvable => return self.isolate(a, t1, s),
                Solved::Near(t) => t,
            };
            let b = (t + (t1 - a) / ZOOM).min(t1);
            if b <= t {
                return self.settle_near(t, t1, s);
            }
            match self.polynomial_once(t, b, true, s) {
                Solved::At(u) => return Some(u),
                Solved::None if b < t1 => a = b,
                Solved::None => return None,
                Solved::Near(u) => return self.settle_near(u, t1, s),
                Solved::Unsolvable => return self.isolate(t, t1, s),
            }
        }
        self.isolate(a, t1, s)
    }

    /// A place `t` no root lies before that the coefficients cannot clear
    /// even over a short stretch (the value is within their error of
    /// zero, where the surface is flat), settled with `f` as written: a
    /// sign change nearby is refined; an interval of `f` around it that
    /// holds zero makes it a touching hit; otherwise interval isolation
    /// takes the rest of the range.
    fn settle_near(&self, t: f64, t1: f64, s: &mut Scratch) -> Option<f64> {
        if self.query == Query::Nearest {
            if let Some(t) = self.sign_change_after(t, t1, s) {
                return Some(t);
            }
        }
        if self.may_vanish_near(t, s) {
            return Some(t);
        }
        self.isolate(t, t1, s)
    }

    /// Whether the interval of `f` over the box around the path's points
    /// within epsilon of `t` holds zero.
    fn may_vanish_near(&self, t: f64, s: &mut Scratch) -> bool {
        let eps = self.limits.epsilon;
        let (p, q) = (self.seg.point(t - eps), self.seg.point(t + eps));
        s.evaluations += 1;
        self.f
            .interval(p.min(q), p.max(q), &mut s.intervals)
            .contains(0.0)
    }

    /// One pass of the polynomial route over `[t0, t1]`: the polynomial's
    /// Bernstein coefficients (from its values at a few points, or from
    /// Taylor arithmetic past [`MOST_INTERPOLATED_DEGREE`]) and their
    /// first root.
    fn polynomial_once(&self, t0: f64, t1: f64, zoomed: bool, s: &mut Scratch) -> Solved {
        let (Some(line), Some(degree)) = (self.seg.as_line(), self.f.degree) else {
            return Solved::Unsolvable;
        };
        let reach = (t0 - line.t0).abs().max((t1 - line.t0).abs()) * (1.0 + 1e-12) + 1e-300;
        let stretch = Stretch {
            line,
            reach,
            start: t0 - line.t0,
            length: t1 - t0,
        };
        let length = stretch.length;
        s.evaluations += 1;
        let found = match zoomed {
            true => self.expand(degree, &stretch, s),
            false => self.coefficients(degree, &stretch, s),
        };
        if !found {
            return Solved::Unsolvable;
        }
        let tolerance = self.limits.epsilon / length;
        let (found, halvings) = first_root_of_bernstein(
            &s.coefficients,
            s.coefficient_error,
            tolerance,
            self.limits.max_steps,
            self.query == Query::Any,
            &mut s.roots,
        );
        s.steps += halvings;
        let at = |u: f64| (t0 + u * length).clamp(t0, t1);
        match found {
            FirstRoot::At(u) => {
                if s.log.is_some() {
                    let v = bernstein_value(&s.coefficients, u);
                    s.note(at(u), v);
                }
                Solved::At(at(u))
            }
            FirstRoot::Near(u) => Solved::Near(at(u)),
            FirstRoot::None => Solved::None,
            FirstRoot::OutOfSteps => {
                s.trouble.out_of_steps = true;
                Solved::None
            }
        }
    }

    /// The polynomial's Bernstein coefficients on the stretch and a bound
    /// on their error, into `s.coefficients` and `s.coefficient_error`:
    /// interpolated where the degree allows, by Taylor arithmetic where
    /// not, or where the interpolation's bound is loose (a formula that
    /// cancels large terms, such as `(x + 1e6)^2 - 1e12 - 2e6 x`, whose
    /// terms' sizes the bound follows; Taylor arithmetic follows the
    /// coefficients' own). False where neither gives finite ones.
    fn coefficients(&self, degree: usize, stretch: &Stretch, s: &mut Scratch) -> bool {
        if degree <= MOST_INTERPOLATED_DEGREE
            && self.interpolate(degree, stretch, s)
            && precise_enough(s)
        {
            return true;
        }
        self.expand(degree, stretch, s)
    }

    /// The polynomial's Bernstein coefficients on the stretch from its
    /// values at the nodes of an
    /// [`interpolation`](crate::expr::univariate::Interpolation), with an
    /// error bound from the object's [`ValueErrors`] (or, where that is
    /// too loose or does not serve, one [`Magnitude`] pass along the
    /// stretch), into `s.coefficients` and
    /// `s.coefficient_error`: a few times cheaper than Taylor arithmetic,
    /// whose every product is a convolution. False where a value or the
    /// bound is not finite.
    fn interpolate(&self, degree: usize, stretch: &Stretch, s: &mut Scratch) -> bool {
        let Stretch {
            line,
            start,
            length,
            ..
        } = *stretch;
        // The polynomial at the nodes' points, as every other route
        // evaluates `f` (native code or not, the same bits).
        let table = interpolation(degree);
        let mut values = [0.0; MOST_INTERPOLATED_DEGREE + 1];
        for (value, &x) in values.iter_mut().zip(&table.nodes) {
            let p = line.start + (start + length * x) * line.direction;
            *value = self.f.solved_value(p, &mut s.points);
        }
        let values = &values[..=degree];
        self.note_stretch(stretch, &table.nodes[..=degree], s);
        if !values.iter().all(|v| v.is_finite()) {
            return false;
        }
        let boxed = self
            .value_errors
            .and_then(|e| e.along(line.start, line.direction, start, start + length));
        if let Some(error) = boxed {
            s.coefficient_error = table.bernstein(values, error, &mut s.coefficients);
            // The bound's error is its worst point's: a stretch where the
            // terms are smaller may still clear with its own.
            if precise_enough(s) {
                return true;
            }
        }
        let error = self.stretch_error(stretch, s);
        if !error.is_finite() {
            return false;
        }
        s.coefficient_error = table.bernstein(values, error, &mut s.coefficients);
        s.coefficient_error.is_finite()
    }

    /// A bound on the error of `f`'s values along this stretch alone, by
    /// one [`Magnitude`] pass: tighter than the object's
    /// [`ValueErrors`] over its whole bound, and for paths that reach
    /// past it.
    fn stretch_error(&self, stretch: &Stretch, s: &mut Scratch) -> f64 {
        let Stretch {
            line,
            reach,
            start,
            length,
        } = *stretch;
        let tape = self.f.solved_tape();
        tape.line_forms(line.start, line.direction, reach, &mut s.line_forms);
        let native = self.f.native_magnitude();
        match native.and_then(|n| n.eval(&s.line_forms, Magnitude::stretch(start, length))) {
            Some((_, error)) => error,
            None => {
                tape.eval_on_line(
                    &s.line_forms,
                    Magnitude::parameter(start, length),
                    &mut s.series.magnitudes,
                )
                .error
            }
        }
    }

    /// A distance past which the polynomial has no root on the path
    /// from `a` on: Fujiwara's bound on the roots' size, `2 max(|c_(n-k)
    /// / c_n|^(1/k))` (the last term halved), from its power coefficients
    /// `c_k` in `t - a`, each counted at its largest and the leading one at
    /// its smallest within their error. `None` where the leading
    /// coefficient is not certainly nonzero (along an asymptotic
    /// direction), or the coefficients are not finite.
    fn roots_end(&self, a: f64, t1: f64, s: &mut Scratch) -> Option<f64> {
        let (line, degree) = (self.seg.as_line()?, self.f.degree?);
        let stretch = Stretch {
            line,
            reach: (a - line.t0).abs() * (1.0 + 1e-12) + 1.0,
            start: a - line.t0,
            length: 1.0,
        };
        let error = self.expand_power(degree, &stretch, s)?;
        s.evaluations += 1;
        let c = &s.power;
        let n = c.len() - 1;
        let lead = c[n].abs() - error;
        if n == 0 || lead <= 0.0 {
            return None;
        }
        let mut size = 0.0f64;
        for k in 1..=n {
            let mut ratio = (c[n - k].abs() + error) / lead;
            if k == n {
                ratio *= 0.5;
            }
            size = size.max(ratio.powf(1.0 / k as f64));
        }
        let end = a + 2.0 * size * (1.0 + 1e-9) + self.limits.epsilon;
        end.is_finite().then_some(end.min(t1))
    }

    /// The power coefficients of `f` along the stretch by one pass of its
    /// tape in Taylor arithmetic, into `s.power`, and a bound on the sum
    /// of their errors; `None` where a coefficient or the bound is not
    /// finite.
    fn expand_power(&self, degree: usize, stretch: &Stretch, s: &mut Scratch) -> Option<f64> {
        let tape = self.f.line_tape.as_ref().unwrap_or(&self.f.value_tape);
        let Stretch {
            line,
            reach,
            start,
            length,
        } = *stretch;
        tape.line_forms(line.start, line.direction, reach, &mut s.line_forms);
        let power = &mut s.power;
        let forms = &s.line_forms;
        macro_rules! expand {
            ($slots:expr, $n:literal) => {{
                let u = Taylor::<$n>::variable(start, length);
                let p = tape.eval_on_line(forms, u, &mut $slots);
                power.clear();
                power.extend_from_slice(&p.coefficients[..=p.degree]);
                p.error
            }};
        }
        let error = match degree {
            0..=4 => expand!(s.series.up_to_4, 5),
            5..=6 => expand!(s.series.up_to_6, 7),
            7..=8 => expand!(s.series.up_to_8, 9),
            9..=12 => expand!(s.series.up_to_12, 13),
            13..=16 => expand!(s.series.up_to_16, 17),
            _ => expand!(s.series.up_to_32, 33),
        };
        (error.is_finite() && power.iter().all(|c| c.is_finite())).then_some(error)
    }

    /// The polynomial's Bernstein coefficients on the stretch by one pass
    /// of its tape in Taylor arithmetic, into `s.coefficients` and
    /// `s.coefficient_error`. False where a coefficient or the bound is
    /// not finite.
    fn expand(&self, degree: usize, stretch: &Stretch, s: &mut Scratch) -> bool {
        let Some(error) = self.expand_power(degree, stretch, s) else {
            return false;
        };
        s.coefficient_error = power_to_bernstein(&s.power, error, &mut s.coefficients);
        self.note_stretch(stretch, &[0.0, 1.0], s);
        true
    }

    /// For `nes probe`, `f` itself at the points `at` (fractions) of the
    /// stretch the polynomial route solved on: where it solves a
    /// stand-in (a numerator), the values shown are still `f`'s.
    fn note_stretch(&self, stretch: &Stretch, at: &[f64], s: &mut Scratch) {
        if s.log.is_none() {
            return;
        }
        let Stretch {
            line,
            start,
            length,
            ..
        } = *stretch;
        for &x in at {
            let p = line.start + (start + length * x) * line.direction;
            let v = self.f.value(p, &mut s.points);
            s.note(line.t0 + start + length * x, v);
        }
    }

    /// Newton steps on a closed-form root, with `f` as written. A quadric's
    /// coefficients are expanded about the origin, so far from it they carry
    /// the cancellation of large terms (a unit sphere at 1e6 has a constant
    /// term near 1e12 and loses ~1e-4 of its radius); the compiled expression,
    /// which subtracts the translation first, does not. A step is kept only
    /// if it brings `f` closer to zero and moves the root by less than a
    /// thousandth of its distance (a near-tangent ray keeps its closed form).
    pub fn polish(&self, t: f64, s: &mut Scratch) -> f64 {
        let (f, seg) = (self.f, self.seg);
        let mut t = t;
        let (mut v, mut g) = f.value_and_gradient(seg.point(t), &mut s.gradient_points);
        s.evaluations += 1;
        s.note(t, v);
        for _ in 0..2 {
            let step = v / g.dot(seg.direction(t));
            if !step.is_finite() || step == 0.0 || step.abs() > 1e-3 * (1.0 + t.abs()) {
                break;
            }
            let (v2, g2) = f.value_and_gradient(seg.point(t - step), &mut s.gradient_points);
            s.evaluations += 1;
            s.note(t - step, v2);
            // Not closer (or NaN): keep what we have.
            if v2.is_nan() || v2.abs() >= v.abs() {
                break;
            }
            (t, v, g) = (t - step, v2, g2);
        }
        t
    }

    #[inline]
    fn value_at(&self, t: f64, s: &mut Scratch) -> f64 {
        let (f, seg) = (self.f, self.seg);
        s.evaluations += 1;
        let v = f.value(seg.point(t), &mut s.points);
        s.note(t, v);
        v
    }

    /// The seed's algorithm 2: fixed steps; on a change of sign against the
    /// start, halve the step and retry from the last point before it, until
    /// the step is below `eps`. Points where `f` is not finite carry no sign.
    pub fn march(&self, t0: f64, t1: f64, step: f64, s: &mut Scratch) -> Option<f64> {
        let Limits {
            epsilon: eps,
            max_steps,
            ..
        } = self.limits;
        let mut t = t0;
        let v0 = self.value_at(t0, s);
        let mut start_sign = if v0.is_finite() { sign(v0) } else { 0 };
        let mut h = step;
        let mut steps = 0;
        // The two nearest points past a change of sign, with |f| there.
        let mut past: Option<(f64, f64)> = None;
        let mut farther: Option<(f64, f64)> = None;
        while t < t1 && steps < max_steps {
            let tn = (t + h).min(t1);
            let v = self.value_at(tn, s);
            steps += 1;
            s.steps += 1;
            let sg = if v.is_finite() { sign(v) } else { 0 };
            if start_sign == 0 {
                // No sign yet (the start was on the surface or undefined).
                start_sign = sg;
                t = tn;
                continue;
            }
            if sg != 0 && sg != start_sign {
                // A point h nearer than the last (not the same one again,
                // reached from a point before it that kept the sign).
                if past.is_none_or(|(at, _)| tn <= at - 0.5 * h) {
                    farther = past;
                    past = Some((tn, v.abs()));
                }
                if h >= eps {
                    h *= 0.5;
                    continue;
                }
                // Closing in on a root, |f| falls; on a pole (tan's) it
                // grows, where a first-order look at the last bracket
                // cannot tell the two apart (f / f' is small at both).
                // A march that began within the last bracket has no
                // farther point: one more value, as far past again.
                let pole = self.f.has_slope_jumps && {
                    let further = farther.map_or_else(
                        || self.value_at(tn + (tn - t), s).abs(),
                        |(_, further)| further,
                    );
                    v.abs() > 1.5 * further
                };
                if !pole && !self.is_jump(tn, s) {
                    return Some(tn);
                }
                // A jump across zero: march on from its far side.
                start_sign = sg;
                h = step;
                (past, farther) = (None, None);
            }
            if v == 0.0 {
                return Some(tn);
            }
            t = tn;
        }
        if t < t1 {
            s.trouble.out_of_steps = true;
        }
        None
    }

    /// The seed's adaptive marching (report 9.1): the step doubles while |f|
    /// falls; when |f| rises again after falling, the stretch around the
    /// minimum is searched again at the base step, since a root may hide there.
    pub fn adaptive(&self, t0: f64, t1: f64, s: &mut Scratch) -> Option<f64> {
        let Limits {
            step, max_steps, ..
        } = self.limits;
        let max_step = step * 64.0;
        let mut t = t0;
        let mut v = self.value_at(t, s);
        let mut h = step;
        let mut falling = false;
        let mut t_before = t0;
        let mut steps = 0;
        while t < t1 && steps < max_steps {
            let tn = (t + h).min(t1);
            let vn = self.value_at(tn, s);
            steps += 1;
            s.steps += 1;
            let finite = v.is_finite() && vn.is_finite();
            if finite && sign(vn) != sign(v) {
                // Only a jump (not a root) lets the march come back empty.
                if let Some(hit) = self.march(t, tn, h * 0.5, s) {
                    return Some(hit);
                }
            }
            if finite && vn.abs() > v.abs() && falling {
                // Passed a minimum of |f| between t_before and tn.
                if let Some(hit) = self.march(t_before, tn, step, s) {
                    return Some(hit);
                }
                falling = false;
                h = step;
            } else if finite && vn.abs() < v.abs() {
                falling = true;
                h = (h * 2.0).min(max_step);
            }
            t_before = t;
            t = tn;
            v = vn;
        }
        if t < t1 {
            s.trouble.out_of_steps = true;
        }
        None
    }

    /// Guaranteed root isolation: split `[t0, t1]` into [`LANES`] pieces,
    /// drop pieces where the interval of `f` over the piece's bounding box
    /// excludes zero, or where the mean-value form `f(a) + slope [0, h]` does;
    /// refine a piece once `f` is provably monotone on it (its derivative
    /// along the path excludes zero) and changes sign; split the rest again.
    /// The nearest piece is always resolved first. A piece that cannot be split
    /// below `eps` and may still hold a zero, with `f` near zero to first
    /// order, is a touching (double) root, and counts as a hit. For
    /// [`Query::Any`], a piece proven to hold a root is not refined: its
    /// start is returned (enough to know that a shadow ray is blocked).
    pub fn isolate(&self, t0: f64, t1: f64, s: &mut Scratch) -> Option<f64> {
        let (f, seg) = (self.f, self.seg);
        // A straight segment is searched in its own parameter: one affine
        // form per coordinate and affine step, computed here once.
        let along = seg.as_line().map(|line| {
            // Every piece's parameter lies within this (a piece's ends are
            // moved outward by an ulp or so).
            let at = line.t0;
            let reach = (t0 - at).abs().max((t1 - at).abs()) * (1.0 + 1e-12) + 1e-300;
            f.value_tape
                .line_forms(line.start, line.direction, reach, &mut s.line_forms);
            at
        });
        let mut stack = std::mem::take(&mut s.pieces);
        stack.clear();
        // Another search's forms (another object or path) are no use here.
        s.near_piece = None;
        let hit = self.isolate_on(along, t0, t1, &mut stack, s);
        s.pieces = stack;
        hit
    }

    /// [`Search::isolate`] with its stack; `along` is the start distance of a straight
    /// segment whose forms are in `s.line_forms`, `None` for other paths
    /// (searched over boxes holding their pieces).
    fn isolate_on(
        &self,
        along: Option<f64>,
        t0: f64,
        t1: f64,
        stack: &mut Vec<Piece>,
        s: &mut Scratch,
    ) -> Option<f64> {
        let (f, seg) = (self.f, self.seg);
        let Limits {
            epsilon: eps,
            max_steps,
            ..
        } = self.limits;
        // The whole range's end values wait until its split leaves a piece
        // that may hold a root: a path through a bound that misses the
        // surface then costs one lane evaluation and no point values.
        stack.push(Piece {
            a: t0,
            b: t1,
            fa: f64::NAN,
            fb: f64::NAN,
        });
        let mut budget = max_steps;
        // The whole range is split at once: its slope test almost never
        // settles it (a path through a bound usually enters and leaves the
        // surface), and the split's lane evaluation tests its range.
        let mut whole = true;
        while let Some(Piece {
            a,
            b,
            mut fa,
            mut fb,
        }) = stack.pop()
        {
            if budget == 0 {
                s.trouble.out_of_steps = true;
                return None;
            }
            budget -= 1;
            s.steps += 1;
            if std::mem::take(&mut whole) {
                // One interval over the whole range first: a cell run the
                // path passes by is settled at an eighth of a split's cost
                // (a tube of capsules: 9% fewer instructions).
                if let Some(at) = along {
                    let u = Interval::hull_of(a - at, b - at);
                    let range = f
                        .value_tape
                        .eval_on_line(&s.line_forms, u, &mut s.intervals);
                    s.evaluations += 1;
                    if let Some(log) = &mut s.log {
                        log.pieces.push(LoggedPiece {
                            object: s.object,
                            a,
                            b,
                            range,
                        });
                    }
                    if !range.contains(0.0) {
                        continue;
                    }
                }
                if b - a > eps {
                    if let Some(t) = self.split(along, Piece { a, b, fa, fb }, false, stack, s)? {
                        return Some(t);
                    }
                    continue;
                }
                fa = self.value_at(a, s);
                fb = self.value_at(b, s);
            }
            // The value over the piece (already known to hold zero for a
            // piece split off by a lane evaluation) and its slope along the
            // path.
            let Some((range, range_slope)) = self.range_and_slope(along, a, b, s) else {
                return self.sampled(a, b, 64, s);
            };
            s.evaluations += 1;
            if let Some(log) = &mut s.log {
                log.pieces.push(LoggedPiece {
                    object: s.object,
                    a,
                    b,
                    range,
                });
            }
            if !range.contains(0.0) {
                continue;
            }
            let unsplittable = b - a > eps && too_narrow_to_split(a, b);
            if b - a <= eps || unsplittable {
                let m = 0.5 * (a + b);
                let p = seg.point(m);
                let (v, g) = f.value_and_gradient(p, &mut s.gradient_points);
                s.note(m, v);
                // A first-order estimate of the distance to the surface:
                // within `eps`, or else within what this distance along
                // the path and the point's coordinates can resolve (a hit
                // kept, but counted as imprecise).
                let grain = 4.0 * f64::EPSILON * p.abs().max_element();
                let slope = 4.0 * g.length();
                // A change of sign across the piece is a root within it,
                // even where the value leaps (an overflowing power goes
                // from -1 to +inf within a nanometre, and its gradient
                // underflows on the other side).
                let crosses = !fa.is_nan() && !fb.is_nan() && sign(fa) * sign(fb) < 0;
                // A pole (1/x at 0, tan at pi/2): f's range over the piece
                // runs from -inf to +inf, and |f| / |grad f| there is the
                // distance to the pole, which no surface is at.
                if range.lo == f64::NEG_INFINITY && range.hi == f64::INFINITY && v != 0.0 {
                    // Infinite ends of opposite signs are no pole a float
                    // can tell from an overflow (`(x^2 - 1) * 1e308 *
                    // 1e308`): a surface may be there, so the pixel is
                    // counted.
                    if crosses && !(fa.is_finite() && fb.is_finite()) {
                        s.trouble.overflow = true;
                    }
                    continue;
                }
                // A pole a `min` or `max` caps on one side (`min(x / y,
                // 5)`: -inf on one side of y = 0, 5 on the other): the
                // range runs to infinity one way while both ends are
                // finite, and |f| / |grad f| falls to zero at it as at a
                // root. No surface is there.
                let unbounded = range.lo == f64::NEG_INFINITY || range.hi == f64::INFINITY;
                if unbounded && v != 0.0 && fa.is_finite() && fb.is_finite() {
                    continue;
                }
                if v.abs() <= eps * slope || v == 0.0 {
                    return Some(m);
                }
                // A function that jumps (floor, fract, if) may change sign
                // across a jump, which is no root: where the slope over the
                // piece is unbounded (a jump may lie in it) and the value
                // stays away from zero to first order, the search goes on.
                let jump = (f.has_jumps || f.has_slope_jumps)
                    && !(range_slope.lo.is_finite() && range_slope.hi.is_finite());
                if crosses && b - a <= eps && !jump {
                    return Some(m);
                }
                if jump {
                    continue;
                }
                if v.abs() <= eps.max(b - a).max(grain) * slope {
                    s.trouble.imprecise = true;
                    return Some(m);
                }
                continue;
            }
            let ends_finite = fa.is_finite() && fb.is_finite();
            // A pole between the ends (tan at pi/2) leaves the slope one-signed
            // and the range unbounded: f is monotone only where it is bounded.
            let bounded = range.lo.is_finite() && range.hi.is_finite();
            if ends_finite && bounded && !range_slope.is_empty() && !range_slope.contains(0.0) {
                // Monotone: a root exactly when the ends differ in sign.
                if sign(fa) * sign(fb) <= 0 {
                    return Some(if self.query == Query::Nearest {
                        self.refine(a, b, fa, fb, s)
                    } else {
                        a
                    });
                }
                continue;
            }
            // The mean-value form: f on the piece lies within f(a) + slope
            // [0, h] and within f(b) - slope [0, h], often far tighter than the
            // natural range for a ray passing close to the surface. The margin
            // covers the rounding of the point values. It needs f continuous
            // on the piece, which a bounded slope proves: across a pole (tan
            // at pi/2) the slope is one-signed but unbounded, and f leaps
            // from +inf to -inf (`tan(x) - y` lost most of its sheets).
            let slope_bounded = range_slope.lo.is_finite() && range_slope.hi.is_finite();
            if ends_finite && slope_bounded {
                let span = Interval::new(0.0, b - a);
                let margin =
                    Interval::new(-1.0, 1.0) * Interval::point(1e-12 * (fa.abs() + fb.abs()));
                let from_a = Interval::point(fa) + range_slope * span + margin;
                let from_b = Interval::point(fb) - range_slope * span + margin;
                if !from_a.contains(0.0) || !from_b.contains(0.0) {
                    continue;
                }
            }
            if let Some(t) = self.split(along, Piece { a, b, fa, fb }, true, stack, s)? {
                return Some(t);
            }
        }
        None
    }

    /// The range of `f` over the piece `[a, b]` of the path and the range of
    /// its slope (derivative with respect to distance) there: along a
    /// straight segment by one dual-number pass in the line's parameter,
    /// otherwise from the gradient over the piece's box dotted with its
    /// directions' box. `None` for a path with no bounds.
    fn range_and_slope(
        &self,
        along: Option<f64>,
        a: f64,
        b: f64,
        s: &mut Scratch,
    ) -> Option<(Interval, Interval)> {
        let (f, seg) = (self.f, self.seg);
        if let Some(at) = along {
            let u = Dual::variable(Interval::hull_of(a - at, b - at));
            let d = f
                .value_tape
                .eval_on_line(&s.line_forms, u, &mut s.dual_intervals);
            return Some((d.v, d.d));
        }
        if let Some(at) = self.near_forms(a, b, s) {
            let u = Dual::variable(Interval::hull_of(a - at, b - at));
            let d = f
                .value_tape
                .eval_on_line(&s.near_forms, u, &mut s.dual_intervals);
            return Some((d.v, d.d));
        }
        let (points, directions) = seg.bounds(a, b)?;
        let mut grad = [Interval::point(0.0); 4];
        f.gradient_tape
            .eval_into(&interval_box(&points), &mut s.intervals, &mut grad);
        let dir = interval_box(&directions);
        Some((
            grad[0],
            grad[1] * dir[0] + grad[2] * dir[1] + grad[3] * dir[2],
        ))
    }

    /// The line forms of `f` along the tangent line of the curved piece
    /// `[a, b]`, with its error bars, in `s.near_forms`, and the distance
    /// their parameter counts from; `None` where the piece is better
    /// served by its box (see [`crate::space::Segment::near_line`]).
    fn near_forms(&self, a: f64, b: f64, s: &mut Scratch) -> Option<f64> {
        if let Some((ca, cb, at)) = s.near_piece {
            if (ca, cb) == (a, b) {
                return Some(at);
            }
        }
        let near = self.seg.near_line(a, b)?;
        self.f.value_tape.near_line_forms(
            near.start,
            near.direction,
            near.reach * (1.0 + 1e-12),
            near.deviation,
            near.slope_deviation,
            &mut s.near_forms,
        );
        s.near_piece = Some((a, b, near.at));
        Some(near.at)
    }

    /// Whether `f`'s slope along the path over `[a, b]` is bounded (so
    /// `f` is continuous there).
    fn slope_bounded(&self, along: Option<f64>, a: f64, b: f64, s: &mut Scratch) -> bool {
        s.evaluations += 1;
        self.range_and_slope(along, a, b, s)
            .is_some_and(|(_, slope)| slope.lo.is_finite() && slope.hi.is_finite())
    }

    /// Splits `piece` into [`LANES`] pieces, computes their ranges and, if
    /// any may hold a root, the values at their ends, in one pass each, and
    /// pushes those whose range holds zero, nearest on top. Without
    /// `ends_known`, `piece`'s own end values are computed here too, and only
    /// then. `Some(Some(t))` when a shadow ray's piece from `t` is proven to
    /// hold a root; `None` when the path has no bounds (not reached: such
    /// segments are sampled instead).
    fn split(
        &self,
        along: Option<f64>,
        piece: Piece,
        ends_known: bool,
        stack: &mut Vec<Piece>,
        s: &mut Scratch,
    ) -> Option<Option<f64>> {
        let (f, seg) = (self.f, self.seg);
        let Piece {
            a,
            b,
            mut fa,
            mut fb,
        } = piece;
        let fractions = if ends_known {
            &EQUAL_SPLIT
        } else {
            &GRADED_SPLIT
        };
        let ends: [f64; LANES + 1] = std::array::from_fn(|k| match k {
            0 => a,
            LANES => b,
            _ => a + fractions[k] * (b - a),
        });
        let range = match along {
            Some(at) => {
                let u =
                    IntervalLanes::from_fn(|k| Interval::hull_of(ends[k] - at, ends[k + 1] - at));
                f.value_tape
                    .eval_on_line(&s.line_forms, u, &mut s.lane_intervals)
            }
            None => match self.near_forms(a, b, s) {
                Some(near_at) => {
                    let u = IntervalLanes::from_fn(|k| {
                        Interval::hull_of(ends[k] - near_at, ends[k + 1] - near_at)
                    });
                    f.value_tape
                        .eval_on_line(&s.near_forms, u, &mut s.lane_intervals)
                }
                None => {
                    let mut boxes = [[Interval::point(0.0); LANES]; 3];
                    for k in 0..LANES {
                        let (points, _) = seg.bounds(ends[k], ends[k + 1])?;
                        let p = interval_box(&points);
                        for axis in 0..3 {
                            boxes[axis][k] = p[axis];
                        }
                    }
                    let boxes = boxes.map(|axis| IntervalLanes::from_fn(|k| axis[k]));
                    f.value_tape.eval(&boxes, &mut s.lane_intervals)
                }
            },
        };
        s.evaluations += LANES as u64;
        if let Some(log) = &mut s.log {
            for k in 0..LANES {
                log.pieces.push(LoggedPiece {
                    object: s.object,
                    a: ends[k],
                    b: ends[k + 1],
                    range: range.lane(k),
                });
            }
        }
        if !(0..LANES).any(|k| range.lane(k).contains(0.0)) {
            return Some(None);
        }
        // The inner split points in lanes 1.., and the piece's start in lane 0
        // when it is not known yet (the lanes compute exactly what a point
        // evaluation does).
        let first = if ends_known { 1 } else { 0 };
        let mut at = [F64Lanes([0.0; LANES]); 3];
        for (k, &t) in ends.iter().enumerate().take(LANES).skip(first) {
            let p = seg.point(t);
            at[0].0[k] = p.x;
            at[1].0[k] = p.y;
            at[2].0[k] = p.z;
        }
        let inner = f.value_tape.eval(&at, &mut s.lane_points).0;
        s.evaluations += (LANES - first) as u64;
        if let Some(log) = &mut s.log {
            for k in first..LANES {
                log.samples.push(LoggedSample {
                    object: s.object,
                    t: ends[k],
                    value: inner[k],
                });
            }
        }
        if !ends_known {
            fa = inner[0];
            fb = self.value_at(b, s);
        }
        let value_at_end = |k: usize| match k {
            0 => fa,
            LANES => fb,
            _ => inner[k],
        };
        // A shadow ray needs only some root: a piece whose values at its
        // ends differ in sign and whose range is bounded (no pole, so `f`
        // is continuous there, barring jumps) holds one. Where a jump may
        // show only in the slope (`atan2`'s branch cut, `atan(y / x)`), the
        // piece's slope must be bounded too.
        if self.query == Query::Any && !f.has_jumps {
            for (k, &start) in ends.iter().enumerate().take(LANES) {
                let (fa, fb) = (value_at_end(k), value_at_end(k + 1));
                let r = range.lane(k);
                if fa.is_finite()
                    && fb.is_finite()
                    && sign(fa) * sign(fb) < 0
                    && r.lo.is_finite()
                    && r.hi.is_finite()
                    && (!f.has_slope_jumps || self.slope_bounded(along, start, ends[k + 1], s))
                {
                    return Some(Some(start));
                }
            }
        }
        // Nearest on top.
        for k in (0..LANES).rev() {
            if range.lane(k).contains(0.0) {
                stack.push(Piece {
                    a: ends[k],
                    b: ends[k + 1],
                    fa: value_at_end(k),
                    fb: value_at_end(k + 1),
                });
            }
        }
        Some(None)
    }

    /// Equal-piece sampling of `[t0, t1]` for a segment with no bounds, a
    /// change of sign refined on the segment.
    fn sampled(&self, t0: f64, t1: f64, pieces: usize, s: &mut Scratch) -> Option<f64> {
        let h = (t1 - t0) / pieces as f64;
        let mut a = t0;
        let mut fa = self.value_at(a, s);
        for i in 1..=pieces {
            let b = if i == pieces { t1 } else { t0 + i as f64 * h };
            let fb = self.value_at(b, s);
            if changes_sign(fa, fb) {
                let t = self.refine(a, b, fa, fb, s);
                if !self.is_jump(t, s) {
                    return Some(t);
                }
            }
            a = b;
            fa = fb;
        }
        None
    }

    /// A segment without conservative boxes (an integrated step), searched
    /// over its sample pieces ([`Segment::sample_pieces`]), a change of sign
    /// refined on the segment. The integrator's steps can be long; sampling
    /// inside them keeps most thin and grazing hits that the seed's
    /// end-to-end sign test would miss. Pieces whose box misses `bound` are
    /// skipped, and sample points cost no trigonometry (the space
    /// precomputes them). `None` also for a segment that has boxes.
    pub fn along_samples(&self, bound: &Aabb, t0: f64, t1: f64, s: &mut Scratch) -> Option<f64> {
        let f = self.f;
        // The last point evaluated, reused when the next piece starts there.
        let mut last: Option<(f64, f64)> = None;
        for piece in self.seg.sample_pieces(t0, t1)? {
            let (a, b) = (piece.a, piece.b);
            if !piece.bounds.overlaps(bound) {
                continue;
            }
            let fa = match last {
                Some((t, v)) if t == a => v,
                _ => {
                    s.evaluations += 1;
                    let v = f.value(piece.start, &mut s.points);
                    s.note(a, v);
                    v
                }
            };
            s.evaluations += 1;
            let fb = f.value(piece.end, &mut s.points);
            s.note(b, fb);
            if changes_sign(fa, fb) {
                let t = self.refine(a, b, fa, fb, s);
                if !self.is_jump(t, s) {
                    return Some(t);
                }
            }
            last = Some((b, fb));
        }
        None
    }

    /// Whether the change of sign bracketed down to `t` is a jump of a
    /// function that has them (floor, fract, if) rather than a root: `f`
    /// stays away from zero there by more than its gradient allows over
    /// the tolerance.
    fn is_jump(&self, t: f64, s: &mut Scratch) -> bool {
        if !self.f.has_jumps && !self.f.has_slope_jumps {
            return false;
        }
        let p = self.seg.point(t);
        let (v, g) = self.f.value_and_gradient(p, &mut s.gradient_points);
        let grain = 4.0 * f64::EPSILON * p.abs().max_element();
        v.abs() > 4.0 * self.limits.epsilon.max(grain) * g.length() && v != 0.0
    }

    /// The root in a bracket with one, by [`illinois`] on `f` as written;
    /// a hit it cannot locate to epsilon is marked imprecise, one over an
    /// undefined stretch undefined.
    fn refine(&self, a: f64, b: f64, fa: f64, fb: f64, s: &mut Scratch) -> f64 {
        match illinois(a, b, fa, fb, self.limits.epsilon, |t| self.value_at(t, s)) {
            Refined::Root(t) => t,
            Refined::Unsettled(t) => {
                s.trouble.imprecise = true;
                t
            }
            Refined::Undefined(t) => {
                s.trouble.nonfinite = true;
                t
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// A search for the nearest root of `f` along `seg`, to 1e-9.
    fn nearest<'a, 'p>(f: &'a Implicit, seg: &'a Segment<'p>) -> Search<'a, 'p> {
        Search {
            f,
            seg,
            limits: Limits {
                epsilon: 1e-9,
                max_steps: 1000,
                step: 0.1,
            },
            query: Query::Nearest,
            value_errors: None,
            parts: &[],
        }
    }

    fn function(expr: &str) -> Implicit {
        let src = format!("shape f = {expr}\ncamera {{ position (-5, 0, 0) }}\nobject f");
        crate::compile_source("t.nes", &src)
            .expect("compiles")
            .objects[0]
            .function
            .clone()
    }

    /// The polynomial route's two sources of Bernstein coefficients, a
    /// polynomial's values at interpolation nodes (native code and tape
    /// lanes) and Taylor arithmetic, agree within the sum of their error
    /// bounds on stretches of many lines through surfaces of every degree
    /// the interpolation serves, near and far from the origin; and the
    /// bounds are not so loose as to be useless.
    #[test]
    fn interpolated_and_expanded_coefficients_agree_within_their_bounds() {
        let shapes = [
            "x^3 + y^3 + z^3 - 3*x*y*z - 0.5",
            "(x^2 + y^2 + z^2 - 1)^2 - 0.3*(x^2 - y^2)",
            "x^6 + y^6 + z^6 - 1.5*x^2*y^2*z^2 - 1",
            "(x^2 + 9/4*y^2 + z^2 - 1)^3 - x^2*z^3 - 9/80*y^2*z^3",
            "128*x^8 - 256*x^6 + 160*x^4 - 32*x^2 + 1 + 128*y^8 - 256*y^6 + 160*y^4 - 32*y^2 + 1 + 128*z^8 - 256*z^6 + 160*z^4 - 32*z^2 + 1",
            "((x - 100)^2 + y^2 + z^2 - 1)^2 - 0.01",
            // Barth's decic, and a product of degree 12.
            "8*(x^2 - 6.85*y^2)*(y^2 - 6.85*z^2)*(z^2 - 6.85*x^2)*(x^4 + y^4 + z^4 - 2*x^2*y^2 - 2*x^2*z^2 - 2*y^2*z^2) + 11.09*(x^2 + y^2 + z^2 - 1)^2*(x^2 + y^2 + z^2 - 0.382)^2",
            "(x^2 + y^2 - 1)^2 * (y^2 + z^2 - 1)^2 * (x^2 + z^2 - 1)^2 - 0.01",
        ];
        let mut next = crate::testing::uniform(0x2545_f491_4f6c_dd1du64);
        for expr in shapes {
            let f = function(expr);
            let degree = f.degree.expect("a polynomial");
            assert!(degree <= MOST_INTERPOLATED_DEGREE, "{expr}");
            let far = if expr.contains("100") { 100.0 } else { 0.0 };
            for _ in 0..200 {
                let start = DVec3::new(far - 3.0 + 0.5 * next(), 2.0 * next() - 1.0, next() - 0.5);
                let target = DVec3::new(
                    far + 2.0 * next() - 1.0,
                    2.0 * next() - 1.0,
                    2.0 * next() - 1.0,
                );
                let seg = Segment::line(start, (target - start).normalize(), 0.0, 10.0);
                let line = seg.as_line().unwrap();
                let (t0, t1) = (0.5 + 2.0 * next(), 3.0 + 3.0 * next());
                let stretch = Stretch {
                    line,
                    reach: t1 * (1.0 + 1e-12),
                    start: t0,
                    length: t1 - t0,
                };
                let search = nearest(&f, &seg);
                let mut s = Scratch::default();
                assert!(search.expand(degree, &stretch, &mut s), "{expr}");
                let (taylor, taylor_error) = (s.coefficients.clone(), s.coefficient_error);
                assert!(search.interpolate(degree, &stretch, &mut s), "{expr}");
                let (values, values_error) = (s.coefficients.clone(), s.coefficient_error);
                let largest = taylor.iter().fold(0.0f64, |m, c| m.max(c.abs()));
                assert_eq!(taylor.len(), values.len(), "{expr}");
                for (a, b) in taylor.iter().zip(&values) {
                    assert!(
                        (a - b).abs() <= taylor_error + values_error,
                        "{expr}: {a} vs {b}, bounds {taylor_error} and {values_error}"
                    );
                }
                // Far from the origin the terms cancel (1e8 against 1),
                // and at degree 12 the interpolation amplifies errors
                // 2 900 times; still no looser than 1e-5 of the terms'
                // size.
                assert!(
                    values_error <= 1e-5 * largest.max(1.0),
                    "{expr}: {values_error} for {largest}"
                );
            }
        }
    }

    /// The native Magnitude pass gives the interpreter's bound, up to its
    /// own rounding, on polynomials of every shape the route meets
    /// (powers, products, quotients by numbers, affine steps).
    #[test]
    fn the_native_magnitude_pass_gives_the_interpreters_bound() {
        let shapes = [
            "128*x^8 - 256*x^6 + 160*x^4 - 32*x^2 + 1 + y^3 - z/3",
            "(x^2 + 9/4*y^2 + z^2 - 1)^3 - x^2*z^3 - 9/80*y^2*z^3",
            "((x - 1)^2 + (2*y + z - 3)^2 - 0.5)^2 - (x + y) * (x - y)",
            // Many affine steps past few other slots (a Roman surface
            // scaled by 1000: its compilation once indexed the slots with
            // an affine step's form and panicked).
            "(x/1000)^2*(y/1000)^2 + (y/1000)^2*(z/1000)^2 + (z/1000)^2*(x/1000)^2 - (x/1000)*(y/1000)*(z/1000)",
        ];
        for expr in shapes {
            let f = function(expr);
            let Some(native) = f.native_magnitude() else {
                assert!(crate::expr::jit::disabled(), "{expr}: not compiled");
                return;
            };
            let mut forms = Vec::new();
            for k in 0..20 {
                let start = DVec3::new(-3.0 + 0.1 * k as f64, 0.3, -0.2);
                let direction = DVec3::new(1.0, 0.05 * k as f64, 0.3).normalize();
                f.value_tape.line_forms(start, direction, 5.0, &mut forms);
                let (a, l) = (0.25 * k as f64 / 20.0, 2.0 + 0.1 * k as f64);
                let (size, error) = native.eval(&forms, Magnitude::stretch(a, l)).unwrap();
                let interpreted =
                    f.value_tape
                        .eval_on_line(&forms, Magnitude::parameter(a, l), &mut Vec::new());
                for (x, y) in [(size, interpreted.size), (error, interpreted.error)] {
                    assert!(
                        (x - y).abs() <= 1e-12 * y.abs(),
                        "{expr}: native {x}, interpreted {y}"
                    );
                }
                assert!(error > 0.0 && size > 0.0, "{expr}");
            }
        }
    }

    /// An object's table of value errors over its bound is at least each
    /// stretch's own [`Magnitude`] bound (a proven one; the table holds
    /// the same sums at sizes rounded up, with a larger input error), and
    /// not so much more that the search would lose its use: within 1000
    /// times (about 170 at worst for these shapes, for stretches across
    /// the whole box), from starts near and far.
    #[test]
    fn the_bounds_error_table_covers_each_stretchs_own_bound() {
        let shapes = [
            ("128*x^8 - 256*x^6 + 160*x^4 - 32*x^2 + 1 + 128*y^8 - 256*y^6 + 160*y^4 - 32*y^2 + 1 + 128*z^8 - 256*z^6 + 160*z^4 - 32*z^2 + 1", 0.0),
            ("(x^2 + 9/4*y^2 + z^2 - 1)^3 - x^2*z^3 - 9/80*y^2*z^3", 0.0),
            ("((x - 1)^2 + (2*y + z - 3)^2 - 0.5)^2 - (x + y) * (x - y)", 0.0),
            ("((x - 100)^2 + y^2 + z^2 - 1)^2 - 0.01", 100.0),
            ("((x + 1e6)^2 - 1e12 - 2e6*x)^2 - 1 + 0.5*y^3 - 0.5*y^3", 0.0),
        ];
        let mut next = crate::testing::uniform(0x9e37_79b9_7f4a_7c15u64);
        for (expr, far) in shapes {
            let f = function(expr);
            let centre = DVec3::new(far, 0.0, 0.0);
            let (lo, hi) = (centre - DVec3::splat(2.0), centre + DVec3::splat(2.0));
            let table = ValueErrors::over_box(f.solved_tape(), lo, hi).expect("a polynomial");
            let inside = |u: f64, v: f64, w: f64| lo + (hi - lo) * DVec3::new(u, v, w);
            for k in 0..200 {
                let (p0, p1) = (
                    inside(next(), next(), next()),
                    inside(next(), next(), next()),
                );
                let direction = (p1 - p0).normalize();
                let back = if k % 2 == 0 { 3.0 } else { 3000.0 };
                let seg = Segment::line(p0 - back * direction, direction, 0.0, 1e4);
                let line = seg.as_line().unwrap();
                let length = (p1 - p0).length();
                let stretch = Stretch {
                    line,
                    reach: (back + length) * (1.0 + 1e-12),
                    start: back,
                    length,
                };
                let search = nearest(&f, &seg);
                let own = search.stretch_error(&stretch, &mut Scratch::default());
                let boxed = table
                    .along(line.start, line.direction, back, back + length)
                    .expect("within the table");
                assert!(own <= boxed, "{expr}: own {own}, table {boxed}");
                assert!(boxed <= 1000.0 * own, "{expr}: own {own}, table {boxed}");
            }
        }
    }

    /// Where `f64` evaluation loses most of its digits, the error bound
    /// of interpolated coefficients still covers the true ones: the
    /// formula below is `x^4 - 1` exactly, but computed it cancels terms
    /// near 1e12, so each value is off by about 1e-4. That bound follows
    /// the terms' sizes and is loose, so the route takes Taylor
    /// arithmetic's coefficients there, whose bound is tighter and also
    /// covers the true ones.
    #[test]
    fn the_interpolation_bound_covers_cancellation() {
        let f = function("((x + 1e6)^2 - 1e12 - 2e6*x)^2 - 1 + 0.5*y^3 - 0.5*y^3");
        let degree = f.degree.expect("a polynomial");
        let mut worst: f64 = 0.0;
        for k in 0..50 {
            let start = DVec3::new(-2.0 + 0.01 * k as f64, 0.25, 0.125);
            let direction = DVec3::new(1.0, 0.1, -0.05).normalize();
            let seg = Segment::line(start, direction, 0.0, 10.0);
            let stretch = Stretch {
                line: seg.as_line().unwrap(),
                reach: 4.0 * (1.0 + 1e-12),
                start: 0.5,
                length: 3.0,
            };
            let search = nearest(&f, &seg);
            let mut s = Scratch::default();
            assert!(search.interpolate(degree, &stretch, &mut s));
            let (values, values_error) = (s.coefficients.clone(), s.coefficient_error);
            assert!(search.coefficients(degree, &stretch, &mut s));
            // x = a + b s along the stretch; x^4 - 1 in power form.
            let (a, b) = (start.x + 0.5 * direction.x, 3.0 * direction.x);
            let power = [
                a.powi(4) - 1.0,
                4.0 * a.powi(3) * b,
                6.0 * a * a * b * b,
                4.0 * a * b.powi(3),
                b.powi(4),
            ];
            let mut exact = Vec::new();
            crate::expr::univariate::power_to_bernstein(&power, 0.0, &mut exact);
            exact.resize(degree + 1, 0.0);
            for (got, want) in values.iter().zip(&exact) {
                let off = (got - want).abs();
                worst = worst.max(off);
                assert!(off <= values_error, "{got} vs {want}: bound {values_error}");
            }
            // The route takes Taylor arithmetic's tighter coefficients.
            for (got, want) in s.coefficients.iter().zip(&exact) {
                assert!(
                    (got - want).abs() <= s.coefficient_error,
                    "{got} vs {want}: bound {}",
                    s.coefficient_error
                );
            }
            assert!(s.coefficient_error < 1e-3 * values_error);
        }
        assert!(worst > 1e-7, "the case no longer cancels: {worst}");
    }

    /// The two ways isolation evaluates a straight segment, in the line's
    /// parameter and over boxes holding its pieces, find the same first
    /// hit (or none) on every ray of a fan through each shape, and a hit
    /// lies on the surface.
    #[test]
    fn line_and_box_evaluation_find_the_same_hits() {
        let shapes = [
            "(x^2 + 9/4*y^2 + z^2 - 1)^3 - x^2*z^3 - 9/80*y^2*z^3",
            "x^8 + y^8 + z^8 - 1",
            "(sqrt(x^2 + y^2) - 1)^2 + z^2 - 0.1",
            "(x^2 + y^2 + z^2 - 1)^2",
            "min(x^2 + y^2 + z^2 - 1, (x - 1.2)^2 + y^2 + z^2 - 0.25)",
        ];
        let eps = 1e-9;
        for expr in shapes {
            let f = function(expr);
            let mut s = Scratch::default();
            let (mut hits, mut rays) = (0, 0);
            for i in 0..41 {
                for j in 0..41 {
                    let start = DVec3::new(-4.0, 0.013, -0.007);
                    let target = DVec3::new(0.0, -1.6 + 0.08 * i as f64, -1.6 + 0.08 * j as f64);
                    let direction = (target - start).normalize();
                    let seg = Segment::line(start, direction, 0.0, 10.0);
                    let search = Search {
                        f: &f,
                        seg: &seg,
                        limits: Limits {
                            epsilon: eps,
                            max_steps: 100_000,
                            step: 0.1,
                        },
                        query: Query::Nearest,
                        value_errors: None,
                        parts: &[],
                    };
                    let on_line = search.isolate(0.0, 10.0, &mut s);
                    let mut stack = Vec::new();
                    let over_boxes = search.isolate_on(None, 0.0, 10.0, &mut stack, &mut s);
                    rays += 1;
                    match (on_line, over_boxes) {
                        (Some(a), Some(b)) => {
                            hits += 1;
                            assert!(
                                (a - b).abs() <= 4.0 * eps,
                                "{expr}: {a} vs {b} along {direction}"
                            );
                            let (v, g) = f.value_and_gradient(seg.point(a), &mut Vec::new());
                            assert!(
                                v.abs() <= 8.0 * eps * g.length().max(1.0),
                                "{expr}: f = {v} at the hit {a}"
                            );
                        }
                        (None, None) => {}
                        other => panic!("{expr} along {direction}: {other:?}"),
                    }
                }
            }
            assert!(
                hits > rays / 10 && hits < rays,
                "{expr}: {hits} hits of {rays}"
            );
        }
    }
}
