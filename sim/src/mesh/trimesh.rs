//! [`TriMesh`]: vertices and triangles that passed every check.

use super::orient::orient;
use crate::math::{Real, Vec3};

/// Largest coordinate magnitude a mesh may have, in metres: beyond this a
/// mesh is in the wrong units or corrupt, and `f64` geometry predicates
/// lose the digits contact needs.
const MAX_COORD: Real = 1.0e6;
/// A triangle whose area is below this fraction of the squared bounding
/// box diagonal has no usable normal.
const DEGENERATE_AREA: Real = 1.0e-14;

/// Why a mesh was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct MeshError(pub String);

/// A triangle mesh with finite vertices, in-range indices, no degenerate
/// triangles and windings that agree (`super::orient`); only
/// [`TriMesh::new`] makes one.
#[derive(Debug, Clone, PartialEq)]
pub struct TriMesh {
    vertices: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Checks and wraps `vertices` and `triangles` (zero-based indices,
    /// counter-clockwise seen from outside, or made so: triangles of no
    /// area are left out and windings turned by `super::orient`).
    pub fn new(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Self, MeshError> {
        if vertices.is_empty() {
            return Err(MeshError("has no vertices".into()));
        }
        if triangles.is_empty() {
            return Err(MeshError("has no triangles".into()));
        }
        for (k, v) in vertices.iter().enumerate() {
            if !v.iter().all(|c| c.is_finite()) {
                return Err(MeshError(format!("vertex {k} is not finite")));
            }
            if v.amax() > MAX_COORD {
                return Err(MeshError(format!(
                    "vertex {k} lies {:.3e} m from the origin, beyond {MAX_COORD:e} m",
                    v.amax()
                )));
            }
        }
        let n = vertices.len();
        for (k, t) in triangles.iter().enumerate() {
            if let Some(&i) = t.iter().find(|&&i| i as usize >= n) {
                return Err(MeshError(format!(
                    "triangle {k} uses vertex {i}, out of range ({n} vertices)"
                )));
            }
        }
        // A triangle of no area covers nothing and has no normal: left
        // out, not a reason to refuse the mesh (exporters leave slivers).
        let mut mesh = Self {
            vertices,
            triangles: Vec::new(),
        };
        let (lo, hi) = mesh.bounds();
        let least = DEGENERATE_AREA * (hi - lo).norm_squared();
        let given = triangles.len();
        mesh.triangles = triangles
            .into_iter()
            .filter(|t| {
                let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
                (b - a).cross(&(c - a)).norm() > least
            })
            .collect();
        if mesh.triangles.is_empty() {
            return Err(MeshError(format!(
                "has no triangle of non-zero area ({given} given)"
            )));
        }
        let turned = orient(&mesh.vertices, &mut mesh.triangles);
        if mesh.triangles.len() < given || turned.triangles > 0 {
            tracing::warn!(
                degenerate = given - mesh.triangles.len(),
                rewound = turned.triangles,
                inward_parts = turned.inward_parts,
                "obstacle mesh repaired: triangles of no area left out, windings made to agree and face outward"
            );
        }
        Ok(mesh)
    }

    /// Vertex positions.
    pub fn vertices(&self) -> &[Vec3] {
        &self.vertices
    }

    /// Triangles as vertex indices.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// The three corners of triangle `k`.
    #[inline]
    pub fn corners(&self, k: usize) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[k];
        [
            self.vertices[a as usize],
            self.vertices[b as usize],
            self.vertices[c as usize],
        ]
    }

    /// `|(b - a) x (c - a)|`, twice the area of triangle `k`.
    pub fn double_area(&self, k: usize) -> Real {
        let [a, b, c] = self.corners(k);
        (b - a).cross(&(c - a)).norm()
    }

    /// Unit normal of triangle `k` (right-handed in its vertex order).
    pub fn face_normal(&self, k: usize) -> Vec3 {
        let [a, b, c] = self.corners(k);
        (b - a).cross(&(c - a)).normalize()
    }

    /// Axis-aligned bounds `(min, max)`.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.vertices.iter().fold(
            (
                Vec3::repeat(Real::INFINITY),
                Vec3::repeat(Real::NEG_INFINITY),
            ),
            |(lo, hi), v| (lo.inf(v), hi.sup(v)),
        )
    }

    /// The triangles wound the other way on moved vertices (the back
    /// offset of a shell); the caller keeps the count.
    pub fn reversed_with_vertices(&self, vertices: Vec<Vec3>) -> Self {
        assert_eq!(vertices.len(), self.vertices.len());
        Self {
            vertices,
            triangles: self.triangles.iter().map(|t| [t[0], t[2], t[1]]).collect(),
        }
    }

    /// The same triangles on moved vertices (the offset surface); the
    /// caller keeps the count.
    pub fn with_vertices(&self, vertices: Vec<Vec3>) -> Self {
        assert_eq!(vertices.len(), self.vertices.len());
        Self {
            vertices,
            triangles: self.triangles.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        (vec![Vec3::zeros(), Vec3::x(), Vec3::y()], vec![[0, 1, 2]])
    }

    #[test]
    fn accepts_a_triangle_and_reports_its_normal() {
        let (v, t) = tri();
        let m = TriMesh::new(v, t).expect("valid");
        assert_eq!(m.face_normal(0), Vec3::z());
        assert!((m.double_area(0) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn triangles_of_no_area_are_left_out() {
        let (mut v, _) = tri();
        v.push(Vec3::x() * 2.0);
        let m = TriMesh::new(v, vec![[0, 1, 1], [0, 1, 3], [0, 1, 2]]).expect("one is usable");
        assert_eq!(m.triangles(), &[[0, 1, 2]]);
    }

    #[test]
    fn refuses_bad_meshes_with_a_message() {
        let msg = |v: Vec<Vec3>, t: Vec<[u32; 3]>| TriMesh::new(v, t).expect_err("refused").0;
        let (v, _) = tri();
        assert!(msg(v.clone(), vec![]).contains("no triangles"));
        assert!(msg(vec![], vec![[0, 1, 2]]).contains("no vertices"));
        assert!(msg(v.clone(), vec![[0, 1, 3]]).contains("out of range"));
        assert!(msg(v.clone(), vec![[0, 1, 1]]).contains("no triangle of non-zero area"));
        let collinear = vec![Vec3::zeros(), Vec3::x(), Vec3::x() * 2.0];
        assert!(msg(collinear, vec![[0, 1, 2]]).contains("no triangle of non-zero area"));
        let mut nan = v.clone();
        nan[1].x = Real::NAN;
        assert!(msg(nan, vec![[0, 1, 2]]).contains("not finite"));
        let mut huge = v;
        huge[2].y = 1e9;
        assert!(msg(huge, vec![[0, 1, 2]]).contains("beyond"));
    }
}
