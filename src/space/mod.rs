//! Spaces: how a ray travels.
//!
//! Input: a ray's start, unit direction and length limit.
//! Output: the pieces of its path, in order, each a shape the intersector
//! can search in closed form or by root isolation. The tracer sees only
//! [`Segment`]s and never looks inside a space; adding a space means adding
//! an implementation of [`Space`] and, if its paths are not straight, a
//! [`Segment`] kind.

use std::ops::ControlFlow;

use glam::DVec3;

use crate::scene::SpaceKind;

/// A piece of a ray's path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Segment {
    /// The points `origin + t * direction` for `t` in `[t0, t1]`, where `t`
    /// is also the distance travelled along the whole path.
    Line {
        origin: DVec3,
        direction: DVec3,
        t0: f64,
        t1: f64,
    },
}

pub trait Space: Sync + Send {
    /// Visit the path from `origin` along the unit vector `direction` for
    /// length `limit`, piece by piece in order, until `visit` breaks.
    fn walk(
        &self,
        origin: DVec3,
        direction: DVec3,
        limit: f64,
        visit: &mut dyn FnMut(&Segment) -> ControlFlow<()>,
    );
}

/// Flat space: every path is one straight segment.
#[derive(Debug, Clone, Copy, Default)]
pub struct Euclidean;

impl Space for Euclidean {
    fn walk(
        &self,
        origin: DVec3,
        direction: DVec3,
        limit: f64,
        visit: &mut dyn FnMut(&Segment) -> ControlFlow<()>,
    ) {
        let _ = visit(&Segment::Line {
            origin,
            direction,
            t0: 0.0,
            t1: limit,
        });
    }
}

/// The space a scene asks for.
pub fn for_scene(kind: SpaceKind) -> Box<dyn Space> {
    match kind {
        SpaceKind::Euclidean => Box::new(Euclidean),
    }
}
