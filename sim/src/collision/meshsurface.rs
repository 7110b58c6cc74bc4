//! A triangle mesh as a collision surface (method.md §3): the offset
//! surface is the mesh with every vertex moved out by `delta` along its
//! angle-weighted normal; one hierarchy, built once, covers both the true
//! and the offset triangles (each leaf box holds both), so the same tree
//! answers continuous tests against the offset surface and distances to
//! the true one.
//!
//! Inside/outside comes from the angle-weighted pseudo-normal of the
//! nearest feature (face, edge or vertex; Bærentzen and Aanæs 2005), which
//! is correct for closed meshes at any query point.
//!
//! An open mesh (an edge with one face: a sheet, a bowl, a box without a
//! lid) encloses nothing, so it is a shell of no thickness with two
//! sides: its collision surface is the set of points `delta` from it, a
//! particle may rest on either side, and none is ever inside the sheet
//! itself. Its offset is traced on both sides (the back one wound the
//! other way, so its normals leave the sheet too), the continuous test
//! meets whichever side a path reaches first, and projections and
//! distances are unsigned: the way out is away from the nearest point of
//! the sheet, to the side the particle is on. Read as a solid, a sheet's
//! underside was its inside: cloth swinging under a table top of one
//! face was thrown up through it, and cloth falling into a box without a
//! lid was torn (stretch 10.3).
//!
//! The choice is the whole mesh's: one open edge makes every part of it a
//! shell, so a closed body and an open sheet belong in two obstacles.

use std::collections::HashMap;

use super::aabb::Aabb;
use super::bvh::Bvh;
use super::surface::{Hit, Projection, Surface};
use super::triangle::{Feature, closest_point, segment_hit};
use crate::math::{Real, Vec3};
use crate::mesh::{
    Curvature, TriMesh, angle_weighted_normals, default_offset, edge_faces, mesh_offset_requirement,
};

/// A mesh with its pseudo-normals.
#[derive(Debug, Clone)]
struct Sided {
    mesh: TriMesh,
    face: Vec<Vec3>,
    vertex: Vec<Vec3>,
    /// Per face, per edge `k` (corner `k` to `k + 1`): the edge's
    /// pseudo-normal, the normalised sum of its two faces' normals.
    edge: Vec<[Vec3; 3]>,
}

impl Sided {
    /// `faces_of`: the topology's edge map, shared by the true and the
    /// offset mesh.
    fn new(mesh: TriMesh, faces_of: &HashMap<(u32, u32), Vec<u32>>) -> Self {
        let face: Vec<Vec3> = (0..mesh.triangles().len())
            .map(|k| mesh.face_normal(k))
            .collect();
        let vertex = angle_weighted_normals(&mesh);
        // Each edge's sum once, then looked up per face: summed per face
        // instead, an edge of `m` faces cost `m²` (a mesh of 100,000 copies
        // of one triangle took 56 s to load).
        let sums: HashMap<(u32, u32), Option<Vec3>> = faces_of
            .iter()
            .map(|(&key, faces)| {
                let sum: Vec3 = faces.iter().map(|&f| face[f as usize]).sum();
                (key, sum.try_normalize(0.0))
            })
            .collect();
        let edge = mesh
            .triangles()
            .iter()
            .enumerate()
            .map(|(k, t)| {
                std::array::from_fn(|c| {
                    let (a, b) = (t[c], t[(c + 1) % 3]);
                    sums[&(a.min(b), a.max(b))].unwrap_or(face[k])
                })
            })
            .collect();
        Self {
            mesh,
            face,
            vertex,
            edge,
        }
    }

    /// Nearest point of triangle `k` to `p`, its squared distance, and the
    /// pseudo-normal of its feature.
    #[inline]
    fn nearest_on(&self, k: usize, p: &Vec3) -> (Vec3, Real, Vec3) {
        let (q, feature) = closest_point(p, &self.mesh.corners(k));
        let n = match feature {
            Feature::Face => self.face[k],
            Feature::Edge(e) => self.edge[k][e as usize],
            Feature::Vertex(c) => self.vertex[self.mesh.triangles()[k][c as usize] as usize],
        };
        (q, (p - q).norm_squared(), n)
    }
}

/// A rigid triangle mesh obstacle in its own frame.
#[derive(Debug, Clone)]
pub struct MeshSurface {
    real: Sided,
    offset: Sided,
    /// A shell's offset on its back (module doc); `None` for a closed mesh.
    back: Option<Sided>,
    bvh: Bvh,
    delta: Real,
    /// Slack of the front test: a particle left this far behind an offset
    /// face by solver tolerance still hits it at `t = 0`.
    slack: Real,
}

impl MeshSurface {
    /// The surface of `mesh` offset by `delta` (default from `spacing` and
    /// the mesh's sharpest convex edge).
    pub fn new(mesh: TriMesh, delta: Option<Real>, spacing: Real) -> Self {
        let delta = delta.unwrap_or_else(|| {
            default_offset(
                spacing,
                Curvature::Mesh(mesh_offset_requirement(&mesh, spacing)),
            )
        });
        let normals = angle_weighted_normals(&mesh);
        let moved = mesh
            .vertices()
            .iter()
            .zip(&normals)
            .map(|(v, n)| v + n * delta)
            .collect();
        let offset_mesh = mesh.with_vertices(moved);
        let faces_of = edge_faces(&mesh);
        let back_mesh = faces_of.values().any(|f| f.len() == 1).then(|| {
            let moved = mesh
                .vertices()
                .iter()
                .zip(&normals)
                .map(|(v, n)| v - n * delta)
                .collect();
            mesh.reversed_with_vertices(moved)
        });
        let boxes: Vec<Aabb> = (0..mesh.triangles().len())
            .map(|k| {
                let back = back_mesh.as_ref().map(|b| b.corners(k));
                Aabb::of_points(
                    mesh.corners(k)
                        .iter()
                        .chain(offset_mesh.corners(k).iter())
                        .chain(back.iter().flatten()),
                )
            })
            .collect();
        Self {
            real: Sided::new(mesh, &faces_of),
            offset: Sided::new(offset_mesh, &faces_of),
            back: back_mesh.map(|b| Sided::new(b, &faces_of)),
            bvh: Bvh::build(&boxes),
            delta,
            slack: 1e-3 * delta + 1e-12,
        }
    }

    /// The true mesh.
    pub fn mesh(&self) -> &TriMesh {
        &self.real.mesh
    }

    /// The hierarchy (for benchmarks and tests).
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Whether the mesh is open, a shell with two sides (module doc).
    pub fn is_shell(&self) -> bool {
        self.back.is_some()
    }

    /// A shell's nearest point of the surface `level` from the sheet, with
    /// the unsigned distance to it less `level`: the normal leaves the
    /// sheet toward `p` (the face's own for a point on the sheet).
    fn shell_nearest(&self, p: &Vec3, level: Real, nodes: &mut u64) -> Projection {
        let Some((k, d2, visited)) = self.bvh.nearest(p, |k| self.real.nearest_on(k, p).1) else {
            return Projection {
                point: *p,
                normal: Vec3::z(),
                distance: Real::INFINITY,
            };
        };
        *nodes += visited;
        let (q, _, pseudo) = self.real.nearest_on(k, p);
        let d = d2.sqrt();
        let normal = if d > 1e-12 * (1.0 + p.norm()) {
            (p - q) / d
        } else {
            pseudo
        };
        Projection {
            point: q + normal * level,
            normal,
            distance: d - level,
        }
    }

    fn nearest(&self, side: &Sided, p: &Vec3, nodes: &mut u64) -> Projection {
        let Some((k, d2, visited)) = self.bvh.nearest(p, |k| side.nearest_on(k, p).1) else {
            return Projection {
                point: *p,
                normal: Vec3::z(),
                distance: Real::INFINITY,
            };
        };
        *nodes += visited;
        let (q, _, pseudo) = side.nearest_on(k, p);
        let d = d2.sqrt();
        let outside = (p - q).dot(&pseudo) >= 0.0;
        let normal = if d > 1e-12 * (1.0 + p.norm()) {
            let u = (p - q) / d;
            if outside { u } else { -u }
        } else {
            pseudo
        };
        Projection {
            point: q,
            normal,
            distance: if outside { d } else { -d },
        }
    }
}

impl Surface for MeshSurface {
    fn bounds(&self) -> Aabb {
        self.bvh.bounds()
    }

    fn offset(&self) -> Real {
        self.delta
    }

    fn first_hit(&self, a: &Vec3, b: &Vec3, nodes: &mut u64) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let query = Aabb::of_segment(a, b).grown(self.slack);
        *nodes += self.bvh.query(&query, |k| {
            for side in std::iter::once(&self.offset).chain(&self.back) {
                let tri = side.mesh.corners(k);
                let n = side.face[k];
                if let Some(h) = segment_hit(a, b, &tri, &n, self.slack)
                    && best.is_none_or(|b| h.t < b.t)
                {
                    best = Some(Hit {
                        t: h.t,
                        point: h.point,
                        normal: n,
                    });
                }
            }
        });
        best
    }

    fn project(&self, p: &Vec3, nodes: &mut u64) -> Projection {
        match self.back {
            None => self.nearest(&self.offset, p, nodes),
            Some(_) => self.shell_nearest(p, self.delta, nodes),
        }
    }

    fn true_distance(&self, p: &Vec3, nodes: &mut u64) -> Real {
        match self.back {
            None => self.nearest(&self.real, p, nodes).distance,
            Some(_) => self.shell_nearest(p, 0.0, nodes).distance,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::analytic::Primitive;
    use crate::mesh::{tessellate_box, tessellate_sphere};

    #[test]
    fn signed_distance_of_a_box_mesh_matches_the_exact_box() {
        let half = Vec3::new(0.5, 0.3, 0.2);
        let s = MeshSurface::new(
            tessellate_box(Vec3::zeros(), half * 2.0, 0.13).expect("tessellates"),
            Some(0.0),
            0.1,
        );
        let exact = Primitive::Box {
            center: Vec3::zeros(),
            half,
        };
        let mut nodes = 0;
        for k in 0..300 {
            let p = Vec3::new(
                (k as Real * 0.37).sin(),
                (k as Real * 0.71).cos() * 0.6,
                (k as Real * 0.13).sin() * 0.5,
            );
            let d = s.true_distance(&p, &mut nodes);
            assert!(
                (d - exact.sdf(&p).0).abs() < 1e-12,
                "{p:?}: {d} vs {:?}",
                exact.sdf(&p)
            );
        }
        assert!(nodes > 0);
    }

    #[test]
    fn an_open_sheet_is_a_shell_with_two_sides() {
        let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
        let v = corners.map(|(x, y)| Vec3::new(x, y, 0.0)).to_vec();
        let sheet = TriMesh::new(v, vec![[0, 1, 2], [0, 2, 3]]).expect("a sheet");
        let s = MeshSurface::new(sheet, Some(0.05), 0.1);
        assert!(s.is_shell());
        let mut nodes = 0;
        for side in [1.0, -1.0] {
            let up = Vec3::z() * side;
            let far = Vec3::new(0.3, -0.2, 0.5 * side);
            assert!((s.true_distance(&far, &mut nodes) - 0.5).abs() < 1e-12);
            // Within the offset on either side: pushed out to that side.
            let pr = s.project(&Vec3::new(0.3, -0.2, 0.02 * side), &mut nodes);
            assert!((pr.distance + 0.03).abs() < 1e-12, "{pr:?}");
            assert!((pr.normal - up).norm() < 1e-12 && (pr.point.z - 0.05 * side).abs() < 1e-12);
            // A path through the sheet meets the offset on its own side.
            let h = s.first_hit(&far, &(far - up), &mut nodes).expect("a hit");
            assert!((h.point.z - 0.05 * side).abs() < 1e-9 && (h.normal - up).norm() < 1e-12);
        }
        // Beside the rim and below the sheet: outside, as far as the rim.
        let beside = Vec3::new(1.3, 0.0, -0.4);
        assert!((s.true_distance(&beside, &mut nodes) - 0.5).abs() < 1e-12);
        let closed = tessellate_box(Vec3::zeros(), Vec3::repeat(1.0), 0.5).expect("a box");
        assert!(!MeshSurface::new(closed, Some(0.05), 0.1).is_shell());
    }

    #[test]
    fn offset_sphere_mesh_is_hit_at_radius_plus_delta() {
        let s = MeshSurface::new(
            tessellate_sphere(Vec3::zeros(), 1.0, 0.02).expect("tessellates"),
            Some(0.05),
            0.1,
        );
        let mut nodes = 0;
        for dir in [
            Vec3::z(),
            Vec3::new(1.0, 1.0, 1.0).normalize(),
            Vec3::new(0.3, -0.9, 0.1).normalize(),
        ] {
            let h = s
                .first_hit(&(dir * 2.0), &(dir * 0.5), &mut nodes)
                .expect("hit");
            // The offset tessellation lies within its chord error of 1.05.
            assert!((h.point.norm() - 1.05).abs() < 2e-4, "{}", h.point.norm());
            assert!(h.normal.dot(&dir) > 0.99);
            let pr = s.project(&(dir * 0.9), &mut nodes);
            assert!(pr.distance < -0.14 && pr.normal.dot(&dir) > 0.99);
        }
    }
}

#[cfg(test)]
mod brute_force {
    use super::*;
    use crate::mesh::tessellate_sphere;
    use rand::{RngExt, SeedableRng, rngs::StdRng};

    #[test]
    fn hierarchy_queries_equal_brute_force_on_random_meshes_and_segments() {
        let mut rng = StdRng::seed_from_u64(3);
        for trial in 0..4 {
            // A bumpy sphere: a random closed mesh with concave parts.
            let base = tessellate_sphere(Vec3::zeros(), 0.5, 0.12 + 0.03 * trial as Real)
                .expect("tessellates");
            let bumped: Vec<Vec3> = base
                .vertices()
                .iter()
                .map(|v| v * rng.random_range(0.8..1.2))
                .collect();
            let mesh = base.with_vertices(bumped);
            let s = MeshSurface::new(mesh, Some(0.02), 0.05);
            let tris = s.offset.mesh.triangles().len();
            for _ in 0..300 {
                let mut r = |k: Real| {
                    Vec3::new(
                        rng.random_range(-k..k),
                        rng.random_range(-k..k),
                        rng.random_range(-k..k),
                    )
                };
                let a = r(1.0);
                let b = a + r(0.4);
                let mut nodes = 0;
                let got = s.first_hit(&a, &b, &mut nodes);
                let want = (0..tris)
                    .filter_map(|k| {
                        segment_hit(
                            &a,
                            &b,
                            &s.offset.mesh.corners(k),
                            &s.offset.face[k],
                            s.slack,
                        )
                    })
                    .map(|h| h.t)
                    .fold(None, |m: Option<Real>, t| Some(m.map_or(t, |m| m.min(t))));
                assert_eq!(got.map(|h| h.t), want);

                let d = s.true_distance(&a, &mut nodes).abs();
                let brute = (0..tris)
                    .map(|k| s.real.nearest_on(k, &a).1.sqrt())
                    .fold(Real::INFINITY, Real::min);
                assert!((d - brute).abs() < 1e-14);
            }
        }
    }
}
