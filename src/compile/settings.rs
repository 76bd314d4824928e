//! Directives and properties: camera, lights, space, render settings.
//!
//! Each value is read as a constant of the right kind and checked against
//! its range here, so the tracer never sees an invalid setting.

use std::collections::HashMap;

use glam::DVec3;

use super::lower::Constant;
use super::{Compiler, Reported};
use crate::ast::{self, Expr, ExprKind, Item, Property};
use crate::camera::{Camera, Projection};
use crate::diagnostic::{suggest, Code, Diagnostic, Span};
use crate::scene::{Falloff, Light, Method, RenderSettings, Scene, Shading, ShadowPaths};
use crate::space::SpaceKind;

/// What `render { }` takes: named in the hint when one is written in
/// another block.
const RENDER_PROPERTIES: &[&str] = &[
    "method",
    "epsilon",
    "step",
    "max_distance",
    "max_steps",
    "samples",
    "shading",
    "shadows",
    "tolerance",
];

/// The properties of one block, checked for unknown and repeated names.
pub(super) struct Props<'a> {
    /// The known properties, in source order.
    pub list: Vec<&'a Property>,
    pub failed: bool,
    /// The known names suggested for unknown ones (`positon` for
    /// `position`): a missing property that was misspelt is reported once,
    /// as the misspelling.
    suggested: Vec<String>,
}

/// The hint for a misspelt `about` (`rotate 30 abut z`), by which the
/// missing axis's own error knows to stay silent.
pub(crate) const ABOUT_HINT: &str = "did you mean `about`? write `rotate DEGREES about AXIS`";

impl<'a> Props<'a> {
    pub fn new(
        c: &mut Compiler,
        props: &'a [Property],
        context: &str,
        known: &[&str],
        repeatable: &[&str],
    ) -> Props<'a> {
        let mut list = Vec::new();
        let mut failed = false;
        let mut seen: HashMap<&str, Span> = HashMap::new();
        let mut suggested = Vec::new();
        for p in props {
            let name = p.name.name.as_str();
            if !known.contains(&name) {
                let suggestion = suggest(name, known.iter().copied());
                suggested.extend(suggestion.clone());
                // `rotate 30 abut z`: the misspelt word is read as a
                // property of its own.
                let about = known.contains(&"rotate") && suggest(name, ["about"]).is_some();
                let hint = match suggestion {
                    _ if about => ABOUT_HINT.to_string(),
                    Some(s) => format!("did you mean `{s}`? {context} takes: {}", known.join(", ")),
                    None if RENDER_PROPERTIES.contains(&name) => format!(
                        "`{name}` is a setting of `render {{ {name} ... }}`, a block of its own; {context} takes: {}",
                        known.join(", ")
                    ),
                    None => format!("{context} takes: {}", known.join(", ")),
                };
                c.diags.push(
                    Diagnostic::new(
                        Code::UnknownSetting,
                        format!("{context} has no property `{name}`"),
                    )
                    .label(p.name.span, "unknown property")
                    .help(hint),
                );
                failed = true;
                continue;
            }
            // `colour` and `color` are one property.
            let canonical = if name == "color" { "colour" } else { name };
            if !repeatable.contains(&name) {
                if let Some(first) = seen.get(canonical) {
                    c.diags.push(
                        Diagnostic::new(Code::DuplicateName, format!("`{name}` is given twice"))
                            .label(p.name.span, "given again here")
                            .label(*first, "first given here")
                            .help("keep one of them"),
                    );
                    failed = true;
                    continue;
                }
                seen.insert(canonical, p.name.span);
            }
            if let (Some(about), false) = (&p.about, name == "rotate") {
                c.diags.push(
                    Diagnostic::new(Code::UnknownSetting, "only `rotate` takes `about`")
                        .label(about.span, "not used here")
                        .help("write `rotate DEGREES about AXIS`"),
                );
                failed = true;
                continue;
            }
            list.push(p);
        }
        Props {
            list,
            failed,
            suggested,
        }
    }

    pub fn get(&self, name: &str) -> Option<&'a Property> {
        self.list.iter().copied().find(|p| p.name.name == name)
    }

    /// Whether an unknown property was reported as a misspelling of `name`.
    pub fn misspelt(&self, name: &str) -> bool {
        self.suggested.iter().any(|s| s == name)
    }
}

/// The largest image side, in pixels.
pub const MAX_IMAGE_SIDE: f64 = 65536.0;

/// A number setting's range and what to say when a value is outside it:
/// **the one table that both the scene file and the command line check
/// against**, so the two cannot drift apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limit {
    /// The setting's name, as written in a scene.
    pub name: &'static str,
    /// The least value allowed (excluded when `above_min`).
    pub min: f64,
    /// The largest value allowed.
    pub max: f64,
    /// Whether `min` itself is excluded (a positive setting).
    pub above_min: bool,
    /// Whether only whole numbers are allowed.
    pub whole: bool,
    /// How to choose a good value.
    pub hint: &'static str,
}

impl Limit {
    const fn between(name: &'static str, min: f64, max: f64, hint: &'static str) -> Limit {
        Limit {
            name,
            min,
            max,
            above_min: false,
            whole: false,
            hint,
        }
    }

    const fn positive(name: &'static str, hint: &'static str) -> Limit {
        Limit {
            name,
            min: 0.0,
            max: f64::MAX,
            above_min: true,
            whole: false,
            hint,
        }
    }

    const fn whole(name: &'static str, min: f64, max: f64, hint: &'static str) -> Limit {
        Limit {
            name,
            min,
            max,
            above_min: false,
            whole: true,
            hint,
        }
    }

    /// `value` if it is within the limit; otherwise what is wrong.
    pub fn check(&self, value: f64) -> Result<f64, String> {
        let below = if self.above_min {
            value <= self.min
        } else {
            value < self.min
        };
        let fits = value.is_finite()
            && !below
            && value <= self.max
            && (!self.whole || value.fract() == 0.0);
        if fits {
            return Ok(value);
        }
        let name = self.name;
        let too_big = value > self.max;
        // 1e300 and 1e-12 as written, not as 301 or 13 digits.
        let value = readable(value);
        if self.above_min && !self.whole && too_big {
            return Err(format!(
                "{name} must be at most {:e}, got {value}",
                self.max
            ));
        }
        Err(if self.whole {
            format!(
                "{name} must be a whole number from {} to {}, got {value}",
                readable(self.min),
                readable(self.max)
            )
        } else if self.above_min {
            format!("{name} must be positive, got {value}")
        } else {
            format!(
                "{name} must be between {} and {}, got {value}",
                readable(self.min),
                readable(self.max)
            )
        })
    }

    /// The label under a value outside the limit.
    fn label(&self, value: f64) -> &'static str {
        if self.above_min && !self.whole && value <= self.min {
            "not positive"
        } else {
            "out of range"
        }
    }
}

const IMAGE_SIZE_HINT: &str =
    "image sizes are whole numbers of pixels from 1 to 65536 (above 11585 x 11585, render in shards)";
/// The camera's image width.
pub const WIDTH: Limit = Limit::whole("width", 1.0, MAX_IMAGE_SIDE, IMAGE_SIZE_HINT);
/// The camera's image height.
pub const HEIGHT: Limit = Limit::whole("height", 1.0, MAX_IMAGE_SIDE, IMAGE_SIZE_HINT);
/// Samples per pixel.
pub const SAMPLES: Limit = Limit::whole(
    "samples",
    1.0,
    1024.0,
    "samples per pixel for anti-aliasing: 1 for none, 4 or 9 for smooth edges",
);
/// The marching step of the march and adaptive methods.
pub const STEP: Limit = Limit::positive("step", "step is the marching step length, e.g. 0.01");

/// The curvature radius of S3 and H3.
const CURVATURE_RADIUS: Limit = Limit {
    name: "the curvature radius",
    min: 0.0,
    max: crate::space::MAX_CURVATURE_RADIUS,
    above_min: true,
    whole: false,
    hint: "the radius R of the space's curvature (+-1/R^2); large R looks Euclidean, and up to 1e6 positions keep their precision",
};

impl Compiler {
    /// What a top-level item that is no directive was most likely meant
    /// to be: an object's property, a value to draw, a render setting,
    /// the render block under another renderer's name, or a misspelling.
    fn not_a_directive(&self, d: &ast::Directive) -> Diagnostic {
        let name = d.name.name.as_str();
        let drawable = self.globals.shapes.contains_key(name)
            || super::lower::BUILTIN_FUNCTIONS.contains(&name)
            || self.globals.lets.contains_key(name)
            || ["x", "y", "z", "p"].contains(&name);
        // What other renderers and config files call the block of render
        // settings.
        const SETTINGS_BLOCKS: &[&str] = &[
            "settings",
            "global_settings",
            "options",
            "config",
            "renderer",
        ];
        let (message, span, label, help) = if super::OBJECT_PROPERTIES.contains(&name) {
            (
                format!("`{name}` is a property of an object, not a directive"),
                d.name.span,
                "a property outside an object's braces",
                format!("an object's properties go in braces after it: `object sphere(1) {{ {name} ... }}`"),
            )
        } else if drawable {
            (
                format!("a value at the top level draws nothing: `{name}` is not a directive"),
                d.span,
                "this is neither an object nor a directive",
                "to draw it, write `object` before it; to name it, `shape NAME = ...` or `let NAME = ...`"
                    .to_string(),
            )
        } else if RENDER_PROPERTIES.contains(&name) {
            (
                format!("`{name}` is a render setting, not a directive"),
                d.name.span,
                "a render setting at the top level",
                format!("render settings go in one block: `render {{ {name} ... }}`"),
            )
        } else {
            let names = || ast::DIRECTIVES.iter().map(|d| d.name);
            let help = if SETTINGS_BLOCKS.contains(&name) {
                "render settings are written `render { ... }`, e.g. `render { shadows off }`"
                    .to_string()
            } else {
                match suggest(name, names().chain(ast::ITEM_KEYWORDS)) {
                    Some(s) => format!("did you mean `{s}`?"),
                    None => format!(
                        "a scene is made of {} and {}",
                        ast::ITEM_KEYWORDS.join(", "),
                        names().collect::<Vec<_>>().join(", ")
                    ),
                }
            };
            (
                format!("unknown directive `{name}`"),
                d.name.span,
                "not a directive",
                help,
            )
        };
        Diagnostic::new(Code::UnknownSetting, message)
            .label(span, label)
            .help(help)
    }

    /// Read every directive into a scene without objects. `None` if any
    /// failed (and then a diagnostic was reported).
    pub(super) fn directives(&mut self, file: &ast::File) -> Option<Scene> {
        let mut first: HashMap<&str, Span> = HashMap::new();
        let mut camera = None;
        let mut camera_seen = false;
        let mut lights = Vec::new();
        let mut ambient = 0.1;
        let mut background = DVec3::ZERO;
        let mut space = SpaceKind::Euclidean;
        let mut settings = RenderSettings::default();
        let mut failed = false;
        for item in &file.items {
            let Item::Directive(d) = item else { continue };
            let name = d.name.name.as_str();
            let Some(spec) = ast::directive(name) else {
                let diagnostic = self.not_a_directive(d);
                self.diags.push(diagnostic);
                failed = true;
                continue;
            };
            if !spec.repeatable {
                if let Some(prev) = first.get(name) {
                    self.diags.push(
                        Diagnostic::new(Code::DuplicateName, format!("`{name}` is given twice"))
                            .label(d.name.span, "given again here")
                            .label(*prev, "first given here")
                            .help("a scene has one of these; keep one"),
                    );
                    failed = true;
                    continue;
                }
                first.insert(name, d.name.span);
            }
            let Ok(value) = self.directive_form(d, spec) else {
                failed = true;
                continue;
            };
            let empty = ast::Block {
                properties: Vec::new(),
                span: d.span,
            };
            let block = d.block.as_ref().unwrap_or(&empty);
            let ok = match name {
                "camera" => {
                    camera_seen = true;
                    self.camera(block).map(|c| camera = Some(c))
                }
                "light" => self.light(block).map(|l| lights.push(l)),
                "ambient" => self
                    .ranged(
                        value.unwrap(),
                        "ambient",
                        0.0,
                        1.0,
                        "ambient is the fraction of colour seen in shadow, from 0 to 1",
                    )
                    .map(|a| ambient = a),
                "background" => self.colour(value.unwrap()).map(|c| background = c),
                "space" => self
                    .space(value.unwrap(), d.block.as_ref())
                    .map(|s| space = s),
                "render" => self.render(block).map(|s| settings = s),
                _ => unreachable!(),
            };
            failed |= ok.is_err();
        }
        if !camera_seen {
            self.diags.push(
                Diagnostic::new(Code::MissingSetting, "the scene has no camera")
                    .label(Span::new(0, 0), "a scene needs a camera")
                    .help("add e.g. `camera { position (-6, 0, 2)  look_at (0, 0, 0) }`"),
            );
            failed = true;
        }
        if let (Method::Ode, Some(reason)) = (settings.method, space.why_not_integrate()) {
            let span = file
                .items
                .iter()
                .find_map(|i| match i {
                    Item::Directive(d) if d.name.name == "render" => d
                        .block
                        .as_ref()
                        .and_then(|b| b.properties.iter().find(|p| p.name.name == "method"))
                        .map(|p| p.value.span),
                    _ => None,
                })
                .unwrap_or_default();
            self.diags.push(
                Diagnostic::new(
                    Code::OutOfRange,
                    format!("method `ode` cannot be used here: {reason}"),
                )
                .label(span, "this method")
                .help(if space.places_objects() {
                    space.instead_of_integrating()
                } else {
                    "use method auto (or exact, interval, march, adaptive)"
                }),
            );
            failed = true;
        }
        if failed {
            return None;
        }
        Some(Scene {
            camera: camera?,
            objects: Vec::new(),
            lights,
            ambient,
            background,
            space,
            settings,
            animated: false,
            warnings: Vec::new(),
            imports: Vec::new(),
        })
    }

    /// Check that `d` is written in its directive's form; its value, if
    /// the form has one.
    fn directive_form<'d>(
        &mut self,
        d: &'d ast::Directive,
        spec: &ast::DirectiveSpec,
    ) -> Result<Option<&'d Expr>, Reported> {
        let name = spec.name;
        match spec.form {
            ast::DirectiveForm::Block => {
                if let Some(v) = &d.value {
                    return self.fail(
                        Diagnostic::new(
                            Code::Syntax,
                            format!("`{name}` takes a block, not a value"),
                        )
                        .label(v.span, "unexpected value")
                        .help(format!("write `{name} {{ property value ... }}`")),
                    );
                }
                return Ok(None);
            }
            ast::DirectiveForm::Value => {
                if let Some(b) = &d.block {
                    return self.fail(
                        Diagnostic::new(
                            Code::Syntax,
                            format!("`{name}` takes a value, not a block"),
                        )
                        .label(b.span, "unexpected block")
                        .help(format!("write e.g. `{}`", spec.example)),
                    );
                }
            }
            ast::DirectiveForm::ValueAndBlock => {}
        }
        match &d.value {
            Some(v) => Ok(Some(v)),
            None => self.fail(
                Diagnostic::new(Code::MissingSetting, format!("`{name}` needs a value"))
                    .label(d.span, "no value")
                    .help(format!("write e.g. `{}`", spec.example)),
            ),
        }
    }

    /// A number checked against `limit`: the one check the scene file and
    /// the command line share.
    pub(super) fn limited(&mut self, e: &Expr, limit: &Limit) -> Result<f64, Reported> {
        let v = self.number(e, limit.name)?;
        match limit.check(v) {
            Ok(v) => Ok(v),
            Err(message) => self.fail(
                Diagnostic::new(Code::OutOfRange, message)
                    .label(e.span, limit.label(v))
                    .help(limit.hint.to_string()),
            ),
        }
    }

    fn ranged(
        &mut self,
        e: &Expr,
        name: &'static str,
        min: f64,
        max: f64,
        hint: &'static str,
    ) -> Result<f64, Reported> {
        self.limited(e, &Limit::between(name, min, max, hint))
    }

    fn positive(
        &mut self,
        e: &Expr,
        name: &'static str,
        hint: &'static str,
    ) -> Result<f64, Reported> {
        self.limited(e, &Limit::positive(name, hint))
    }

    pub(super) fn integer(
        &mut self,
        e: &Expr,
        name: &'static str,
        min: f64,
        max: f64,
        hint: &'static str,
    ) -> Result<u64, Reported> {
        self.limited(e, &Limit::whole(name, min, max, hint))
            .map(|v| v as u64)
    }

    /// A bare word from `options`.
    fn word(
        &mut self,
        e: &Expr,
        what: &str,
        options: &[&'static str],
    ) -> Result<&'static str, Reported> {
        if let ExprKind::Variable(v) = &e.kind {
            if let Some(o) = options.iter().find(|o| **o == v) {
                return Ok(o);
            }
            let hint = match suggest(v, options.iter().copied()) {
                Some(s) => format!("did you mean `{s}`? choose one of: {}", options.join(", ")),
                None => format!("choose one of: {}", options.join(", ")),
            };
            return self.fail(
                Diagnostic::new(Code::UnknownName, format!("unknown {what} `{v}`"))
                    .label(e.span, format!("not a {what}"))
                    .help(hint),
            );
        }
        self.fail(
            Diagnostic::new(
                Code::WrongKind,
                format!("{what} must be one of: {}", options.join(", ")),
            )
            .label(e.span, "expected a word")
            .help(format!("write one of: {}", options.join(", "))),
        )
    }

    fn switch(&mut self, e: &Expr, what: &str) -> Result<bool, Reported> {
        Ok(matches!(
            self.word(e, what, &["on", "off", "true", "false"])?,
            "on" | "true"
        ))
    }

    fn camera(&mut self, block: &ast::Block) -> Result<Camera, Reported> {
        let props = Props::new(
            self,
            &block.properties,
            "the camera",
            &[
                "position",
                "look_at",
                "yaw",
                "pitch",
                "up",
                "fov",
                "width",
                "height",
                "projection",
                "correction",
            ],
            &[],
        );
        let mut failed = props.failed;
        let position = match props.get("position") {
            Some(p) => self.vector(&p.value, "the camera position").ok(),
            None => {
                if !props.misspelt("position") {
                    self.diags.push(
                        Diagnostic::new(Code::MissingSetting, "the camera has no position")
                            .label(block.span, "this camera")
                            .help("add e.g. `position (-6, 0, 2)`"),
                    );
                }
                None
            }
        };
        let up = match props.get("up") {
            Some(p) => match self.vector(&p.value, "the camera's up") {
                Ok(v) if crate::camera::unit_vector(v).is_some() => Some(v),
                Ok(_) => {
                    self.diags.push(
                        Diagnostic::new(Code::ZeroLength, "the camera's up vector cannot be zero")
                            .label(p.value.span, "length zero")
                            .help("z is up by default; leave `up` out or give a non-zero vector"),
                    );
                    None
                }
                Err(Reported) => None,
            },
            None => Some(DVec3::Z),
        };
        let look_at = props.get("look_at");
        let (yaw, pitch) = (props.get("yaw"), props.get("pitch"));
        let mut forward = None;
        if let Some(l) = look_at {
            if let Some(other) = yaw.or(pitch) {
                self.diags.push(
                    Diagnostic::new(
                        Code::DuplicateName,
                        "give the camera either look_at or yaw/pitch, not both",
                    )
                    .label(other.name.span, "this")
                    .label(l.name.span, "conflicts with this")
                    .help("remove one way of aiming the camera"),
                );
                failed = true;
            } else if let (Ok(target), Some(pos)) = (self.vector(&l.value, "look_at"), position) {
                if (target - pos).length() == 0.0 {
                    self.diags.push(
                        Diagnostic::new(Code::ZeroLength, "the camera looks at its own position")
                            .label(l.value.span, "same point as the camera's position")
                            .help("look_at must be a point away from the camera"),
                    );
                    failed = true;
                } else {
                    // Halves first: the difference of two far-apart points
                    // near the largest float would overflow.
                    forward = Some(0.5 * target - 0.5 * pos);
                }
            }
        } else {
            let yaw_deg = yaw.map(|p| self.number(&p.value, "yaw")).transpose();
            let pitch_deg = pitch
                .map(|p| {
                    self.ranged(
                        &p.value,
                        "pitch",
                        -90.0,
                        90.0,
                        "pitch is the angle above the horizon, in degrees",
                    )
                })
                .transpose();
            if let (Ok(y), Ok(p)) = (yaw_deg, pitch_deg) {
                let (y, p) = (y.unwrap_or(0.0).to_radians(), p.unwrap_or(0.0).to_radians());
                forward = Some(DVec3::new(p.cos() * y.cos(), p.cos() * y.sin(), p.sin()));
            } else {
                failed = true;
            }
        }
        let fov = match props.get("fov") {
            Some(p) => {
                let v = self.number(&p.value, "the field of view");
                match v {
                    Ok(v) if v > 0.0 && v < 180.0 => Some(v),
                    Ok(v) => {
                        self.diags.push(
                            Diagnostic::new(Code::OutOfRange, format!("the field of view must be between 0 and 180 degrees, got {v}"))
                                .label(p.value.span, "out of range")
                                .help("fov is the angle across the image diagonal in degrees; 60 is a normal lens, 84 the seed's"),
                        );
                        None
                    }
                    Err(Reported) => None,
                }
            }
            None => Some(60.0),
        };
        let width = props
            .get("width")
            .map(|p| self.limited(&p.value, &WIDTH).map(|v| v as u64))
            .transpose();
        let height = props
            .get("height")
            .map(|p| self.limited(&p.value, &HEIGHT).map(|v| v as u64))
            .transpose();
        let correction = props
            .get("correction")
            .map(|p| self.switch(&p.value, "correction setting"))
            .transpose();
        let projection = props
            .get("projection")
            .map(|p| self.word(&p.value, "projection", &["rectilinear", "angular"]))
            .transpose();
        let (
            Some(position),
            Some(up),
            Some(forward),
            Some(fov),
            Ok(width),
            Ok(height),
            Ok(correction),
            Ok(projection),
        ) = (
            position, up, forward, fov, width, height, correction, projection,
        )
        else {
            return Err(Reported);
        };
        if failed {
            return Err(Reported);
        }
        let up_hint = up;
        let Some((forward, left, up)) = Camera::frame(forward, up) else {
            let span = ["up", "pitch", "look_at"]
                .iter()
                .find_map(|n| props.get(n))
                .map_or(block.span, |p| p.value.span);
            return self.fail(
                Diagnostic::new(Code::ZeroLength, "the camera looks straight along its up direction")
                    .label(span, "the view direction is parallel to `up`")
                    .help("give an `up` vector that is not parallel to the view, e.g. up (1, 0, 0) for a camera looking straight down"),
            );
        };
        let projection = match projection {
            Some("angular") => Projection::Angular {
                correction: correction.unwrap_or(true),
            },
            _ => Projection::Rectilinear,
        };
        let target = look_at.and_then(|l| self.vector(&l.value, "look_at").ok());
        Ok(Camera {
            position,
            forward,
            left,
            up,
            target,
            up_hint,
            fov_degrees: fov,
            width: width.unwrap_or(800) as u32,
            height: height.unwrap_or(600) as u32,
            projection,
        })
    }

    fn light(&mut self, block: &ast::Block) -> Result<Light, Reported> {
        let props = Props::new(
            self,
            &block.properties,
            "a light",
            &["position", "colour", "color", "intensity", "falloff"],
            &[],
        );
        let position = match props.get("position") {
            Some(p) => self.vector(&p.value, "the light's position").ok(),
            None => {
                if !props.misspelt("position") {
                    self.diags.push(
                        Diagnostic::new(Code::MissingSetting, "the light has no position")
                            .label(block.span, "this light")
                            .help("add e.g. `position (0, -8, 6)`"),
                    );
                }
                None
            }
        };
        let colour = props
            .get("colour")
            .or(props.get("color"))
            .map(|p| self.colour(&p.value))
            .transpose();
        let intensity = props
            .get("intensity")
            .map(|p| {
                self.ranged(
                    &p.value,
                    "intensity",
                    0.0,
                    1e6,
                    "intensity scales the light; 1 is full strength",
                )
            })
            .transpose();
        let falloff = props
            .get("falloff")
            .map(|p| {
                self.word(&p.value, "falloff", Falloff::NAMES)
                    .map(|w| match w {
                        "physical" => Falloff::Physical,
                        _ => Falloff::None,
                    })
            })
            .transpose();
        match (position, colour, intensity, falloff, props.failed) {
            (Some(position), Ok(colour), Ok(intensity), Ok(falloff), false) => Ok(Light {
                position,
                colour: colour.unwrap_or(DVec3::ONE),
                intensity: intensity.unwrap_or(1.0),
                falloff: falloff.unwrap_or_default(),
            }),
            _ => Err(Reported),
        }
    }

    fn space(&mut self, value: &Expr, block: Option<&ast::Block>) -> Result<SpaceKind, Reported> {
        let name = self.word(value, "space", &crate::space::SPACE_NAMES)?;
        let default = SpaceKind::default_named(name).expect("every listed space has defaults");
        let empty = ast::Block {
            properties: Vec::new(),
            span: value.span,
        };
        let block = block.unwrap_or(&empty);
        match default {
            SpaceKind::Euclidean => {
                if block.span != value.span {
                    return self.fail(
                        Diagnostic::new(
                            Code::UnknownSetting,
                            "the euclidean space has no parameters",
                        )
                        .label(block.span, "unexpected block")
                        .help("write just `space euclidean`"),
                    );
                }
                Ok(SpaceKind::Euclidean)
            }
            SpaceKind::Torus {
                mut min,
                mut max,
                mut wraps,
                mut periodic,
            } => {
                let props = Props::new(
                    self,
                    &block.properties,
                    "the torus",
                    &["min", "max", "wraps", "periodic"],
                    &[],
                );
                let mut failed = props.failed;
                // A corner as a number (the same on every axis) or a vector.
                let mut corner = |c: &mut Compiler, name: &str, into: &mut DVec3| {
                    if let Some(p) = props.get(name) {
                        match c.constant(&p.value) {
                            Ok(Constant::Num(n)) if n.is_finite() => *into = DVec3::splat(n),
                            Ok(Constant::Vector(v)) if v.is_finite() => *into = v,
                            Ok(_) => {
                                c.diags.push(
                                    Diagnostic::new(Code::WrongKind, format!("the torus's `{name}` must be a number or a vector"))
                                        .label(p.value.span, "not a finite number or vector")
                                        .help("write e.g. `min -10` for the cube [-10, 10]^3, or `min (-10, -5, -5)`"),
                                );
                                failed = true;
                            }
                            Err(Reported) => failed = true,
                        }
                    }
                };
                corner(self, "min", &mut min);
                corner(self, "max", &mut max);
                if let Some(p) = props.get("wraps") {
                    match self.integer(&p.value, "wraps", 0.0, 1e7, "wraps is how many times a ray may cross a face of the cell; the seed used 500") {
                        Ok(w) => wraps = w as u32,
                        Err(Reported) => failed = true,
                    }
                }
                if let Some(p) = props.get("periodic") {
                    match self.switch(&p.value, "periodic setting") {
                        Ok(b) => periodic = b,
                        Err(Reported) => failed = true,
                    }
                }
                if !failed && !(min.cmplt(max).all()) {
                    let span = props
                        .get("max")
                        .or(props.get("min"))
                        .map_or(block.span, |p| p.value.span);
                    return self.fail(
                        Diagnostic::new(
                            Code::OutOfRange,
                            format!(
                                "the torus's cell is empty: min ({}, {}, {}) is not below max ({}, {}, {}) on every axis",
                                min.x, min.y, min.z, max.x, max.y, max.z
                            ),
                        )
                        .label(span, "not above min on every axis")
                        .help("the cell is the box from min to max; give min < max, e.g. min -10 max 10"),
                    );
                }
                if failed {
                    return Err(Reported);
                }
                Ok(SpaceKind::Torus {
                    min,
                    max,
                    wraps,
                    periodic,
                })
            }
            SpaceKind::Sphere { mut radius, path } => {
                let props = Props::new(
                    self,
                    &block.properties,
                    "the sphere space",
                    &["radius"],
                    &[],
                );
                if let Some(p) = props.get("radius") {
                    radius = self.limited(
                        &p.value,
                        &Limit {
                            name: "the sphere space's radius",
                            min: 0.0,
                            max: crate::space::MAX_SPHERE_RADIUS,
                            above_min: true,
                            whole: false,
                            hint: "the radius of the circles rays follow; the seed used 25, and at 1e100 paths are straight to within rounding",
                        },
                    )?;
                }
                if props.failed {
                    return Err(Reported);
                }
                Ok(SpaceKind::Sphere { radius, path })
            }
            SpaceKind::S3 {
                mut radius,
                mut loops,
            } => {
                let props = Props::new(self, &block.properties, "s3", &["radius", "loops"], &[]);
                let mut failed = props.failed;
                if let Some(p) = props.get("radius") {
                    match self.limited(&p.value, &CURVATURE_RADIUS) {
                        Ok(r) => radius = r,
                        Err(Reported) => failed = true,
                    }
                }
                if let Some(p) = props.get("loops") {
                    match self.integer(
                        &p.value,
                        "loops",
                        1.0,
                        1e4,
                        "loops is how many times a ray may go round the 3-sphere (2 pi R each)",
                    ) {
                        Ok(n) => loops = n as u32,
                        Err(Reported) => failed = true,
                    }
                }
                if failed {
                    return Err(Reported);
                }
                Ok(SpaceKind::S3 { radius, loops })
            }
            SpaceKind::H3 { mut radius } => {
                let props = Props::new(self, &block.properties, "h3", &["radius"], &[]);
                if let Some(p) = props.get("radius") {
                    radius = self.limited(&p.value, &CURVATURE_RADIUS)?;
                }
                if props.failed {
                    return Err(Reported);
                }
                Ok(SpaceKind::H3 { radius })
            }
            SpaceKind::Metric(_) => self.metric_space(block),
        }
    }

    fn render(&mut self, block: &ast::Block) -> Result<RenderSettings, Reported> {
        let props = Props::new(self, &block.properties, "render", RENDER_PROPERTIES, &[]);
        let mut s = RenderSettings::default();
        let mut failed = props.failed;
        for p in &props.list {
            let v = &p.value;
            let ok = match p.name.name.as_str() {
                "method" => self
                    .word(v, "method", Method::NAMES)
                    .map(|m| s.method = Method::from_name(m).unwrap()),
                "epsilon" => self
                    .positive(
                        v,
                        "epsilon",
                        "epsilon is how precisely hits are located, e.g. 1e-6",
                    )
                    .map(|x| s.epsilon = x),
                "step" => self.limited(v, &STEP).map(|x| s.step = x),
                "max_distance" => self
                    .positive(
                        v,
                        "max_distance",
                        "max_distance is how far rays travel, e.g. 100",
                    )
                    .map(|x| s.max_distance = x),
                "max_steps" => self
                    .integer(
                        v,
                        "max_steps",
                        1.0,
                        1e9,
                        "max_steps bounds the marching steps per ray",
                    )
                    .map(|x| s.max_steps = x),
                "samples" => self.limited(v, &SAMPLES).map(|x| s.samples = x as u32),
                "shading" => self.word(v, "shading", &["lambert", "flat"]).map(|w| {
                    s.shading = if w == "flat" {
                        Shading::Flat
                    } else {
                        Shading::Lambert
                    }
                }),
                "shadows" => self
                    .word(
                        v,
                        "shadows setting",
                        &["on", "off", "true", "false", "euclidean", "geodesic"],
                    )
                    .map(|w| match w {
                        "off" | "false" => s.shadows = false,
                        "geodesic" => s.shadow_paths = ShadowPaths::Geodesic,
                        "euclidean" => s.shadow_paths = ShadowPaths::Euclidean,
                        _ => {}
                    }),
                "tolerance" => self
                    .ranged(
                        v,
                        "tolerance",
                        1e-14,
                        1e-2,
                        "the integrator's relative tolerance (for `method ode`, and for every path in a metric space), e.g. 1e-8",
                    )
                    .map(|x| s.tolerance = x),
                _ => unreachable!("checked by Props"),
            };
            failed |= ok.is_err();
        }
        if s.epsilon >= s.step {
            // The one the user wrote is at fault; a default the user may
            // not know of is named as such.
            match (props.get("epsilon"), props.get("step")) {
                (Some(epsilon), step) => {
                    let step = if step.is_some() {
                        format!("step ({})", readable(s.step))
                    } else {
                        format!("the marching step ({}, the default)", readable(s.step))
                    };
                    return self.fail(
                        Diagnostic::new(Code::OutOfRange, format!("epsilon ({}) must be smaller than {step}", readable(s.epsilon)))
                            .label(epsilon.value.span, "not smaller than the step")
                            .help("epsilon is how closely a hit is located, in scene units (1e-6 is usual), step the first stride of a march; make epsilon much smaller"),
                    );
                }
                (None, Some(step)) => {
                    return self.fail(
                        Diagnostic::new(
                            Code::OutOfRange,
                            format!(
                                "step ({}) must be larger than epsilon ({}, the default)",
                                readable(s.step),
                                readable(s.epsilon)
                            ),
                        )
                        .label(step.value.span, "not larger than epsilon")
                        .help("step is the first stride of a march, in scene units (0.01 is usual), epsilon how closely a hit is located; make the step much larger"),
                    );
                }
                (None, None) => {}
            }
        }
        if failed {
            Err(Reported)
        } else {
            Ok(s)
        }
    }
}

/// A limit or value for a message: `1e-14` rather than
/// `0.00000000000001`, and plain digits in between.
pub(crate) fn readable(v: f64) -> String {
    if v != 0.0 && v.is_finite() && (v.abs() < 1e-4 || v.abs() >= 1e16) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}
