//! Mesh input formats: Wavefront OBJ (through `tobj`) and STL, binary or
//! ASCII, as base64 (through `stl_io`). Both end in [`TriMesh::new`], so
//! every format gets the same checks.

use std::io::Cursor;

use base64::Engine;

use super::trimesh::{MeshError, TriMesh};
use crate::math::Vec3;
use crate::spec::MeshSource;

/// The mesh a spec's `mesh` object describes (OBJ, STL or inline arrays).
pub fn from_source(source: &MeshSource) -> Result<TriMesh, MeshError> {
    if let Some(text) = &source.obj {
        return from_obj(text);
    }
    if let Some(data) = &source.stl {
        return from_stl_base64(data);
    }
    let vertices = source.vertices.as_deref().unwrap_or_default();
    let triangles = source.triangles.clone().unwrap_or_default();
    TriMesh::new(vertices.iter().map(|v| Vec3::from(*v)).collect(), triangles)
}

/// Parses OBJ text; polygons are triangulated, every object and group is
/// merged into one mesh, materials are ignored.
pub fn from_obj(text: &str) -> Result<TriMesh, MeshError> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    // NOTE: a spec carries no material files; a `mtllib` line loads nothing.
    let (models, _) = tobj::load_obj_buf(&mut Cursor::new(text.as_bytes()), &options, |_| {
        Ok(Default::default())
    })
    .map_err(|e| MeshError(format!("is not valid OBJ: {e}")))?;
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let base = vertices.len() as u32;
        vertices.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        triangles.extend(
            m.indices
                .chunks_exact(3)
                .map(|t| [base + t[0], base + t[1], base + t[2]]),
        );
    }
    TriMesh::new(vertices, triangles)
}

/// Decodes base64 and parses STL (binary or ASCII); shared corners are
/// merged by the parser.
pub fn from_stl_base64(data: &str) -> Result<TriMesh, MeshError> {
    let compact: String = data.chars().filter(|c| !c.is_whitespace()).collect();
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(compact)
        .map_err(|e| MeshError(format!("is not valid base64: {e}")))?;
    let mesh = stl_io::read_stl(&mut Cursor::new(bytes))
        .map_err(|e| MeshError(format!("is not valid STL: {e}")))?;
    let vertices = mesh
        .vertices
        .iter()
        .map(|v| Vec3::new(v.0[0].into(), v.0[1].into(), v.0[2].into()))
        .collect();
    let mut triangles = Vec::with_capacity(mesh.faces.len());
    for f in &mesh.faces {
        let t = f.vertices.map(|i| u32::try_from(i).unwrap_or(u32::MAX));
        triangles.push(t);
    }
    TriMesh::new(vertices, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TETRA_OBJ: &str =
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

    #[test]
    fn obj_tetrahedron_loads() {
        let m = from_obj(TETRA_OBJ).expect("valid OBJ");
        assert_eq!(m.vertices().len(), 4);
        assert_eq!(m.triangles().len(), 4);
        // Outward: the face on z = 0 points down.
        assert!((m.face_normal(0) - Vec3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
    }

    #[test]
    fn obj_quads_are_triangulated_and_errors_are_clear() {
        let quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
        assert_eq!(from_obj(quad).expect("quad").triangles().len(), 2);
        assert!(from_obj("v 0 0 0\nf 1 2 3\n").is_err());
        assert!(from_obj("").expect_err("empty").0.contains("no"));
    }

    #[test]
    fn stl_ascii_and_binary_load() {
        let ascii = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
        let b64 = base64::engine::general_purpose::STANDARD.encode(ascii);
        let m = from_stl_base64(&b64).expect("ascii stl");
        assert_eq!(m.triangles().len(), 1);

        let mut bin = vec![0u8; 80];
        bin.extend(1u32.to_le_bytes());
        for f in [
            0.0f32, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0,
        ] {
            bin.extend(f.to_le_bytes());
        }
        bin.extend([0u8, 0]);
        let b64 = base64::engine::general_purpose::STANDARD.encode(&bin);
        let m = from_stl_base64(&b64).expect("binary stl");
        assert_eq!(m.face_normal(0), Vec3::z());

        assert!(
            from_stl_base64("not base64!")
                .expect_err("bad")
                .0
                .contains("base64")
        );
        let junk = base64::engine::general_purpose::STANDARD.encode([1u8, 2, 3]);
        assert!(from_stl_base64(&junk).is_err());
    }
}
