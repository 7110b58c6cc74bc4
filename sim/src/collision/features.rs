//! An obstacle's sharp features in its own frame: the corners and edges
//! that a cloth edge or triangle can wrap around or be pierced by between
//! its particles (method.md §3 tests particles only, and widens the
//! offset to cover these; `sim::sharp` tests them directly instead, so
//! the offset shrinks to its margin).
//!
//! A box has its 8 corners and 12 edges; a mesh its sharp convex edges
//! and rims (`mesh::sharp_edges`) with their ends. Spheres and planes
//! have none, and a cylinder's rims are still covered by its offset.

use super::analytic::Primitive;
use crate::math::{Real, Vec3};
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
    /// The features of an exact primitive, or `None` when the default
    /// offset still covers its shape.
    pub fn of_primitive(p: &Primitive) -> Option<Self> {
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

    /// The longest edge: how far apart the feature points may be.
    pub fn longest_edge(&self) -> Real {
        self.edges
            .iter()
            .map(|&[a, b]| (self.points[a as usize] - self.points[b as usize]).norm())
            .fold(0.0, Real::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::tessellate_box;

    #[test]
    fn a_box_has_eight_corners_and_twelve_edges_of_its_sides() {
        let half = Vec3::new(0.5, 0.25, 0.1);
        let f = Features::of_primitive(&Primitive::Box {
            center: Vec3::z(),
            half,
        })
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
        assert!(Features::of_primitive(&sphere).is_none());
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
