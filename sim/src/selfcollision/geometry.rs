//! Exact primitives between cloth features: closest points of a point and
//! a triangle and of two segments (Ericson, *Real-Time Collision
//! Detection*, §5.1.5 and §5.1.9), and the segment–triangle crossing test
//! that defines "the cloth passes through itself".

use crate::collision::closest_region;
use crate::math::{Real, Vec3};

/// The closest point of triangle `(a, b, c)` to `p` as barycentric weights
/// `[wa, wb, wc]` (non-negative, summing to one): the obstacle tests' own
/// region walk (`collision::closest_region`).
pub fn point_triangle(p: &Vec3, a: &Vec3, b: &Vec3, c: &Vec3) -> [Real; 3] {
    closest_region(p, &[*a, *b, *c]).weights()
}

/// The closest points of segments `p1 q1` and `p2 q2` as parameters
/// `(s, t)` in `[0, 1]`: `p1 + s (q1 - p1)` and `p2 + t (q2 - p2)`.
pub fn segment_segment(p1: &Vec3, q1: &Vec3, p2: &Vec3, q2: &Vec3) -> (Real, Real) {
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = d1.norm_squared();
    let e = d2.norm_squared();
    let f = d2.dot(&r);
    let tiny = 1e-30;
    if a <= tiny && e <= tiny {
        return (0.0, 0.0);
    }
    if a <= tiny {
        return (0.0, (f / e).clamp(0.0, 1.0));
    }
    let c = d1.dot(&r);
    if e <= tiny {
        return ((-c / a).clamp(0.0, 1.0), 0.0);
    }
    let b = d1.dot(&d2);
    let denom = a * e - b * b;
    let mut s = if denom > tiny * a * e {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        0.0 // parallel: any s; take the first end
    };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    (s, t)
}

/// Whether the segment `p q` passes through the triangle `(a, b, c)`: its
/// ends strictly on opposite sides of the plane and the crossing point
/// strictly inside the triangle. Touching is not crossing: an end on the
/// plane (to a billionth of the features' size, so a flat sheet's rounding
/// never counts) or a crossing exactly on an edge counts as none.
pub fn segment_crosses_triangle(p: &Vec3, q: &Vec3, a: &Vec3, b: &Vec3, c: &Vec3) -> bool {
    let n = (b - a).cross(&(c - a));
    let size = (q - p).norm() + (b - a).norm().max((c - a).norm());
    let tol = 1e-9 * n.norm() * size;
    let (sp, sq) = (n.dot(&(p - a)), n.dot(&(q - a)));
    if tol.is_nan() || tol <= 0.0 || sp.abs() <= tol || sq.abs() <= tol || (sp > 0.0) == (sq > 0.0)
    {
        return false;
    }
    let x = p + (q - p) * (sp / (sp - sq));
    n.dot(&(b - a).cross(&(x - a))) > 0.0
        && n.dot(&(c - b).cross(&(x - b))) > 0.0
        && n.dot(&(a - c).cross(&(x - c))) > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(w: [Real; 3], a: &Vec3, b: &Vec3, c: &Vec3) -> Vec3 {
        a * w[0] + b * w[1] + c * w[2]
    }

    /// The closest point found is no farther than any of a dense sample
    /// of the triangle, for points in every Voronoi region.
    #[test]
    fn point_triangle_is_the_minimum_over_the_triangle() {
        let (a, b, c) = (
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.1, 0.0),
            Vec3::new(0.3, 0.9, 0.2),
        );
        for k in 0..200 {
            let f = k as Real;
            let p = Vec3::new(
                1.5 * (0.37 * f).sin(),
                1.5 * (0.61 * f).cos(),
                (0.23 * f).sin(),
            );
            let w = point_triangle(&p, &a, &b, &c);
            assert!(w.iter().all(|x| *x >= -1e-12) && (w.iter().sum::<Real>() - 1.0).abs() < 1e-12);
            let best = (p - at(w, &a, &b, &c)).norm();
            for i in 0..=40 {
                for j in 0..=40 - i {
                    let (u, v) = (i as Real / 40.0, j as Real / 40.0);
                    let q = at([1.0 - u - v, u, v], &a, &b, &c);
                    assert!(best <= (p - q).norm() + 1e-12, "point {k}");
                }
            }
        }
    }

    #[test]
    fn segment_segment_is_the_minimum_over_both_segments() {
        for k in 0..100 {
            let f = k as Real;
            let p1 = Vec3::new(f.sin(), 0.0, 0.3 * f.cos());
            let q1 = Vec3::new(1.0, (0.7 * f).sin(), 0.0);
            let p2 = Vec3::new(0.5, -1.0, (1.3 * f).sin());
            let q2 = Vec3::new(0.2 * f.cos(), 1.0, 0.5);
            let (s, t) = segment_segment(&p1, &q1, &p2, &q2);
            let best = ((p1 + (q1 - p1) * s) - (p2 + (q2 - p2) * t)).norm();
            for i in 0..=50 {
                for j in 0..=50 {
                    let (u, v) = (i as Real / 50.0, j as Real / 50.0);
                    let d = ((p1 + (q1 - p1) * u) - (p2 + (q2 - p2) * v)).norm();
                    assert!(best <= d + 1e-12, "pair {k}");
                }
            }
        }
        // Parallel segments.
        let (s, t) = segment_segment(
            &Vec3::zeros(),
            &Vec3::x(),
            &Vec3::new(0.5, 1.0, 0.0),
            &Vec3::new(1.5, 1.0, 0.0),
        );
        let d = (Vec3::x() * s - (Vec3::new(0.5, 1.0, 0.0) + Vec3::x() * t)).norm();
        assert!((d - 1.0).abs() < 1e-12);
    }

    #[test]
    fn crossing_is_strict() {
        let (a, b, c) = (Vec3::zeros(), Vec3::x(), Vec3::y());
        let inside = Vec3::new(0.2, 0.2, 0.0);
        let up = Vec3::z();
        assert!(segment_crosses_triangle(
            &(inside + up),
            &(inside - up),
            &a,
            &b,
            &c
        ));
        // Ending on the plane, passing outside, parallel, on an edge.
        assert!(!segment_crosses_triangle(
            &(inside + up),
            &inside,
            &a,
            &b,
            &c
        ));
        let outside = Vec3::new(0.8, 0.8, 0.0);
        assert!(!segment_crosses_triangle(
            &(outside + up),
            &(outside - up),
            &a,
            &b,
            &c
        ));
        assert!(!segment_crosses_triangle(&a, &b, &a, &b, &c));
        // A segment in the plane, across the triangle, with rounding-level
        // tilt: a flat sheet's own edges never count.
        let tilt = Vec3::new(0.0, 0.0, 1e-17);
        assert!(!segment_crosses_triangle(
            &(Vec3::new(0.1, -0.5, 0.0) + tilt),
            &(Vec3::new(0.1, 1.5, 0.0) - tilt),
            &a,
            &b,
            &c
        ));
        let on_edge = Vec3::new(0.5, 0.0, 0.0);
        assert!(!segment_crosses_triangle(
            &(on_edge + up),
            &(on_edge - up),
            &a,
            &b,
            &c
        ));
    }
}
