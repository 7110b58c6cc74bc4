//! What the collision stage computes during a step and throws away after
//! it: this step's poses, swept boxes, predicted path ends, contact
//! geometry, and counters. Kept between steps only so nothing allocates.

use super::aabb::Aabb;
use super::contact::{Contact, Plan};
use super::pose::Pose;
use crate::math::Vec3;

/// Counters of one step.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CollisionCounters {
    /// Hierarchy nodes visited.
    pub nodes: u64,
    /// Contacts made.
    pub new: usize,
    /// Contacts released.
    pub released: usize,
    /// Solves redone because a particle crossed a surface.
    pub redone: usize,
}

/// A piece of the path test: its crossings, `(particle, obstacle)`, and
/// the hierarchy nodes it visited.
pub(super) type PathPiece = (Vec<(u32, u32)>, u64);

/// The collision stage's per-step buffers.
#[derive(Debug, Default)]
pub struct CollisionScratch {
    /// This step's geometry of each contact (parallel to the contact set).
    pub(super) plans: Vec<Plan>,
    /// Which contacts are leaving their surface (parallel to the plans).
    pub(super) leaving: Vec<bool>,
    /// This step's poses (start, end) of each obstacle...
    pub(super) poses: Vec<(Pose, Pose)>,
    /// ...and the box each obstacle sweeps over the step.
    pub(super) swept: Vec<Aabb>,
    /// Predicted end positions.
    pub(super) predicted: Vec<Vec3>,
    /// One particle's contacts with their plans.
    pub(super) group: Vec<(Contact, Plan)>,
    /// Crossings found by the last test, `(particle, obstacle)`.
    pub(super) found: Vec<(u32, u32)>,
    /// Crossings found by this step's earlier solves, `(particle,
    /// obstacle)`, sorted: held through the step's redos, never let go as
    /// leaving (`CollisionStage::prepare`); cleared when the step is
    /// accepted.
    pub(super) held: Vec<(u32, u32)>,
    /// The path test's pieces (`super::paths`).
    pub(super) pieces: Vec<PathPiece>,
    /// Contacts the last accepted step released, with the velocity change
    /// their hold took away (`Self::released`).
    pub(super) released: Vec<(u32, Vec3)>,
    /// The contacts the last accepted step kept, `(particle, outward
    /// normal)`, in particle order (`Self::kept`).
    pub(super) kept: Vec<(u32, Vec3)>,
    /// Counters since the last [`Self::take_counters`].
    pub(super) counters: CollisionCounters,
}

impl CollisionScratch {
    /// Buffers for `obstacles` obstacles.
    pub fn new(obstacles: usize) -> Self {
        Self {
            poses: vec![(Pose::identity(), Pose::identity()); obstacles],
            swept: vec![Aabb::empty(); obstacles],
            ..Self::default()
        }
    }

    /// The particles whose contact the last accepted step released, each
    /// with the velocity change that contact's hold took from it: added to
    /// the warm start, it makes the next step's predicted path the one the
    /// particle takes free, so a particle leaving a surface is not caught
    /// again by a prediction biased towards the surface.
    pub fn released(&self) -> &[(u32, Vec3)] {
        &self.released
    }

    /// The contacts the last accepted step kept, each as its particle and
    /// the obstacle's outward normal there, in particle order: what holds
    /// a particle against a surface lets it leave along that normal (the
    /// self-collision response lifts a layer off a layer beneath it).
    pub fn kept(&self) -> &[(u32, Vec3)] {
        &self.kept
    }

    /// Counters accumulated since the last call, reset.
    pub fn take_counters(&mut self) -> CollisionCounters {
        std::mem::take(&mut self.counters)
    }
}
