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

    /// The particle deepest inside an obstacle's true surface at time `t`,
    /// if one is more than `tolerance` inside: the obstacle's index, the
    /// particle's, and how deep (metres, positive).
    pub fn deepest_inside(
        &self,
        x: &[Vec3],
        t: Real,
        tolerance: Real,
    ) -> Option<(usize, usize, Real)> {
        let mut deepest: Option<(usize, usize, Real)> = None;
        for (k, c) in self.colliders.iter().enumerate() {
            let pose = c.trajectory.pose(t);
            let bounds = c.surface.bounds();
            for (i, p) in x.iter().enumerate() {
                let l = pose.inverse_transform_point(&(*p).into()).coords;
                // Outside the bounds is outside the solid.
                if bounds.distance_squared(&l) > 0.0 {
                    continue;
                }
                let depth = -c.surface.true_distance(&l, &mut 0);
                if depth > tolerance && deepest.is_none_or(|(_, _, d)| depth > d) {
                    deepest = Some((k, i, depth));
                }
            }
        }
        deepest
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
                // The bounds hold the true solid, so a point outside them
                // is outside the solid, at least that far from it. Inside
                // them nothing is known: the point may be deep in the
                // solid (its distance negative, below any best so far).
                let outside = bounds.distance_squared(&l).sqrt();
                if outside > 0.0 && outside >= best {
                    continue;
                }
                let mut nodes = 0;
                best = best.min(c.surface.true_distance(&l, &mut nodes));
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::Sphere;

    /// The deepest particle counts, whichever particle inside the solid's
    /// bounds comes first: a shallow one found first once hid a deep one.
    #[test]
    fn the_deepest_particle_sets_the_smallest_distance() {
        let ball = Obstacle {
            sphere: Some(Sphere {
                center: [0.0, 0.0, 0.0],
                radius: 0.1,
            }),
            ..Obstacle::default()
        };
        let obstacles = Obstacles::new(&[ball], 0.01)
            .expect("builds")
            .expect("obstacles");
        let shallow = Vec3::new(0.0, 0.0, 0.097);
        let deep = Vec3::new(0.0, 0.03, 0.0);
        let outside = Vec3::new(0.3, 0.0, 0.0);
        for x in [[outside, shallow, deep], [deep, shallow, outside]] {
            let d = obstacles.min_true_distance(&x, 0.0);
            assert!((d + 0.07).abs() < 1e-12, "{d}");
        }
        let d = obstacles.min_true_distance(&[outside], 0.0);
        assert!((d - 0.2).abs() < 1e-12, "{d}");
        let (k, i, depth) = obstacles
            .deepest_inside(&[outside, shallow, deep], 0.0, 1e-9)
            .expect("two inside");
        assert_eq!((k, i), (0, 2));
        assert!((depth - 0.07).abs() < 1e-12, "{depth}");
        assert_eq!(obstacles.deepest_inside(&[outside], 0.0, 1e-9), None);
    }
}
