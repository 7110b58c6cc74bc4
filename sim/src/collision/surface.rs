//! What the collision stage asks of an obstacle's shape, in the obstacle's
//! own frame: the first crossing of a particle's path with the offset
//! surface, the nearest offset-surface point (for particles already inside
//! and for contacts that persist), and the signed distance to the true
//! surface (for statistics). Exact primitives and triangle meshes answer
//! the same questions.

use std::fmt::Debug;

use super::aabb::Aabb;
use crate::math::{Real, Vec3};

/// The first crossing of the offset surface along a path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Fraction of the path, in `[0, 1]`.
    pub t: Real,
    /// The crossing point, on the offset surface.
    pub point: Vec3,
    /// Outward unit normal of the offset surface there.
    pub normal: Vec3,
}

/// The offset-surface point nearest to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Nearest point on the offset surface.
    pub point: Vec3,
    /// Outward unit normal there: the direction that leaves the solid.
    pub normal: Vec3,
    /// Signed distance of the query to the offset surface (negative inside).
    pub distance: Real,
}

/// A collision shape in its own frame.
pub trait Surface: Debug + Send + Sync {
    /// The box of the offset solid (may be unbounded along some axes).
    fn bounds(&self) -> Aabb;

    /// The offset `delta` of the collision surface.
    fn offset(&self) -> Real;

    /// The earliest crossing, from outside to inside, of the offset surface
    /// by the segment `a -> b`; `nodes` counts hierarchy nodes visited.
    fn first_hit(&self, a: &Vec3, b: &Vec3, nodes: &mut u64) -> Option<Hit>;

    /// The nearest point of the offset surface to `p`.
    fn project(&self, p: &Vec3, nodes: &mut u64) -> Projection;

    /// Signed distance from `p` to the true (not offset) surface.
    fn true_distance(&self, p: &Vec3, nodes: &mut u64) -> Real;
}
