//! nes: a ray tracer for implicit surfaces in Euclidean and non-Euclidean
//! spaces, driven by a scene language.
//!
//! The pipeline, one module per stage (see ARCHITECTURE.md):
//! [`syntax`] (text to [`ast`]) -> [`compile`] (AST to a checked
//! [`scene::Scene`], using the [`expr`] IR) -> [`space`] (how rays
//! travel) -> [`trace`] (geometric queries: hits, shadows, normals) ->
//! [`shade`] (hits to colours) -> [`render`](mod@render) (the per-pixel
//! loop) -> [`output`] (pixels to PNG and animations); [`shard`] writes
//! one part of a render as a file and stitches the parts.
//!
//! Beside the pipeline: [`tools`] (explain, accuracy, probe, rays),
//! [`live`] (watch and its preview server) and [`cli`] (the command line,
//! which validates arguments once and reports every error).

#![warn(missing_docs)]

pub mod ast;
pub mod camera;
pub mod cli;
pub mod compile;
pub mod diagnostic;
pub mod expr;
pub mod live;
pub mod output;
pub mod render;
pub mod scene;
pub mod shade;
pub mod shard;
pub mod space;
pub mod syntax;
#[cfg(test)]
mod testing;
pub mod tools;
pub mod trace;

pub use compile::{compile_source, compile_source_at};
pub use diagnostic::SceneError;
pub use render::{render, Image, RenderStats};
pub use scene::Scene;
