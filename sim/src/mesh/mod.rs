//! Triangle meshes of rigid obstacles (method.md §3): input (OBJ, STL,
//! inline arrays), checks that refuse bad geometry with a clear message,
//! primitives tessellated for display and for the mesh pipeline,
//! angle-weighted vertex normals, and the offset surface.

mod edges;
mod load;
mod normals;
mod offset;
mod orient;
mod polygon;
mod primitive;
mod trimesh;

pub use load::{from_obj, from_source, from_stl_base64, obj_triangles};
pub use normals::{angle_weighted_normals, edge_faces};
pub use offset::{Curvature, SHARP_TURN, default_offset, mesh_offset_requirement, sharp_edges};
pub use primitive::{
    frame_of, tessellate_box, tessellate_cylinder, tessellate_plane, tessellate_sphere,
};
pub use trimesh::{MeshError, TriMesh};
