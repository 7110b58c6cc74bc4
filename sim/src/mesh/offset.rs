//! How far out the collision surface sits (method.md §3, fig. 5): the
//! offset `delta` that keeps an obstacle's curvature and gentle edges from
//! poking between cloth particles, since the offset surface tests only
//! particles. Sharp edges and corners (a box's, a cylinder's rims, mesh
//! edges turning by [`SHARP_TURN`] or more) are tested against the cloth's edges and
//! triangles directly (`crate::sim` sharp-feature stage) and add nothing
//! here.
//!
//! A cloth edge of length `s` whose ends rest on the offset surface sags
//! towards the obstacle between them. The default offset is the smallest
//! that keeps that chord outside the true surface, plus a margin:
//!
//! - flat: no sag; only the margin;
//! - smooth, radius `R`: the cloth triangle's diagonal `√2 s` sags
//!   `(√2 s)² / 8R = s² / 4R`;
//! - a mesh offset along vertex normals is chamfered, not rounded, at an
//!   edge turning by `θ`: the chord passes the chamfer's apex at
//!   `delta - (s/2) tan(θ/2)`, so `delta >= (s/2) tan(θ/2)` for the edges
//!   gentler than [`SHARP_TURN`]. (An exact offset surface, rounded by
//!   `delta`, would need `(s/2) sin(θ/2)`: `0.354 s` at a box's edge,
//!   which is what boxes and cylinders had before their edges were
//!   tested.)
//!
//! `s` is taken 2 % long (the stretch the solver allows) and the margin is
//! 5 % of the spacing: what solver tolerance and the one-step lag of
//! release may leave a particle inside the offset surface.

use std::collections::HashMap;

use super::normals::edge_faces;
use super::trimesh::TriMesh;
use crate::math::Real;

/// Margin of every offset, as a fraction of the particle spacing.
const MARGIN: Real = 0.05;
/// Chord length allowance for stretch.
const STRETCH: Real = 1.02;
/// Turning angles beyond this (a knife edge) are treated as this, so the
/// offset stays below one particle spacing.
const MAX_TURN: Real = 2.0 * std::f64::consts::FRAC_PI_3;

/// The shape feature that sets an obstacle's offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Curvature {
    /// A plane.
    Flat,
    /// A smooth surface with this smallest radius of curvature.
    Smooth(Real),
    /// A triangle mesh offset along vertex normals, with this requirement
    /// (from [`mesh_offset_requirement`]).
    Mesh(Real),
}

/// The default offset for a cloth with particle spacing `spacing`.
pub fn default_offset(spacing: Real, curvature: Curvature) -> Real {
    let s = spacing * STRETCH;
    let need = match curvature {
        Curvature::Flat => 0.0,
        Curvature::Smooth(r) => (s * s / (4.0 * r)).min(0.5 * s),
        Curvature::Mesh(need) => need,
    };
    MARGIN * spacing + need
}

/// A turn at which a mesh edge is a sharp feature: tested against cloth
/// edges and triangles directly (`collision::Features`), so it no longer
/// sets the offset. At this turn the chamfer requirement would be
/// `(s/2) tan 10° = 0.09 s`; every gentler edge stays under it.
pub const SHARP_TURN: Real = 20.0 * std::f64::consts::PI / 180.0;

/// A convex edge of a mesh: its vertices, the turn `θ` between its
/// faces' normals and the width `w` of the faces across it.
struct Convex {
    edge: [u32; 2],
    theta: Real,
    width: Real,
}

/// Every convex edge between two faces (`faces`: the mesh's
/// [`edge_faces`]), in a fixed order.
fn convex_edges(mesh: &TriMesh, faces: &HashMap<(u32, u32), Vec<u32>>) -> Vec<Convex> {
    let mut out = Vec::new();
    for (&(a, b), faces) in faces {
        let [f, g] = match faces.as_slice() {
            [f, g] => [*f as usize, *g as usize],
            _ => continue, // boundary or non-manifold edge: no turn to follow
        };
        let (nf, ng) = (mesh.face_normal(f), mesh.face_normal(g));
        let theta = nf.angle(&ng);
        // Convex if g's far corner lies behind f's plane.
        let pa = mesh.vertices()[a as usize];
        let Some(&c) = mesh.triangles()[g].iter().find(|&&i| i != a && i != b) else {
            continue;
        };
        let far = mesh.vertices()[c as usize];
        if nf.dot(&(far - pa)) > 0.0 || theta < 1e-6 {
            continue;
        }
        let len = (mesh.vertices()[b as usize] - pa).norm();
        let width = (mesh.double_area(f) + mesh.double_area(g)) / (2.0 * len);
        out.push(Convex {
            edge: [a, b],
            theta,
            width,
        });
    }
    out.sort_unstable_by_key(|c| c.edge);
    out
}

/// The mesh's sharp features: convex edges turning by [`SHARP_TURN`] or
/// more, and boundary edges (a sheet's rim, a knife edge), sorted.
pub fn sharp_edges(mesh: &TriMesh) -> Vec<[u32; 2]> {
    let faces = edge_faces(mesh);
    let mut sharp: Vec<[u32; 2]> = convex_edges(mesh, &faces)
        .into_iter()
        .filter(|c| c.theta >= SHARP_TURN)
        .map(|c| c.edge)
        .collect();
    sharp.extend(
        faces
            .into_iter()
            .filter(|(_, f)| f.len() == 1)
            .map(|((a, b), _)| [a, b]),
    );
    sharp.sort_unstable();
    sharp
}

/// The offset a mesh needs beyond the margin: the chamfer requirement
/// `(s/2) tan(Θ/2)`, largest over the convex edges that are not sharp
/// features (those are tested directly), where `Θ` is the turn a cloth
/// edge of length `s` must follow there. An edge turning by `θ` between
/// faces wider than `s` turns the cloth edge by `Θ = θ`; where the faces
/// are narrower (a fine tessellation of a curved surface) the cloth edge
/// spans `s / w` such edges, `Θ = θ s / w`, which for a smooth surface of
/// radius `R` (`θ / w = 1 / R`) gives the smooth bound `s² / 4R` again.
pub fn mesh_offset_requirement(mesh: &TriMesh, spacing: Real) -> Real {
    let s = spacing * STRETCH;
    convex_edges(mesh, &edge_faces(mesh))
        .iter()
        .filter(|c| c.theta < SHARP_TURN)
        .map(|c| {
            let turn = (c.theta * (s / c.width).max(1.0)).min(MAX_TURN);
            0.5 * s * (turn / 2.0).tan()
        })
        .fold(0.0, Real::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::mesh::{tessellate_box, tessellate_sphere};

    #[test]
    fn offsets_follow_the_chord_bounds() {
        let s = 0.1;
        assert!((default_offset(s, Curvature::Flat) - 0.005).abs() < 1e-15);
        assert!(
            default_offset(s, Curvature::Smooth(1.0)) < default_offset(s, Curvature::Smooth(0.5))
        );
        // A cube mesh: its 90° edges are sharp features, tested directly,
        // and its flat faces need no more than the margin.
        let cube = tessellate_box(Vec3::zeros(), Vec3::repeat(1.0), 0.25).expect("tessellates");
        assert_eq!(mesh_offset_requirement(&cube, s), 0.0);
        assert_eq!(sharp_edges(&cube).len(), 12 * 4, "12 edges of 4 segments");
        // A fine sphere mesh needs about the smooth requirement, far less
        // than a sharp edge.
        let ball = tessellate_sphere(Vec3::zeros(), 0.5, 0.01).expect("tessellates");
        let need = mesh_offset_requirement(&ball, s);
        let smooth = (s * STRETCH).powi(2) / (4.0 * 0.5);
        assert!(
            need > 0.5 * smooth && need < 2.5 * smooth,
            "{need} vs {smooth}"
        );
    }
}
