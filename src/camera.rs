//! The camera: from a pixel position to a primary ray direction.
//!
//! Conventions: right-handed, z up. The camera frame is `forward`, `left`,
//! `up`; image columns run to the right (towards `-left`), rows downward.
//! The field of view is measured along the image diagonal, in both
//! projections (seed report, DIGEST section 4).

use glam::DVec3;

/// How image pixels map to directions: the `projection` setting of the
/// `camera` directive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Projection {
    /// A pinhole camera: straight lines stay straight.
    Rectilinear,
    /// The seed's equiangular grid: equal angle per pixel. With
    /// `correction`, the elevation of each row is corrected so horizontal
    /// lines stay horizontal: `u = atan(tan(u0) cos v)`.
    Angular {
        /// Whether rows are corrected to keep horizontal lines horizontal
        /// (`correction on`, the default) or stay at equal elevation angles
        /// (`correction off`, the seed's plain grid).
        correction: bool,
    },
}

/// Where the eye is, which way it looks and how its image is laid out: the
/// `camera` directive, checked by the compiler.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// The eye, in world coordinates; every primary ray starts here.
    pub position: DVec3,
    /// The unit viewing direction, through the image centre.
    pub forward: DVec3,
    /// The unit vector to the camera's left, orthogonal to `forward`; image
    /// columns grow towards `-left`.
    pub left: DVec3,
    /// The unit vector up in the image, orthogonal to `forward` and `left`
    /// (`forward x left`).
    pub up: DVec3,
    /// The `look_at` point, if the camera was aimed by one (curved spaces
    /// aim along the geodesic to it).
    pub target: Option<DVec3>,
    /// The `up` the scene gave (z by default), which the frame was built
    /// from.
    pub up_hint: DVec3,
    /// Diagonal field of view, in degrees, in (0, 180).
    pub fov_degrees: f64,
    /// Image width in pixels, 1 to 16384 (from the scene, or `--width`).
    pub width: u32,
    /// Image height in pixels, 1 to 16384 (from the scene, or `--height`).
    pub height: u32,
    /// How pixels map to directions.
    pub projection: Projection,
}

/// `v` scaled to length 1, or `None` when it is zero or not finite. Safe
/// for finite vectors of any size: `(1e300, 1e300, 0)`, whose length
/// overflows, is scaled down first.
pub fn unit_vector(v: DVec3) -> Option<DVec3> {
    let scale = v.abs().max_element();
    if scale == 0.0 || !scale.is_finite() {
        return None;
    }
    // By a power of two, which is exact: the direction is `v`'s to the
    // last bit, and its square neither overflows nor underflows.
    (v / crate::expr::power_of_two_below(scale)).try_normalize()
}

impl Camera {
    /// An orthonormal frame looking along `forward` with `up_hint` upward.
    /// Returns `None` when the two are parallel or either is zero.
    pub fn frame(forward: DVec3, up_hint: DVec3) -> Option<(DVec3, DVec3, DVec3)> {
        let f = unit_vector(forward)?;
        let side = unit_vector(up_hint).unwrap_or(DVec3::ZERO).cross(f);
        // Nearly parallel counts as parallel: the frame would be unstable.
        if side.length() < 1e-9 {
            return None;
        }
        let left = side.normalize();
        let up = f.cross(left);
        Some((f, left, up))
    }

    /// The unit direction through image point (`px`, `py`), in pixels from
    /// the top-left corner (pixel centres are at half-integers).
    pub fn direction(&self, px: f64, py: f64) -> DVec3 {
        self.rays().direction(px, py)
    }

    /// The per-image constants of ray generation, computed once.
    pub fn rays(&self) -> RayGenerator {
        let w = self.width as f64;
        let h = self.height as f64;
        let half_diagonal = 0.5 * (w * w + h * h).sqrt();
        let half_fov = 0.5 * self.fov_degrees.to_radians();
        let per_pixel = match self.projection {
            Projection::Rectilinear => half_fov.tan() / half_diagonal,
            Projection::Angular { .. } => half_fov / half_diagonal,
        };
        RayGenerator {
            camera: *self,
            centre: (0.5 * w, 0.5 * h),
            per_pixel,
        }
    }
}

/// A camera with the constants of its image precomputed.
#[derive(Debug, Clone, Copy)]
pub struct RayGenerator {
    camera: Camera,
    centre: (f64, f64),
    /// Image-plane units (rectilinear) or radians (angular) per pixel.
    per_pixel: f64,
}

impl RayGenerator {
    /// The unit direction through image point (`px`, `py`), in pixels from the
    /// top-left corner, as [`Camera::direction`]: the same result, without
    /// recomputing the per-image constants.
    #[inline]
    pub fn direction(&self, px: f64, py: f64) -> DVec3 {
        let c = &self.camera;
        // Offsets from the image centre, right and up.
        let right = (px - self.centre.0) * self.per_pixel;
        let upward = (self.centre.1 - py) * self.per_pixel;
        match c.projection {
            Projection::Rectilinear => (c.forward - c.left * right + c.up * upward).normalize(),
            Projection::Angular { correction } => {
                // Azimuth is positive to the left.
                let v = -right;
                let u = if correction {
                    (upward.tan() * v.cos()).atan()
                } else {
                    upward
                };
                let (su, cu) = u.sin_cos();
                let (sv, cv) = v.sin_cos();
                c.forward * (cu * cv) + c.left * (cu * sv) + c.up * su
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(projection: Projection) -> Camera {
        let (forward, left, up) = Camera::frame(DVec3::X, DVec3::Z).unwrap();
        Camera {
            position: DVec3::ZERO,
            forward,
            left,
            up,
            target: None,
            up_hint: DVec3::Z,
            fov_degrees: 90.0,
            width: 400,
            height: 300,
            projection,
        }
    }

    #[test]
    fn the_image_centre_looks_forward() {
        for p in [
            Projection::Rectilinear,
            Projection::Angular { correction: true },
            Projection::Angular { correction: false },
        ] {
            let d = camera(p).direction(200.0, 150.0);
            assert!((d - DVec3::X).length() < 1e-12, "{p:?}: {d}");
        }
    }

    #[test]
    fn the_corners_span_the_diagonal_field_of_view() {
        let c = camera(Projection::Rectilinear);
        let a = c.direction(0.0, 0.0);
        let b = c.direction(400.0, 300.0);
        let angle = a.angle_between(b).to_degrees();
        assert!((angle - 90.0).abs() < 1e-9, "{angle}");
    }

    #[test]
    fn the_angular_grid_has_equal_angles_per_pixel() {
        // The seed's grid: du = dv = fov / sqrt(W^2 + H^2) per pixel, so
        // the centre row spans fov * W / 500 across 400 of 500 diagonal
        // pixels.
        let c = camera(Projection::Angular { correction: false });
        let left = c.direction(0.0, 150.0);
        let right = c.direction(400.0, 150.0);
        let angle = left.angle_between(right).to_degrees();
        assert!((angle - 90.0 * 400.0 / 500.0).abs() < 1e-9, "{angle}");
        let quarter = c
            .direction(100.0, 150.0)
            .angle_between(c.direction(200.0, 150.0));
        assert!((quarter.to_degrees() - 90.0 * 100.0 / 500.0).abs() < 1e-9);
    }

    #[test]
    fn right_of_centre_is_minus_y_and_top_is_plus_z() {
        let c = camera(Projection::Rectilinear);
        assert!(c.direction(399.0, 150.0).y < 0.0);
        assert!(c.direction(200.0, 1.0).z > 0.0);
    }

    #[test]
    fn correction_keeps_a_horizontal_line_horizontal() {
        // Points of one row, intersected with the wall x = 1, share a
        // height only with the correction on.
        let c = camera(Projection::Angular { correction: true });
        let heights: Vec<f64> = [20.0, 200.0, 380.0]
            .iter()
            .map(|&px| {
                let d = c.direction(px, 40.0);
                d.z / d.x
            })
            .collect();
        assert!((heights[0] - heights[1]).abs() < 1e-12);
        assert!((heights[2] - heights[1]).abs() < 1e-12);
    }
}
