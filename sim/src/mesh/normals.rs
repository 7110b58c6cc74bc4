//! Angle-weighted vertex normals (Thürmer and Wüthrich; Bærentzen and
//! Aanæs): each face adds its normal times its corner angle at the vertex.
//! Unlike area or uniform weights they depend only on the surface, not on
//! how it was triangulated, and they are the pseudo-normals that make the
//! sign of a nearest-point distance reliable at vertices.

use std::collections::HashMap;

use super::edges::faces_by_edge;
use super::trimesh::TriMesh;
use crate::math::Vec3;

/// One unit normal per vertex.
pub fn angle_weighted_normals(mesh: &TriMesh) -> Vec<Vec3> {
    let mut acc = vec![Vec3::zeros(); mesh.vertices().len()];
    for (k, t) in mesh.triangles().iter().enumerate() {
        let n = mesh.face_normal(k);
        let p = mesh.corners(k);
        for c in 0..3 {
            let e1 = p[(c + 1) % 3] - p[c];
            let e2 = p[(c + 2) % 3] - p[c];
            let angle = e1.angle(&e2);
            acc[t[c] as usize] += n * angle;
        }
    }
    acc.into_iter()
        .map(|n| n.try_normalize(0.0).unwrap_or_else(Vec3::z))
        .collect()
}

/// For every edge (as a sorted vertex pair) the faces that use it.
pub fn edge_faces(mesh: &TriMesh) -> HashMap<(u32, u32), Vec<u32>> {
    faces_by_edge(mesh.triangles())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::tessellate_box;

    #[test]
    fn cube_corner_normals_point_along_the_diagonal() {
        // Whatever the triangulation of the faces, a cube corner's
        // angle-weighted normal is the diagonal (each face contributes
        // a right angle).
        let m = tessellate_box(Vec3::zeros(), Vec3::repeat(2.0), 0.7).expect("tessellates");
        let normals = angle_weighted_normals(&m);
        for (v, n) in m.vertices().iter().zip(&normals) {
            if v.iter().all(|c| (c.abs() - 1.0).abs() < 1e-12) {
                let diag = v.normalize();
                assert!((n - diag).norm() < 1e-12, "{v:?}: {n:?}");
            }
        }
        // Every edge of a closed mesh has two faces.
        assert!(edge_faces(&m).values().all(|f| f.len() == 2));
    }
}
