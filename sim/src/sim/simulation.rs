//! [`Simulation`]: a scene advanced frame by frame. It holds the three
//! parts of a run — the [`World`] the scene built, the [`RunState`] the
//! steps change (and a checkpoint copies), the [`Workspace`] they scribble
//! in — and hands them to the driver and the step.

use std::time::Instant;

use super::control::{Control, Progress};
use super::driver::Driver;
use super::error::SimError;
use super::stage::StageTimes;
use super::state::RunState;
use super::stats::{FrameStats, RunStats, StatsRecorder};
use super::step::{StepReport, step};
use super::workspace::Workspace;
use super::world::World;
use crate::cloth::{ForceModel, Grid};
use crate::collision::{Collider, Contact};
use crate::math::Real;
use crate::solver::ClothState;
use crate::spec::Scene;

/// A running simulation.
#[derive(Debug)]
pub struct Simulation {
    world: World,
    run: RunState,
    ws: Workspace,
}

impl Simulation {
    /// Builds the cloth, its forces, the obstacles and the solver for
    /// `scene`, at rest at time 0.
    pub fn new(scene: &Scene) -> Result<Self, SimError> {
        let world = World::new(scene)?;
        let run = RunState::new(&world);
        let ws = Workspace::new(&world, &run);
        Ok(Self { world, run, ws })
    }

    /// The scene being simulated.
    pub fn scene(&self) -> &Scene {
        &self.world.scene
    }

    /// The particle grid.
    pub fn grid(&self) -> &Grid {
        &self.world.grid
    }

    /// The force model.
    pub fn model(&self) -> &ForceModel {
        &self.world.model
    }

    /// The obstacles (empty without a collision stage).
    pub fn obstacles(&self) -> &[Collider] {
        self.world.obstacles.as_ref().map_or(&[], |o| o.colliders())
    }

    /// The particles held by obstacles now.
    pub fn contacts(&self) -> &[Contact] {
        self.run.contacts()
    }

    /// The particles in self contact in the last step, in index order;
    /// `None` when the cloth does not collide with itself.
    pub fn self_contact_particles(&self) -> Option<Vec<u32>> {
        self.ws
            .self_collision
            .as_ref()
            .map(|sc| sc.contact_particles().collect())
    }

    /// The cloth now.
    pub fn state(&self) -> &ClothState {
        &self.run.state
    }

    /// The whole run's state.
    pub fn run_state(&self) -> &RunState {
        &self.run
    }

    /// Replaces the cloth, to start from a configuration other than the
    /// flat grid (tests, a crumpled start). Pins are re-anchored where the
    /// new state puts them; contacts are dropped and found again. A state
    /// with another particle count is refused.
    pub fn set_state(&mut self, state: ClothState) -> Result<(), SimError> {
        let n = self.world.grid.len();
        if state.x.len() != n || state.v.len() != n {
            return Err(SimError::Checkpoint(format!(
                "holds a cloth of another size (expected {n} particles)"
            )));
        }
        self.run.replace_cloth(&self.world, state);
        Ok(())
    }

    /// The run's state now, to continue later with [`Self::resume`]. Taken
    /// between frames (in a frame callback), it resumes exactly.
    pub fn checkpoint(&self) -> RunState {
        self.run.clone()
    }

    /// Continues from `state`, a checkpoint of a run of the same scene. A
    /// checkpoint that does not fit the scene (another particle count,
    /// contacts with unknown particles or obstacles, a frame past the end)
    /// is refused, and the simulation is left as it was.
    pub fn resume(&mut self, state: RunState) -> Result<(), SimError> {
        state.check_fits(&self.world)?;
        self.run = state;
        Ok(())
    }

    /// Index of the last finished frame (0 before any step).
    pub fn frame(&self) -> usize {
        self.run.frame
    }

    /// Steps taken so far.
    pub fn steps(&self) -> usize {
        self.run.steps
    }

    /// `true` once every frame of the scene is done.
    pub fn is_done(&self) -> bool {
        self.run.frame >= self.world.scene.frames
    }

    /// Kinetic energy `1/2 Σ m v²`.
    pub fn kinetic_energy(&self) -> Real {
        self.run.kinetic_energy(&self.world.grid.mass)
    }

    /// Statistics of the current state as frame `frame` (no steps).
    pub fn snapshot_stats(&self) -> FrameStats {
        let x = &self.run.state.x;
        FrameStats {
            frame: self.run.frame,
            time: self.run.state.time,
            steps: 0,
            cg_iterations: 0,
            cg_iterations_max: 0,
            unconverged_solves: 0,
            subdivided_steps: 0,
            energy_subdivided_steps: 0,
            rejected_steps: 0,
            error_missed_steps: 0,
            local_error: 0.0,
            contacts: self.run.contacts.len(),
            new_contacts: 0,
            released_contacts: 0,
            nodes_visited: 0,
            redone_solves: 0,
            collision_seconds: 0.0,
            step_seconds: 0.0,
            kinetic_energy: self.kinetic_energy(),
            max_stretch: self.world.model.stretch.max_ratio(x),
            min_signed_distance: self
                .world
                .obstacles
                .as_ref()
                .map(|o| o.min_true_distance(x, self.run.state.time)),
            dt: 0.0,
            self_contacts: 0,
            self_collisions: 0,
            impact_zones: 0,
            self_failsafe_steps: 0,
            self_collision_seconds: 0.0,
            self_crossings: 0,
            obstacle_crossings: 0,
        }
    }

    /// One step of `h` outside the frame loop (benchmarks, tools): pins
    /// held, no subdivision, no frame bookkeeping.
    pub fn step_once(&mut self, h: Real) -> Result<StepReport, SimError> {
        let _flush = crate::subnormals::Flush::new();
        step(&self.world, &mut self.run, &mut self.ws, h)
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
        let _flush = crate::subnormals::Flush::new();
        let acc = Driver {
            world: &self.world,
            run: &mut self.run,
            ws: &mut self.ws,
        }
        .advance_frame(control)?;
        // Land exactly on the frame time despite summed round-off.
        self.run.state.time = (self.run.frame + 1) as Real * self.world.scene.frame_dt();
        self.run.frame += 1;
        let counters = self.ws.collision.take_counters();
        let x = &self.run.state.x;
        let self_crossings = match (&mut self.ws.self_collision, &mut self.ws.crossings) {
            (Some(sc), _) => sc.crossings(x),
            (None, Some(mesh)) => crate::selfcollision::count_crossings_culled(mesh, x),
            (None, None) => 0,
        };
        let obstacle_crossings = match (&mut self.ws.sharp, &self.world.obstacles) {
            (Some(sharp), Some(obstacles)) => {
                sharp.crossings(obstacles, self.run.state.time, &self.run.state.x)
            }
            _ => 0,
        };
        let stats = FrameStats {
            steps: acc.steps,
            cg_iterations: acc.iterations,
            cg_iterations_max: acc.iterations_max,
            unconverged_solves: acc.unconverged,
            subdivided_steps: acc.subdivided,
            energy_subdivided_steps: acc.energy_subdivided,
            rejected_steps: acc.rejected,
            error_missed_steps: acc.missed,
            local_error: acc.error,
            collision_seconds: acc.times.collision(),
            new_contacts: counters.new,
            released_contacts: counters.released,
            nodes_visited: counters.nodes,
            redone_solves: counters.redone,
            step_seconds: start.elapsed().as_secs_f64(),
            dt: acc.last_h,
            self_contacts: acc.self_collision.contacts,
            self_collisions: acc.self_collision.collisions,
            impact_zones: acc.self_collision.zones,
            self_failsafe_steps: acc.self_failsafe_steps,
            self_collision_seconds: acc.times.get(super::stage::Stage::SelfCollision),
            self_crossings,
            obstacle_crossings,
            ..self.snapshot_stats()
        };
        if let Some(p) = control.progress {
            p(Progress {
                frame: self.run.frame,
                frames: self.world.scene.frames,
                steps: self.run.steps,
                time: self.run.state.time,
            });
        }
        Ok((stats, acc.times))
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
        if self.run.frame == 0 && self.run.steps == 0 {
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
        let mut rec = StatsRecorder::new(&self.world.scene.name, self.world.grid.len());
        if let Some(o) = &self.world.obstacles {
            rec.set_obstacle_offsets(o.offsets());
        }
        rec.set_cloth_thickness(self.world.scene.cloth.self_thickness);
        rec.set_integrator(self.world.scene.solver.integrator);
        rec
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::scene_from_json;

    /// A run stopped at frame 5 and resumed from its checkpoint (after a
    /// round trip through JSON) writes the same frames, bit for bit, as an
    /// uninterrupted run: the checkpoint holds everything the steps read.
    #[test]
    fn resumed_run_matches_uninterrupted_run() {
        let s = scene_from_json(
            r#"{"cloth": {"grid": [8, 8], "size": [0.5, 0.5], "origin": [-0.25, -0.25, 0.3]},
                "material": "cotton",
                "obstacles": [{"sphere": {"center": [0, 0, 0], "radius": 0.2}, "friction": 0.4}],
                "duration": 0.5, "fps": 20}"#,
        );
        let control = Control::default();
        let mut whole = Simulation::new(&s).expect("builds");
        let mut reference = Vec::new();
        while !whole.is_done() {
            whole.advance_frame(&control).expect("steps");
            reference.push(whole.state().x.clone());
        }

        let mut first = Simulation::new(&s).expect("builds");
        for _ in 0..5 {
            first.advance_frame(&control).expect("steps");
        }
        let text = serde_json::to_string(&first.checkpoint()).expect("serialises");
        let mut second = Simulation::new(&s).expect("builds");
        second
            .resume(serde_json::from_str(&text).expect("deserialises"))
            .expect("fits");
        assert_eq!(second.frame(), 5);
        assert!(
            !second.contacts().is_empty(),
            "the cloth touches the sphere by frame 5, so contacts are carried over"
        );
        let mut k = 5;
        while !second.is_done() {
            second.advance_frame(&control).expect("steps");
            assert_eq!(second.state().x, reference[k], "frame {}", k + 1);
            k += 1;
        }
        assert_eq!(k, reference.len());
    }

    #[test]
    fn checkpoint_of_another_scene_is_refused() {
        let small = scene_from_json(
            r#"{"cloth": {"grid": [3, 3], "size": [1, 1]}, "material": "cotton", "duration": 0.1, "fps": 10}"#,
        );
        let big = scene_from_json(
            r#"{"cloth": {"grid": [4, 3], "size": [1, 1]}, "material": "cotton", "duration": 0.1, "fps": 10}"#,
        );
        let c = Simulation::new(&small).expect("builds").checkpoint();
        let mut sim = Simulation::new(&big).expect("builds");
        let e = sim.resume(c).expect_err("refused");
        assert!(e.to_string().contains("12 particles"), "{e}");
        let e = sim
            .set_state(Simulation::new(&small).expect("builds").state().clone())
            .expect_err("refused");
        assert!(e.to_string().contains("12 particles"), "{e}");
    }

    /// A checkpoint's step level beyond the scene's deepest is refused: the
    /// adaptive controller counts its steps down from it.
    #[test]
    fn checkpoint_past_the_deepest_level_is_refused() {
        let text = r#"{"cloth": {"grid": [3, 3], "size": [1, 1]}, "material": "cotton",
            "duration": 0.1, "fps": 10, "solver": {"dt": "adaptive"}}"#;
        let mut sim = Simulation::new(&scene_from_json(text)).expect("builds");
        let crate::spec::TimeStepping::Adaptive {
            max_level: deepest, ..
        } = sim.scene().solver.stepping
        else {
            panic!("adaptive")
        };
        let mut c = sim.checkpoint();
        c.level = deepest;
        sim.resume(c.clone()).expect("the deepest level");
        c.level = deepest + 1;
        let e = sim.resume(c).expect_err("refused");
        assert!(
            e.to_string()
                .contains(&format!("step level {}", deepest + 1)),
            "{e}"
        );
    }
}
