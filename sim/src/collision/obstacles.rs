//! The obstacles of a scene as the collision stage sees them: built once
//! from the spec, never changed by a step.

use super::collider::Collider;
use crate::math::{Real, Vec3};
use crate::mesh::MeshError;
use crate::spec::Obstacle;

/// Most a particle is pushed out along the surface normal in one step, as
/// a fraction of the particle spacing: a deep initial overlap is resolved
/// over a few steps instead of in one jolt that would overstretch the
/// springs to its free neighbours.
const MAX_PUSH: Real = 0.1;

/// Every obstacle of a scene, ready for collision.
#[derive(Debug)]
pub struct Obstacles {
    colliders: Vec<Collider>,
    /// Largest push-out per step (see [`MAX_PUSH`]).
    pub(super) max_push: Real,
}

impl Obstacles {
    /// The obstacles of a scene whose cloth has particle spacing `spacing`
    /// (it sets the default offsets), or `None` when there are none: a
    /// scene without obstacles has no collision stage at all. An obstacle
    /// that cannot be built is reported with its index.
    pub fn new(obstacles: &[Obstacle], spacing: Real) -> Result<Option<Self>, (usize, MeshError)> {
        if obstacles.is_empty() {
            return Ok(None);
        }
        let colliders = obstacles
            .iter()
            .enumerate()
            .map(|(k, o)| Collider::new(o, spacing).map_err(|e| (k, e)))
            .collect::<Result<Vec<_>, _>>()?;
        for (k, c) in colliders.iter().enumerate() {
            tracing::debug!(
                obstacle = k,
                offset = c.surface.offset(),
                "collision offset"
            );
        }
        Ok(Some(Self {
            colliders,
            max_push: MAX_PUSH * spacing,
        }))
    }

    /// The obstacles, in the scene's order.
    pub fn colliders(&self) -> &[Collider] {
        &self.colliders
    }

    /// Each obstacle's collision offset `delta`, metres.
    pub fn offsets(&self) -> Vec<Real> {
        self.colliders.iter().map(|c| c.surface.offset()).collect()
    }

    /// The smallest signed distance from a particle to a true obstacle
    /// surface at time `t` (negative inside).
    pub fn min_true_distance(&self, x: &[Vec3], t: Real) -> Real {
        let mut best = Real::INFINITY;
        for c in &self.colliders {
            let pose = c.trajectory.pose(t);
            let bounds = c.surface.bounds();
            for p in x {
                let l = pose.inverse_transform_point(&(*p).into()).coords;
                // The bounds hold the true solid: a lower bound on distance.
                if bounds.distance_squared(&l).sqrt() >= best {
                    continue;
                }
                let mut nodes = 0;
                best = best.min(c.surface.true_distance(&l, &mut nodes));
            }
        }
        best
    }
}
