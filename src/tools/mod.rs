//! Tools beside the pipeline: they run its stages and report on what they
//! did, for people to read or look at. None of them is a stage; the
//! pipeline never calls into here.
//!
//! - [`explain`]: a checked scene to its render plan in words.
//! - [`accuracy`]: run time against error, per method and setting.
//! - [`probe`]: one ray's function values, samples and roots.
//! - [`rays`]: ray diagrams, paths projected onto a plane.

pub mod accuracy;
pub mod explain;
mod plot;
pub mod probe;
pub mod rays;
