//! nes: a ray tracer for implicit surfaces in Euclidean and non-Euclidean
//! spaces, driven by a scene language.
//!
//! The pipeline, one module per stage (see ARCHITECTURE.md):
//! [`syntax`] (text to [`ast`]) -> [`compile`] (AST to a checked
//! [`scene::Scene`], using the [`expr`] IR) -> [`space`] (how rays travel)
//! -> [`trace`] (rays to hits) -> [`shade`] (hits to colours) -> [`output`]
//! (pixels to PNG). [`explain`] describes the plan of a render in words;
//! [`watch`] drives the loop of `nes watch`, and [`serve`] its live page;
//! [`accuracy`] measures run time against error.

pub mod accuracy;
pub mod ast;
pub mod camera;
pub mod compile;
pub mod diagnostic;
pub mod explain;
pub mod expr;
pub mod output;
mod plot;
pub mod probe;
pub mod rays;
pub mod scene;
pub mod serve;
pub mod shade;
pub mod space;
pub mod syntax;
pub mod trace;
pub mod watch;

pub use compile::{compile_source, compile_source_at};
pub use diagnostic::SceneError;
pub use scene::Scene;
pub use trace::{render, Image, RenderStats};
