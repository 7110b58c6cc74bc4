//! Pinned particles: held where they start, or carried by a rigid motion
//! (a hand pulling a table cloth). Each step they become fixed constraints
//! of the modified PCG (method.md §2, `S = 0` with targets `z` and
//! corrections `y`), never forces.

use crate::collision::Trajectory;
use crate::math::{Real, Vec3};

use crate::solver::{ClothState, Constraints, Scheme};
use crate::spec::ClothScene;

/// The pins of a scene.
#[derive(Debug, Clone)]
pub struct Pins {
    /// Pinned particles, sorted.
    indices: Vec<usize>,
    /// For each of `indices`, the motion it follows (`None`: held still).
    group: Vec<Option<usize>>,
    /// The motions of moving pin groups.
    motions: Vec<Trajectory>,
    /// `true` for each pinned particle, by particle index.
    mask: Vec<bool>,
}

impl Pins {
    /// The pins of a validated cloth of `n` particles.
    pub fn new(cloth: &ClothScene, n: usize) -> Self {
        let mut mask = vec![false; n];
        for &i in &cloth.pinned {
            mask[i] = true;
        }
        Self {
            indices: cloth.pinned.clone(),
            group: cloth.pin_group.clone(),
            motions: cloth
                .pin_motions
                .iter()
                .map(|m| Trajectory::new(Some(m)))
                .collect(),
            mask,
        }
    }

    /// Number of pinned particles.
    pub fn len(&self) -> usize {
        self.indices.len()
    }

    /// `true` when nothing is pinned.
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// `true` when some pin group moves (does work on the cloth).
    pub fn moving(&self) -> bool {
        !self.motions.is_empty()
    }

    /// `true` at each pinned particle's index.
    pub fn mask(&self) -> &[bool] {
        &self.mask
    }

    /// Where each pinned particle is held, given positions `x` at `time`:
    /// a fixed pin where it is, a moving one in its motion's frame at
    /// `time`, so it follows the motion's change from there. One rule for
    /// a new run and a replaced state.
    pub fn anchors(&self, x: &[Vec3], time: Real) -> Vec<Vec3> {
        self.indices
            .iter()
            .zip(&self.group)
            .map(|(&i, group)| match group {
                None => x[i],
                Some(g) => {
                    self.motions[*g]
                        .pose(time)
                        .inverse_transform_point(&x[i].into())
                        .coords
                }
            })
            .collect()
    }

    /// Clears `c` and fills the constraints of a step of `scheme` from
    /// `state`: a fixed pin holds its anchor (velocity 0, `y` the drift
    /// back); a moving pin ends the step exactly where its motion puts the
    /// anchor, at the motion's mean velocity over the step (`z` and `y` of
    /// eq. [20], written through the scheme's end of step).
    pub fn constrain(
        &self,
        state: &ClothState,
        anchors: &[Vec3],
        scheme: &Scheme<'_>,
        c: &mut Constraints,
    ) {
        c.clear();
        let (time, h) = (state.time, scheme.h);
        // Each group's pose at both ends of the step, once per group.
        let poses: Vec<_> = self
            .motions
            .iter()
            .map(|m| (m.pose(time), m.pose(time + h)))
            .collect();
        for ((&i, anchor), group) in self.indices.iter().zip(anchors).zip(&self.group) {
            let (x, v) = (state.x[i], state.v[i]);
            match group {
                None => c.fix(i, -v, anchor - scheme.end(i, &x, &Vec3::zeros())),
                Some(g) => {
                    let (start, end) = &poses[*g];
                    let p0 = start * nalgebra::Point3::from(*anchor);
                    let p1 = end * nalgebra::Point3::from(*anchor);
                    let target = (p1 - p0) / h;
                    c.fix(i, target - v, p1.coords - scheme.end(i, &x, &target));
                }
            }
        }
    }
}
