//! How a frame's interval is cut into steps: fixed steps (each redone as
//! two halves when it overstretches in one jump), or the adaptive
//! controller. Both save the state before a step that may be rejected and
//! put it back from the workspace's rollback buffers.

use super::control::Control;
use super::error::SimError;
use super::stage::StageTimes;
use super::state::RunState;
use super::step::{StepReport, step};
use super::workspace::Workspace;
use super::world::World;
use crate::math::Real;
use crate::selfcollision::SelfReport;
use crate::solver::SolveStatus;
use crate::spec::{IntegratorKind, TimeStepping};

/// Largest edge stretch an adaptive step may reach before it is redone at
/// half the size; beyond 10 % a fabric is far outside its linear range.
const ADAPTIVE_MAX_STRETCH: Real = 1.10;
/// A fixed step that leaves an edge stretched past this is redone as two
/// half steps (the user's bound: stretch under 2 %)...
const SUBDIVIDE_STRETCH: Real = 1.02;
/// ...if the step itself raised the worst stretch by more than this: a jump
/// within one step is the step's artifact, while a steady stretch (a point
/// load at a pin on a fine grid) is physics that smaller steps cannot remove.
const SUBDIVIDE_JUMP: Real = 0.005;
/// Halvings of one fixed step at most (a step becomes at most 16 steps).
const SUBDIVIDE_MAX_DEPTH: u32 = 4;
/// Accepted steps in a row, each with room for a step twice as large,
/// before the adaptive controller takes one.
const ADAPTIVE_GROW_AFTER: u32 = 4;
/// The room: a doubled step's predicted error at most this share of its
/// allowance (the estimate is itself good to tens of percent).
const ADAPTIVE_GROW_MARGIN: Real = 0.5;

/// The steps of one frame, summed.
#[derive(Debug, Default)]
pub struct FrameAccumulator {
    /// Steps accepted.
    pub steps: usize,
    /// CG iterations.
    pub iterations: usize,
    /// Most CG iterations of one step.
    pub iterations_max: usize,
    /// Solves that stopped before the tolerance.
    pub unconverged: usize,
    /// Fixed steps redone as two halves.
    pub subdivided: usize,
    /// Of those, BDF2 steps that gained energy (`super::energy`).
    pub energy_subdivided: usize,
    /// Adaptive steps rejected and redone at half size.
    pub rejected: usize,
    /// Adaptive steps accepted over their error share at the finest size.
    pub missed: usize,
    /// The steps' local error estimates summed, metres.
    pub error: Real,
    /// Stage times, of the steps redone too (their work was done).
    pub times: StageTimes,
    /// The last step's size.
    pub last_h: Real,
    /// Self-collision's work, summed (`failsafe` unused).
    pub self_collision: SelfReport,
    /// Steps that needed self-collision's fail-safe stop.
    pub self_failsafe_steps: usize,
}

impl FrameAccumulator {
    fn add(&mut self, r: &StepReport, h: Real) {
        self.steps += 1;
        self.iterations += r.solve.iterations;
        self.iterations_max = self.iterations_max.max(r.solve.iterations);
        self.unconverged += usize::from(r.solve.status != SolveStatus::Converged);
        self.times.add(&r.times);
        self.last_h = h;
        self.error += r.error;
        let s = &r.self_collision;
        self.self_collision.contacts += s.contacts;
        self.self_collision.collisions += s.collisions;
        self.self_collision.zones += s.zones;
        self.self_failsafe_steps += usize::from(s.failsafe);
    }
}

/// The simulation's parts a driver moves: fixed world, state, buffers.
#[derive(Debug)]
pub struct Driver<'a> {
    /// What the scene built.
    pub world: &'a World,
    /// The run's state.
    pub run: &'a mut RunState,
    /// Scratch.
    pub ws: &'a mut Workspace,
}

impl Driver<'_> {
    /// One step of `h`, its loops shared or alone as the tuner says
    /// (`parallel::Tuner`: the same results either way).
    fn step(&mut self, h: Real) -> Result<super::step::StepReport, SimError> {
        self.ws.tuner.begin();
        let result = step(self.world, self.run, self.ws, h);
        self.ws.tuner.end();
        result
    }

    /// Whether the step just taken from the state saved at `slot` gained
    /// energy, for a BDF2 cloth without obstacles or moving pins
    /// (`super::energy`; its restarts by backward Euler too, which gain
    /// energy from the states BDF2 leaves where Euler alone would not go).
    fn gained_energy(&mut self, slot: usize) -> bool {
        self.world.scene.solver.integrator == IntegratorKind::Bdf2
            && self.world.obstacles.is_none()
            && !self.world.pins.moving()
            && self
                .ws
                .energy
                .gained(self.world, &self.ws.rollback[slot].state, &self.run.state)
    }

    /// Steps over one frame interval (the caller lands the time exactly
    /// on the frame).
    pub fn advance_frame(&mut self, control: &Control<'_>) -> Result<FrameAccumulator, SimError> {
        let mut acc = FrameAccumulator::default();
        let frame_dt = self.world.scene.frame_dt();
        match self.world.scene.solver.stepping {
            TimeStepping::Fixed { substeps } => {
                let h = frame_dt / substeps as Real;
                for _ in 0..substeps {
                    self.check_cancel(control)?;
                    self.guarded_step(h, 0, &mut acc)?;
                }
            }
            TimeStepping::Adaptive { max_level, error } => {
                self.adaptive(control, max_level, error, &mut acc)?;
            }
        }
        Ok(acc)
    }

    /// A fixed step of `h`, redone as two half steps (recursively, up to
    /// [`SUBDIVIDE_MAX_DEPTH`]) when it stretches an edge past
    /// [`SUBDIVIDE_STRETCH`] in one jump, or when a BDF2 step of a cloth
    /// without obstacles or moving pins gains energy (`super::energy`): a
    /// long step through a fast swing (a free edge whipping round) is
    /// where one implicit step overshoots, and the halves resolve it.
    /// Also when self-collision's or the sharp-feature stage's pairs
    /// passed their budget (`selfcollision::budget`), or the sharp-feature
    /// stage's corrections passed the cloth through itself
    /// (`selfcollision::recheck`): the halves move the cloth less; at the
    /// deepest halving the step is kept as it is.
    /// Ordinary steps pay one O(springs) check, and BDF2's one energy
    /// evaluation.
    fn guarded_step(
        &mut self,
        h: Real,
        depth: u32,
        acc: &mut FrameAccumulator,
    ) -> Result<(), SimError> {
        let stretch = &self.world.model.stretch;
        let before = stretch.max_ratio(&self.run.state.x);
        let may_halve = depth < SUBDIVIDE_MAX_DEPTH;
        let slot = depth as usize;
        if may_halve {
            self.ws.save(slot, self.run);
        }
        let r = self.step(h)?;
        let after = stretch.max_ratio(&self.run.state.x);
        let jumped = after > SUBDIVIDE_STRETCH && after - before > SUBDIVIDE_JUMP;
        let crowded = r.self_collision.over_budget || r.sharp_over_budget;
        let crossed = r.crossed_after_sharp;
        let gained = may_halve && !jumped && !crowded && !crossed && self.gained_energy(slot);
        if may_halve && (jumped || crowded || crossed || gained) {
            self.ws.restore(slot, self.run);
            acc.times.add(&r.times);
            acc.subdivided += 1;
            acc.energy_subdivided += usize::from(gained);
            self.guarded_step(h / 2.0, depth + 1, acc)?;
            self.guarded_step(h / 2.0, depth + 1, acc)
        } else {
            acc.add(&r, h);
            Ok(())
        }
    }

    /// Steps of `frame_dt / 2^level` until the frame is covered, the level
    /// set by each step's embedded error estimate (`StepReport::error`):
    /// a step may add its share `error · h / frame_dt` of the frame's
    /// error, so the frame's local errors sum to at most `error`.
    ///
    /// A step is redone at half size when its estimate exceeds its share,
    /// its solve fails, it produces non-finite numbers, it stretches an
    /// edge past [`ADAPTIVE_MAX_STRETCH`], self-collision's or the
    /// sharp-feature stage's pairs passed their budget, or the
    /// sharp-feature stage's corrections passed the cloth through itself
    /// (the fail-safes). After
    /// [`ADAPTIVE_GROW_AFTER`] steps in a row whose estimate says a step
    /// twice as large would pass with room to spare (the estimate scales
    /// as `h^q`, `q` the local order: 2 for backward Euler, 3 for BDF2,
    /// against a share that scales as `h`), the size doubles where that
    /// stays aligned with the frame. Power-of-two steps keep frames on
    /// steps and BDF2's step ratios at 1/2, 1 or 2, inside its stable range.
    fn adaptive(
        &mut self,
        control: &Control<'_>,
        max_level: u32,
        error: Real,
        acc: &mut FrameAccumulator,
    ) -> Result<(), SimError> {
        let frame_dt = self.world.scene.frame_dt();
        let order: i32 = match self.world.scene.solver.integrator {
            IntegratorKind::Euler => 2,
            IntegratorKind::Bdf2 => 3,
        };
        // The frame in units of the finest step.
        let units: u64 = 1 << max_level;
        let mut done: u64 = 0;
        while done < units {
            self.check_cancel(control)?;
            let h = frame_dt / (1u64 << self.run.level) as Real;
            let share = error * h / frame_dt;
            self.ws.save(0, self.run);
            let result = self.step(h);
            let ok = match &result {
                Ok(r) => {
                    r.solve.status == SolveStatus::Converged
                        && !r.self_collision.over_budget
                        && !r.sharp_over_budget
                        && !r.crossed_after_sharp
                        && r.error <= share
                        && self.world.model.stretch.max_ratio(&self.run.state.x)
                            <= ADAPTIVE_MAX_STRETCH
                }
                Err(_) => false,
            };
            if !ok && self.run.level < max_level {
                self.ws.restore(0, self.run);
                if let Ok(r) = &result {
                    acc.times.add(&r.times);
                }
                self.run.level += 1;
                self.run.easy_steps = 0;
                acc.rejected += 1;
                continue;
            }
            let r = result?;
            acc.add(&r, h);
            acc.missed += usize::from(r.error > share);
            let level = self.run.level;
            done += 1 << (max_level - level);
            let doubled = r.error * Real::powi(2.0, order);
            if doubled <= ADAPTIVE_GROW_MARGIN * 2.0 * share {
                self.run.easy_steps += 1;
            } else {
                self.run.easy_steps = 0;
            }
            let coarser = 1u64 << (max_level - level + 1);
            if self.run.easy_steps >= ADAPTIVE_GROW_AFTER
                && level > 0
                && done.is_multiple_of(coarser)
            {
                self.run.level -= 1;
                self.run.easy_steps = 0;
            }
        }
        Ok(())
    }

    fn check_cancel(&self, control: &Control<'_>) -> Result<(), SimError> {
        if control.is_cancelled() {
            Err(SimError::Cancelled {
                step: self.run.steps,
            })
        } else {
            Ok(())
        }
    }
}
