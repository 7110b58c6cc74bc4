//! Rigid obstacle motion (DESIGN.md `motion`) as a pose over time. Shapes
//! are stored in their own frame — their spec coordinates at `t = 0` — and
//! a particle is brought into that frame by the inverse pose (method.md §3,
//! "moving obstacles"), so the hierarchy never changes.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use crate::math::{Real, Vec3};
use crate::spec::Motion;

/// A pose: `world = rotation * local + translation`.
pub type Pose = Isometry3<Real>;

/// How an obstacle moves.
#[derive(Debug, Clone, PartialEq)]
pub enum Trajectory {
    /// Never moves: the identity pose.
    Static,
    /// Constant linear velocity plus constant angular velocity about a
    /// pivot (the pivot moving with the linear velocity).
    Constant {
        /// m/s.
        velocity: Vec3,
        /// rad/s.
        angular_velocity: Vec3,
        /// Centre of rotation at `t = 0`.
        pivot: Vec3,
    },
    /// Keyed poses, linear/slerp between keys, held outside them.
    Keyframes(Vec<(Real, Pose)>),
}

impl Trajectory {
    /// The trajectory of a validated motion (`None`: static).
    pub fn new(motion: Option<&Motion>) -> Self {
        let Some(m) = motion else {
            return Self::Static;
        };
        if let Some(keys) = &m.keyframes {
            return Self::Keyframes(
                keys.iter()
                    .map(|k| {
                        let [x, y, z, w] = k.rotation;
                        let q =
                            UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
                        let t = Translation3::from(Vector3::from(k.translation));
                        (k.time, Isometry3::from_parts(t, q))
                    })
                    .collect(),
            );
        }
        Self::Constant {
            velocity: m.velocity.map_or_else(Vec3::zeros, Vec3::from),
            angular_velocity: m.angular_velocity.map_or_else(Vec3::zeros, Vec3::from),
            pivot: m.pivot.map_or_else(Vec3::zeros, Vec3::from),
        }
    }

    /// `true` when the pose is the identity at every time.
    pub fn is_static(&self) -> bool {
        match self {
            Self::Static => true,
            Self::Constant {
                velocity,
                angular_velocity,
                ..
            } => *velocity == Vec3::zeros() && *angular_velocity == Vec3::zeros(),
            Self::Keyframes(keys) => keys.iter().all(|(_, p)| *p == Pose::identity()),
        }
    }

    /// The pose at time `t`.
    pub fn pose(&self, t: Real) -> Pose {
        match self {
            Self::Static => Pose::identity(),
            Self::Constant {
                velocity,
                angular_velocity,
                pivot,
            } => {
                let r = UnitQuaternion::from_scaled_axis(angular_velocity * t);
                // world = R (x - c) + c + v t
                let shift = pivot - r * pivot + velocity * t;
                Isometry3::from_parts(Translation3::from(shift), r)
            }
            Self::Keyframes(keys) => {
                let k = keys.partition_point(|(kt, _)| *kt <= t);
                if k == 0 {
                    return keys[0].1;
                }
                if k == keys.len() {
                    return keys[k - 1].1;
                }
                let (t0, p0) = &keys[k - 1];
                let (t1, p1) = &keys[k];
                let s = (t - t0) / (t1 - t0);
                p0.lerp_slerp(p1, s)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::Keyframe;

    #[test]
    fn constant_motion_rotates_about_the_moving_pivot() {
        let m = Motion {
            velocity: Some([1.0, 0.0, 0.0]),
            angular_velocity: Some([0.0, 0.0, std::f64::consts::PI]),
            pivot: Some([0.0, 1.0, 0.0]),
            keyframes: None,
        };
        let tr = Trajectory::new(Some(&m));
        assert!(!tr.is_static());
        // Half a turn about (0,1,0) in 1 s, then 1 m along x.
        let p = tr.pose(1.0) * nalgebra::Point3::new(0.0, 0.0, 0.0);
        assert!((p.coords - Vec3::new(1.0, 2.0, 0.0)).norm() < 1e-12);
        assert!(Trajectory::new(None).is_static());
    }

    #[test]
    fn keyframes_interpolate_and_hold() {
        let quarter = UnitQuaternion::from_scaled_axis(Vec3::z() * std::f64::consts::FRAC_PI_2);
        let q = quarter.quaternion();
        let m = Motion {
            velocity: None,
            angular_velocity: None,
            pivot: None,
            keyframes: Some(vec![
                Keyframe {
                    time: 1.0,
                    translation: [0.0; 3],
                    rotation: [0.0, 0.0, 0.0, 1.0],
                },
                Keyframe {
                    time: 2.0,
                    translation: [2.0, 0.0, 0.0],
                    rotation: [q.i, q.j, q.k, q.w],
                },
            ]),
        };
        let tr = Trajectory::new(Some(&m));
        let at = |t: Real| (tr.pose(t) * nalgebra::Point3::new(1.0, 0.0, 0.0)).coords;
        assert!((at(0.0) - Vec3::x()).norm() < 1e-12);
        let mid = at(1.5); // 45° and 1 m
        let c = std::f64::consts::FRAC_1_SQRT_2;
        assert!((mid - Vec3::new(1.0 + c, c, 0.0)).norm() < 1e-12, "{mid:?}");
        assert!((at(5.0) - Vec3::new(2.0, 1.0, 0.0)).norm() < 1e-12);
    }
}
