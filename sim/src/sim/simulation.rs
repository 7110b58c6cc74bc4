//! [`Simulation`]: a scene's cloth, forces and solver, advanced frame by
//! frame.

use std::time::Instant;

use super::control::{Control, Progress};
use super::error::SimError;
use super::stats::{FrameStats, RunStats, StatsRecorder};
use crate::cloth::{ForceModel, Grid};
use crate::collision::{CollisionCounters, CollisionStage, Contact, Trajectory};
use crate::math::{Real, Vec3};
use crate::solver::{
    ClothState, Constraints, Integrator, MpcgOptions, Physics, SolveStatus, StageTimes, StepReport,
    make_preconditioner,
};
use crate::spec::{ClothScene, Scene, TimeStepping};

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

/// Redos of one step's solve when particles cross a surface mid-step;
/// crossings left after the last are handled by the next step.
const MAX_REDOS: usize = 2;

/// Accepted steps in a row before the adaptive controller tries a step
/// twice as large.
const ADAPTIVE_GROW_AFTER: u32 = 8;

/// A running simulation.
#[derive(Debug)]
pub struct Simulation {
    scene: Scene,
    grid: Grid,
    model: ForceModel,
    state: ClothState,
    integrator: Integrator,
    constraints: Constraints,
    /// Obstacles and contacts; `None` when the scene has no obstacles (or
    /// collision is switched off): no collision stage at all.
    collision: Option<CollisionStage>,
    pinned: Vec<bool>,
    /// Where pinned particles are held: their positions when the run
    /// started (or when the state was last replaced), in the frame of the
    /// motion they follow.
    anchors: Vec<Vec3>,
    /// Motions of moving pin groups (`scene.cloth.pin_motions`).
    pin_trajectories: Vec<Trajectory>,
    frame: usize,
    steps: usize,
    /// Adaptive stepping: current subdivision level and run of easy steps.
    level: u32,
    easy_steps: u32,
}

impl Simulation {
    /// Builds the cloth, its forces and the solver for `scene`.
    pub fn new(scene: &Scene) -> Result<Self, SimError> {
        let grid = Grid::new(&scene.cloth, scene.material.density);
        let model = ForceModel::new(&grid, &scene.material);
        let n = grid.len();
        let integrator = Integrator::new(
            n,
            &model,
            make_preconditioner(scene.solver.preconditioner, grid.nu, grid.nv),
            MpcgOptions {
                tolerance: scene.solver.tolerance,
                max_iterations: scene.solver.max_iterations,
                reference: None,
            },
            scene.solver.warm_start,
        );
        let state = ClothState {
            time: 0.0,
            x: grid.rest.clone(),
            v: vec![Vec3::zeros(); n],
        };
        let pin_trajectories: Vec<Trajectory> = scene
            .cloth
            .pin_motions
            .iter()
            .map(|m| Trajectory::new(Some(m)))
            .collect();
        let anchors = pin_anchors(&scene.cloth, &pin_trajectories, &grid.rest, 0.0);
        let mut pinned = vec![false; n];
        for &i in &scene.cloth.pinned {
            pinned[i] = true;
        }
        // NOTE: the offset follows the finer spacing: a grid resolves the
        // drape along its fine direction, and a strip spaced 1 mm along and
        // 5 mm across must not float 2 mm above its support.
        let collision = if scene.solver.collision {
            CollisionStage::new(&scene.obstacles, grid.du.min(grid.dv)).map_err(|(index, e)| {
                SimError::Obstacle {
                    index,
                    message: e.to_string(),
                }
            })?
        } else {
            None
        };
        let level = match scene.solver.stepping {
            TimeStepping::Fixed { .. } => 0,
            // Start near 1/240 s and let the controller find its way.
            TimeStepping::Adaptive { max_level } => {
                ((scene.frame_dt() * 240.0).log2().ceil().max(0.0) as u32).min(max_level)
            }
        };
        Ok(Self {
            scene: scene.clone(),
            grid,
            model,
            state,
            integrator,
            constraints: Constraints::free(n),
            collision,
            pinned,
            anchors,
            pin_trajectories,
            frame: 0,
            steps: 0,
            level,
            easy_steps: 0,
        })
    }

    /// The scene being simulated.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The particle grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The force model.
    pub fn model(&self) -> &ForceModel {
        &self.model
    }

    /// The current state.
    pub fn state(&self) -> &ClothState {
        &self.state
    }

    /// Replaces the state, to start from a configuration other than the
    /// flat grid (tests, checkpoints). Pins are re-anchored where the new
    /// state puts them; contacts are dropped and found again.
    pub fn set_state(&mut self, state: ClothState) {
        assert_eq!(
            state.x.len(),
            self.grid.len(),
            "state has the wrong particle count"
        );
        self.anchors = pin_anchors(
            &self.scene.cloth,
            &self.pin_trajectories,
            &state.x,
            state.time,
        );
        self.state = state;
        self.integrator.reset_warm_start();
        if let Some(stage) = &mut self.collision {
            // Contacts belong to the old state; the new one finds its own.
            stage.set_contacts(Vec::new());
        }
    }

    /// Index of the last finished frame (0 before any step).
    pub fn frame(&self) -> usize {
        self.frame
    }

    /// Steps taken so far.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// `true` once every frame of the scene is done.
    pub fn is_done(&self) -> bool {
        self.frame >= self.scene.frames
    }

    /// Kinetic energy `1/2 Σ m v²`.
    pub fn kinetic_energy(&self) -> Real {
        self.state
            .v
            .iter()
            .zip(&self.grid.mass)
            .map(|(v, m)| 0.5 * m * v.norm_squared())
            .sum()
    }

    /// Statistics of the current state as frame `frame` (no steps).
    pub fn snapshot_stats(&self) -> FrameStats {
        FrameStats {
            frame: self.frame,
            time: self.state.time,
            steps: 0,
            cg_iterations: 0,
            cg_iterations_max: 0,
            unconverged_solves: 0,
            subdivided_steps: 0,
            contacts: self.collision.as_ref().map_or(0, |c| c.contacts().len()),
            new_contacts: 0,
            released_contacts: 0,
            nodes_visited: 0,
            redone_solves: 0,
            collision_seconds: 0.0,
            step_seconds: 0.0,
            kinetic_energy: self.kinetic_energy(),
            max_stretch: self.model.stretch.max_ratio(&self.state.x),
            min_signed_distance: self
                .collision
                .as_ref()
                .map(|c| c.min_true_distance(&self.state.x, self.state.time)),
            dt: 0.0,
        }
    }

    /// Fills the constraints of a step from `time` to `time + h`: a fixed
    /// pin holds its anchor (`dv = -v`, `y` the drift back); a moving pin
    /// ends the step exactly where its motion puts the anchor, at the
    /// motion's mean velocity over the step (`z` and `y` of eq. [20]).
    fn constrain(&mut self, time: Real, h: Real) {
        self.constraints.clear();
        let cloth = &self.scene.cloth;
        // Each group's pose at both ends of the step, once per group.
        let poses: Vec<_> = self
            .pin_trajectories
            .iter()
            .map(|m| (m.pose(time), m.pose(time + h)))
            .collect();
        for ((&i, anchor), group) in cloth.pinned.iter().zip(&self.anchors).zip(&cloth.pin_group) {
            let (x, v) = (self.state.x[i], self.state.v[i]);
            match group {
                None => self.constraints.fix(i, -v, anchor - x),
                Some(g) => {
                    let (start, end) = &poses[*g];
                    let p0 = start * nalgebra::Point3::from(*anchor);
                    let p1 = end * nalgebra::Point3::from(*anchor);
                    let target = (p1 - p0) / h;
                    self.constraints
                        .fix(i, target - v, p1.coords - (x + h * target));
                }
            }
        }
    }

    /// One step of size `h`, with the step counter and errors attached:
    /// collision prepares contacts, the integrator solves, collision checks
    /// the path taken and the solve is redone (up to [`MAX_REDOS`] times)
    /// when a particle crossed a surface; then contacts are released or
    /// change friction state from the accepted solve's constraint forces.
    fn step(&mut self, h: Real) -> Result<StepReport, SimError> {
        let _span = tracing::trace_span!("step", step = self.steps).entered();
        let time = self.state.time;
        let start = self.collision.is_some().then(|| self.state.clone());
        let mut iterations = 0;
        let mut times = StageTimes::default();
        let mut collision_seconds = 0.0;
        let mut redos = 0;
        loop {
            self.constrain(time, h);
            if let Some(stage) = &mut self.collision {
                let t = Instant::now();
                stage.prepare(
                    &self.state.x,
                    &self.state.v,
                    self.integrator.last_dv(),
                    &self.grid.mass,
                    time,
                    h,
                    &self.pinned,
                    &mut self.constraints,
                );
                collision_seconds += t.elapsed().as_secs_f64();
            }
            let physics = Physics {
                model: &self.model,
                mass: &self.grid.mass,
                gravity: self.scene.gravity,
            };
            let report = self
                .integrator
                .step(&mut self.state, &physics, &self.constraints, h)
                .map_err(|e| SimError::NonFinite {
                    step: self.steps,
                    time,
                    particle: e.particle,
                    quantity: e.quantity,
                })?;
            iterations += report.solve.iterations;
            times.add(&report.times);
            let mut solve = report.solve;
            solve.iterations = iterations;
            let (Some(stage), Some(start)) = (&mut self.collision, &start) else {
                self.steps += 1;
                return Ok(StepReport { solve, times });
            };
            let t = Instant::now();
            let crossings = stage.check(&start.x, &self.state.x, &self.pinned);
            if !crossings.is_empty() && redos < MAX_REDOS {
                stage.redo_with(&crossings);
                self.state.clone_from(start);
                redos += 1;
                collision_seconds += t.elapsed().as_secs_f64();
                continue;
            }
            let integrator = &self.integrator;
            let g = self.scene.gravity.norm();
            stage.update(&self.state.v, &self.grid.mass, g, h, |i| {
                integrator.constraint_impulse(i)
            });
            stage.add_late(&crossings);
            collision_seconds += t.elapsed().as_secs_f64();
            self.steps += 1;
            times.collision = collision_seconds;
            return Ok(StepReport { solve, times });
        }
    }

    /// What a rejected step must restore: the cloth and the contact set.
    fn snapshot(&self) -> (ClothState, Option<Vec<Contact>>) {
        (
            self.state.clone(),
            self.collision.as_ref().map(|c| c.contacts().to_vec()),
        )
    }

    fn restore(&mut self, (state, contacts): (ClothState, Option<Vec<Contact>>)) {
        self.state = state;
        if let (Some(stage), Some(contacts)) = (&mut self.collision, contacts) {
            stage.set_contacts(contacts);
        }
        self.integrator.reset_warm_start();
    }

    /// One step of `h` outside the frame loop (benchmarks, tools): pins
    /// held, no subdivision, no frame bookkeeping.
    pub fn step_once(&mut self, h: Real) -> Result<StepReport, SimError> {
        self.step(h)
    }

    /// Advances to the next frame and returns its statistics.
    pub fn advance_frame(&mut self, control: &Control<'_>) -> Result<FrameStats, SimError> {
        let (stats, _) = self.advance_frame_timed(control)?;
        Ok(stats)
    }

    /// [`Self::advance_frame`], also returning the frame's stage times.
    pub fn advance_frame_timed(
        &mut self,
        control: &Control<'_>,
    ) -> Result<(FrameStats, StageTimes), SimError> {
        let start = Instant::now();
        let mut acc = FrameAccumulator::default();
        let frame_dt = self.scene.frame_dt();
        let target = (self.frame + 1) as Real * frame_dt;
        match self.scene.solver.stepping {
            TimeStepping::Fixed { substeps } => {
                let h = frame_dt / substeps as Real;
                for _ in 0..substeps {
                    self.check_cancel(control)?;
                    self.guarded_step(h, 0, &mut acc)?;
                }
            }
            TimeStepping::Adaptive { max_level } => {
                self.advance_adaptive(control, max_level, &mut acc)?;
            }
        }
        // Land exactly on the frame time despite summed round-off.
        self.state.time = target;
        self.frame += 1;
        let mut stats = self.snapshot_stats();
        stats.steps = acc.steps;
        stats.cg_iterations = acc.iterations;
        stats.cg_iterations_max = acc.iterations_max;
        stats.unconverged_solves = acc.unconverged;
        stats.subdivided_steps = acc.subdivided;
        stats.collision_seconds = acc.times.collision;
        if let Some(stage) = &mut self.collision {
            let counters: CollisionCounters = stage.take_counters();
            stats.new_contacts = counters.new;
            stats.released_contacts = counters.released;
            stats.nodes_visited = counters.nodes;
            stats.redone_solves = counters.redone;
        }
        stats.step_seconds = start.elapsed().as_secs_f64();
        stats.dt = acc.last_h;
        if let Some(p) = control.progress {
            p(Progress {
                frame: self.frame,
                frames: self.scene.frames,
                steps: self.steps,
                time: self.state.time,
            });
        }
        Ok((stats, acc.times))
    }

    /// A fixed step of `h`, redone as two half steps (recursively, up to
    /// [`SUBDIVIDE_MAX_DEPTH`]) when it stretches an edge past
    /// [`SUBDIVIDE_STRETCH`] in one jump: a long step through a fast swing (a free edge
    /// whipping round) is where one implicit step overshoots, and the
    /// halves resolve it. Ordinary steps pay one O(springs) check.
    fn guarded_step(
        &mut self,
        h: Real,
        depth: u32,
        acc: &mut FrameAccumulator,
    ) -> Result<(), SimError> {
        let before = self.model.stretch.max_ratio(&self.state.x);
        let backup = (depth < SUBDIVIDE_MAX_DEPTH).then(|| self.snapshot());
        let r = self.step(h)?;
        let after = self.model.stretch.max_ratio(&self.state.x);
        match backup {
            Some(snapshot) if after > SUBDIVIDE_STRETCH && after - before > SUBDIVIDE_JUMP => {
                self.restore(snapshot);
                self.steps -= 1;
                acc.subdivided += 1;
                self.guarded_step(h / 2.0, depth + 1, acc)?;
                self.guarded_step(h / 2.0, depth + 1, acc)
            }
            _ => {
                acc.add(&r, h);
                Ok(())
            }
        }
    }

    /// Steps of `frame_dt / 2^level` until the frame is covered: a step is
    /// redone at half size when its solve fails, it produces non-finite
    /// numbers, or it stretches an edge past [`ADAPTIVE_MAX_STRETCH`]; after
    /// [`ADAPTIVE_GROW_AFTER`] good steps the size doubles where that stays
    /// aligned with the frame.
    fn advance_adaptive(
        &mut self,
        control: &Control<'_>,
        max_level: u32,
        acc: &mut FrameAccumulator,
    ) -> Result<(), SimError> {
        let frame_dt = self.scene.frame_dt();
        // The frame in units of the finest step.
        let units: u64 = 1 << max_level;
        let mut done: u64 = 0;
        while done < units {
            self.check_cancel(control)?;
            let h = frame_dt / (1u64 << self.level) as Real;
            let backup = self.snapshot();
            let result = self.step(h);
            let ok = match &result {
                Ok(r) => {
                    r.solve.status == SolveStatus::Converged
                        && self.model.stretch.max_ratio(&self.state.x) <= ADAPTIVE_MAX_STRETCH
                }
                Err(_) => false,
            };
            if !ok && self.level < max_level {
                self.restore(backup);
                self.level += 1;
                self.easy_steps = 0;
                if result.is_ok() {
                    self.steps -= 1; // the rejected step does not count
                }
                continue;
            }
            let r = result?;
            acc.add(&r, h);
            done += 1 << (max_level - self.level);
            self.easy_steps += 1;
            let coarser = 1u64 << (max_level - self.level + 1);
            if self.easy_steps >= ADAPTIVE_GROW_AFTER
                && self.level > 0
                && done.is_multiple_of(coarser)
            {
                self.level -= 1;
                self.easy_steps = 0;
            }
        }
        Ok(())
    }

    fn check_cancel(&self, control: &Control<'_>) -> Result<(), SimError> {
        if control.is_cancelled() {
            Err(SimError::Cancelled { step: self.steps })
        } else {
            Ok(())
        }
    }

    /// Runs every remaining frame, handing each to `on_frame` (frame 0
    /// first if nothing has run yet) and recording it in `rec`. On error the
    /// recorder still holds every finished frame, so the caller can report
    /// them.
    pub fn run<E: std::fmt::Display>(
        &mut self,
        control: &Control<'_>,
        rec: &mut StatsRecorder,
        mut on_frame: impl FnMut(&Self, &FrameStats) -> Result<(), E>,
    ) -> Result<(), SimError> {
        if self.frame == 0 && self.steps == 0 {
            let s = self.snapshot_stats();
            on_frame(self, &s).map_err(|e| SimError::Output(e.to_string()))?;
            rec.record(s, &StageTimes::default());
        }
        while !self.is_done() {
            let (s, times) = match self.advance_frame_timed(control) {
                Ok(r) => r,
                Err(e) => {
                    if matches!(e, SimError::NonFinite { .. }) {
                        rec.mark_non_finite();
                    }
                    return Err(e);
                }
            };
            on_frame(self, &s).map_err(|e| SimError::Output(e.to_string()))?;
            rec.record(s, &times);
        }
        Ok(())
    }

    /// [`Self::run`] with a fresh [`Self::recorder`], timed here: the
    /// statistics of every finished frame (`wall_seconds` for the whole
    /// call) and how the run ended.
    pub fn run_recorded<E: std::fmt::Display>(
        &mut self,
        control: &Control<'_>,
        on_frame: impl FnMut(&Self, &FrameStats) -> Result<(), E>,
    ) -> (RunStats, Result<(), SimError>) {
        let mut rec = self.recorder();
        let start = Instant::now();
        let result = self.run(control, &mut rec, on_frame);
        (rec.finish(start.elapsed().as_secs_f64()), result)
    }

    /// A fresh recorder for this simulation's run.
    pub fn recorder(&self) -> StatsRecorder {
        let mut rec = StatsRecorder::new(&self.scene.name, self.grid.len());
        if let Some(stage) = &self.collision {
            rec.set_obstacle_offsets(
                stage
                    .colliders()
                    .iter()
                    .map(|c| c.surface.offset())
                    .collect(),
            );
        }
        rec
    }

    /// Where the pins are held.
    pub(crate) fn anchors(&self) -> &[Vec3] {
        &self.anchors
    }

    /// The next solve's warm start.
    pub(crate) fn warm_start(&self) -> &[Vec3] {
        self.integrator.last_dv()
    }

    /// The adaptive controller's level and run of easy steps.
    pub(crate) fn adaptive_state(&self) -> (u32, u32) {
        (self.level, self.easy_steps)
    }

    /// Puts a checked checkpoint in place (see `checkpoint.rs`).
    pub(crate) fn restore_checkpoint(&mut self, c: super::Checkpoint) {
        self.frame = c.frame;
        self.steps = c.steps;
        self.state = c.state;
        self.anchors = c.anchors;
        if let Some(stage) = &mut self.collision {
            stage.set_contacts(c.contacts);
        }
        self.integrator.set_warm_start(&c.warm_start);
        self.level = c.level;
        self.easy_steps = c.easy_steps;
    }

    /// The collision stage, if the scene has one.
    pub fn collision(&self) -> Option<&CollisionStage> {
        self.collision.as_ref()
    }
}

/// Where each pinned particle is held, given positions `x` at `time`: a
/// fixed pin where it is, a moving one in its motion's frame at `time`,
/// so it follows the motion's change from there. One rule for a new run
/// and a replaced state.
fn pin_anchors(cloth: &ClothScene, motions: &[Trajectory], x: &[Vec3], time: Real) -> Vec<Vec3> {
    cloth
        .pinned
        .iter()
        .zip(&cloth.pin_group)
        .map(|(&i, group)| match group {
            None => x[i],
            Some(g) => {
                motions[*g]
                    .pose(time)
                    .inverse_transform_point(&x[i].into())
                    .coords
            }
        })
        .collect()
}

/// Sums step reports within a frame.
#[derive(Debug, Default)]
struct FrameAccumulator {
    steps: usize,
    iterations: usize,
    iterations_max: usize,
    unconverged: usize,
    subdivided: usize,
    times: StageTimes,
    last_h: Real,
}

impl FrameAccumulator {
    fn add(&mut self, r: &StepReport, h: Real) {
        self.steps += 1;
        self.iterations += r.solve.iterations;
        self.iterations_max = self.iterations_max.max(r.solve.iterations);
        self.unconverged += usize::from(r.solve.status != SolveStatus::Converged);
        self.times.add(&r.times);
        self.last_h = h;
    }
}
