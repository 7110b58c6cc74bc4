//! Continuous collision tests between moving cloth features (Provot 1997;
//! Bridson, Fedkiw & Anderson 2002 §6): a vertex and a triangle, or two
//! edges, moving linearly over the step can only meet when their four
//! points are coplanar. Coplanarity is a cubic in the step fraction `t`;
//! each of its roots in `[0, 1]`, earliest first, is checked for the
//! features actually being within `eta` of each other there.

use super::geometry::{point_triangle, segment_segment};
use crate::math::{Real, Vec3};

/// Four points of a pair, each with a start position and a motion over
/// the step: a vertex then a triangle's three corners, or two edges.
#[derive(Debug, Clone, Copy)]
pub struct Moving {
    /// Start positions.
    pub x: [Vec3; 4],
    /// Displacements over the step.
    pub d: [Vec3; 4],
}

/// The kind of pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Point 0 against the triangle of points 1, 2, 3.
    VertexFace,
    /// The edge of points 0, 1 against the edge of points 2, 3.
    EdgeEdge,
}

/// Where a pair is closest: its weights `c` (the relative position of the
/// two features is `Σ c_k x_k`), and that vector's length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    /// Weights of the four points; positive on the first feature.
    pub c: [Real; 4],
    /// `Σ c_k x_k`: from the second feature's closest point to the first's.
    pub gap: Vec3,
}

/// The closest points of the pair at positions `x`.
pub fn closest(kind: Kind, x: &[Vec3; 4]) -> Closest {
    let c = match kind {
        Kind::VertexFace => {
            let w = point_triangle(&x[0], &x[1], &x[2], &x[3]);
            [1.0, -w[0], -w[1], -w[2]]
        }
        Kind::EdgeEdge => {
            let (s, t) = segment_segment(&x[0], &x[1], &x[2], &x[3]);
            [1.0 - s, s, -(1.0 - t), -t]
        }
    };
    let gap = x[0] * c[0] + x[1] * c[1] + x[2] * c[2] + x[3] * c[3];
    Closest { c, gap }
}

impl Moving {
    /// Positions at step fraction `t`.
    pub fn at(&self, t: Real) -> [Vec3; 4] {
        std::array::from_fn(|k| self.x[k] + self.d[k] * t)
    }

    /// The earliest step fraction at which the features come within
    /// `eta` of each other while coplanar, with the closest points there.
    pub fn first_contact(&self, kind: Kind, eta: Real) -> Option<(Real, Closest)> {
        // Each feature's points move at most `reach` of it, so the
        // features' distance shrinks by at most the two reaches: a pair
        // farther apart than that at the start cannot touch (the test
        // that rejects almost every pair of a smoothly moving cloth).
        let split = if kind == Kind::VertexFace { 1 } else { 2 };
        let reach = |r: std::ops::Range<usize>| {
            self.d[r]
                .iter()
                .map(|d| d.norm_squared())
                .fold(0.0, Real::max)
                .sqrt()
        };
        let dist0 = closest(kind, &self.x).gap.norm();
        if dist0 > eta + reach(0..split) + reach(split..4) {
            return None;
        }
        // Edges of the coplanarity triple product, relative to point 0 for
        // a vertex-face pair and to point 2 for an edge pair.
        let (a, b, c) = match kind {
            Kind::VertexFace => ([2, 1], [3, 1], [0, 1]),
            Kind::EdgeEdge => ([1, 0], [3, 2], [2, 0]),
        };
        let e = |[i, j]: [usize; 2]| (self.x[i] - self.x[j], self.d[i] - self.d[j]);
        let (e1, f1) = e(a);
        let (e2, f2) = e(b);
        let (e3, f3) = e(c);
        let cubic = triple_product_cubic(&e1, &f1, &e2, &f2, &e3, &f3);
        let mut roots = [0.0; 3];
        let count = unit_roots(&cubic, &mut roots);
        let check = |t: Real| {
            let x = self.at(t);
            let cl = closest(kind, &x);
            (cl.gap.norm() <= eta).then_some((t, cl))
        };
        if count == usize::MAX {
            // Coplanar all along: the start is separated (the state has no
            // crossings), so check where the motion ends.
            return check(1.0);
        }
        roots[..count].iter().find_map(|&t| check(t))
    }
}

/// Coefficients `[c0, c1, c2, c3]` of `((e1 + t f1) × (e2 + t f2))·(e3 + t f3)`.
fn triple_product_cubic(
    e1: &Vec3,
    f1: &Vec3,
    e2: &Vec3,
    f2: &Vec3,
    e3: &Vec3,
    f3: &Vec3,
) -> [Real; 4] {
    let ee = e1.cross(e2);
    let ef = f1.cross(e2) + e1.cross(f2);
    let ff = f1.cross(f2);
    [
        ee.dot(e3),
        ef.dot(e3) + ee.dot(f3),
        ff.dot(e3) + ef.dot(f3),
        ff.dot(f3),
    ]
}

fn eval(c: &[Real; 4], t: Real) -> Real {
    ((c[3] * t + c[2]) * t + c[1]) * t + c[0]
}

/// The roots of the cubic `c` in `[0, 1]`, ascending, into `out`; returns
/// their number, or `usize::MAX` when the cubic vanishes identically (to
/// rounding). The interval is cut at the derivative's roots into monotone
/// pieces, each bisected to full precision where it changes sign.
fn unit_roots(c: &[Real; 4], out: &mut [Real; 3]) -> usize {
    let scale = c.iter().fold(0.0, |m: Real, v| m.max(v.abs()));
    if scale <= 1e-300 {
        return usize::MAX;
    }
    let mut cuts = [0.0, 1.0, 1.0, 1.0];
    let mut n_cuts = 1;
    // f'(t) = c1 + 2 c2 t + 3 c3 t².
    let (qa, qb, qc) = (3.0 * c[3], 2.0 * c[2], c[1]);
    let mut crit = [Real::NAN; 2];
    if qa.abs() > 1e-14 * scale {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 {
            let s = disc.sqrt();
            // Numerically stable quadratic roots.
            let q = -0.5 * (qb + qb.signum() * s);
            crit = [q / qa, if q != 0.0 { qc / q } else { Real::NAN }];
        }
    } else if qb.abs() > 1e-14 * scale {
        crit[0] = -qc / qb;
    }
    crit.sort_by(|a, b| a.total_cmp(b));
    for t in crit {
        if t > 0.0 && t < 1.0 {
            cuts[n_cuts] = t;
            n_cuts += 1;
        }
    }
    cuts[n_cuts] = 1.0;
    let mut count = 0;
    let tiny = 1e-15 * scale;
    for k in 0..n_cuts {
        let (mut lo, mut hi) = (cuts[k], cuts[k + 1]);
        let (mut flo, fhi) = (eval(c, lo), eval(c, hi));
        let root = if flo.abs() <= tiny {
            Some(lo)
        } else if (flo < 0.0) == (fhi < 0.0) && fhi.abs() > tiny {
            None
        } else if fhi.abs() <= tiny {
            Some(hi)
        } else {
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                let fm = eval(c, mid);
                if (fm < 0.0) == (flo < 0.0) {
                    lo = mid;
                    flo = fm;
                } else {
                    hi = mid;
                }
            }
            Some(0.5 * (lo + hi))
        };
        if let Some(t) = root
            && (count == 0 || t > out[count - 1])
        {
            out[count] = t;
            count += 1;
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cubic_roots_are_found_in_order() {
        // (t - 0.2)(t - 0.5)(t - 0.9) and a double root at 0.3.
        let r = [0.2, 0.5, 0.9];
        let c = [
            -r[0] * r[1] * r[2],
            r[0] * r[1] + r[1] * r[2] + r[0] * r[2],
            -(r[0] + r[1] + r[2]),
            1.0,
        ];
        let mut out = [0.0; 3];
        assert_eq!(unit_roots(&c, &mut out), 3);
        for k in 0..3 {
            assert!((out[k] - r[k]).abs() < 1e-12, "{out:?}");
        }
        let d = [0.09, -0.6, 1.0, 0.0];
        let n = unit_roots(&d, &mut out);
        assert!(n >= 1 && (out[0] - 0.3).abs() < 1e-6, "{:?}", &out[..n]);
        assert_eq!(unit_roots(&[1.0, 1.0, 0.0, 0.0], &mut out), 0);
        assert_eq!(unit_roots(&[0.0; 4], &mut out), usize::MAX);
    }

    /// A vertex falling through the middle of a triangle is caught at the
    /// fraction where it reaches the plane; one passing beside it is not.
    #[test]
    fn vertex_through_face() {
        let tri = [Vec3::zeros(), Vec3::x(), Vec3::y()];
        let mk = |p: Vec3| Moving {
            x: [p, tri[0], tri[1], tri[2]],
            d: [
                Vec3::new(0.0, 0.0, -1.0),
                Vec3::zeros(),
                Vec3::zeros(),
                Vec3::zeros(),
            ],
        };
        let (t, cl) = mk(Vec3::new(0.2, 0.2, 0.25))
            .first_contact(Kind::VertexFace, 1e-6)
            .expect("hit");
        assert!((t - 0.25).abs() < 1e-9);
        assert!(cl.gap.norm() < 1e-6);
        assert!(
            mk(Vec3::new(0.8, 0.8, 0.25))
                .first_contact(Kind::VertexFace, 1e-6)
                .is_none()
        );
    }

    /// Two crossed edges, one moving down through the other, with a
    /// rotating triangle case for the cubic's higher terms.
    #[test]
    fn edge_through_edge_and_rotating_face() {
        let m = Moving {
            x: [
                Vec3::new(-1.0, 0.0, 0.5),
                Vec3::new(1.0, 0.0, 0.5),
                Vec3::new(0.0, -1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
            d: [
                Vec3::new(0.0, 0.0, -1.0),
                Vec3::new(0.0, 0.0, -1.0),
                Vec3::zeros(),
                Vec3::zeros(),
            ],
        };
        let (t, _) = m.first_contact(Kind::EdgeEdge, 1e-6).expect("hit");
        assert!((t - 0.5).abs() < 1e-9);
        // Parallel edges passing beside each other never meet.
        let mut beside = m;
        beside.x[2] = Vec3::new(-1.0, 0.3, 0.0);
        beside.x[3] = Vec3::new(1.0, 0.3, 0.0);
        assert!(beside.first_contact(Kind::EdgeEdge, 1e-6).is_none());
        // A triangle tilting up through a resting vertex: corner 3 rises.
        let r = Moving {
            x: [
                Vec3::new(0.2, 0.2, 0.1),
                Vec3::zeros(),
                Vec3::x(),
                Vec3::y(),
            ],
            d: [
                Vec3::zeros(),
                Vec3::zeros(),
                Vec3::zeros(),
                Vec3::new(0.0, -0.5, 1.0),
            ],
        };
        let (t, cl) = r.first_contact(Kind::VertexFace, 1e-6).expect("hit");
        let x = r.at(t);
        let n = (x[2] - x[1]).cross(&(x[3] - x[1]));
        assert!(n.dot(&(x[0] - x[1])).abs() < 1e-9 && cl.gap.norm() < 1e-6);
    }
}
