//! Recognising planes and quadrics: expressions of degree at most 2 in
//! x, y, z, which a ray meets in closed form.

use std::collections::HashMap;

use glam::{DMat3, DVec3};

use super::graph::{Binary, Graph, Node, NodeId, Unary};

/// `q(p) = p . (M p) + b . p + c`, with `M` symmetric.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quadric {
    pub m: DMat3,
    pub b: DVec3,
    pub c: f64,
    /// The largest |entry| of `m` and of `b`, computed once, for
    /// [`Quadric::cancels_at`], which runs per ray.
    largest: (f64, f64),
}

impl Quadric {
    pub fn value(&self, p: DVec3) -> f64 {
        p.dot(self.m * p) + self.b.dot(p) + self.c
    }

    pub fn gradient(&self, p: DVec3) -> DVec3 {
        2.0 * (self.m * p) + self.b
    }

    /// Whether evaluating the expanded form near `p` loses digits that
    /// matter: its largest term there exceeds 1e4, so rounding (1e-16
    /// relative) reaches 1e-12 absolute, the scale of a hit's accuracy.
    /// Then hits are polished with the expression as written.
    pub fn cancels_at(&self, p: DVec3) -> bool {
        let r = p.abs().max_element();
        let (m, b) = self.largest;
        self.c.abs().max(b * r).max(m * r * r) > 1e4
    }

    /// Degree 1: a plane (or a constant).
    pub fn is_linear(&self) -> bool {
        self.m == DMat3::ZERO
    }
}

/// A polynomial of degree <= 2 in x, y, z. Coefficients of
/// 1, x, y, z, xx, yy, zz, xy, xz, yz.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Poly {
    k: [f64; 10],
    degree: u8,
}

const fn pair_index(i: usize, j: usize) -> usize {
    match (i, j) {
        (0, 0) => 4,
        (1, 1) => 5,
        (2, 2) => 6,
        (0, 1) | (1, 0) => 7,
        (0, 2) | (2, 0) => 8,
        _ => 9,
    }
}

impl Poly {
    fn constant(c: f64) -> Poly {
        let mut k = [0.0; 10];
        k[0] = c;
        Poly { k, degree: 0 }
    }
    fn var(i: usize) -> Poly {
        let mut k = [0.0; 10];
        k[1 + i] = 1.0;
        Poly { k, degree: 1 }
    }
    fn combine(a: Poly, b: Poly, sb: f64) -> Poly {
        let mut k = a.k;
        for (x, y) in k.iter_mut().zip(b.k) {
            *x += sb * y;
        }
        Poly {
            k,
            degree: a.degree.max(b.degree),
        }
    }
    fn scale(a: Poly, s: f64) -> Poly {
        Poly {
            k: a.k.map(|x| x * s),
            degree: a.degree,
        }
    }
    fn mul(a: Poly, b: Poly) -> Option<Poly> {
        if a.degree + b.degree > 2 {
            return None;
        }
        if a.degree == 0 {
            return Some(Poly::scale(b, a.k[0]));
        }
        if b.degree == 0 {
            return Some(Poly::scale(a, b.k[0]));
        }
        // Both linear.
        let mut k = [0.0; 10];
        k[0] = a.k[0] * b.k[0];
        for i in 0..3 {
            k[1 + i] = a.k[0] * b.k[1 + i] + b.k[0] * a.k[1 + i];
            for j in 0..3 {
                k[pair_index(i, j)] += a.k[1 + i] * b.k[1 + j];
            }
        }
        Some(Poly { k, degree: 2 })
    }
}

/// The quadric the expression at `root` is, if its degree in x, y, z is at
/// most 2 and it uses only polynomial operations.
pub fn as_quadric(graph: &Graph, root: NodeId) -> Option<Quadric> {
    let mut memo = HashMap::new();
    let p = poly(graph, root, &mut memo)?;
    let k = p.k;
    let m = DMat3::from_cols(
        DVec3::new(k[4], k[7] / 2.0, k[8] / 2.0),
        DVec3::new(k[7] / 2.0, k[5], k[9] / 2.0),
        DVec3::new(k[8] / 2.0, k[9] / 2.0, k[6]),
    );
    let b = DVec3::new(k[1], k[2], k[3]);
    let q = Quadric {
        m,
        b,
        c: k[0],
        largest: (
            m.abs().to_cols_array().into_iter().fold(0.0, f64::max),
            b.abs().max_element(),
        ),
    };
    let finite = k.iter().all(|x| x.is_finite());
    // A constant is no surface at all.
    (finite && p.degree > 0).then_some(q)
}

fn poly(graph: &Graph, id: NodeId, memo: &mut HashMap<NodeId, Option<Poly>>) -> Option<Poly> {
    if let Some(p) = memo.get(&id) {
        return *p;
    }
    let p = match graph.node(id) {
        Node::Const(bits) => Some(Poly::constant(f64::from_bits(bits))),
        Node::Input(i) if i < 3 => Some(Poly::var(i as usize)),
        Node::Input(_) => None,
        Node::Unary(Unary::Neg, a) => poly(graph, a, memo).map(|a| Poly::scale(a, -1.0)),
        Node::Unary(Unary::Square, a) => poly(graph, a, memo).and_then(|a| Poly::mul(a, a)),
        Node::Unary(..) => None,
        Node::Binary(op, a, b) => {
            let pa = poly(graph, a, memo);
            let pb = poly(graph, b, memo);
            match (op, pa, pb) {
                (Binary::Add, Some(a), Some(b)) => Some(Poly::combine(a, b, 1.0)),
                (Binary::Sub, Some(a), Some(b)) => Some(Poly::combine(a, b, -1.0)),
                (Binary::Mul, Some(a), Some(b)) => Poly::mul(a, b),
                (Binary::Div, Some(a), Some(b)) if b.degree == 0 && b.k[0] != 0.0 => {
                    Some(Poly::scale(a, 1.0 / b.k[0]))
                }
                _ => None,
            }
        }
    };
    memo.insert(id, p);
    p
}
