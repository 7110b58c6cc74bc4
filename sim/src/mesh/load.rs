//! Mesh input formats: Wavefront OBJ (through `tobj`) and STL, binary or
//! ASCII, as base64 (through `stl_io`). Both end in [`TriMesh::new`], so
//! every format gets the same checks.

use std::io::Cursor;

use base64::Engine;

use super::polygon;
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

/// How many triangles the faces of OBJ `text` are cut into, counted from
/// its `f` lines without parsing it: a face of `n` corners gives `n - 2`.
/// What validation bounds before [`from_obj`] builds anything.
pub fn obj_triangles(text: &str) -> usize {
    text.lines()
        .filter_map(|l| l.trim_start().strip_prefix('f'))
        .filter(|rest| rest.starts_with([' ', '\t']))
        .map(|rest| rest.split_whitespace().count().saturating_sub(2))
        .sum()
}

/// Parses OBJ text; polygons are cut into triangles that cover them
/// exactly, concave ones too (`polygon`), every object and group is
/// merged into one mesh, materials are ignored.
pub fn from_obj(text: &str) -> Result<TriMesh, MeshError> {
    let options = tobj::LoadOptions {
        // NOTE: tobj triangulates as a fan, which covers a concave face's
        // notch; the faces come whole and `polygon` cuts them.
        triangulate: false,
        single_index: true,
        ..Default::default()
    };
    // NOTE: a spec carries no material files; a `mtllib` line loads nothing.
    let (models, _) = tobj::load_obj_buf(&mut Cursor::new(text.as_bytes()), &options, |_| {
        Ok(Default::default())
    })
    .map_err(|e| MeshError(format!("is not valid OBJ: {e}")))?;
    if models.iter().all(|m| m.mesh.indices.is_empty())
        && text.lines().any(|l| l.trim_start().starts_with("v "))
    {
        // tobj keeps only the vertices that faces use.
        return Err(MeshError("has vertices but no faces (`f` lines)".into()));
    }
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
        if m.face_arities.is_empty() {
            // Triangles only.
            triangles.extend(
                m.indices
                    .chunks_exact(3)
                    .map(|t| [base + t[0], base + t[1], base + t[2]]),
            );
            continue;
        }
        let (mut start, mut cut) = (0, Vec::new());
        for &arity in &m.face_arities {
            let face = &m.indices[start..start + arity as usize];
            start += arity as usize;
            let corners = face
                .iter()
                .map(|&i| vertices.get((base + i) as usize).copied())
                .collect::<Option<Vec<Vec3>>>()
                .ok_or_else(|| MeshError("has a face with a vertex index out of range".into()))?;
            cut.clear();
            polygon::triangulate(&corners, &mut cut);
            triangles.extend(cut.iter().map(|t| t.map(|k| base + face[k])));
        }
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

    /// The count validation bounds before parsing is what parsing gives.
    #[test]
    fn obj_triangles_counts_what_faces_are_cut_into() {
        assert_eq!(
            obj_triangles(TETRA_OBJ),
            from_obj(TETRA_OBJ).expect("tetra").triangles().len()
        );
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 1.5 0\n\
                    f 1 2 3\n  f\t1 2 3 4\nf 1 2 5 3 4\nfo 1 2 3\n# f 1 2 3\nf 1\n";
        assert_eq!(obj_triangles(text), 1 + 2 + 3);
    }

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
        assert!(from_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3 9\n").is_err());
        assert!(from_obj("").expect_err("empty").0.contains("no"));
        let points = from_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\n").expect_err("no faces");
        assert!(points.0.contains("no faces"), "{points:?}");
    }

    /// An L-shaped face listed from the corner before its reflex one
    /// loads as triangles that cover the L and nothing over its notch (a
    /// fan laid one there).
    #[test]
    fn obj_concave_faces_are_cut_exactly() {
        let l = "v 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 0\nv 2 0 0\nf 1 2 3 4 5 6\n";
        let m = from_obj(l).expect("L");
        assert_eq!(m.triangles().len(), 4);
        let mut area = 0.0;
        for t in m.triangles() {
            let [a, b, c] = t.map(|k| m.vertices()[k as usize]);
            let n = (b - a).cross(&(c - a));
            assert!(n.z > 0.0, "{t:?} flipped");
            area += n.z / 2.0;
            let centre = (a + b + c) / 3.0;
            assert!(!(centre.x > 1.0 && centre.y > 1.0), "{t:?} over the notch");
        }
        assert!((area - 3.0).abs() < 1e-12, "{area}");
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
