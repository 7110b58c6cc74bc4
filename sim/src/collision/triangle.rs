//! Particle against one triangle: the continuous segment–plane test of
//! method.md §3 eqs. [13][14] with the barycentric inside test the paper
//! leaves implicit, and the closest point on a triangle (for particles
//! already inside, and for distances).

use crate::math::{Real, Vec3};

/// Relative slack of the barycentric inside test, so a particle crossing
/// exactly over a shared edge is caught by one of its two triangles.
const BARY_SLACK: Real = 1e-9;

/// Where a moving particle meets a triangle's plane from the front.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneHit {
    /// Fraction of the segment, in `[0, 1]`.
    pub t: Real,
    /// The hit point.
    pub point: Vec3,
}

/// The particle moves on `Q(t) = a + t (b - a)`; the triangle `tri` has
/// unit normal `n` (its front side). With the plane `n·x + D = 0`,
///
/// ```text
/// t = -(D + n·a) / (n·(b - a))        eq. [14]
/// ```
///
/// A hit is a crossing from front to back (`n·(b - a) < 0`, `a` not more
/// than `front_slack` behind the plane, `b` behind it) with `t ≤ 1` and the
/// hit point inside the triangle. A start within `front_slack` behind the
/// plane (a particle left there by solver tolerance) hits at `t = 0`.
pub fn segment_hit(
    a: &Vec3,
    b: &Vec3,
    tri: &[Vec3; 3],
    n: &Vec3,
    front_slack: Real,
) -> Option<PlaneHit> {
    let d = b - a;
    let denom = n.dot(&d);
    if denom >= 0.0 {
        return None; // parallel or moving out: no front-to-back crossing
    }
    let dist_a = n.dot(&(a - tri[0])); // n·a + D
    let dist_b = dist_a + denom;
    if dist_a < -front_slack || dist_b >= 0.0 {
        return None;
    }
    let t = (dist_a / -denom).clamp(0.0, 1.0);
    let point = a + d * t;
    inside(&point, tri, n).then_some(PlaneHit { t, point })
}

/// Barycentric inside test of a point on (or near) the triangle's plane:
/// the point is inside when it is on the inner side of all three edges.
#[inline]
fn inside(p: &Vec3, tri: &[Vec3; 3], n: &Vec3) -> bool {
    let scale = (tri[1] - tri[0])
        .norm_squared()
        .max((tri[2] - tri[0]).norm_squared());
    (0..3).all(|k| {
        let e = tri[(k + 1) % 3] - tri[k];
        e.cross(&(p - tri[k])).dot(n) >= -BARY_SLACK * scale
    })
}

/// Which part of a triangle a closest point lies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feature {
    /// The interior.
    Face,
    /// Edge `k`, from corner `k` to corner `k + 1`.
    Edge(u8),
    /// Corner `k`.
    Vertex(u8),
}

/// Where on a triangle `[a, b, c]` the point closest to some point lies,
/// with the parameters Ericson's region walk computes for it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Region {
    /// Corner `k`.
    Vertex(u8),
    /// `a + (b - a) v` on edge 0.
    EdgeAb(Real),
    /// `b + (c - b) w` on edge 1.
    EdgeBc(Real),
    /// `a + (c - a) w` on edge 2.
    EdgeCa(Real),
    /// `a + (b - a) v + (c - a) w` inside.
    Face(Real, Real),
}

impl Region {
    /// The part of the triangle it is on.
    pub fn feature(self) -> Feature {
        match self {
            Region::Vertex(k) => Feature::Vertex(k),
            Region::EdgeAb(_) => Feature::Edge(0),
            Region::EdgeBc(_) => Feature::Edge(1),
            Region::EdgeCa(_) => Feature::Edge(2),
            Region::Face(..) => Feature::Face,
        }
    }

    /// The point itself.
    pub fn point(self, tri: &[Vec3; 3]) -> Vec3 {
        let [a, b, c] = *tri;
        match self {
            Region::Vertex(k) => tri[k as usize],
            Region::EdgeAb(v) => a + (b - a) * v,
            Region::EdgeBc(w) => b + (c - b) * w,
            Region::EdgeCa(w) => a + (c - a) * w,
            Region::Face(v, w) => a + (b - a) * v + (c - a) * w,
        }
    }

    /// Its barycentric weights of `a`, `b`, `c` (non-negative, summing to
    /// one); a degenerate (zero-area) triangle's face gives its first
    /// corner.
    pub fn weights(self) -> [Real; 3] {
        let w = match self {
            Region::Vertex(k) => {
                let mut w = [0.0; 3];
                w[k as usize] = 1.0;
                w
            }
            Region::EdgeAb(v) => [1.0 - v, v, 0.0],
            Region::EdgeBc(w) => [0.0, 1.0 - w, w],
            Region::EdgeCa(w) => [1.0 - w, 0.0, w],
            Region::Face(v, w) => [1.0 - v - w, v, w],
        };
        if w.iter().all(|x| x.is_finite()) {
            w
        } else {
            [1.0, 0.0, 0.0]
        }
    }
}

/// The region of triangle `tri` holding the point closest to `p` (Ericson,
/// "Real-Time Collision Detection", 5.1.5): vertex regions, then edge
/// regions, then the face.
pub fn closest_region(p: &Vec3, tri: &[Vec3; 3]) -> Region {
    let [a, b, c] = *tri;
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return Region::Vertex(0);
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return Region::Vertex(1);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return Region::EdgeAb(d1 / (d1 - d3));
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return Region::Vertex(2);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return Region::EdgeCa(d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return Region::EdgeBc((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    Region::Face(vb * denom, vc * denom)
}

/// The point of triangle `tri` closest to `p`, and its feature.
pub fn closest_point(p: &Vec3, tri: &[Vec3; 3]) -> (Vec3, Feature) {
    let r = closest_region(p, tri);
    (r.point(tri), r.feature())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng, rngs::StdRng};

    fn tri() -> [Vec3; 3] {
        [Vec3::zeros(), Vec3::x(), Vec3::y()]
    }

    #[test]
    fn hits_and_misses() {
        let (t, n) = (tri(), Vec3::z());
        let hit = |a: Vec3, b: Vec3| segment_hit(&a, &b, &t, &n, 0.0);
        // Straight down through the interior: t from eq. [14].
        let h = hit(Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.2, 0.2, -3.0)).expect("hit");
        assert!((h.t - 0.25).abs() < 1e-15 && h.point.z.abs() < 1e-15);
        // Slanted segment: the hit point is where it crosses the plane.
        let h = hit(Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.5, 0.5, -1.0)).expect("hit");
        assert!((h.point - Vec3::new(0.25, 0.25, 0.0)).norm() < 1e-15);
        // Outside the triangle, stopping short, moving up, from behind.
        assert!(hit(Vec3::new(0.8, 0.8, 1.0), Vec3::new(0.8, 0.8, -1.0)).is_none());
        assert!(hit(Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.2, 0.2, 0.1)).is_none());
        assert!(hit(Vec3::new(0.2, 0.2, -1.0), Vec3::new(0.2, 0.2, 1.0)).is_none());
        assert!(hit(Vec3::new(0.2, 0.2, -0.1), Vec3::new(0.2, 0.2, -1.0)).is_none());
        // Parallel to the plane, in it or above it.
        assert!(hit(Vec3::new(0.1, 0.1, 0.0), Vec3::new(0.3, 0.1, 0.0)).is_none());
        assert!(hit(Vec3::new(0.1, 0.1, 0.5), Vec3::new(0.3, 0.1, 0.5)).is_none());
        // Ending exactly on the plane is not yet a crossing.
        assert!(hit(Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.2, 0.2, 0.0)).is_none());
        // Starting just behind within the slack hits at t = 0.
        let h = segment_hit(
            &Vec3::new(0.2, 0.2, -1e-6),
            &Vec3::new(0.2, 0.2, -1.0),
            &t,
            &n,
            1e-5,
        )
        .expect("slack hit");
        assert_eq!(h.t, 0.0);
    }

    #[test]
    fn edges_and_corners_are_not_leaks() {
        // Two triangles sharing the diagonal of the unit square: a crossing
        // exactly on the shared edge or a corner is caught by one of them.
        let t1 = [Vec3::zeros(), Vec3::x(), Vec3::new(1.0, 1.0, 0.0)];
        let t2 = [Vec3::zeros(), Vec3::new(1.0, 1.0, 0.0), Vec3::y()];
        for p in [
            Vec3::new(0.5, 0.5, 0.0),
            Vec3::zeros(),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.3, 0.0, 0.0),
        ] {
            let a = p + Vec3::z();
            let b = p - Vec3::z();
            let any = [t1, t2]
                .iter()
                .any(|t| segment_hit(&a, &b, t, &Vec3::z(), 0.0).is_some());
            assert!(any, "leak at {p:?}");
        }
    }

    #[test]
    fn closest_point_is_the_minimum_over_the_triangle() {
        let mut rng = StdRng::seed_from_u64(7);
        for _ in 0..500 {
            let mut r = || {
                Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                )
            };
            let t = [r(), r(), r()];
            let p = r() * 2.0;
            let (q, _) = closest_point(&p, &t);
            let d = (p - q).norm();
            // No sampled point of the triangle is closer.
            for i in 0..=20 {
                for j in 0..=(20 - i) {
                    let (u, v) = (i as Real / 20.0, j as Real / 20.0);
                    let s = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v;
                    assert!((p - s).norm() >= d - 1e-12);
                }
            }
        }
        let (q, f) = closest_point(&Vec3::new(2.0, -1.0, 3.0), &tri());
        assert_eq!((q, f), (Vec3::x(), Feature::Vertex(1)));
        let (_, f) = closest_point(&Vec3::new(0.5, -1.0, 0.0), &tri());
        assert_eq!(f, Feature::Edge(0));
        let (_, f) = closest_point(&Vec3::new(0.2, 0.2, 1.0), &tri());
        assert_eq!(f, Feature::Face);
    }
}
