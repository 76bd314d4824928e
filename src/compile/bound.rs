//! Object bounds, computed once at compile time: the region rays can reach
//! is subdivided into cells, cells where the interval of `f` excludes zero
//! are dropped, and the box around the remaining cells bounds the surface.
//! Rays that miss the box skip the object.

use glam::DVec3;

use crate::expr::{Implicit, Interval};
use crate::scene::{CellGrid, Scene, ShadowPaths};
use crate::space::{Aabb, Euclidean, Space};

/// Cells per axis of an object's occupancy grid.
const GRID_CELLS: usize = 16;

/// Subdivision stops at this depth or when this many cells remain.
const MAX_DEPTH: u32 = 10;
const MAX_CELLS: usize = 1024;

/// The box that holds every point, in object coordinates, that a primary
/// ray or a shadow ray can reach: what the space says a path from the
/// camera can reach, and its shadow paths from there to each light (in a
/// torus these stay in the cell, however far away a light is written).
pub fn reachable_region(scene: &Scene) -> Aabb {
    let space = scene.build_space();
    let seen = space.reach(scene.camera.position, scene.settings.max_distance);
    let shadow_space: &dyn Space = match scene.settings.shadow_paths {
        ShadowPaths::Geodesic => space.as_ref(),
        ShadowPaths::Euclidean => &Euclidean,
    };
    let mut region = seen;
    for l in &scene.lights {
        let lit = shadow_space.light_reach(seen, l.position);
        region.min = region.min.min(lit.min);
        region.max = region.max.max(lit.max);
    }
    region
}

/// Recompute every object's bound, after the scene's space, camera or
/// settings changed.
pub fn compute_bounds(scene: &mut Scene) {
    let region = reachable_region(scene);
    for o in &mut scene.objects {
        o.bound = compute_bound(&o.function, region);
        o.cells = o.bound.map(|b| compute_cells(&o.function, b));
    }
}

/// A box holding every point of `region` where `f` may be zero, or `None`
/// when `f` is provably non-zero throughout the region.
pub fn compute_bound(f: &Implicit, region: Aabb) -> Option<Aabb> {
    let mut slots = Vec::new();
    let may_vanish = |lo: DVec3, hi: DVec3, slots: &mut Vec<Interval>| {
        let v = f.interval(lo, hi, slots);
        v.contains(0.0)
    };
    let mut cells = vec![(region.min, region.max)];
    if !may_vanish(region.min, region.max, &mut slots) {
        return None;
    }
    for _ in 0..MAX_DEPTH {
        let mut next = Vec::with_capacity(cells.len() * 8);
        for &(lo, hi) in &cells {
            let mid = (lo + hi) * 0.5;
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
                if may_vanish(clo, chi, &mut slots) {
                    next.push((clo, chi));
                }
            }
        }
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
    for (lo, hi) in cells {
        b.min = b.min.min(lo);
        b.max = b.max.max(hi);
    }
    let b = shrink_faces(b, |lo, hi| may_vanish(lo, hi, &mut slots));
    // A contracted box can be as thin as the surface (a plane's slab); a
    // margin keeps roots that rounding puts a hair outside it.
    let scale = b.min.abs().max(b.max.abs()).max_element();
    let margin = DVec3::splat(1e-9 * (1.0 + scale));
    Some(Aabb {
        min: b.min - margin,
        max: b.max + margin,
    })
}

/// Moves each face of `b` inwards past every slab where `f` provably has
/// no zero. The cells stop at a fixed depth, so the box they make can be
/// loose by a cell's size (for a plane across a large region, a whole unit
/// of empty space that every grazing path would search); this contracts
/// it to the surface. Inclusion-monotone interval arithmetic makes the
/// test monotone in the slab's thickness, so bisection finds the largest
/// empty slab.
fn shrink_faces(mut b: Aabb, mut may_vanish: impl FnMut(DVec3, DVec3) -> bool) -> Aabb {
    const ROUNDS: usize = 2;
    const BISECTIONS: usize = 40;
    for _ in 0..ROUNDS {
        for axis in 0..3 {
            for upper in [false, true] {
                let width = b.max[axis] - b.min[axis];
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
                let (mut empty, mut full) = (0.0, width);
                for _ in 0..BISECTIONS {
                    let d = 0.5 * (empty + full);
                    let (lo, hi) = slab(d);
                    if may_vanish(lo, hi) {
                        full = d;
                    } else {
                        empty = d;
                    }
                }
                if upper {
                    b.max[axis] -= empty;
                } else {
                    b.min[axis] += empty;
                }
            }
        }
    }
    b
}

/// The cells of a grid over `bound` where `f` may vanish.
pub fn compute_cells(f: &Implicit, bound: Aabb) -> CellGrid {
    let mut slots = Vec::new();
    CellGrid::new(bound, GRID_CELLS, |lo, hi| {
        f.interval(lo, hi, &mut slots).contains(0.0)
    })
}
