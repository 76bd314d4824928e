//! The shade stage: a hit to a colour.
//!
//! Input: a [`Hit`], the scene's lights and the tracer's shadow queries.
//! Output: a linear RGB colour.
//! Lambert shading with ambient light and hard shadows, or the seed's flat
//! look. Also the sRGB transfer functions used at the edges of the
//! pipeline (colours in scene files and pixels in PNGs are sRGB; all
//! arithmetic is linear).

use glam::DVec3;

use crate::scene::{Falloff, Shading};
use crate::trace::intersect::Scratch;
use crate::trace::{Hit, Tracer};

/// The most a light's physical falloff may amplify it: finite, so that
/// colour times falloff is never infinite or NaN.
const MAX_FALLOFF: f64 = 1e12;

/// The linear colour of `hit`: the object's colour under ambient light
/// plus each light that reaches the point (Lambert), or the seed's flat
/// look. Shadow rays cast are added to `shadow_rays`.
pub fn shade(tracer: &Tracer, hit: &Hit, s: &mut Scratch, shadow_rays: &mut u64) -> DVec3 {
    let scene = tracer.scene;
    let settings = &scene.settings;
    let obj = &scene.objects[hit.object];
    let (n, inside) = tracer.normal_and_side(hit, s);
    let (colour, undefined) =
        obj.paint(inside)
            .at(&obj.function, hit.local, &mut s.gradient_points);
    s.trouble.colour_undefined |= undefined;
    let start = tracer.shadow_start(hit, n);
    match settings.shading {
        Shading::Lambert => {
            let mut light_sum = DVec3::ZERO;
            for light in &scene.lights {
                // The light arrives along each of its paths' directions:
                // straight, bent in a curved space, and in S3 by both arcs
                // of the great circle.
                for path in tracer
                    .light_paths(hit.point, light.position)
                    .into_iter()
                    .flatten()
                {
                    let cos = n.dot(path.direction);
                    // A surface facing away from the light gets none of it
                    // this way, so no shadow ray is needed to know.
                    if cos <= 0.0 {
                        continue;
                    }
                    if settings.shadows {
                        *shadow_rays += 1;
                        if tracer.blocked(start, path.walk, path.length, s) {
                            continue;
                        }
                    }
                    let falloff = match light.falloff {
                        Falloff::None => 1.0,
                        // Capped where geodesic spheres close up (at the
                        // light, and at its antipode in S3), so that a
                        // black surface stays black there.
                        Falloff::Physical => tracer.spread(path.length).powi(-2).min(MAX_FALLOFF),
                    };
                    light_sum += light.colour * (light.intensity * cos * falloff);
                }
            }
            colour * (DVec3::splat(scene.ambient) + light_sum)
        }
        Shading::Flat => {
            let shadowed = settings.shadows
                && scene.lights.iter().any(|l| {
                    *shadow_rays += 1;
                    tracer.in_shadow(start, l.position, s)
                });
            if shadowed {
                colour / 4.0
            } else {
                colour
            }
        }
    }
}

/// An sRGB channel value (0 to 1) as linear light.
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A linear channel value as sRGB, clamped to 0 to 1.
pub fn linear_to_srgb(c: f64) -> f64 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.0031308 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// A linear colour as 8-bit sRGB: the same bytes as rounding
/// [`linear_to_srgb`], found from the 255 linear values where the byte
/// steps up (a `powf` per channel was ~5% of a render): a table gives the
/// byte at the start of the value's 1/4096-wide bin, and at most a step or
/// two up from there reaches it (a binary search of the steps was still
/// 2% of a render).
pub fn to_srgb8(c: DVec3) -> [u8; 3] {
    let (steps, bins) = srgb8_tables();
    c.to_array().map(|v| {
        // NaN and values at or below 0 are black; 1 and above are white.
        if v.is_nan() || v <= 0.0 {
            return 0;
        }
        if v >= 1.0 {
            return 255;
        }
        let mut byte = bins[(v * SRGB8_BINS as f64) as usize] as usize;
        while byte < 255 && steps[byte] <= v {
            byte += 1;
        }
        byte as u8
    })
}

/// Bins of the linear range [0, 1] in [`to_srgb8`]'s table.
const SRGB8_BINS: usize = 4096;

/// The steps (for each byte k in 1..=255, the least linear value that
/// rounds to k or more) and, for each bin, the byte at its start.
fn srgb8_tables() -> &'static ([f64; 255], [u8; SRGB8_BINS]) {
    static TABLES: std::sync::OnceLock<([f64; 255], [u8; SRGB8_BINS])> = std::sync::OnceLock::new();
    TABLES.get_or_init(|| {
        let steps = srgb8_steps();
        let bins = std::array::from_fn(|i| {
            let start = i as f64 / SRGB8_BINS as f64;
            steps.partition_point(|&t| t <= start) as u8
        });
        (steps, bins)
    })
}

/// The direct form of [`to_srgb8`], one channel.
fn srgb8_direct(v: f64) -> u8 {
    (linear_to_srgb(if v.is_nan() { 0.0 } else { v }) * 255.0).round() as u8
}

/// For each byte k in 1..=255, the least linear value that rounds to k or
/// more, found by bisection over the f64 values in [0, 1] (their bit
/// patterns are ordered like the values).
fn srgb8_steps() -> [f64; 255] {
    std::array::from_fn(|i| {
        let k = i as u8 + 1;
        let (mut lo, mut hi) = (0u64, 1f64.to_bits());
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if srgb8_direct(f64::from_bits(mid)) >= k {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        f64::from_bits(lo)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table's bytes equal the direct formula's, at every step, one
    /// ulp either side of it, at every bin edge, and at values spread over
    /// [-1, 2].
    #[test]
    fn srgb_bytes_match_the_formula() {
        let mut values = vec![f64::NAN, f64::INFINITY, -f64::INFINITY, -0.0, 0.0, 1.0];
        values.extend((0..=SRGB8_BINS).map(|i| i as f64 / SRGB8_BINS as f64));
        for t in srgb8_steps() {
            values.extend([
                t,
                f64::from_bits(t.to_bits() - 1),
                f64::from_bits(t.to_bits() + 1),
            ]);
        }
        values.extend((0..200_000).map(|i| -1.0 + 3.0 * i as f64 / 200_000.0));
        for v in values {
            assert_eq!(to_srgb8(DVec3::splat(v))[0], srgb8_direct(v), "{v:e}");
        }
    }
}
