//! An obstacle's sharp features in its own frame: the corners and edges
//! that a cloth edge or triangle can wrap around or be pierced by between
//! its particles (method.md §3 tests particles only, and widens the
//! offset to cover these; `sim::sharp` tests them directly instead, so
//! the offset shrinks to its margin).
//!
//! A box has its 8 corners and 12 edges; a cylinder its two rims, as
//! polygons around them; a mesh its sharp convex edges and rims
//! (`mesh::sharp_edges`) with their ends. Spheres and planes have none.

use super::analytic::Primitive;
use crate::math::{Real, Vec3};
use crate::mesh::frame_of;
use crate::mesh::{TriMesh, sharp_edges};

/// Corners and edges of the true (not offset) surface.
#[derive(Debug, Clone, PartialEq)]
pub struct Features {
    /// Corner points: every end of an edge.
    pub points: Vec<Vec3>,
    /// Edges as pairs of indices into `points`.
    pub edges: Vec<[u32; 2]>,
}

impl Features {
    /// The features of an exact primitive, or `None` for a smooth one;
    /// `offset` is the primitive's collision offset (it sets how finely a
    /// cylinder's rims are traced).
    pub fn of_primitive(p: &Primitive, offset: Real) -> Option<Self> {
        if let Primitive::Cylinder {
            center,
            axis,
            radius,
            half,
        } = p
        {
            return Some(Self::of_rims(*center, *axis, *radius, *half, offset));
        }
        let Primitive::Box { center, half } = p else {
            return None;
        };
        // Corner k has coordinate signs from the bits of k.
        let points = (0..8)
            .map(|k: u32| {
                let sign = |bit: u32| if k & (1 << bit) == 0 { -1.0 } else { 1.0 };
                center + Vec3::new(sign(0) * half.x, sign(1) * half.y, sign(2) * half.z)
            })
            .collect();
        // Corners differing in one bit share an edge.
        let edges = (0..8u32)
            .flat_map(|k| (0..3).map(move |bit| [k, k | (1 << bit)]))
            .filter(|[a, b]| a != b)
            .collect();
        Some(Self { points, edges })
    }

    /// A cylinder's rims as polygons circumscribed about them, so no point
    /// of a polygon is inside the cylinder, with sides short enough that
    /// their corners stand out from the rim by at most a twentieth of the
    /// offset (`r (1/cos(π/n) - 1) <= offset/20`, a tenth of what the cloth
    /// keeps from features; between 8 and 1024 sides).
    fn of_rims(center: Vec3, axis: Vec3, radius: Real, half: Real, offset: Real) -> Self {
        let out = 1.0 + 0.05 * offset / radius;
        let sides = if out > 1.0 {
            (std::f64::consts::PI / (1.0 / out).acos()).ceil()
        } else {
            1024.0
        };
        let sides = sides.clamp(8.0, 1024.0) as u32;
        let (u, v) = frame_of(&axis);
        let reach = radius / (std::f64::consts::PI / Real::from(sides)).cos();
        let mut points = Vec::with_capacity(2 * sides as usize);
        let mut edges = Vec::with_capacity(2 * sides as usize);
        for (rim, end) in [-half, half].into_iter().enumerate() {
            let base = rim as u32 * sides;
            for k in 0..sides {
                let a = std::f64::consts::TAU * Real::from(k) / Real::from(sides);
                points.push(center + axis * end + (u * a.cos() + v * a.sin()) * reach);
                edges.push([base + k, base + (k + 1) % sides]);
            }
        }
        Self { points, edges }
    }

    /// The sharp edges of a mesh and their ends, or `None` if it has none.
    pub fn of_mesh(mesh: &TriMesh) -> Option<Self> {
        let sharp = sharp_edges(mesh);
        if sharp.is_empty() {
            return None;
        }
        let mut index = vec![u32::MAX; mesh.vertices().len()];
        let mut points = Vec::new();
        let edges = sharp
            .iter()
            .map(|e| {
                e.map(|v| {
                    let slot = &mut index[v as usize];
                    if *slot == u32::MAX {
                        *slot = points.len() as u32;
                        points.push(mesh.vertices()[v as usize]);
                    }
                    *slot
                })
            })
            .collect();
        Some(Self { points, edges })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::tessellate_box;

    #[test]
    fn a_box_has_eight_corners_and_twelve_edges_of_its_sides() {
        let half = Vec3::new(0.5, 0.25, 0.1);
        let f = Features::of_primitive(
            &Primitive::Box {
                center: Vec3::z(),
                half,
            },
            1e-3,
        )
        .expect("a box has features");
        assert_eq!(f.points.len(), 8);
        assert_eq!(f.edges.len(), 12);
        let mut lengths: Vec<Real> = f
            .edges
            .iter()
            .map(|&[a, b]| (f.points[a as usize] - f.points[b as usize]).norm())
            .collect();
        lengths.sort_by(Real::total_cmp);
        for (k, want) in [0.2, 0.5, 1.0].iter().enumerate() {
            assert!(
                lengths[4 * k..4 * k + 4]
                    .iter()
                    .all(|l| (l - want).abs() < 1e-15)
            );
        }
        let sphere = Primitive::Sphere {
            center: Vec3::zeros(),
            radius: 1.0,
        };
        assert!(Features::of_primitive(&sphere, 1e-3).is_none());
    }

    #[test]
    fn a_cylinders_rims_are_traced_outside_it_within_a_twentieth_of_the_offset() {
        let (radius, offset) = (0.2, 2e-3);
        let f = Features::of_primitive(
            &Primitive::Cylinder {
                center: Vec3::zeros(),
                axis: Vec3::new(1.0, 1.0, 0.0).normalize(),
                radius,
                half: 0.3,
            },
            offset,
        )
        .expect("rims");
        assert_eq!(f.points.len(), f.edges.len());
        let axis = Vec3::new(1.0, 1.0, 0.0).normalize();
        for &[a, b] in &f.edges {
            let (p, q) = (f.points[a as usize], f.points[b as usize]);
            // Both ends on one rim plane, and the side's midpoint (nearest
            // the axis) on the rim or outside it.
            assert!((p.dot(&axis) - q.dot(&axis)).abs() < 1e-12);
            let mid = (p + q) / 2.0;
            let r = (mid - axis * mid.dot(&axis)).norm();
            assert!(r >= radius * (1.0 - 1e-12), "{r}");
            let corner = (p - axis * p.dot(&axis)).norm();
            assert!(corner - radius <= 0.05 * offset, "{corner}");
        }
    }

    #[test]
    fn a_box_mesh_has_its_edges_as_features_and_nothing_of_its_faces() {
        let mesh = tessellate_box(Vec3::zeros(), Vec3::repeat(1.0), 0.5).expect("tessellates");
        let f = Features::of_mesh(&mesh).expect("sharp");
        assert_eq!(f.edges.len(), 24, "12 edges in 2 segments");
        // Every point lies on two faces of the cube at least (on an edge).
        for p in &f.points {
            let on_face = p.iter().filter(|c| (c.abs() - 0.5).abs() < 1e-12).count();
            assert!(on_face >= 2, "{p:?}");
        }
        assert_eq!(f.points.len(), 8 + 12);
    }
}
