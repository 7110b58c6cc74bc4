//! One obstacle as the collision stage sees it: its exact or meshed
//! surface in its own frame, how it moves, and its friction.

use super::aabb::Aabb;
use super::analytic::{Analytic, Primitive};
use super::features::Features;
use super::meshsurface::MeshSurface;
use super::pose::{Pose, Trajectory};
use super::surface::Surface;
use crate::math::{Real, Vec3};
use crate::mesh::{
    MeshError, TriMesh, from_source, tessellate_box, tessellate_cylinder, tessellate_plane,
    tessellate_sphere,
};
use crate::spec::Obstacle;

/// A rigid obstacle ready for collision.
#[derive(Debug)]
pub struct Collider {
    /// Shape and offset surface, in the obstacle's own frame.
    pub surface: Box<dyn Surface>,
    /// Pose over time.
    pub trajectory: Trajectory,
    /// Coulomb coefficient.
    pub friction: Real,
    /// The pose never changes: no per-step transforms.
    pub is_static: bool,
    /// Sharp corners and edges, tested against cloth edges and triangles
    /// (`crate::sim::sharp`), if the shape has any.
    pub features: Option<Features>,
}

impl Collider {
    /// Builds a validated obstacle for a cloth of particle spacing
    /// `spacing` (which sets the default offset).
    pub fn new(o: &Obstacle, spacing: Real) -> Result<Self, MeshError> {
        let (surface, features): (Box<dyn Surface>, _) = match Primitive::of(o) {
            Some(p) => {
                let analytic = Analytic::new(p.clone(), o.offset, spacing);
                let features = Features::of_primitive(&p, analytic.offset());
                (Box::new(analytic), features)
            }
            None => {
                let source = o
                    .mesh
                    .as_ref()
                    .ok_or_else(|| MeshError("has no shape".into()))?;
                let mesh = from_source(source)?;
                let features = Features::of_mesh(&mesh);
                (
                    Box::new(MeshSurface::new(mesh, o.offset, spacing)),
                    features,
                )
            }
        };
        let trajectory = Trajectory::new(o.motion.as_ref());
        Ok(Self {
            surface,
            is_static: trajectory.is_static(),
            trajectory,
            friction: o.friction,
            features,
        })
    }

    /// The offset solid's box in the world at pose `p` (unbounded when the
    /// local box is and the obstacle moves).
    pub fn world_bounds(&self, p: &Pose) -> Aabb {
        let local = self.surface.bounds();
        if self.is_static {
            return local;
        }
        if !(local
            .lo
            .iter()
            .chain(local.hi.iter())
            .all(|c| c.is_finite()))
        {
            return Aabb {
                lo: Vec3::repeat(Real::NEG_INFINITY),
                hi: Vec3::repeat(Real::INFINITY),
            };
        }
        Aabb::of_points(&local.corners().map(|c| p.transform_point(&c.into()).coords))
    }
}

/// A triangle mesh picturing an obstacle in its own frame, with edges about
/// `edge` long (planes drawn as a square of side `2 extent`, in at most
/// 32 x 32 squares): what a viewer draws.
pub fn display_mesh(o: &Obstacle, edge: Real, extent: Real) -> Result<TriMesh, MeshError> {
    if let Some(s) = &o.sphere {
        return tessellate_sphere(s.center.into(), s.radius, edge);
    }
    if let Some(b) = &o.box_ {
        return tessellate_box(b.center.into(), b.size.into(), edge);
    }
    if let Some(p) = &o.plane {
        return tessellate_plane(
            p.point.into(),
            p.normal.into(),
            extent,
            edge.max(extent / 16.0),
        );
    }
    if let Some(c) = &o.cylinder {
        return tessellate_cylinder(c.center.into(), c.axis.into(), c.radius, c.height, edge);
    }
    from_source(
        o.mesh
            .as_ref()
            .ok_or_else(|| MeshError("has no shape".into()))?,
    )
}
