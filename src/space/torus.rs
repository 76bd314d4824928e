//! The flat 3-torus: the box `[min, max]` with opposite faces glued.
//!
//! A ray is straight in the unwrapped space R^3; the torus walks it cell by
//! cell (a 3D DDA) and hands each piece to the tracer moved back into the
//! fundamental cell. Each face crossing is computed from the cell index and
//! the original ray, never from the previous crossing, so no error builds
//! up however many times the ray wraps.

use std::ops::ControlFlow;

use glam::DVec3;

use super::{Aabb, Cell, Image, Placement, Segment, Space};

/// The flat 3-torus, ready to walk rays: the box from `min` to `max` with
/// opposite faces glued, each ray followed face by face for at most `wraps`
/// crossings.
#[derive(Debug, Clone, Copy)]
pub struct TorusSpace {
    min: DVec3,
    size: DVec3,
    /// Face crossings allowed per ray.
    wraps: u32,
    /// Objects repeat with the lattice (a true torus); otherwise only the
    /// part of each object inside the cell exists (the seed report's look).
    periodic: bool,
}

impl TorusSpace {
    /// The torus on the cell `[min, max]` (`min < max` on every axis, as the
    /// compiler checks), allowing `wraps` face crossings per ray; with
    /// `periodic`, objects repeat across the faces, otherwise the cell clips
    /// them.
    pub fn new(min: DVec3, max: DVec3, wraps: u32, periodic: bool) -> Self {
        TorusSpace {
            min,
            size: max - min,
            wraps,
            periodic,
        }
    }

    fn fundamental_cell(&self) -> Aabb {
        Aabb {
            min: self.min,
            max: self.min + self.size,
        }
    }
}

impl Space for TorusSpace {
    fn walk(
        &self,
        origin: DVec3,
        direction: DVec3,
        limit: f64,
        visit: &mut dyn FnMut(&Segment) -> ControlFlow<()>,
    ) {
        let d = direction;
        // The cell of the start, as integer-valued floats.
        let mut k = ((origin - self.min) / self.size).floor();
        let mut t = 0.0;
        for _ in 0..=self.wraps {
            let mut exits = [f64::INFINITY; 3];
            for i in 0..3 {
                let face = if d[i] > 0.0 {
                    k[i] + 1.0
                } else if d[i] < 0.0 {
                    k[i]
                } else {
                    continue;
                };
                exits[i] = (self.min[i] + face * self.size[i] - origin[i]) / d[i];
            }
            let exit = exits[0].min(exits[1]).min(exits[2]).max(t);
            let t1 = exit.min(limit);
            let segment = Segment::line((origin + t * d) - k * self.size, d, t, t1);
            if visit(&segment).is_break() || t1 >= limit || !exit.is_finite() {
                return;
            }
            // Leave through every face reached at this distance (corners).
            for i in 0..3 {
                if exits[i] <= exit {
                    k[i] += d[i].signum();
                }
            }
            t = t1;
        }
    }

    fn images(&self, bound: &Aabb, _placement: &Placement) -> Vec<Image> {
        if !self.periodic {
            return vec![Image::HERE];
        }
        let cell = self.fundamental_cell();
        // Lattice shifts that move some of the bound into the cell.
        // Only the cell and one cell beyond each face fold into it (see
        // `reach`): at most 5 shifts per axis, whatever the bound.
        let lo = ((cell.min - bound.max) / self.size)
            .ceil()
            .max(DVec3::splat(-2.0));
        let hi = ((cell.max - bound.min) / self.size)
            .floor()
            .min(DVec3::splat(2.0));
        let mut out = Vec::new();
        let mut i = lo.x;
        while i <= hi.x {
            let mut j = lo.y;
            while j <= hi.y {
                let mut k = lo.z;
                while k <= hi.z {
                    out.push(Image::offset(DVec3::new(i, j, k) * self.size));
                    k += 1.0;
                }
                j += 1.0;
            }
            i += 1.0;
        }
        out
    }

    fn connect(&self, from: DVec3, to: DVec3) -> Option<(DVec3, f64)> {
        // `to` folded into the cell first (fmod is exact), so that a light
        // written far away (1e40) does not lose its place in the cell to
        // rounding; then its nearest image.
        let folded = self.min + (to - self.min).rem_euclid(self.size);
        let m = ((from - folded) / self.size).round();
        let nearest = folded + m * self.size;
        let d = nearest - from;
        let len = d.length();
        (len > 0.0).then(|| (d / len, len))
    }

    fn cell(&self) -> Option<Cell> {
        let cell = self.fundamental_cell();
        Some(Cell {
            min: cell.min,
            max: cell.max,
            legend: "torus cell: leaving through a face, a path re-enters opposite",
        })
    }

    fn light_reach(&self, region: Aabb, _light: DVec3) -> Aabb {
        // A shadow path goes to the light's nearest image: it stays in the
        // cell, however far away the light is written.
        region
    }

    fn reach(&self, _origin: DVec3, _limit: f64) -> Aabb {
        // Objects are written in the unwrapped space around the cell; the
        // cell and one cell beyond each face is what can be folded into it.
        let cell = self.fundamental_cell();
        if self.periodic {
            Aabb {
                min: cell.min - self.size,
                max: cell.max + self.size,
            }
        } else {
            cell
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every piece starts where the previous one ended, lies in the cell
    /// after the shift, and the pieces add up to the unwrapped line.
    #[test]
    fn pieces_tile_the_unwrapped_ray() {
        let torus = TorusSpace::new(DVec3::splat(-1.0), DVec3::splat(1.0), 1000, true);
        let o = DVec3::new(0.3, -0.2, 0.1);
        let d = DVec3::new(0.7, 0.5, -0.3).normalize();
        let mut last_end = 0.0;
        let mut pieces = 0;
        torus.walk(o, d, 50.0, &mut |seg| {
            assert!(seg.as_line().is_some());
            let (t0, t1) = seg.range();
            assert!((t0 - last_end).abs() < 1e-12);
            for t in [t0, 0.5 * (t0 + t1), t1] {
                let p = seg.point(t);
                assert!(
                    p.cmpge(DVec3::splat(-1.0 - 1e-9)).all()
                        && p.cmple(DVec3::splat(1.0 + 1e-9)).all(),
                    "{p}"
                );
            }
            last_end = t1;
            pieces += 1;
            ControlFlow::Continue(())
        });
        assert!((last_end - 50.0).abs() < 1e-12);
        assert!(pieces > 30);
    }

    #[test]
    fn the_nearest_image_is_connected() {
        let torus = TorusSpace::new(DVec3::splat(-10.0), DVec3::splat(10.0), 10, true);
        let (dir, len) = torus
            .connect(DVec3::new(9.0, 0.0, 0.0), DVec3::new(-9.0, 0.0, 0.0))
            .unwrap();
        assert!((len - 2.0).abs() < 1e-12);
        assert!((dir - DVec3::X).length() < 1e-12);
    }

    /// A light written far away is connected as if written at its place in
    /// the cell (the exact remainder of its coordinates), by a path no
    /// longer than half the cell's diagonal.
    #[test]
    fn a_far_light_keeps_its_place_in_the_cell() {
        let torus = TorusSpace::new(DVec3::splat(-10.0), DVec3::splat(10.0), 10, true);
        let far = DVec3::new(1e40, 4294967296.0, -3.0);
        let folded = DVec3::new(
            (1e40f64 + 10.0).rem_euclid(20.0) - 10.0,
            (4294967296.0f64 + 10.0).rem_euclid(20.0) - 10.0,
            -3.0,
        );
        let from = DVec3::new(1.0, 2.0, 3.0);
        let (dir, len) = torus.connect(from, far).unwrap();
        let (want_dir, want_len) = torus.connect(from, folded).unwrap();
        assert!(len <= 20.0 * 3f64.sqrt() / 2.0 + 1e-9, "{len}");
        assert!((len - want_len).abs() < 1e-9 && (dir - want_dir).length() < 1e-9);
    }
}
