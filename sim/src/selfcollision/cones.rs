//! Normal cones: which patches of the cloth cannot collide with
//! themselves over a step, so the self-test of a hierarchy node can be
//! skipped (Volino & Magnenat-Thalmann 1994; over a step, Tang, Curtis,
//! Yoon & Manocha 2009, "ICCD", §4).
//!
//! A connected patch whose normals all lie strictly within a half-space
//! `n · a > 0` is a graph over the plane normal to `a` wherever its
//! boundary's projection does not overlap itself, and a graph has no two
//! layers to meet. Over a step where every particle moves linearly,
//! `x(t) = x0 + t (x1 - x0)`, a triangle's (unnormalised) normal
//! `(b - a) × (c - a)` is quadratic in `t`; in Bernstein form
//!
//! ```text
//! n(t) = (1 - t)² n0 + 2 t (1 - t) m + t² n1,
//! n0 = e1(0) × e2(0),   n1 = e1(1) × e2(1),   m = (e1(0) × e2(1) + e1(1) × e2(0)) / 2
//! ```
//!
//! with non-negative weights, so every normal over the step lies in the
//! convex cone of `n0`, `m` and `n1`; a cone holding those for every
//! triangle of a patch bounds the patch's normals over the whole step.
//! Cones are merged up the hierarchy (the smallest cone holding both).
//!
//! The boundary condition is `super::contour`'s.

use crate::collision::Bvh;
use crate::math::{Real, Vec3};

/// Largest half-angle of a patch's cone for its self-test to be skipped:
/// below the 90° the argument needs, by a margin for round-off in the
/// cone arithmetic.
pub const FLAT_HALF_ANGLE: Real = 85.0 * std::f64::consts::PI / 180.0;

/// A cone of directions narrower than [`FLAT_HALF_ANGLE`]: a unit axis
/// and the cosine and sine of its half-angle; or no bound at all
/// ([`Cone::WHOLE`]). Only flat cones are ever merged (a patch holding a
/// wider one is never flat, nor is any patch holding it), so the
/// arithmetic needs no trigonometric functions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cone {
    axis: Vec3,
    cos: Real,
    sin: Real,
}

impl Default for Cone {
    fn default() -> Self {
        Self::WHOLE
    }
}

/// `cos(FLAT_HALF_ANGLE)`.
fn flat_cos() -> Real {
    FLAT_HALF_ANGLE.cos()
}

impl Cone {
    /// No bound: every direction.
    pub const WHOLE: Cone = Cone {
        axis: Vec3::new(0.0, 0.0, 1.0),
        cos: -1.0,
        sin: 0.0,
    };

    /// The cone's axis (unit).
    pub fn axis(&self) -> &Vec3 {
        &self.axis
    }

    /// Whether every direction of the cone is within
    /// [`FLAT_HALF_ANGLE`] of its axis.
    pub fn is_flat(&self) -> bool {
        self.cos > flat_cos()
    }

    /// The cone about `axis` (unit) whose half-angle has cosine `cos`, or
    /// [`Cone::WHOLE`] if that is not flat.
    fn about(axis: Vec3, cos: Real) -> Self {
        if cos > flat_cos() {
            let cos = cos.min(1.0);
            Self {
                axis,
                cos,
                sin: (1.0 - cos * cos).max(0.0).sqrt(),
            }
        } else {
            Self::WHOLE
        }
    }

    /// A cone holding the directions of `vectors` (at most three: a
    /// triangle's normal coefficients), about their mean direction;
    /// [`Cone::WHOLE`] for more than three, if one of them is
    /// (numerically) zero, since it has no direction to bound, or if they
    /// spread too far.
    pub fn holding(vectors: &[Vec3]) -> Self {
        let mut units = [Vec3::zeros(); 3];
        if vectors.len() > units.len() {
            return Self::WHOLE;
        }
        // PERF: each norm taken once.
        let mut norms = [0.0; 3];
        for (n, v) in norms.iter_mut().zip(vectors) {
            *n = v.norm();
        }
        let scale = norms.iter().fold(0.0, |a: Real, &b| a.max(b));
        let mut sum = Vec3::zeros();
        for (k, v) in vectors.iter().enumerate() {
            let n = norms[k];
            if n == 0.0 || n <= 1e-12 * scale {
                return Self::WHOLE;
            }
            units[k] = v / n;
            sum += v / n;
        }
        let len = sum.norm();
        if len <= 1e-12 {
            return Self::WHOLE;
        }
        let axis = sum / len;
        let cos = units[..vectors.len()]
            .iter()
            .map(|u| u.dot(&axis))
            .fold(1.0, Real::min);
        Self::about(axis, cos)
    }

    /// The cone of a triangle's normals over a step in which its corners
    /// move linearly from `x0` to `x1` (module doc).
    pub fn of_triangle(x0: [&Vec3; 3], x1: [&Vec3; 3]) -> Self {
        let (a0, b0, c0) = (x0[0], x0[1], x0[2]);
        let (a1, b1, c1) = (x1[0], x1[1], x1[2]);
        let (e10, e20) = (b0 - a0, c0 - a0);
        let (e11, e21) = (b1 - a1, c1 - a1);
        let n0 = e10.cross(&e20);
        if x0 == x1 {
            return Self::holding(&[n0]);
        }
        let n1 = e11.cross(&e21);
        let m = (e10.cross(&e21) + e11.cross(&e20)) * 0.5;
        Self::holding(&[n0, m, n1])
    }

    /// The cone of a triangle's normals while its edge vectors each
    /// change by at most `bend` from their values at `x` (any motion of
    /// its corners whose differences move by at most `bend`): about its
    /// normal `n = e1 × e2` at `x`, whose change
    /// `d1 × e2 + e1 × d2 + d1 × d2` is at most
    /// `ρ = bend (|e1| + |e2|) + bend²` long, so every normal of the
    /// motion is within `asin(ρ / |n|)` of it.
    pub fn of_turning_triangle(x: [&Vec3; 3], bend: Real) -> Self {
        let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
        let n = e1.cross(&e2);
        let len = n.norm();
        let turn = bend * (e1.norm() + e2.norm()) + bend * bend;
        // Round-off in `n` itself, relative to the edges' product.
        let turn = turn + 1e-12 * e1.norm() * e2.norm();
        if turn >= len {
            return Self::WHOLE;
        }
        let sin = turn / len;
        Self::about(n / len, (1.0 - sin * sin).sqrt())
    }

    /// A cone holding both, about the mean of their axes: each part's
    /// directions are within `θ + h` of it, `θ` the angle between the
    /// axes, `h` the part's half-angle, and `cos(θ + h)` needs no angle.
    pub fn merge(&self, o: &Cone) -> Cone {
        if !self.is_flat() || !o.is_flat() {
            return Self::WHOLE;
        }
        let sum = self.axis + o.axis;
        let len = sum.norm();
        if len <= 1e-12 {
            return Self::WHOLE;
        }
        let axis = sum / len;
        let reach = |c: &Cone| {
            let cos_t = c.axis.dot(&axis).min(1.0);
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            cos_t * c.cos - sin_t * c.sin
        };
        Self::about(axis, reach(self).min(reach(o)))
    }
}

/// Each node's cone of `bvh`, from its triangles' cones `tri_cones`, into
/// `out` (numbered as by [`Bvh::fold_up`]): a leaf's merged from its
/// triangles', an inner node's from its children's.
pub fn fold(bvh: &Bvh, tri_cones: &[Cone], out: &mut Vec<Cone>) {
    bvh.fold_up_shared(
        out,
        |leaf| {
            leaf.iter()
                .map(|&t| tri_cones[t as usize])
                .reduce(|a, b| a.merge(&b))
                .unwrap_or_default()
        },
        Cone::merge,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng, rngs::StdRng};

    fn random_unit(rng: &mut StdRng) -> Vec3 {
        loop {
            let v = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            if v.norm() > 0.1 && v.norm() < 1.0 {
                return v.normalize();
            }
        }
    }

    fn holds(c: &Cone, v: &Vec3) -> bool {
        !c.is_flat() || c.axis.dot(&v.normalize()) >= c.cos - 1e-12
    }

    /// Merged cones hold every direction either part held, and a merge
    /// is no wider than the two cones side by side.
    #[test]
    fn merged_cones_hold_both_parts() {
        let mut rng = StdRng::seed_from_u64(3);
        for _ in 0..2000 {
            let spread = rng.random_range(0.0..0.8);
            let centre = random_unit(&mut rng);
            let group = |rng: &mut StdRng| -> Vec<Vec3> {
                (0..3)
                    .map(|_| (centre + random_unit(rng) * spread).normalize())
                    .collect()
            };
            let (va, vb) = (group(&mut rng), group(&mut rng));
            let (ca, cb) = (Cone::holding(&va), Cone::holding(&vb));
            let c = ca.merge(&cb);
            for v in va.iter().chain(&vb) {
                assert!(holds(&c, v), "{c:?} misses {v:?}");
            }
            // Two narrow groups about one direction stay flat.
            if spread < 0.3 {
                assert!(c.is_flat(), "spread {spread}: {c:?}");
            }
        }
    }

    /// The cone of a triangle over a step holds its normal at every
    /// moment of the step, sampled finely.
    #[test]
    fn a_triangles_cone_holds_its_normal_over_the_step() {
        let mut rng = StdRng::seed_from_u64(9);
        let mut bounded = 0;
        for _ in 0..500 {
            let x0: [Vec3; 3] = std::array::from_fn(|_| random_unit(&mut rng));
            let x1: [Vec3; 3] = std::array::from_fn(|k| x0[k] + random_unit(&mut rng) * 0.4);
            let c = Cone::of_triangle([&x0[0], &x0[1], &x0[2]], [&x1[0], &x1[1], &x1[2]]);
            bounded += usize::from(c.is_flat());
            for s in 0..=100 {
                let t = s as Real / 100.0;
                let x: Vec<Vec3> = (0..3).map(|k| x0[k] + (x1[k] - x0[k]) * t).collect();
                let n = (x[1] - x[0]).cross(&(x[2] - x[0]));
                if n.norm() > 1e-9 {
                    assert!(holds(&c, &n), "t {t}: {c:?} misses {n:?}");
                }
            }
        }
        assert!(bounded > 100, "only {bounded} of 500 cones bounded");
    }

    /// A turning triangle's cone holds its normal under random changes
    /// of its corners whose differences stay within the bound.
    #[test]
    fn a_turning_triangles_cone_holds_every_normal_within_its_bound() {
        let mut rng = StdRng::seed_from_u64(5);
        let mut bounded = 0;
        for _ in 0..500 {
            let x: [Vec3; 3] = std::array::from_fn(|_| random_unit(&mut rng));
            let bend = rng.random_range(0.0..0.3);
            let c = Cone::of_turning_triangle([&x[0], &x[1], &x[2]], bend);
            bounded += usize::from(c.is_flat());
            for _ in 0..50 {
                // Corner 0 moves anywhere; the others so that each edge
                // vector from corner 0 changes by at most `bend`.
                let d0 = random_unit(&mut rng) * rng.random_range(0.0..2.0);
                let y: Vec<Vec3> = (0..3)
                    .map(|k| {
                        let own = if k == 0 {
                            Vec3::zeros()
                        } else {
                            random_unit(&mut rng) * (bend * rng.random_range(0.0..1.0))
                        };
                        x[k] + d0 + own
                    })
                    .collect();
                let n = (y[1] - y[0]).cross(&(y[2] - y[0]));
                if n.norm() > 1e-9 {
                    assert!(holds(&c, &n), "bend {bend}: {c:?} misses {n:?}");
                }
            }
        }
        assert!(bounded > 100, "only {bounded} of 500 cones bounded");
    }

    /// A static flat patch has a cone of zero width; a zero-area triangle
    /// bounds nothing.
    #[test]
    fn flat_and_degenerate_triangles() {
        let (a, b, c) = (Vec3::zeros(), Vec3::x(), Vec3::y());
        let flat = Cone::of_triangle([&a, &b, &c], [&a, &b, &c]);
        assert!(flat.cos > 1.0 - 1e-15 && flat.is_flat());
        let line = Cone::of_triangle([&a, &b, &(b * 2.0)], [&a, &b, &(b * 2.0)]);
        assert_eq!(line, Cone::WHOLE);
        assert!(!line.is_flat());
    }
}
