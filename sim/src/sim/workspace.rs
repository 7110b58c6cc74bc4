//! Scratch memory of a running simulation: everything a step writes and
//! the next step overwrites, kept only so that nothing allocates per step.

use super::apart::ApartScratch;
use super::energy::EnergyGuard;
use super::sharp::SharpStage;
use super::state::RunState;
use super::world::World;
use crate::collision::CollisionScratch;
use crate::selfcollision::{ClothMesh, SelfCollision};
use crate::solver::{ClothState, Constraints, Integrator};

/// The buffers of a simulation.
#[derive(Debug)]
pub struct Workspace {
    /// The linear system, its preconditioner and the solver's scratch.
    pub integrator: Integrator,
    /// This step's filters, targets, corrections and impulses.
    pub constraints: Constraints,
    /// The collision stage's buffers.
    pub collision: CollisionScratch,
    /// The cloth at the start of the step being taken (a redo restarts
    /// from it, the collision stage tests the path from it).
    pub step_start: ClothState,
    /// States saved before steps that may be rejected, one per nesting
    /// depth of subdivision.
    pub rollback: Vec<RunState>,
    /// BDF2's energy guard (`super::energy`).
    pub energy: EnergyGuard,
    /// Each particle's displacement in the step being taken.
    pub moved: Vec<crate::math::Vec3>,
    /// Each particle's displacement as the solve left it, before the
    /// self-collision and sharp-feature stages corrected it: BDF2's
    /// memory (`RunState::last_dx`).
    pub solved: Vec<crate::math::Vec3>,
    /// The positions the self-collision stage left, before the
    /// sharp-feature stage's corrections (`selfcollision::recheck`).
    pub before_sharp: Vec<crate::math::Vec3>,
    /// The first solve's friction impulses while a step is redone
    /// (`Integrator::patch_for_redo`).
    pub redo_impulse: Vec<crate::math::Vec3>,
    /// The cloth's self-collision (`None` when the scene turns it off).
    pub self_collision: Option<SelfCollision>,
    /// The cloth's mesh for the crossing count of every frame when
    /// self-collision is off (with it on, its own mesh counts).
    pub crossings: Option<ClothMesh>,
    /// The self-collision stage's buffers.
    pub apart: ApartScratch,
    /// The sharp-feature stage (`None` when no obstacle has features).
    pub sharp: Option<SharpStage>,
    /// Whether the steps' loops run faster shared or alone.
    pub tuner: crate::parallel::Tuner,
}

impl Workspace {
    /// Buffers for `world`, shaped like `state`.
    pub fn new(world: &World, state: &RunState) -> Self {
        let n = world.grid.len();
        let spring = world
            .model
            .stretch
            .springs
            .iter()
            .map(|s| s.k)
            .fold(0.0, crate::math::Real::max);
        Self {
            integrator: Integrator::new(
                &world.grid,
                &world.model,
                &world.scene.solver,
                world.scene.largest_step(),
            ),
            constraints: Constraints::free(n),
            collision: CollisionScratch::new(
                world.obstacles.as_ref().map_or(0, |o| o.colliders().len()),
            ),
            step_start: state.state.clone(),
            rollback: Vec::new(),
            energy: EnergyGuard::default(),
            moved: vec![crate::math::Vec3::zeros(); n],
            solved: Vec::new(),
            before_sharp: Vec::new(),
            redo_impulse: Vec::new(),
            self_collision: world
                .scene
                .cloth
                .self_thickness
                .map(|t| SelfCollision::new(&world.grid, t)),
            crossings: world
                .scene
                .cloth
                .self_thickness
                .is_none()
                .then(|| ClothMesh::new(&world.grid)),
            apart: ApartScratch::default(),
            sharp: SharpStage::new(&world.grid, spring, world.obstacles.as_ref()),
            tuner: crate::parallel::Tuner::default(),
        }
    }

    /// Saves `state` in the rollback buffer of `depth`.
    pub fn save(&mut self, depth: usize, state: &RunState) {
        if self.rollback.len() <= depth {
            self.rollback.resize_with(depth + 1, || state.clone());
        }
        self.rollback[depth].clone_from(state);
    }

    /// Puts back the state saved at `depth`, forgetting the rejected
    /// step's velocity change (it must not warm-start the retry).
    pub fn restore(&self, depth: usize, state: &mut RunState) {
        state.clone_from(&self.rollback[depth]);
        state.warm_start.fill(nalgebra::zero());
    }
}
