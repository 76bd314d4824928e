//! The compile stage: AST to a checked [`Scene`].
//!
//! Input: an [`ast::File`] (the user's) plus the embedded prelude.
//! Output: a [`Scene`] whose every value is validated, whose objects are
//! compiled [`Implicit`] functions (transforms folded in, simplified,
//! differentiated, quadrics recognised, bounds computed), or every
//! diagnostic found. Nothing here traces a ray.

mod bound;
mod lint;
pub use lint::relint;
mod lower;
mod metric;
mod settings;
pub(crate) use settings::readable;

use std::collections::{HashMap, HashSet};

use glam::{DAffine3, DMat3, DVec3};

use crate::ast::{self, CsgOp, Expr, ExprKind, Ident, Item, Solid, SolidKind, TransformOp};
use crate::diagnostic::{suggest, Code, Diagnostic, SceneError, Span};
use crate::expr::{Graph, Implicit, NodeId};
use crate::scene::{Clock, Object, Paint, Scene};
use crate::space::{Placement, Rigid, SpaceKind};

pub use bound::{
    compute_bound, compute_bounds, loose_bound, reachable_region, Culprit, LooseBound,
};

/// The ranges of the settings the command line can also set: one table
/// for both (see [`limits::Limit`]).
pub mod limits {
    pub use super::settings::{Limit, HEIGHT, MAX_IMAGE_SIDE, SAMPLES, STEP, WIDTH};
}
use lower::{
    Constant, Frame, Globals, Lowerer, ParamKind, ShapeDef, Value, COLOUR_FIELD_NAMES, RESERVED,
};

/// The built-in shapes, written in the scene language.
pub const PRELUDE: &str = include_str!("../prelude.nes");

/// Parse and compile a scene's source text.
///
/// Runs on a thread with a large stack: parsing and compiling recurse over
/// nested expressions, and the syntax stage's limits are sized for it.
pub fn compile_source(source_name: &str, source: &str) -> Result<Scene, SceneError> {
    compile_source_at(source_name, source, Clock::default())
}

/// [`compile_source`] with `time` and `frame` at `clock`: one frame of an
/// animation.
pub fn compile_source_at(
    source_name: &str,
    source: &str,
    clock: Clock,
) -> Result<Scene, SceneError> {
    // A byte-order mark is no part of the scene.
    let source = source.strip_prefix('\u{feff}').unwrap_or(source);
    let source = &*crate::syntax::lone_carriage_returns_as_newlines(source);
    on_large_stack("nes-compile", || {
        compile_source_here(source_name, source, clock)
    })
}

/// `work` on a thread named `name` with a stack of
/// [`COMPILE_STACK_BYTES`] (see [`compile_source`]), its panic carried on;
/// on the current thread when that is one already (the command line runs
/// every command on one: a second such stack did not fit a render under a
/// 1 GiB address-space limit). Where the stack cannot be reserved (an
/// address-space limit under about 600 MB), a smaller one, and at last the
/// current thread: a scene of ordinary depth then still compiles (a
/// trial's tanglecube under `ulimit -v 600000` panicked here instead).
pub(crate) fn on_large_stack<T: Send>(name: &str, work: impl FnOnce() -> T + Send) -> T {
    thread_local! {
        static LARGE_STACK: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    }
    if LARGE_STACK.get() {
        return work();
    }
    // The work moves into the thread that starts, so it is kept in an
    // option a failed spawn leaves in place.
    let work = std::sync::Mutex::new(Some(work));
    for bytes in [
        COMPILE_STACK_BYTES,
        COMPILE_STACK_BYTES / 8,
        COMPILE_STACK_BYTES / 64,
    ] {
        let work = &work;
        let outcome = std::thread::scope(|scope| {
            let spawned = std::thread::Builder::new()
                .name(name.into())
                .stack_size(bytes)
                .spawn_scoped(scope, || {
                    LARGE_STACK.set(true);
                    let work = work.lock().unwrap_or_else(|e| e.into_inner()).take();
                    work.map(|w| w())
                });
            spawned.ok().map(|thread| {
                thread
                    .join()
                    .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
            })
        });
        if let Some(Some(result)) = outcome {
            return result;
        }
    }
    let work = work.into_inner().unwrap_or_else(|e| e.into_inner());
    work.expect("no thread took the work")()
}

/// The stack of the compile thread: reserved, not touched unless used.
pub const COMPILE_STACK_BYTES: usize = 512 << 20;

/// The stack of the worker threads, which compile parts of a scene in
/// parallel and recurse as deep as a formula nests (a `min` of 100 000
/// terms overflowed their default 2 MB); kept small enough that a render
/// fits under a 1 GiB address-space limit with two of them.
pub const WORKER_STACK_BYTES: usize = 96 << 20;

fn compile_source_here(source_name: &str, source: &str, clock: Clock) -> Result<Scene, SceneError> {
    compile_loaded(source_name, source, clock, None)
}

/// Read the imports of `source`, then compile it all, in the file's own
/// space or in `space`.
fn compile_loaded(
    source_name: &str,
    source: &str,
    clock: Clock,
    space: Option<SpaceKind>,
) -> Result<Scene, SceneError> {
    let loaded = crate::syntax::imports::load(source_name, source);
    let error = |d| SceneError::new(source_name, source, d).with_imports(&loaded.files);
    let file = loaded.result.as_ref().map_err(|d| error(d.clone()))?;
    let mut scene = compile_in(file, Some(source), clock, space).map_err(error)?;
    scene.imports = loaded.files[1..]
        .iter()
        .filter_map(|f| f.path.clone())
        .collect();
    Ok(scene)
}

/// Compile a parsed file (a still: frame 0, time 0).
pub fn compile(file: &ast::File) -> Result<Scene, Vec<Diagnostic>> {
    compile_at(file, Clock::default())
}

/// Compile a parsed file at `clock`.
pub fn compile_at(file: &ast::File, clock: Clock) -> Result<Scene, Vec<Diagnostic>> {
    compile_in(file, None, clock, None)
}

/// Compile source text at `clock` in `space` instead of the space the
/// file names (for `--space`: objects are placed differently in curved
/// spaces, so a scene is compiled for each).
pub fn compile_source_in(
    source_name: &str,
    source: &str,
    clock: Clock,
    space: SpaceKind,
) -> Result<Scene, SceneError> {
    let source = crate::syntax::lone_carriage_returns_as_newlines(source);
    on_large_stack("nes-compile", || {
        compile_loaded(source_name, &source, clock, Some(space))
    })
}

/// In S3 and H3 the camera looks along the geodesic to its `look_at`
/// point, which leaves the camera in another direction than the
/// straight line does.
fn aim_along_geodesic(scene: &mut Scene) {
    let Some(target) = scene.camera.target else {
        return;
    };
    if !scene.space.places_objects() {
        return;
    }
    let space = scene.build_space();
    if let Some((forward, _)) = space.connect(scene.camera.position, target) {
        if let Some((f, l, u)) = crate::camera::Camera::frame(forward, scene.camera.up_hint) {
            (scene.camera.forward, scene.camera.left, scene.camera.up) = (f, l, u);
        }
    }
}

/// In a metric space the camera's frame is made orthonormal in the metric
/// at its position: its forward and up, written as chart directions, are
/// turned into the frame's components there, so that the field of view
/// keeps its meaning.
fn aim_in_frame(scene: &mut Scene, metric: &crate::space::Metric) {
    let Some(frame) = metric.frame_at(scene.camera.position) else {
        return;
    };
    let forward = frame.to_frame(scene.camera.forward);
    let up = frame.to_frame(scene.camera.up_hint);
    if let Some((f, l, u)) = crate::camera::Camera::frame(forward, up) {
        (scene.camera.forward, scene.camera.left, scene.camera.up) = (f, l, u);
    }
}

fn compile_in(
    file: &ast::File,
    source: Option<&str>,
    clock: Clock,
    space: Option<SpaceKind>,
) -> Result<Scene, Vec<Diagnostic>> {
    check_counts(file)?;
    let mut c = Compiler {
        source: source.map(str::to_string),
        ..Compiler::default()
    };
    c.globals.clock = clock;
    c.load_prelude();
    c.define(file);
    let mut settings = c.directives(file);
    if let Some(s) = &mut settings {
        if let Some(space) = space {
            s.space = space;
        }
        c.placing = s.space.places_objects();
        c.curvature = s.space.curvature();
        c.globals.curvature = c.curvature.map(|k| (k.sign(), k.radius()));
        c.check_camera_within_reach(file, s);
        aim_along_geodesic(s);
        if let SpaceKind::Metric(m) = &s.space {
            let m = m.0.clone();
            if c.check_metric_at_camera(&m, s.camera.position) {
                aim_in_frame(s, &m);
            }
        }
    }
    let objects = c.objects(file);
    if !c.diags.is_empty() {
        let mut warnings = Vec::new();
        c.file_warnings(file, &mut warnings);
        let mut all = std::mem::take(&mut c.diags);
        all.extend(warnings);
        return Err(all);
    }
    let (mut scene, objects) = match (settings, objects) {
        (Some(s), Some(o)) => (s, o),
        // Every failure pushes its diagnostic; should one ever not, the
        // user still gets an error, not a panic.
        _ => {
            return Err(vec![Diagnostic::new(
                Code::Syntax,
                "the scene could not be compiled, and no reason was recorded",
            )
            .label(Span::new(0, 0), "somewhere in this file")
            .help("this is a bug in nes: please report it with the scene file")]);
        }
    };
    let region = bound::reachable_region(&scene);
    let straight = scene.build_space().straight_paths();
    scene.objects = objects
        .into_iter()
        .map(|o| {
            let local = bound::local_region(&scene, region, &o.placement);
            let (bound, cells, pruned) =
                bound::search_aids(&o.function, o.clip.as_ref(), local, straight);
            let value_errors = bound::value_errors(&o.function, bound);
            let parts = bound::parts(&o.function, bound);
            let clip_cuts = bound::clip_cuts(
                &o.function,
                o.clip.as_ref(),
                bound,
                scene.settings.epsilon,
                straight,
            );
            Object {
                clip_cuts,
                pruned,
                parts,
                value_errors,
                cells,
                bound,
                label: o.label,
                span: o.span,
                curved_uses: o.curved_uses,
                function: o.function,
                colour: o.colour,
                inside: o.inside,
                clip: o.clip,
                placement: o.placement,
            }
        })
        .collect();
    scene.animated = c.globals.read_clock.get();
    scene.warnings = c.lint(file, &scene);
    Ok(scene)
}

/// What an object's block may hold.
pub(crate) const OBJECT_PROPERTIES: &[&str] = &[
    "translate",
    "rotate",
    "scale",
    "colour",
    "color",
    "inside",
    "clip",
];

/// An object as compiled, before its bound is computed.
struct CompiledObject {
    label: String,
    span: Span,
    curved_uses: Vec<String>,
    function: Implicit,
    colour: Paint,
    inside: Option<Paint>,
    clip: Option<Implicit>,
    placement: Placement,
}

/// For a plane `b . p + c = 0` off the origin: the same plane through the
/// origin, `b . p = 0`, and the foot point `-c b / |b|^2` it must be moved
/// to. In S3 and H3 a plane is the totally geodesic one through its foot
/// point, normal to the geodesic from the origin (in normal coordinates
/// only planes through the origin are totally geodesic).
fn plane_through_origin(f: &Implicit) -> Option<(Implicit, DVec3)> {
    let q = f.quadric.as_ref()?;
    let linear = q.m.to_cols_array().iter().all(|v| *v == 0.0);
    let n2 = q.b.length_squared();
    if !linear || n2 == 0.0 || q.c == 0.0 {
        return None;
    }
    let mut g = Graph::new();
    let terms = [0, 1, 2].map(|i| {
        let c = g.constant(q.b[i]);
        let x = g.input(i as u8);
        g.mul(c, x)
    });
    let sum = g.add(terms[0], terms[1]);
    let root = g.add(sum, terms[2]);
    Some((Implicit::new(&g, root), -q.c * q.b / n2))
}

/// Where a solid is evaluated: the point `then(nodes)`, with `nodes` the
/// world point (x, y, z) unless a curved space's translation has mapped
/// it. Affine maps compose without building nodes until a leaf needs the
/// point.
#[derive(Debug, Clone, Copy)]
struct At {
    nodes: Option<[NodeId; 3]>,
    then: DAffine3,
}

impl At {
    fn affine(map: DAffine3) -> At {
        At {
            nodes: None,
            then: map,
        }
    }

    /// The point mapped further by `map`.
    fn then(self, map: DAffine3) -> At {
        At {
            nodes: self.nodes,
            then: map * self.then,
        }
    }

    /// The point as three graph nodes.
    fn nodes(&self, g: &mut Graph) -> [NodeId; 3] {
        match self.nodes {
            None => affine_point(g, self.then),
            Some(n) => affine_nodes(g, self.then, n),
        }
    }
}

/// The world point (x, y, z) mapped by `map`, as three graph nodes.
fn affine_point(g: &mut Graph, map: DAffine3) -> [NodeId; 3] {
    let inputs = [g.input(0), g.input(1), g.input(2)];
    affine_nodes(g, map, inputs)
}

/// The point `inputs` mapped by `map`.
fn affine_nodes(g: &mut Graph, map: DAffine3, inputs: [NodeId; 3]) -> [NodeId; 3] {
    if map == DAffine3::IDENTITY {
        return inputs;
    }
    let m = map.matrix3;
    let t = map.translation;
    [0, 1, 2].map(|i| {
        let row = m.row(i);
        let mut acc = g.constant(t[i]);
        for j in 0..3 {
            let c = g.constant(row[j]);
            let term = g.mul(c, inputs[j]);
            acc = g.add(acc, term);
        }
        acc
    })
}

/// The most objects a scene may draw: every ray tests each one's bound,
/// and each is compiled and bounded on its own (about 60 us apiece), so
/// this is about a second of compiling and stays a fraction of the work
/// per ray.
pub const MAX_OBJECTS: usize = 10_000;
/// The most lights: every visible hit casts a shadow ray to each.
pub const MAX_LIGHTS: usize = 1_000;

/// Too many objects or lights is one diagnostic, found before any is
/// compiled (a file of 700 000 objects took 9 s and 900 MB to report 700 000
/// errors).
fn check_counts(file: &ast::File) -> Result<(), Vec<Diagnostic>> {
    let objects = file.items.iter().filter_map(|i| match i {
        Item::Object(o) => Some(o.span),
        _ => None,
    });
    let lights = file.items.iter().filter_map(|i| match i {
        Item::Directive(d) if d.name.name == "light" => Some(d.span),
        _ => None,
    });
    for (mut spans, limit, what) in [
        (
            Box::new(objects) as Box<dyn Iterator<Item = Span>>,
            MAX_OBJECTS,
            "objects",
        ),
        (Box::new(lights), MAX_LIGHTS, "lights"),
    ] {
        if let Some(span) = spans.nth(limit) {
            return Err(vec![Diagnostic::new(
                Code::TooLarge,
                format!("the scene has more than {limit} {what}"),
            )
            .label(span, format!("{what} number {}", limit + 1))
            .help(if what == "lights" {
                format!(
                    "a scene may hold at most {limit} lights; raise the `intensity` of fewer \
                     lights, or raise `ambient`, for the same brightness"
                )
            } else {
                format!(
                    "a scene may hold at most {limit} {what}; combine several into one shape \
                     (e.g. a `min` of their expressions, or `union`)"
                )
            })]);
        }
    }
    Ok(())
}

/// Proof that a diagnostic was reported: what a failed check returns, so
/// that no part of the compiler can fail without saying why.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Reported;

#[derive(Default)]
struct Compiler {
    globals: Globals,
    diags: Vec<Diagnostic>,
    /// Whether the scene's space places objects by its isometries (S3,
    /// H3): transforms from the first `translate` on become the object's
    /// placement instead of being folded into its formula.
    placing: bool,
    /// The curvature of S3 or H3: a `translate` inside a combination maps
    /// the point through the space's isometry, in expressions.
    curvature: Option<crate::space::Curvature>,
    /// Where a metric space's parts were written.
    metric_spans: Option<metric::MetricSpans>,
    /// The main file's text, when compiled from text: objects written as
    /// formulas are named in messages by their text.
    source: Option<String>,
}

impl Compiler {
    /// In H3 paths end [`crate::space::H3_REACH`] curvature radii from the
    /// origin: a camera beyond would see nothing at all, silently.
    fn check_camera_within_reach(&mut self, file: &ast::File, settings: &Scene) {
        let Some(k) = self.curvature else { return };
        if k.sign() > 0.0 {
            return;
        }
        let reach = crate::space::H3_REACH * k.radius();
        let d = settings.camera.position.length();
        if d < reach {
            return;
        }
        let camera = file.items.iter().find_map(|i| match i {
            Item::Directive(d) if d.name.name == "camera" => Some(d),
            _ => None,
        });
        let span = camera
            .and_then(|d| {
                let block = d.block.as_ref()?;
                block.properties.iter().find(|p| p.name.name == "position")
            })
            .map(|p| p.value.span)
            .or(camera.map(|d| d.span))
            .unwrap_or(Span::new(0, 0));
        self.diags.push(
            Diagnostic::new(
                Code::OutOfRange,
                format!(
                    "the camera is {} from the origin, and paths of H3 end {} from it (12 curvature radii)",
                    short_number(d),
                    short_number(reach)
                ),
            )
            .label(span, "too far from the origin for H3")
            .help("far from the origin the hyperboloid's coordinates grow as e^(d/R) and lose the precision a hit needs; move the camera and the scene toward the origin, or raise the space's `radius`"),
        );
    }

    fn load_prelude(&mut self) {
        let file = crate::syntax::parse(PRELUDE).expect("the prelude parses (tested)");
        for item in file.items {
            if let Item::Shape(s) = item {
                let params = s
                    .params
                    .iter()
                    .map(|p| {
                        let kind = p
                            .kind
                            .as_ref()
                            .and_then(|k| ParamKind::from_name(&k.name))
                            .unwrap_or(ParamKind::Number);
                        (p.name.clone(), kind)
                    })
                    .collect();
                let def = ShapeDef {
                    name: s.name,
                    params,
                    body: s.body,
                    function: s.function,
                    prelude: true,
                };
                self.globals
                    .shapes
                    .insert(def.name.name.clone(), def.clone());
                self.globals.prelude.insert(def.name.name.clone(), def);
            }
        }
    }

    fn lowerer<'a>(&'a mut self, graph: &'a mut Graph) -> Lowerer<'a> {
        Lowerer::new(&self.globals, graph, &mut self.diags)
    }

    /// A constant value of an expression in a constant position.
    fn constant(&mut self, e: &Expr) -> Result<Constant, Reported> {
        let mut g = Graph::new();
        let v = self.lowerer(&mut g).lower(e, Frame::constant())?;
        let get = |n: NodeId| g.as_const(n).expect("constant frames fold fully");
        Ok(match v {
            Value::Num(n) => Constant::Num(get(n)),
            Value::Vector(v) => Constant::Vector(DVec3::new(get(v[0]), get(v[1]), get(v[2]))),
            Value::Colour(c) => Constant::Colour(c),
            Value::Cond(_) => {
                return self.fail(
                    Diagnostic::new(Code::WrongKind, "a condition cannot be a constant")
                        .label(e.span, "this is a condition")
                        .help("conditions choose between values inside formulas: `if x < 1 then a else b`"),
                )
            }
        })
    }

    /// Collect lets and shapes, check names, recursion and shape bodies.
    fn define(&mut self, file: &ast::File) {
        let mut user_shapes: Vec<&ast::ShapeItem> = Vec::new();
        let mut first_definition: HashMap<String, Span> = HashMap::new();
        let mut claim = |c: &mut Compiler, name: &Ident, what: &str| -> bool {
            if RESERVED.contains(&name.name.as_str()) {
                c.diags.push(
                    Diagnostic::new(
                        Code::DuplicateName,
                        format!("`{}` is built in and cannot be redefined", name.name),
                    )
                    .label(name.span, format!("this {what} uses a reserved name"))
                    .help(lower::RESERVED_HELP),
                );
                return false;
            }
            // Calls of these names reach the builtin before any shape.
            if what == "shape" && lower::BUILTIN_FUNCTIONS.contains(&name.name.as_str()) {
                c.diags.push(
                    Diagnostic::new(
                        Code::DuplicateName,
                        format!(
                            "`{}` is a built-in function and cannot be redefined",
                            name.name
                        ),
                    )
                    .label(name.span, "this definition would never be used")
                    .help(format!(
                        "choose another name, like `my_{}`; the prelude's shapes and functions (sphere, box, cbrt, ...) may be redefined",
                        name.name
                    )),
                );
                return false;
            }
            if let Some(first) = first_definition.get(&name.name) {
                c.diags.push(
                    Diagnostic::new(
                        Code::DuplicateName,
                        format!("`{}` is defined twice", name.name),
                    )
                    .label(name.span, "defined again here")
                    .label(*first, "first defined here")
                    .help("rename one of them"),
                );
                return false;
            }
            first_definition.insert(name.name.clone(), name.span);
            true
        };
        // Shapes first: lets may not use them, but their names are taken.
        for item in &file.items {
            if let Item::Shape(s) = item {
                if claim(self, &s.name, "shape") {
                    user_shapes.push(s);
                } else {
                    // Its uses are not reported again as unknown shapes.
                    self.globals.broken_names.insert(s.name.name.clone());
                }
            }
        }
        for item in &file.items {
            if let Item::Let(l) = item {
                let ok = claim(self, &l.name, "constant");
                if let ExprKind::List(items) = &l.value.kind {
                    let values: Vec<Result<Constant, Reported>> =
                        items.iter().map(|i| self.constant(i)).collect();
                    if ok && values.iter().all(|v| v.is_ok()) {
                        let values = values.into_iter().map(|v| v.unwrap()).collect();
                        self.globals.lists.insert(l.name.name.clone(), values);
                    } else {
                        self.globals.broken_names.insert(l.name.name.clone());
                    }
                    continue;
                }
                match self.constant(&l.value) {
                    Ok(v) if ok => {
                        self.globals.lets.insert(l.name.name.clone(), v);
                    }
                    // Its uses are not reported again as unknown names.
                    _ => {
                        self.globals.broken_names.insert(l.name.name.clone());
                    }
                }
            }
        }
        for s in &user_shapes {
            let mut params = Vec::new();
            let mut seen: HashSet<&str> = HashSet::new();
            for p in &s.params {
                if RESERVED.contains(&p.name.name.as_str()) {
                    self.diags.push(
                        Diagnostic::new(
                            Code::DuplicateName,
                            format!("a parameter cannot be called `{}`", p.name.name),
                        )
                        .label(p.name.span, "reserved name")
                        .help(lower::RESERVED_HELP),
                    );
                    self.globals.broken_names.insert(s.name.name.clone());
                }
                if !seen.insert(&p.name.name) {
                    self.diags.push(
                        Diagnostic::new(
                            Code::DuplicateName,
                            format!("parameter `{}` appears twice", p.name.name),
                        )
                        .label(p.name.span, "repeated")
                        .help("give each parameter its own name"),
                    );
                    self.globals.broken_names.insert(s.name.name.clone());
                }
                let kind = match &p.kind {
                    None => ParamKind::Number,
                    Some(k) => match ParamKind::from_name(&k.name) {
                        Some(kind) => kind,
                        None => {
                            let hint = match suggest(&k.name, ParamKind::NAMES.iter().copied()) {
                                Some(s) => format!("did you mean `{s}`? kinds are number, positive, vector and direction"),
                                None => "kinds are number, positive, vector and direction".into(),
                            };
                            self.diags.push(
                                Diagnostic::new(
                                    Code::UnknownName,
                                    format!("unknown parameter kind `{}`", k.name),
                                )
                                .label(k.span, "not a kind")
                                .help(hint),
                            );
                            self.globals.broken_names.insert(s.name.name.clone());
                            ParamKind::Number
                        }
                    },
                };
                params.push((p.name.clone(), kind));
            }
            self.globals.shapes.insert(
                s.name.name.clone(),
                ShapeDef {
                    name: s.name.clone(),
                    params,
                    body: s.body.clone(),
                    function: s.function,
                    prelude: false,
                },
            );
        }
        self.check_recursion(&user_shapes);
        for s in &user_shapes {
            if !self.globals.broken_names.contains(&s.name.name) {
                self.check_shape_body(&s.name.name);
            }
        }
    }

    /// Report every cycle in the shape-call graph once.
    fn check_recursion(&mut self, user_shapes: &[&ast::ShapeItem]) {
        /// Collects the shape calls in `e`. `locals` counts the local
        /// names in scope (parameters, `let`s, aggregate variables); a name
        /// is added for its body and removed after, not copied per level
        /// (a copy per nested `let` made 12 000 of them take 2 GB).
        fn calls<'e>(
            e: &'e Expr,
            locals: &mut HashMap<&'e str, usize>,
            shapes: &HashMap<String, ShapeDef>,
            out: &mut Vec<(String, Span)>,
        ) {
            let in_scope =
                |locals: &HashMap<&str, usize>, v: &str| locals.get(v).is_some_and(|&n| n > 0);
            let hiding = match &e.kind {
                ExprKind::Variable(v) if !in_scope(locals, v) && shapes.contains_key(v) => {
                    out.push((v.clone(), e.span));
                    None
                }
                ExprKind::Call { name, .. } if shapes.contains_key(&name.name) => {
                    out.push((name.name.clone(), name.span));
                    None
                }
                // A local name hides a shape of the same name in its body
                // (the last child); what it is bound to is outside it.
                ExprKind::Let { name, .. } | ExprKind::Aggregate { name, .. } => Some(name),
                _ => None,
            };
            let children = e.children();
            let last = children.len().saturating_sub(1);
            for (i, c) in children.into_iter().enumerate() {
                match hiding {
                    Some(name) if i == last => {
                        *locals.entry(name.name.as_str()).or_default() += 1;
                        calls(c, locals, shapes, out);
                        *locals.entry(name.name.as_str()).or_default() -= 1;
                    }
                    _ => calls(c, locals, shapes, out),
                }
            }
        }
        let shapes = &self.globals.shapes;
        let mut edges: HashMap<String, Vec<(String, Span)>> = HashMap::new();
        for (name, def) in shapes {
            let mut locals: HashMap<&str, usize> = def
                .params
                .iter()
                .map(|(p, _)| (p.name.as_str(), 1))
                .collect();
            let mut out = Vec::new();
            calls(&def.body, &mut locals, shapes, &mut out);
            edges.insert(name.clone(), out);
        }
        // Depth-first search from each user shape in source order. The
        // stack holds each shape on the current path with the span of the
        // call that entered it.
        struct Search<'e> {
            edges: &'e HashMap<String, Vec<(String, Span)>>,
            functions: HashSet<String>,
            done: HashSet<String>,
            stack: Vec<(String, Span)>,
            reported: HashSet<Vec<String>>,
            found: Vec<Diagnostic>,
            broken: HashSet<String>,
        }
        impl Search<'_> {
            fn visit(&mut self, node: &str) {
                for (callee, span) in self.edges.get(node).into_iter().flatten() {
                    if let Some(pos) = self.stack.iter().position(|(n, _)| n == callee) {
                        let cycle: Vec<(String, Span)> = self.stack[pos..].to_vec();
                        let mut names: Vec<String> = cycle.iter().map(|(n, _)| n.clone()).collect();
                        self.broken.extend(names.iter().cloned());
                        let path = names
                            .iter()
                            .chain(std::iter::once(callee))
                            .map(|n| format!("`{n}`"))
                            .collect::<Vec<_>>()
                            .join(" -> ");
                        names.sort();
                        if !self.reported.insert(names) {
                            continue;
                        }
                        let function = self.functions.contains(callee);
                        let mut d = Diagnostic::new(
                            Code::RecursiveShape,
                            format!(
                                "{} `{callee}` is defined in terms of itself",
                                if function { "function" } else { "shape" }
                            ),
                        )
                        .label(*span, format!("this call closes the cycle {path}"));
                        for (_, s) in &cycle[1..] {
                            d = d.label(*s, "part of the cycle");
                        }
                        self.found.push(d.help(if function {
                            "nes writes every function out into one formula, so a function cannot call itself; for a repeated step use sum(...), product(...), min(...) or max(...) over a range"
                        } else {
                            "a shape is one formula and cannot use itself; write the formula out, or combine shapes with union(...) in an object"
                        }));
                    } else if !self.done.contains(callee) {
                        self.stack.push((callee.clone(), *span));
                        self.visit(callee);
                        self.stack.pop();
                    }
                }
                self.done.insert(node.to_string());
            }
        }
        let mut search = Search {
            edges: &edges,
            functions: shapes
                .iter()
                .filter(|(_, d)| d.function)
                .map(|(n, _)| n.clone())
                .collect(),
            done: HashSet::new(),
            stack: Vec::new(),
            reported: HashSet::new(),
            found: Vec::new(),
            broken: HashSet::new(),
        };
        for s in user_shapes {
            if !search.done.contains(&s.name.name) {
                search.stack = vec![(s.name.name.clone(), s.name.span)];
                search.visit(&s.name.name);
            }
        }
        let (found, broken) = (search.found, search.broken);
        self.diags.extend(found);
        self.globals.broken_names.extend(broken);
    }

    /// Lower a shape's body once with symbolic parameters, to report its
    /// errors at their place in the definition.
    fn check_shape_body(&mut self, name: &str) {
        let def = self.globals.shapes[name].clone();
        let mut g = Graph::new();
        let point = [g.input(0), g.input(1), g.input(2)];
        let mut next = 3u8;
        let mut params = Vec::new();
        for (p, kind) in &def.params {
            let v = match kind {
                ParamKind::Number | ParamKind::Positive => {
                    next = next.saturating_add(1);
                    Value::Num(g.input(next - 1))
                }
                ParamKind::Vector | ParamKind::Direction => {
                    let v = [0, 1, 2].map(|i| g.input(next.saturating_add(i)));
                    next = next.saturating_add(3);
                    Value::Vector(v)
                }
            };
            params.push((p.name.clone(), v));
        }
        let frame = Frame {
            params: lower::Scope::of(&params),
            point: Some(point),
        };
        let before = self.diags.len();
        let mut lowerer = self.lowerer(&mut g);
        lowerer.parameters_unknown = true;
        let result = lowerer.lower(&def.body, frame);
        match result {
            Ok(Value::Num(_)) => {}
            Ok(Value::Vector(_) | Value::Cond(_)) if def.function => {}
            Ok(Value::Cond(_)) => {}
            Ok(v) => self.diags.push(
                Diagnostic::new(Code::WrongKind, format!("shape `{name}` must be a number, not {}", v.kind_name()))
                    .label(def.body.span, format!("this is {}", v.kind_name()))
                    .label(def.name.span, "in this shape")
                    .help("a shape is a function f(x, y, z) whose zero set is the surface; for a vector v use e.g. length(v) - 1"),
            ),
            Err(Reported) => {}
        }
        if self.diags.len() > before || result.is_err() {
            self.globals.broken_names.insert(name.to_string());
        }
    }

    /// Compile every object. `None` if any failed.
    fn objects(&mut self, file: &ast::File) -> Option<Vec<CompiledObject>> {
        let mut out = Vec::new();
        let mut ok = true;
        for item in &file.items {
            let Item::Object(obj) = item else { continue };
            match self.object(obj) {
                Ok(o) => out.push(o),
                Err(Reported) => ok = false,
            }
        }
        ok.then_some(out)
    }

    fn object(&mut self, obj: &ast::ObjectItem) -> Result<CompiledObject, Reported> {
        let props = settings::Props::new(
            self,
            &obj.properties,
            "an object",
            OBJECT_PROPERTIES,
            &["translate", "rotate", "scale"],
        );
        let mut colour = Paint::Flat(DVec3::splat(0.8));
        let mut inside = None;
        let mut failed = false;
        let mut world_transforms = Vec::new();
        let mut clip_expr = None;
        for p in props.list {
            match p.name.name.as_str() {
                "colour" | "color" => match self.paint(&p.value) {
                    Ok(c) => colour = c,
                    Err(Reported) => failed = true,
                },
                "inside" => match self.paint(&p.value) {
                    Ok(c) => inside = Some(c),
                    Err(Reported) => failed = true,
                },
                "clip" => clip_expr = Some(p.value.clone()),
                op => {
                    let op = match op {
                        "translate" => TransformOp::Translate,
                        "rotate" => TransformOp::Rotate,
                        _ => TransformOp::Scale,
                    };
                    world_transforms.push(ast::Transform {
                        op,
                        value: p.value.clone(),
                        about: p.about.clone(),
                        span: p.span,
                    });
                }
            }
        }
        let mut g = Graph::unsimplified();
        self.globals.curved_uses.borrow_mut().clear();
        let mut own = DAffine3::IDENTITY;
        let (root, local_to_world, placement) = if self.placing {
            // The solid's own transforms, then the object's, as one chain.
            let chain: Vec<ast::Transform> = obj
                .solid
                .transforms
                .iter()
                .chain(&world_transforms)
                .cloned()
                .collect();
            let (linear, placement) = match self.placed(&chain) {
                Ok(split) => split,
                Err(Reported) => {
                    failed = true;
                    (DAffine3::IDENTITY, Placement::default())
                }
            };
            let root = self.solid_body(&mut g, &obj.solid, At::affine(linear.inverse()));
            (root, linear, placement)
        } else {
            let mut local_to_world = DAffine3::IDENTITY;
            for t in &world_transforms {
                // Object properties apply after the solid's own transforms.
                match self.transform(t) {
                    Ok(a) => local_to_world = a * local_to_world,
                    Err(Reported) => failed = true,
                }
            }
            // Built as written; Implicit::new simplifies, so that the
            // saving can be reported.
            let root = self.solid(&mut g, &obj.solid, At::affine(local_to_world.inverse()));
            // The clip is in the solid's own coordinates: it moves with the
            // transforms written after the solid too, as in S3 and H3.
            // (Their errors were reported by `solid`.)
            let reported = self.diags.len();
            for t in &obj.solid.transforms {
                if let Ok(a) = self.transform(t) {
                    own = a * own;
                }
            }
            self.diags.truncate(reported);
            (root, local_to_world * own, Placement::default())
        };
        if failed || props.failed {
            return Err(Reported);
        }
        let root = root?;
        let curved_uses = std::mem::take(&mut *self.globals.curved_uses.borrow_mut());
        let clip = match &clip_expr {
            Some(e) => {
                let mut cg = Graph::unsimplified();
                let node = self.formula_at(&mut cg, e, local_to_world.inverse(), "clip")?;
                Some(Implicit::new(&cg, node))
            }
            None => None,
        };
        let label = solid_label(&obj.solid, self.source.as_deref());
        let mut function = Implicit::new(&g, root);
        let mut placement = placement;
        if self.placing && clip.is_none() {
            if let Some((plane, foot)) = plane_through_origin(&function) {
                function = plane;
                placement.0.insert(0, Rigid::Translate(foot));
            }
        }
        // The Hessian for the curvatures, built once if either side reads them.
        let hessian = std::cell::OnceCell::new();
        for paint in std::iter::once(&mut colour).chain(inside.as_mut()) {
            if let Paint::Field(f) = paint {
                if f.reads_curvature() {
                    let tape = hessian.get_or_init(|| Implicit::second_derivatives(&g, root));
                    f.second_derivatives = Some(tape.clone());
                }
            }
        }
        Ok(CompiledObject {
            label,
            span: obj.solid.span,
            curved_uses,
            function,
            colour,
            inside,
            clip,
            placement,
        })
    }

    /// A chain of transforms in S3 or H3, split into the linear part
    /// before the first `translate` (folded into the formula, in normal
    /// coordinates about the object's centre) and the rigid motions from
    /// there on (the placement). A `scale` after a `translate` has no
    /// meaning there: it is not a motion of the space.
    fn placed(&mut self, chain: &[ast::Transform]) -> Result<(DAffine3, Placement), Reported> {
        let mut linear = DAffine3::IDENTITY;
        let mut placement = Placement::default();
        let mut moved = false;
        let mut failed = false;
        for t in chain {
            let Ok(a) = self.transform(t) else {
                failed = true;
                continue;
            };
            match t.op {
                TransformOp::Translate => {
                    moved = true;
                    placement.0.push(Rigid::Translate(a.translation));
                }
                TransformOp::Rotate if moved => placement.0.push(Rigid::Rotate(a.matrix3)),
                TransformOp::Scale if moved => {
                    self.diags.push(
                        Diagnostic::new(
                            Code::OutOfRange,
                            "in a curved space an object cannot be scaled after it is moved",
                        )
                        .label(t.span, "this scale comes after a translate")
                        .help("in s3 and h3 `translate` and `rotate` are motions of the space and `scale` is not; write the scale before the first translate"),
                    );
                    failed = true;
                }
                TransformOp::Rotate | TransformOp::Scale => linear = a * linear,
            }
        }
        if failed {
            Err(Reported)
        } else {
            Ok((linear, placement))
        }
    }

    /// A formula in x, y, z (a property's value, like `clip`), lowered at
    /// the world point mapped by `world_to_local`; it must be a number.
    fn formula_at(
        &mut self,
        g: &mut Graph,
        e: &Expr,
        world_to_local: DAffine3,
        what: &str,
    ) -> Result<NodeId, Reported> {
        let point = affine_point(g, world_to_local);
        match self.region_at(g, e, point)? {
            Ok(n) => Ok(n),
            Err(v) => self.fail(
                Diagnostic::new(
                    Code::WrongKind,
                    format!("`{what}` takes a formula in x, y, z, not {}", v.kind_name()),
                )
                .label(e.span, format!("this is {}", v.kind_name()))
                .help(format!(
                    "write the region to keep as a formula negative inside it, e.g. `{what} cube(1.2)` or `{what} z - 0.5`"
                )),
            ),
        }
    }

    /// One transform as a local-to-parent affine map.
    fn transform(&mut self, t: &ast::Transform) -> Result<DAffine3, Reported> {
        let before = self.diags.len();
        let result = self.transform_amount(t);
        // `x` in an object's own transform: say why it has no value there,
        // and how to write a transform that varies with the point (a trial
        // was told only that x exists inside a shape).
        for d in &mut self.diags[before..] {
            if d.code == Code::NotConstant
                && d.span()
                    .is_some_and(|s| s.start >= t.value.span.start && s.end <= t.value.span.end)
            {
                if let Some(label) = d.labels.first_mut() {
                    label.text = "the transforms written after an object take constants".into();
                }
                d.help = Some("for a transform that varies with the point (a twist), move it into the formula: `shape twisted = cube(1) rotate 30 * z about z`, or an argument, `min(cube(1) rotate 30 * z about z, ...)`; a formula after `+` or `*` here is read as part of the amount, so put the moved solid in brackets: `(sphere(1) translate (1, 0, 0)) + ...`".into());
            }
        }
        result
    }

    fn transform_amount(&mut self, t: &ast::Transform) -> Result<DAffine3, Reported> {
        if t.op != TransformOp::Rotate {
            if let Some(about) = &t.about {
                self.diags.push(
                    Diagnostic::new(Code::UnknownSetting, "only `rotate` takes `about`")
                        .label(about.span, "not used here")
                        .help("write `rotate DEGREES about AXIS`"),
                );
                return Err(Reported);
            }
        }
        match t.op {
            TransformOp::Translate => Ok(DAffine3::from_translation(
                self.vector(&t.value, "translate")?,
            )),
            TransformOp::Rotate => {
                let degrees = self.number(&t.value, "a rotation angle (in degrees)");
                let Some(about) = &t.about else {
                    if !about_misspelt_after(&self.diags, t.span) {
                        self.diags.push(
                            Diagnostic::new(Code::MissingSetting, "a rotation needs an axis")
                                .label(t.span, "no axis given")
                                .help(
                                    "write e.g. `rotate 30 about z` or `rotate 45 about (1, 1, 0)`",
                                ),
                        );
                    }
                    return Err(Reported);
                };
                let axis = self.axis(about);
                let (degrees, axis) = (degrees?, axis?);
                Ok(DAffine3::from_mat3(rotation(axis, degrees)))
            }
            TransformOp::Scale => {
                let factors = match self.constant(&t.value)? {
                    Constant::Num(s) => DVec3::splat(s),
                    Constant::Vector(v) => v,
                    Constant::Colour(_) => {
                        return self.fail(
                            Diagnostic::new(
                                Code::WrongKind,
                                "a scale must be a number or a vector, not a colour",
                            )
                            .label(t.value.span, "this is a colour")
                            .help("write `scale 2` or `scale (1, 2, 1)`"),
                        )
                    }
                };
                if factors
                    .to_array()
                    .iter()
                    .any(|f| *f == 0.0 || !f.is_finite())
                {
                    return self.fail(
                        Diagnostic::new(Code::OutOfRange, "a scale factor must be finite and not zero")
                            .label(t.value.span, format!("scale ({}, {}, {})", factors.x, factors.y, factors.z))
                            .help("a zero scale flattens the object to nothing; use a small positive factor"),
                    );
                }
                Ok(DAffine3::from_scale(factors))
            }
        }
    }

    fn fail<T>(&mut self, d: Diagnostic) -> Result<T, Reported> {
        self.diags.push(d);
        Err(Reported)
    }

    /// `x`, `y`, `z` or a non-zero vector, normalised.
    fn axis(&mut self, e: &Expr) -> Result<DVec3, Reported> {
        if let ExprKind::Variable(v) = &e.kind {
            match v.as_str() {
                "x" => return Ok(DVec3::X),
                "y" => return Ok(DVec3::Y),
                "z" => return Ok(DVec3::Z),
                name if !self.globals.lets.contains_key(name) => {
                    return self.fail(
                        Diagnostic::new(Code::UnknownName, format!("`{name}` is not an axis"))
                            .label(e.span, "not x, y, z or a vector")
                            .help(
                                "an axis is x, y, z or a vector, like `rotate 30 about (1, 1, 0)`",
                            ),
                    )
                }
                _ => {}
            }
        }
        let v = self.vector(e, "a rotation axis")?;
        match crate::camera::unit_vector(v) {
            Some(u) => Ok(u),
            None => self.fail(
                Diagnostic::new(Code::ZeroLength, "a rotation axis cannot be zero")
                    .label(e.span, "this vector has length zero")
                    .help("rotate about x, y, z or a non-zero vector like (1, 1, 0)"),
            ),
        }
    }

    /// Lower a solid into `g`, evaluated at `world_to_parent(p)`.
    fn solid(&mut self, g: &mut Graph, solid: &Solid, at: At) -> Result<NodeId, Reported> {
        let mut steps = Vec::new();
        let mut failed = false;
        for t in &solid.transforms {
            match self.transform(t) {
                Ok(a) => steps.push((t.op, a)),
                Err(Reported) => failed = true,
            }
        }
        if failed {
            return Err(Reported);
        }
        // The parent's point in the solid's own coordinates: undo its
        // transforms, the last written first. In S3 and H3 a translate is
        // the space's isometry, which normal coordinates do not keep
        // linear: the point is mapped through the model in expressions.
        let mut at = at;
        for (op, a) in steps.iter().rev() {
            match (op, self.curvature) {
                (TransformOp::Translate, Some(k)) => {
                    self.globals.note_curved_use("translate");
                    let q = at.nodes(g);
                    at = At {
                        nodes: Some(lower::translated_back(g, &k, q, a.translation)),
                        then: DAffine3::IDENTITY,
                    };
                }
                _ => at = at.then(a.inverse()),
            }
        }
        self.solid_body(g, solid, at)
    }

    /// Lower a solid without its own transforms, evaluated at `at`.
    fn solid_body(&mut self, g: &mut Graph, solid: &Solid, at: At) -> Result<NodeId, Reported> {
        let mut failed = false;
        let result = match &solid.kind {
            SolidKind::Shape { name, args } => {
                self.shape_instance(g, name, args.as_deref().unwrap_or(&[]), solid.span, at)
            }
            SolidKind::Formula(formula) => self.formula_solid(g, formula, at),
            SolidKind::Csg { op, children } => {
                let mut nodes = Vec::new();
                for c in children {
                    match self.solid(g, c, at) {
                        Ok(n) => nodes.push(n),
                        Err(Reported) => failed = true,
                    }
                }
                if failed {
                    return Err(Reported);
                }
                let first = nodes[0];
                Ok(nodes[1..].iter().fold(first, |acc, &n| match op {
                    CsgOp::Union => g.min(acc, n),
                    CsgOp::Intersection => g.max(acc, n),
                    CsgOp::Difference => {
                        let outside = g.neg(n);
                        g.max(acc, outside)
                    }
                }))
            }
        };
        if failed {
            return Err(Reported);
        }
        result
    }

    /// `e` at `point` as a formula negative inside a region: a number as
    /// it stands, a condition as the region where it holds; any other kind
    /// is given back for the caller's message.
    fn region_at(
        &mut self,
        g: &mut Graph,
        e: &Expr,
        point: [NodeId; 3],
    ) -> Result<Result<NodeId, Value>, Reported> {
        let frame = lower::Frame {
            params: lower::Scope::EMPTY,
            point: Some(point),
        };
        Ok(match self.lowerer(g).lower(e, frame)? {
            Value::Num(n) => Ok(n),
            Value::Cond(c) => Ok(g.neg(c)),
            v => Err(v),
        })
    }

    /// A formula of x, y, z drawn as it stands, evaluated at `at`.
    fn formula_solid(&mut self, g: &mut Graph, formula: &Expr, at: At) -> Result<NodeId, Reported> {
        let point = at.nodes(g);
        match self.region_at(g, formula, point)? {
            Ok(n) => Ok(n),
            Err(v) => self.fail(
                Diagnostic::new(
                    Code::WrongKind,
                    format!("this gives {}, and an object needs a number", v.kind_name()),
                )
                .label(formula.span, format!("this is {}", v.kind_name()))
                .help("an object draws where a formula is 0: give it a shape or a formula of x, y, z; for a vector v use e.g. length(v) - 1"),
            ),
        }
    }

    /// A solid named by `name` (with `args`): a shape, a builtin of
    /// formulas (`smin(sphere(1), cube(0.8) translate (1, 0, 0), 0.3)`),
    /// or a coordinate or constant (`object x`), drawn as a formula.
    fn shape_instance(
        &mut self,
        g: &mut Graph,
        name: &Ident,
        args: &[Expr],
        span: Span,
        at: At,
    ) -> Result<NodeId, Reported> {
        if matches!(name.name.as_str(), "union" | "intersection" | "difference") {
            return self.fail(
                Diagnostic::new(
                    Code::WrongKind,
                    format!("`{}` combines solids, and none were given", name.name),
                )
                .label(span, "nothing to combine")
                .help(format!(
                    "write the parts in brackets, like `{}(sphere(1), cube(0.8) translate (1, 0, 0))`",
                    name.name
                )),
            );
        }
        if self.globals.broken_names.contains(&name.name) {
            return Err(Reported);
        }
        let n = name.name.as_str();
        let shape = self.globals.shapes.contains_key(n);
        let builtin = lower::BUILTIN_FUNCTIONS.contains(&n);
        let value =
            args.is_empty() && (lower::RESERVED.contains(&n) || self.globals.lets.contains_key(n));
        if !(shape || builtin || value) {
            // An object may be a formula, so a builtin function is a guess too.
            let names = self.globals.shapes.keys().map(|s| s.as_str());
            let hint = match suggest(n, names.chain(lower::BUILTIN_FUNCTIONS.iter().copied())) {
                Some(s) => format!("did you mean `{s}`?"),
                None => "define it with `shape NAME(...) = ...`, or use a built-in shape like sphere, box or torus".into(),
            };
            return self.fail(
                Diagnostic::new(Code::UnknownName, format!("unknown shape `{n}`"))
                    .label(name.span, "no shape has this name")
                    .help(hint),
            );
        }
        let kind = if shape || builtin {
            ExprKind::Call {
                name: name.clone(),
                args: args.to_vec(),
            }
        } else {
            ExprKind::Variable(name.name.clone())
        };
        self.formula_solid(g, &Expr { kind, span }, at)
    }

    fn number(&mut self, e: &Expr, what: &str) -> Result<f64, Reported> {
        match self.constant(e)? {
            Constant::Num(n) if n.is_finite() => Ok(n),
            Constant::Num(n) => self.fail(
                Diagnostic::new(Code::OutOfRange, format!("{what} must be finite, got {n}"))
                    .label(e.span, "not a finite number")
                    .help("check for a division by zero or an overflow"),
            ),
            other => self.fail(
                Diagnostic::new(
                    Code::WrongKind,
                    format!("{what} must be a number, not {}", kind_name(other)),
                )
                .label(e.span, format!("this is {}", kind_name(other)))
                .help("give a single number here"),
            ),
        }
    }

    fn vector(&mut self, e: &Expr, what: &str) -> Result<DVec3, Reported> {
        match self.constant(e)? {
            Constant::Vector(v) if v.is_finite() => Ok(v),
            Constant::Vector(_) => self.fail(
                Diagnostic::new(Code::OutOfRange, format!("{what} must be finite"))
                    .label(e.span, "a component is not finite")
                    .help("check for a division by zero or an overflow"),
            ),
            other => self.fail(
                Diagnostic::new(
                    Code::WrongKind,
                    format!("{what} must be a vector, not {}", kind_name(other)),
                )
                .label(e.span, format!("this is {}", kind_name(other)))
                .help("write a vector as (x, y, z)"),
            ),
        }
    }

    /// An object's `colour` or `inside`: one colour, or a formula of the
    /// point, the normal and the curvatures giving sRGB components.
    fn paint(&mut self, e: &Expr) -> Result<Paint, Reported> {
        let mut g = Graph::new();
        let point = [0, 1, 2].map(|i| g.input(i));
        let params = vec![
            (
                COLOUR_FIELD_NAMES[0].to_string(),
                Value::Vector([3, 4, 5].map(|i| g.input(i))),
            ),
            (COLOUR_FIELD_NAMES[1].to_string(), Value::Num(g.input(6))),
            (COLOUR_FIELD_NAMES[2].to_string(), Value::Num(g.input(7))),
        ];
        let frame = Frame {
            params: lower::Scope::of(&params),
            point: Some(point),
        };
        let constant = match self.lowerer(&mut g).lower(e, frame)? {
            Value::Vector(v) if v.iter().any(|&n| g.depends_on_input(n)) => {
                let tape = crate::expr::Tape::new(&g, &v);
                return Ok(Paint::Field(Box::new(crate::scene::ColourField::new(tape))));
            }
            Value::Vector(v) => {
                let c = v.map(|n| g.constant_value(n).expect("a vector of no input is constant"));
                Constant::Vector(DVec3::from(c))
            }
            Value::Colour(c) => Constant::Colour(c),
            Value::Num(n) if g.depends_on_input(n) => {
                return self.fail(
                    Diagnostic::new(Code::WrongKind, "a colour that varies needs three components, not one number")
                        .label(e.span, "this is a number")
                        .help("map a number to a colour with viridis(t) or diverging(t), or write (red, green, blue) with each from 0 to 1"),
                )
            }
            Value::Num(n) => Constant::Num(g.constant_value(n).expect("a number of no input is constant")),
            Value::Cond(_) => {
                return self.fail(
                    Diagnostic::new(Code::WrongKind, "a colour must be a colour, not a condition")
                        .label(e.span, "this is a condition")
                        .help("choose between colours with `if CONDITION then A else B`"),
                )
            }
        };
        self.checked_colour(constant, e).map(Paint::Flat)
    }

    /// A colour, returned in linear RGB.
    fn colour(&mut self, e: &Expr) -> Result<DVec3, Reported> {
        let c = self.constant(e)?;
        self.checked_colour(c, e)
    }

    /// A constant written as a colour: an sRGB colour, or a vector of
    /// components from 0 to 1; returned in linear RGB.
    fn checked_colour(&mut self, c: Constant, e: &Expr) -> Result<DVec3, Reported> {
        let srgb = match c {
            Constant::Colour(c) => c,
            Constant::Vector(v) if v.cmpge(DVec3::ZERO).all() && v.cmple(DVec3::ONE).all() => v,
            Constant::Vector(v) => return self.fail(
                Diagnostic::new(
                    Code::OutOfRange,
                    format!(
                        "colour components must lie in 0 to 1, got ({}, {}, {})",
                        v.x, v.y, v.z
                    ),
                )
                .label(e.span, "out of range")
                .help(
                    "write fractions like (1, 0.5, 0.2), bytes with rgb(255, 128, 51), or #ff8033",
                ),
            ),
            Constant::Num(_) => {
                return self.fail(
                    Diagnostic::new(Code::WrongKind, "a colour must be a colour, not a number")
                        .label(e.span, "this is a number")
                        .help(
                            "write #ff8800, a name like orange, rgb(255, 136, 0) or (1, 0.53, 0)",
                        ),
                )
            }
        };
        Ok(srgb.to_array().map(crate::shade::srgb_to_linear).into())
    }
}

fn kind_name(c: Constant) -> &'static str {
    match c {
        Constant::Num(_) => "a number",
        Constant::Vector(_) => "a vector",
        Constant::Colour(_) => "a colour",
    }
}

/// A number for a message: at most four significant digits, no trailing
/// zeros (`13`, `0.1235`, `1.5e-7`).
fn short_number(v: f64) -> String {
    if v != 0.0 && (v.abs() < 1e-3 || v.abs() >= 1e6) {
        return format!("{v:.3e}");
    }
    let t = format!("{:.4}", v);
    let t = t.trim_end_matches('0').trim_end_matches('.');
    t.to_string()
}

/// A short name for a solid, for messages and `nes explain`: a formula is
/// named by its text (shortened), where the source is known.
fn solid_label(s: &Solid, source: Option<&str>) -> String {
    const LONGEST: usize = 40;
    match &s.kind {
        SolidKind::Shape { name, .. } => name.name.clone(),
        SolidKind::Formula(e) => {
            let Some(text) = source.and_then(|src| src.get(e.span.start..e.span.end)) else {
                return "formula".into();
            };
            let text = text.split_whitespace().collect::<Vec<_>>().join(" ");
            if text.chars().count() <= LONGEST {
                text
            } else {
                let head: String = text.chars().take(LONGEST - 3).collect();
                format!("{}...", head.trim_end())
            }
        }
        SolidKind::Csg { op, children } => {
            let op = match op {
                CsgOp::Union => "union",
                CsgOp::Intersection => "intersection",
                CsgOp::Difference => "difference",
            };
            let inner: Vec<String> = children.iter().map(|c| solid_label(c, source)).collect();
            format!("{op}({})", inner.join(", "))
        }
    }
}

/// The rotation by `degrees` about the unit `axis`. Quarter turns are
/// exact: `rotate 90 about z` must not leave `6e-17 * x` terms in every
/// expression it touches (they cost an operation per evaluation and stop
/// planes and quadrics from being recognised as axis-aligned).
fn rotation(axis: DVec3, degrees: f64) -> DMat3 {
    let turns = degrees.rem_euclid(360.0);
    let (s, c) = match turns {
        0.0 => (0.0, 1.0),
        90.0 => (1.0, 0.0),
        180.0 => (0.0, -1.0),
        270.0 => (-1.0, 0.0),
        _ => degrees.to_radians().sin_cos(),
    };
    let omc = 1.0 - c;
    let (x, y, z) = (axis.x, axis.y, axis.z);
    DMat3::from_cols(
        DVec3::new(x * x * omc + c, x * y * omc + z * s, x * z * omc - y * s),
        DVec3::new(x * y * omc - z * s, y * y * omc + c, y * z * omc + x * s),
        DVec3::new(x * z * omc + y * s, y * z * omc - x * s, z * z * omc + c),
    )
}

/// Whether a misspelt `about` (`rotate 30 abut z`, reported as an unknown
/// property whose hint says so) follows the transform at `span`: that
/// report covers the missing axis, which is not reported again.
pub(crate) fn about_misspelt_after(diags: &[Diagnostic], span: Span) -> bool {
    diags.iter().any(|d| {
        d.code == Code::UnknownSetting
            && d.help.as_deref() == Some(settings::ABOUT_HINT)
            && d.span()
                .is_some_and(|s| s.start > span.end && s.start <= span.end + 8)
    })
}

#[cfg(test)]
mod rotation_tests {
    use super::*;

    #[test]
    fn rotations_match_glam_and_quarter_turns_are_exact() {
        let axis = DVec3::new(1.0, -2.0, 0.5).normalize();
        for degrees in [-30.0, 17.0, 45.0, 123.0, 400.0] {
            let ours = rotation(axis, degrees);
            let glam = DMat3::from_axis_angle(axis, f64::to_radians(degrees));
            assert!(ours.abs_diff_eq(glam, 1e-12), "{degrees}");
        }
        let quarter = rotation(DVec3::Z, 90.0);
        assert_eq!(quarter * DVec3::X, DVec3::Y);
        assert_eq!(rotation(DVec3::X, -90.0) * DVec3::Y, DVec3::NEG_Z);
        assert_eq!(rotation(DVec3::Y, 180.0) * DVec3::Z, DVec3::NEG_Z);
    }
}
