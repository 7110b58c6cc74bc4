//! Primitives handled exactly: sphere, box, plane and capped cylinder by
//! their signed distance functions. The offset surface is then the exact
//! Minkowski offset `{sdf = delta}` (edges rounded by `delta`), with no
//! tessellation error — a sphere stays a sphere.
//!
//! The continuous test is conservative advancement along the segment:
//! with `f(t) = sdf(Q(t)) - delta` and `|∇sdf| = 1`, a step of
//! `f(t) / |b - a|` cannot pass the surface, so the first root is found
//! without missing thin features of the path.

use super::aabb::Aabb;
use super::surface::{Hit, Projection, Surface};
use crate::math::{Real, Vec3};
use crate::mesh::{Curvature, default_offset};
use crate::spec::Obstacle;

/// Iterations of conservative advancement before a grazing path is
/// settled by its end point.
const MAX_ADVANCE: usize = 64;

/// An exact primitive in its own frame.
#[derive(Debug, Clone, PartialEq)]
pub enum Primitive {
    /// Centre and radius.
    Sphere { center: Vec3, radius: Real },
    /// Centre and half extents.
    Box { center: Vec3, half: Vec3 },
    /// A point and the unit outward normal.
    Plane { point: Vec3, normal: Vec3 },
    /// Centre, unit axis, radius, half height.
    Cylinder {
        center: Vec3,
        axis: Vec3,
        radius: Real,
        half: Real,
    },
}

impl Primitive {
    /// The primitive of a validated obstacle, or `None` for a mesh.
    pub fn of(o: &Obstacle) -> Option<Self> {
        if let Some(s) = &o.sphere {
            return Some(Self::Sphere {
                center: s.center.into(),
                radius: s.radius,
            });
        }
        if let Some(b) = &o.box_ {
            return Some(Self::Box {
                center: b.center.into(),
                half: Vec3::from(b.size) / 2.0,
            });
        }
        if let Some(p) = &o.plane {
            return Some(Self::Plane {
                point: p.point.into(),
                normal: Vec3::from(p.normal).normalize(),
            });
        }
        o.cylinder.as_ref().map(|c| Self::Cylinder {
            center: c.center.into(),
            axis: Vec3::from(c.axis).normalize(),
            radius: c.radius,
            half: c.height / 2.0,
        })
    }

    /// What sets the default offset (see `mesh::offset`).
    pub fn curvature(&self) -> Curvature {
        match self {
            Self::Sphere { radius, .. } => Curvature::Smooth(*radius),
            // A box's edges and corners are tested directly
            // (`super::Features`): its faces are flat.
            Self::Plane { .. } | Self::Box { .. } => Curvature::Flat,
            // Its rims are features too; its side is curved.
            Self::Cylinder { radius, .. } => Curvature::Smooth(*radius),
        }
    }

    /// Signed distance to the true surface and its gradient (the outward
    /// unit normal of the nearest surface point).
    pub fn sdf(&self, p: &Vec3) -> (Real, Vec3) {
        match self {
            Self::Sphere { center, radius } => {
                let d = p - center;
                let r = d.norm();
                let n = if r > 0.0 { d / r } else { Vec3::z() };
                (r - radius, n)
            }
            Self::Plane { point, normal } => (normal.dot(&(p - point)), *normal),
            Self::Box { center, half } => {
                let d = p - center;
                let q = d.abs() - half;
                let sign = d.map(|c| if c < 0.0 { -1.0 } else { 1.0 });
                let out = q.sup(&Vec3::zeros());
                let o = out.norm();
                if o > 0.0 {
                    (o, out.component_mul(&sign) / o)
                } else {
                    let k = q.imax();
                    let mut n = Vec3::zeros();
                    n[k] = sign[k];
                    (q[k], n)
                }
            }
            Self::Cylinder {
                center,
                axis,
                radius,
                half,
            } => {
                let d = p - center;
                let z = axis.dot(&d);
                let radial = d - axis * z;
                let r = radial.norm();
                let er = if r > 0.0 {
                    radial / r
                } else {
                    crate::mesh::frame_of(axis).0
                };
                let ez = if z < 0.0 { -axis } else { *axis };
                let (qx, qz) = (r - radius, z.abs() - half);
                if qx > 0.0 && qz > 0.0 {
                    let o = (qx * qx + qz * qz).sqrt();
                    (o, (er * qx + ez * qz) / o)
                } else if qx > qz {
                    (qx, er)
                } else {
                    (qz, ez)
                }
            }
        }
    }
}

/// An exact primitive with its offset.
#[derive(Debug, Clone, PartialEq)]
pub struct Analytic {
    shape: Primitive,
    delta: Real,
}

impl Analytic {
    /// The primitive with offset `delta`, or the default for `spacing`.
    pub fn new(shape: Primitive, delta: Option<Real>, spacing: Real) -> Self {
        let delta = delta.unwrap_or_else(|| default_offset(spacing, shape.curvature()));
        Self { shape, delta }
    }

    /// The primitive.
    pub fn shape(&self) -> &Primitive {
        &self.shape
    }
}

impl Surface for Analytic {
    fn bounds(&self) -> Aabb {
        let r = self.delta;
        match &self.shape {
            Primitive::Sphere { center, radius } => Aabb {
                lo: *center,
                hi: *center,
            }
            .grown(radius + r),
            Primitive::Box { center, half } => Aabb {
                lo: center - half,
                hi: center + half,
            }
            .grown(r),
            Primitive::Cylinder {
                center,
                axis,
                radius,
                half,
            } => {
                let ext = Vec3::from_fn(|k, _| {
                    axis[k].abs() * (half + r)
                        + (radius + r) * (1.0 - axis[k] * axis[k]).max(0.0).sqrt()
                });
                Aabb {
                    lo: center - ext,
                    hi: center + ext,
                }
            }
            Primitive::Plane { point, normal } => {
                // The solid is the half-space behind the plane: bounded only
                // along an axis the normal is aligned with.
                let mut b = Aabb {
                    lo: Vec3::repeat(Real::NEG_INFINITY),
                    hi: Vec3::repeat(Real::INFINITY),
                };
                for k in 0..3 {
                    if (normal[k].abs() - 1.0).abs() < 1e-12 {
                        if normal[k] > 0.0 {
                            b.hi[k] = point[k] + r;
                        } else {
                            b.lo[k] = point[k] - r;
                        }
                    }
                }
                b
            }
        }
    }

    fn offset(&self) -> Real {
        self.delta
    }

    fn first_hit(&self, a: &Vec3, b: &Vec3, _nodes: &mut u64) -> Option<Hit> {
        let d = b - a;
        let len = d.norm();
        let tol = 1e-10 + 1e-7 * self.delta;
        let (f0, n0) = self.sdf_offset(a);
        if f0 < -tol {
            return None; // already inside: the caller projects it out
        }
        if len == 0.0 {
            return None;
        }
        let mut t = 0.0;
        let mut f = f0;
        let mut n = n0;
        for _ in 0..MAX_ADVANCE {
            if f <= tol {
                // At the surface: a hit only if the path goes in.
                if n.dot(&d) >= 0.0 && t == 0.0 {
                    return None;
                }
                let q = a + d * t;
                return Some(Hit {
                    t,
                    point: q - n * f,
                    normal: n,
                });
            }
            t += f / len;
            if t > 1.0 {
                return None;
            }
            (f, n) = self.sdf_offset(&(a + d * t));
        }
        // A grazing path: it crosses only if it ends inside.
        let (fb, nb) = self.sdf_offset(b);
        (fb < 0.0).then(|| Hit {
            t,
            point: a + d * t - nb * f,
            normal: n,
        })
    }

    fn project(&self, p: &Vec3, _nodes: &mut u64) -> Projection {
        let (f, n) = self.sdf_offset(p);
        Projection {
            point: p - n * f,
            normal: n,
            distance: f,
        }
    }

    fn true_distance(&self, p: &Vec3, _nodes: &mut u64) -> Real {
        self.shape.sdf(p).0
    }
}

impl Analytic {
    /// Signed distance to the offset surface and the outward normal.
    #[inline]
    fn sdf_offset(&self, p: &Vec3) -> (Real, Vec3) {
        let (d, n) = self.shape.sdf(p);
        (d - self.delta, n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shapes() -> Vec<Primitive> {
        vec![
            Primitive::Sphere {
                center: Vec3::new(0.1, 0.0, 0.0),
                radius: 0.5,
            },
            Primitive::Box {
                center: Vec3::zeros(),
                half: Vec3::new(0.5, 0.3, 0.2),
            },
            Primitive::Plane {
                point: Vec3::zeros(),
                normal: Vec3::new(0.0, 0.6, 0.8),
            },
            Primitive::Cylinder {
                center: Vec3::zeros(),
                axis: Vec3::new(0.0, 0.6, 0.8),
                radius: 0.3,
                half: 0.4,
            },
        ]
    }

    #[test]
    fn sdf_gradient_is_unit_and_matches_finite_differences() {
        for s in shapes() {
            for k in 0..200 {
                let p = Vec3::new(
                    (k as Real * 0.37).sin(),
                    (k as Real * 0.71).cos(),
                    (k as Real * 0.13).sin(),
                ) * 0.9;
                let (d, n) = s.sdf(&p);
                assert!((n.norm() - 1.0).abs() < 1e-12);
                let eps = 1e-6;
                let fd = Vec3::from_fn(|i, _| {
                    let mut e = Vec3::zeros();
                    e[i] = eps;
                    (s.sdf(&(p + e)).0 - s.sdf(&(p - e)).0) / (2.0 * eps)
                });
                // Away from the medial axis (where the gradient jumps).
                if (fd.norm() - 1.0).abs() < 1e-3 {
                    assert!((fd - n).norm() < 1e-4, "{s:?} at {p:?}: {fd:?} vs {n:?}");
                }
                // The projection lands on the surface.
                let q = p - n * d;
                assert!(s.sdf(&q).0.abs() < 1e-9, "{s:?}");
            }
        }
    }

    #[test]
    fn continuous_test_finds_the_first_crossing_of_the_offset() {
        let sphere = Analytic::new(
            Primitive::Sphere {
                center: Vec3::zeros(),
                radius: 1.0,
            },
            Some(0.1),
            0.1,
        );
        let mut nodes = 0;
        let h = sphere
            .first_hit(
                &Vec3::new(0.0, 0.0, 3.0),
                &Vec3::new(0.0, 0.0, -3.0),
                &mut nodes,
            )
            .expect("hit");
        assert!((h.point - Vec3::new(0.0, 0.0, 1.1)).norm() < 1e-8);
        assert!((h.t - 1.9 / 6.0).abs() < 1e-8);
        // Grazing past at 1.2 > 1.1: no hit; ending short: no hit.
        assert!(
            sphere
                .first_hit(
                    &Vec3::new(-3.0, 0.0, 1.2),
                    &Vec3::new(3.0, 0.0, 1.2),
                    &mut nodes
                )
                .is_none()
        );
        assert!(
            sphere
                .first_hit(
                    &Vec3::new(0.0, 0.0, 3.0),
                    &Vec3::new(0.0, 0.0, 1.2),
                    &mut nodes
                )
                .is_none()
        );
        // A thin box passed through in one step (tunnelling) is caught.
        let blade = Analytic::new(
            Primitive::Box {
                center: Vec3::zeros(),
                half: Vec3::new(1.0, 1.0, 0.001),
            },
            Some(0.0),
            0.1,
        );
        let h = blade
            .first_hit(
                &Vec3::new(0.2, 0.1, 1.0),
                &Vec3::new(0.2, 0.1, -1.0),
                &mut nodes,
            )
            .expect("blade");
        assert!((h.point.z - 0.001).abs() < 1e-8 && h.normal == Vec3::z());
        // Leaving the surface is not a hit.
        assert!(
            sphere
                .first_hit(
                    &Vec3::new(0.0, 0.0, 1.1),
                    &Vec3::new(0.0, 0.0, 2.0),
                    &mut nodes
                )
                .is_none()
        );
    }
}
