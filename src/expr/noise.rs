//! Gradient noise: Perlin's improved noise (2002) and its partial
//! derivatives, in points and over boxes.
//!
//! Input: a point or a box of `(x, y, z)` and a partial derivative order
//! per axis. Output: the noise (or that partial derivative) at the point,
//! or an interval enclosing every value it takes on the box.
//!
//! The noise is a sum over the eight corners of the unit lattice cell
//! holding the point: each corner's gradient (one of Perlin's twelve cube
//! edge directions, picked by his permutation hash, so the noise is the
//! same on every machine) dotted with the offset from the corner,
//! weighted by the quintic fade `6t^5 - 15t^4 + 10t^3` of each
//! coordinate's offset. Written per axis, a corner's term is a product of
//! one-dimensional polynomials of the cell offsets `t` (the fade, one
//! minus it, and each times `t - corner`), so every partial derivative is
//! the same sum with those factors differentiated. The noise is twice
//! continuously differentiable; derivatives of order three and more per
//! axis jump on cell faces, and each is taken as its value inside the cell.
//!
//! Over a box, each one-dimensional factor's range on the box's offsets
//! is exact up to rounding (its values at the ends and at its critical
//! points), the corner sum is done in interval arithmetic, and a box
//! spanning several cells is the hull of its cells (a box over more than
//! 8 cells gets the bound that holds everywhere). The corner sum suffers
//! the dependency problem (the corners' weights are not independent), so
//! on a box a third of a cell across the enclosure is up to about five
//! times the range; its excess shrinks in proportion to the box, and the
//! root search's slopes come from the partials' own enclosures.

use std::sync::LazyLock;

use super::interval::Interval;
use super::number::Number;
use super::op::Noise;

/// Partial derivative orders per axis at and above which a factor is
/// identically zero: the factors are polynomials of degree at most 6.
pub const VANISHING_ORDER: u8 = 7;

/// A box spanning more lattice cells than this is enclosed by the bound
/// that holds everywhere, rather than cell by cell: the hull of many
/// cells' enclosures is seldom narrower. Eight keeps every box smaller
/// than a cell (which may straddle a lattice corner) cell by cell, so
/// enclosures shrink with the box. (On a noisy sphere and a noise level
/// set, 64 cells cost 1.5x the time of 8 for the same evaluations, within
/// 0.1%; 1 cell cost 2.3x and 3.2x the evaluations.)
const MAX_CELLS: f64 = 8.0;

/// Ken Perlin's reference permutation.
const PERMUTATION: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69,
    142, 8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219,
    203, 117, 35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175,
    74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60, 211, 133, 230,
    220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216, 80, 73, 209, 76,
    132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173,
    186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206,
    59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163,
    70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232,
    178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179, 162,
    241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184, 84, 204,
    176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141,
    128, 195, 78, 66, 215, 61, 156, 180,
];

/// The gradients: the twelve edge directions of a cube, four of them
/// repeated so that a hash picks one by its low four bits (Perlin 2002).
const GRADIENTS: [[i8; 3]; 16] = [
    [1, 1, 0],
    [-1, 1, 0],
    [1, -1, 0],
    [-1, -1, 0],
    [1, 0, 1],
    [-1, 0, 1],
    [1, 0, -1],
    [-1, 0, -1],
    [0, 1, 1],
    [0, -1, 1],
    [0, 1, -1],
    [0, -1, -1],
    [1, 1, 0],
    [0, -1, 1],
    [-1, 1, 0],
    [0, -1, -1],
];

/// The gradient at the lattice point `(i, j, k)` (each taken modulo 256:
/// the noise repeats every 256 units).
fn gradient(i: i64, j: i64, k: i64) -> [i8; 3] {
    let p = |n: i64| PERMUTATION[(n & 255) as usize] as i64;
    GRADIENTS[(p(p(p(i) + j) + k) & 15) as usize]
}

/// The four one-dimensional factors of a corner's term along one axis,
/// for the corner at offset `bit` (0 or 1) from the cell's low corner:
/// the weight (`1 - fade`, or `fade`) and the weight times `t - bit`.
#[derive(Clone, Copy)]
enum Kind {
    Weight0,
    Weight1,
    Offset0,
    Offset1,
}

/// One factor, differentiated some number of times: a polynomial on the
/// cell's `t` in `[0, 1]`.
struct Factor {
    /// Coefficients of `t^0 .. t^7`.
    coefficients: [f64; 8],
    /// The number of coefficients up to the last non-zero one.
    len: usize,
    /// A bound on the rounding error of evaluating it for `t` in `[0, 1]`
    /// (Horner's rule: 2 degree ulps of the sum of the coefficients' sizes).
    slack: f64,
    /// Where its derivative changes sign in `(0, 1)`: its extremes.
    critical: Vec<f64>,
}

impl Factor {
    #[inline]
    fn at(&self, t: f64) -> f64 {
        polynomial_at(&self.coefficients[..self.len], t)
    }

    /// Every value on `[t0, t1]` (within `[0, 1]`), rounded outward.
    fn over(&self, t0: f64, t1: f64) -> Interval {
        let (a, b) = (self.at(t0), self.at(t1));
        let (mut lo, mut hi) = (a.min(b), a.max(b));
        for &c in &self.critical {
            if t0 < c && c < t1 {
                let v = self.at(c);
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        Interval::new(lo - self.slack, hi + self.slack)
    }
}

fn derivative(c: [f64; 8]) -> [f64; 8] {
    std::array::from_fn(|i| {
        if i < 7 {
            c[i + 1] * (i + 1) as f64
        } else {
            0.0
        }
    })
}

fn polynomial_at(c: &[f64], t: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &k| acc * t + k)
}

/// The points of `(0, 1)` where the polynomial `c` changes sign, found by
/// a fine scan and bisection to the last bit.
fn sign_changes(c: &[f64; 8]) -> Vec<f64> {
    const SAMPLES: usize = 4096;
    let mut roots = Vec::new();
    if c.iter().all(|&k| k == 0.0) {
        return roots;
    }
    let mut prev = (0.0, polynomial_at(c, 0.0));
    for i in 1..=SAMPLES {
        let t = i as f64 / SAMPLES as f64;
        let v = polynomial_at(c, t);
        if prev.1 * v < 0.0 {
            let (mut a, mut b) = (prev.0, t);
            let sa = prev.1.signum();
            for _ in 0..80 {
                let m = 0.5 * (a + b);
                if m <= a || m >= b {
                    break;
                }
                if polynomial_at(c, m).signum() == sa {
                    a = m;
                } else {
                    b = m;
                }
            }
            roots.push(0.5 * (a + b));
        }
        // A sampled zero is skipped: the bisection between its
        // neighbours finds it.
        if v != 0.0 {
            prev = (t, v);
        }
    }
    roots
}

/// `FACTORS[kind][order]`.
static FACTORS: LazyLock<[[Factor; VANISHING_ORDER as usize + 1]; 4]> = LazyLock::new(|| {
    let fade = [0.0, 0.0, 0.0, 10.0, -15.0, 6.0, 0.0, 0.0];
    let times_t = |c: [f64; 8]| std::array::from_fn(|i| if i == 0 { 0.0 } else { c[i - 1] });
    let minus = |a: [f64; 8], b: [f64; 8]| std::array::from_fn(|i| a[i] - b[i]);
    let mut one_minus_fade = fade.map(|c| -c);
    one_minus_fade[0] += 1.0;
    let bases = [
        one_minus_fade,
        fade,
        times_t(one_minus_fade),
        minus(times_t(fade), fade),
    ];
    bases.map(|base| {
        let mut c = base;
        std::array::from_fn(|_| {
            let size: f64 = c.iter().map(|k| k.abs()).sum();
            let factor = Factor {
                coefficients: c,
                len: c.iter().rposition(|&k| k != 0.0).map_or(0, |i| i + 1),
                slack: 16.0 * f64::EPSILON * size + f64::MIN_POSITIVE,
                critical: sign_changes(&derivative(c)),
            };
            c = derivative(c);
            factor
        })
    })
});

fn factor(kind: Kind, order: u8) -> &'static Factor {
    &FACTORS[kind as usize][order.min(VANISHING_ORDER) as usize]
}

/// The noise's partial derivative of order `partial` (per axis) at `p`.
/// NaN where a coordinate is not finite.
pub fn value(p: [f64; 3], partial: [u8; 3]) -> f64 {
    if p.iter().any(|c| !c.is_finite()) {
        return f64::NAN;
    }
    if (Noise { partial }).vanishes() {
        return 0.0;
    }
    let cell = p.map(f64::floor);
    let t: [f64; 3] = std::array::from_fn(|a| p[a] - cell[a]);
    // factors[a][bit] = (weight, weight times offset), differentiated.
    let factors: [[(f64, f64); 2]; 3] = std::array::from_fn(|a| {
        let (k, t) = (partial[a], t[a]);
        [
            (
                factor(Kind::Weight0, k).at(t),
                factor(Kind::Offset0, k).at(t),
            ),
            (
                factor(Kind::Weight1, k).at(t),
                factor(Kind::Offset1, k).at(t),
            ),
        ]
    });
    let gradients = corner_gradients(cell.map(|c| c as i64));
    corner_sum(&gradients, [&factors[0], &factors[1], &factors[2]])
}

/// One cell's eight corner gradients, low corner first, x fastest.
fn corner_gradients(index: [i64; 3]) -> [[i8; 3]; 8] {
    std::array::from_fn(|corner| {
        gradient(
            index[0] + (corner & 1) as i64,
            index[1] + ((corner >> 1) & 1) as i64,
            index[2] + ((corner >> 2) & 1) as i64,
        )
    })
}

/// The corner sum of one cell, in any [`Number`] (f64 at a point,
/// intervals over a box): axis `a`'s (weight, weight times offset) factors
/// for each corner bit from `factors[a]`. Every gradient has one zero
/// component, so each corner adds two products.
fn corner_sum<N: Number>(gradients: &[[i8; 3]; 8], factors: [&[(N, N); 2]; 3]) -> N {
    let mut sum = N::constant(0.0);
    for (corner, g) in gradients.iter().enumerate() {
        let bit = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
        let [x, y, z] = [0, 1, 2].map(|a| factors[a][bit[a]]);
        let signed = |s: i8, v: N| if s > 0 { v } else { -v };
        if g[0] != 0 {
            sum = sum + signed(g[0], x.1 * (y.0 * z.0));
        }
        if g[1] != 0 {
            sum = sum + signed(g[1], y.1 * (x.0 * z.0));
        }
        if g[2] != 0 {
            sum = sum + signed(g[2], z.1 * (x.0 * y.0));
        }
    }
    sum
}

/// A bound on the partial derivative `partial` that holds everywhere: the
/// corner sum over a whole cell with every gradient component taken as
/// any of -1, 0 and 1.
fn global_bound(partial: [u8; 3]) -> Interval {
    // Every enclosure is clipped to it: computed once per partial.
    const N: usize = VANISHING_ORDER as usize;
    static BOUNDS: LazyLock<Vec<Interval>> = LazyLock::new(|| {
        (0..N * N * N)
            .map(|i| {
                let order = [i % N, (i / N) % N, i / (N * N)].map(|o| o as u8);
                compute_global_bound(order)
            })
            .collect()
    });
    match partial.map(usize::from) {
        [x, y, z] if x < N && y < N && z < N => BOUNDS[x + N * (y + N * z)],
        _ => Interval::point(0.0),
    }
}

fn compute_global_bound(partial: [u8; 3]) -> Interval {
    if (Noise { partial }).vanishes() {
        return Interval::point(0.0);
    }
    let size = |i: Interval| i.lo.abs().max(i.hi.abs());
    let factors: [[(f64, f64); 2]; 3] = std::array::from_fn(|a| {
        let k = partial[a];
        [
            (
                size(factor(Kind::Weight0, k).over(0.0, 1.0)),
                size(factor(Kind::Offset0, k).over(0.0, 1.0)),
            ),
            (
                size(factor(Kind::Weight1, k).over(0.0, 1.0)),
                size(factor(Kind::Offset1, k).over(0.0, 1.0)),
            ),
        ]
    });
    let mut bound = 0.0;
    for corner in 0..8 {
        let bit = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
        let [x, y, z] = [0, 1, 2].map(|a| factors[a][bit[a]]);
        bound += x.1 * y.0 * z.0 + x.0 * y.1 * z.0 + x.0 * y.0 * z.1;
    }
    // Generous against the rounding of the sum above.
    let mut bound = bound * (1.0 + 1e-12);
    if partial == [0, 0, 0] {
        bound = bound.min(VALUE_BOUND);
    }
    Interval::new(-bound, bound)
}

/// A bound on the noise's size everywhere. The corners' weights are
/// non-negative and sum to 1, and a corner's gradient (two components of
/// size 1, one 0) dotted with its offset is at most the sum of the
/// offset's two largest components in size; whatever gradients the hash
/// picks, the noise is at most the weighted sum of those, whose maximum
/// over the cell is 1.0363 (at about (0.355, 0.496, 0.480)).
/// `the_value_bound_is_proved` proves this bound by branch and bound.
const VALUE_BOUND: f64 = 1.04;

/// An interval enclosing the partial derivative `partial` over the box
/// `p`: empty if any side is empty. Each cell's enclosure is its corner
/// sum over the box's offsets in it. (A mean-value form about the box's
/// middle was tried: on the renders it cost twice the time and saved
/// under 4% of the evaluations, as the root search takes its own slopes.)
pub fn enclose(p: [Interval; 3], partial: [u8; 3]) -> Interval {
    if p.iter().any(|i| i.is_empty()) {
        return Interval::EMPTY;
    }
    if (Noise { partial }).vanishes() {
        return Interval::point(0.0);
    }
    let first = p.map(|i| i.lo.floor());
    let last = p.map(|i| i.hi.floor());
    let cells: f64 = (0..3).map(|a| last[a] - first[a] + 1.0).product();
    // Beyond 2^52 every float is an integer and cells are not resolved.
    let huge = p.iter().any(|i| i.lo.abs().max(i.hi.abs()) >= 4.5e15);
    // NaN cells (an infinite side) fail the comparison too.
    if cells.is_nan() || cells > MAX_CELLS || huge {
        return global_bound(partial);
    }
    // The offsets of the box within the cell whose low corner is `k`.
    let offsets = |a: usize, k: f64| {
        let t0 = if k > first[a] {
            0.0
        } else {
            (p[a].lo - k).next_down().max(0.0)
        };
        let t1 = if k < last[a] {
            1.0
        } else {
            (p[a].hi - k).next_up().min(1.0)
        };
        (t0, t1)
    };
    // Each cell's corner sum suffers the dependency problem; the bound
    // that holds everywhere may be tighter.
    let global = global_bound(partial);
    let within = |h: Interval| Interval::new(h.lo.max(global.lo), h.hi.min(global.hi));
    // Each axis's factors per cell along it: a box's cells are the
    // product of the axes' cells, and the factors of each depend on its
    // own axis's offsets alone.
    let along = |a: usize| -> Vec<[(Interval, Interval); 2]> {
        let n = (last[a] - first[a]) as usize + 1;
        (0..n)
            .map(|i| {
                let (t0, t1) = offsets(a, first[a] + i as f64);
                let k = partial[a];
                [
                    (
                        factor(Kind::Weight0, k).over(t0, t1),
                        factor(Kind::Offset0, k).over(t0, t1),
                    ),
                    (
                        factor(Kind::Weight1, k).over(t0, t1),
                        factor(Kind::Offset1, k).over(t0, t1),
                    ),
                ]
            })
            .collect()
    };
    let [fx, fy, fz] = [along(0), along(1), along(2)];
    let corner = first.map(|c| c as i64);
    let mut hull = Interval::EMPTY;
    for (k, z) in fz.iter().enumerate() {
        for (j, y) in fy.iter().enumerate() {
            for (i, x) in fx.iter().enumerate() {
                let index = [
                    corner[0] + i as i64,
                    corner[1] + j as i64,
                    corner[2] + k as i64,
                ];
                let e = corner_sum(&corner_gradients(index), [x, y, z]);
                hull = if hull.is_empty() {
                    e
                } else {
                    Interval::new(hull.lo.min(e.lo), hull.hi.max(e.hi))
                };
            }
        }
    }
    if hull.is_empty() {
        hull
    } else {
        within(hull)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Zero at every lattice point, whatever the gradient there.
    #[test]
    fn vanishes_on_the_lattice() {
        for p in [[0.0, 0.0, 0.0], [3.0, -7.0, 12.0], [-255.0, 256.0, 1.0]] {
            assert_eq!(value(p, [0, 0, 0]), 0.0, "{p:?}");
        }
    }

    /// Each factor's critical points are where its derivative is zero.
    #[test]
    fn critical_points_are_roots_of_the_derivative() {
        for kind in [Kind::Weight0, Kind::Weight1, Kind::Offset0, Kind::Offset1] {
            for order in 0..VANISHING_ORDER {
                let f = factor(kind, order);
                let d = derivative(f.coefficients);
                for &c in &f.critical {
                    assert!(polynomial_at(&d, c).abs() < 1e-9, "{order}: {c}");
                }
            }
        }
        // The fade's slope 30 t^2 (1 - t)^2 peaks at one half.
        assert_eq!(factor(Kind::Weight1, 1).critical, vec![0.5]);
    }

    /// A small deterministic generator, so failures reproduce.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    const PARTIALS: [[u8; 3]; 8] = [
        [0, 0, 0],
        [1, 0, 0],
        [0, 1, 0],
        [0, 0, 1],
        [1, 1, 0],
        [0, 2, 0],
        [2, 1, 3],
        [0, 0, 6],
    ];

    /// Over random boxes, from a hundredth of a cell to several cells
    /// across, every sampled value of every partial lies in the box's
    /// enclosure.
    #[test]
    fn enclosures_hold_every_sampled_value() {
        let mut rng = Rng(0x9e3779b97f4a7c15);
        for _ in 0..400 {
            let size = 10f64.powf(-2.0 + 2.7 * rng.next());
            let lo: [f64; 3] = std::array::from_fn(|_| -20.0 + 40.0 * rng.next());
            let hi = lo.map(|c| c + size);
            let b: [Interval; 3] = std::array::from_fn(|a| Interval::new(lo[a], hi[a]));
            for partial in PARTIALS {
                let e = enclose(b, partial);
                for _ in 0..60 {
                    let p: [f64; 3] = std::array::from_fn(|a| lo[a] + (hi[a] - lo[a]) * rng.next());
                    let v = value(p, partial);
                    assert!(
                        e.contains(v),
                        "{partial:?} at {p:?}: {v} outside {e:?} over {lo:?}..{hi:?}"
                    );
                }
                // The corners of the box too, where the extremes often are.
                for corner in 0..8 {
                    let p: [f64; 3] =
                        std::array::from_fn(|a| if corner >> a & 1 == 1 { hi[a] } else { lo[a] });
                    assert!(e.contains(value(p, partial)), "{partial:?} at corner {p:?}");
                }
            }
        }
    }

    /// The bound for boxes too large to go cell by cell holds at every
    /// sampled point, and is what a box over the whole line gets.
    #[test]
    fn the_global_bound_holds_everywhere() {
        let mut rng = Rng(7);
        for partial in PARTIALS {
            let bound = global_bound(partial);
            for _ in 0..20_000 {
                let p: [f64; 3] = std::array::from_fn(|_| -300.0 + 600.0 * rng.next());
                assert!(bound.contains(value(p, partial)), "{partial:?} at {p:?}");
            }
            assert_eq!(enclose([Interval::ENTIRE; 3], partial), bound);
        }
        assert_eq!(global_bound([0, 0, 0]), Interval::new(-1.04, 1.04));
    }

    /// [`VALUE_BOUND`] holds: over every box of a subdivision of the cell,
    /// the weighted sum of the corners' largest possible terms is below
    /// it. Over a box each corner's term is at most the two largest
    /// offsets' upper ends, and the weights are a product of per-axis
    /// weights, so the sum is multilinear in the three fades and largest
    /// at one of the eight corners of the fades' box (the fade is
    /// increasing, so its range is its ends'). Boxes whose bound is
    /// above it are split along their widest side; the proof succeeds
    /// when none is left. Rounding is 1e-15 of the sums; the margin is
    /// 2.5e-3.
    #[test]
    fn the_value_bound_is_proved() {
        for g in GRADIENTS {
            let sizes = g.map(|c| c.unsigned_abs());
            assert_eq!(sizes.iter().map(|&s| s as u32).sum::<u32>(), 2, "{g:?}");
            assert!(sizes.iter().all(|&s| s <= 1), "{g:?}");
        }
        let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
        let corners: [[usize; 3]; 8] = std::array::from_fn(|c| [c & 1, (c >> 1) & 1, (c >> 2) & 1]);
        let upper = |lo: [f64; 3], hi: [f64; 3]| {
            let largest: [f64; 8] = std::array::from_fn(|c| {
                let mut d: [f64; 3] = std::array::from_fn(|a| {
                    let corner = corners[c][a] as f64;
                    (lo[a] - corner).abs().max((hi[a] - corner).abs())
                });
                d.sort_by(f64::total_cmp);
                d[1] + d[2]
            });
            let fades = [lo.map(fade), hi.map(fade)];
            corners
                .iter()
                .map(|v| {
                    let f: [f64; 3] = std::array::from_fn(|a| fades[v[a]][a]);
                    (0..8)
                        .map(|c| {
                            let w: f64 = (0..3)
                                .map(|a| if corners[c][a] == 1 { f[a] } else { 1.0 - f[a] })
                                .product();
                            w * largest[c]
                        })
                        .sum::<f64>()
                })
                .fold(0.0, f64::max)
        };
        let mut open = vec![([0.0; 3], [1.0; 3])];
        let mut boxes = 0usize;
        while let Some((lo, hi)) = open.pop() {
            boxes += 1;
            assert!(boxes < 10_000_000, "no proof within 10^7 boxes");
            if upper(lo, hi) * (1.0 + 1e-15) <= VALUE_BOUND {
                continue;
            }
            let a = (0..3)
                .max_by(|&i, &j| (hi[i] - lo[i]).total_cmp(&(hi[j] - lo[j])))
                .unwrap();
            assert!(hi[a] - lo[a] > 1e-9, "the bound fails near {lo:?}");
            let mid = 0.5 * (lo[a] + hi[a]);
            let (mut left, mut right) = (hi, lo);
            left[a] = mid;
            right[a] = mid;
            open.push((lo, left));
            open.push((right, hi));
        }
    }

    /// Each partial is the finite difference of the one below it, inside
    /// cells and across their faces (the first derivatives are continuous
    /// there, so central differences straddling a face agree too).
    #[test]
    fn partials_match_finite_differences() {
        let mut rng = Rng(42);
        let h = 1e-6;
        for _ in 0..2000 {
            let p: [f64; 3] = std::array::from_fn(|_| -10.0 + 20.0 * rng.next());
            for lower in [[0, 0, 0], [1, 0, 0], [0, 1, 1]] {
                for axis in 0..3 {
                    // Third derivatives jump on faces: a difference
                    // straddling one is only first-order accurate there.
                    if (p[axis] - p[axis].round()).abs() < 2.0 * h {
                        continue;
                    }
                    let mut higher = lower;
                    higher[axis] += 1;
                    let (mut a, mut b) = (p, p);
                    a[axis] -= h;
                    b[axis] += h;
                    let fd = (value(b, lower) - value(a, lower)) / (2.0 * h);
                    let exact = value(p, higher);
                    assert!(
                        (fd - exact).abs() < 1e-6 * (1.0 + exact.abs()),
                        "d{axis} of {lower:?} at {p:?}: {fd} vs {exact}"
                    );
                }
            }
        }
        // Straddling a face: x = 3 exactly.
        for y in [0.1, 0.37, 0.8] {
            let p = [3.0, y, 0.55];
            let fd =
                (value([3.0 + h, y, 0.55], [0; 3]) - value([3.0 - h, y, 0.55], [0; 3])) / (2.0 * h);
            let exact = value(p, [1, 0, 0]);
            assert!((fd - exact).abs() < 1e-6, "across x = 3: {fd} vs {exact}");
        }
    }

    /// The value and its first and second derivatives are continuous
    /// across cell faces: both sides of a face agree.
    #[test]
    fn continuous_across_faces() {
        for partial in [[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [1, 1, 0]] {
            for y in [0.2, 0.5, 0.9] {
                let below = value([(-2.0f64).next_down(), y, 0.3], partial);
                let above = value([-2.0, y, 0.3], partial);
                assert!(
                    (below - above).abs() < 1e-9,
                    "{partial:?} at y {y}: {below} vs {above}"
                );
            }
        }
    }

    /// The same numbers on every machine, and Perlin's: his reference
    /// implementation (ImprovedNoise.java) gives 0.13691995878400012 at
    /// (3.14, 42, 7); the other two are pinned from this one.
    #[test]
    fn pinned_values() {
        let cases = [
            // Perlin's own example point, not an approximation of pi.
            #[allow(clippy::approx_constant)]
            ([3.14, 42.0, 7.0], PINNED[0]),
            ([1.25, -3.5, 7.75], PINNED[1]),
            ([-10.3, 4.1, 0.9], PINNED[2]),
        ];
        for (p, want) in cases {
            let v = value(p, [0, 0, 0]);
            assert!((v - want).abs() < 1e-12, "{p:?}: {v} (pinned {want})");
        }
    }

    const PINNED: [f64; 3] = [
        0.13691995878400012,
        -0.5875997543334961,
        0.29400923615954033,
    ];
}
