//! Per-frame and whole-run statistics: the fields of DESIGN.md's
//! `stats.json`, plus stage timings.

use serde::{Deserialize, Serialize};

use super::stage::StageTimes;

/// One output frame's statistics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameStats {
    /// Frame index (0 is the initial state).
    pub frame: usize,
    /// Simulated time of the frame.
    pub time: f64,
    /// Steps taken since the previous frame.
    pub steps: usize,
    /// CG iterations summed over those steps.
    pub cg_iterations: usize,
    /// Largest CG iteration count of one step.
    pub cg_iterations_max: usize,
    /// Steps whose solve stopped before the tolerance.
    pub unconverged_solves: usize,
    /// Fixed steps redone as two halves because they overstretched or
    /// (BDF2 without obstacles or moving pins) gained energy.
    pub subdivided_steps: usize,
    /// Of those, the BDF2 steps that gained energy (`sim::energy`).
    #[serde(default)]
    pub energy_subdivided_steps: usize,
    /// Adaptive steps rejected (error estimate over its share, failed
    /// solve, overstretch) and redone at half size.
    #[serde(default)]
    pub rejected_steps: usize,
    /// Adaptive steps accepted over their share of `solver.error` because
    /// they were already the finest step allowed (`2^-max_level` of a
    /// frame): the target is finer than the controller can reach there.
    #[serde(default)]
    pub error_missed_steps: usize,
    /// The position error the frame's steps added by their embedded
    /// estimates (RMS over free particles, summed over steps), metres;
    /// `solver.error` bounds it under `dt: "adaptive"`.
    #[serde(default)]
    pub local_error: f64,
    /// Particles in contact at the end of the frame.
    pub contacts: usize,
    /// Contacts made during the frame.
    pub new_contacts: usize,
    /// Contacts released during the frame.
    pub released_contacts: usize,
    /// BVH nodes visited during the frame.
    pub nodes_visited: u64,
    /// Solves redone because a particle crossed a surface mid-step.
    pub redone_solves: usize,
    /// Collision stage wall time during the frame, seconds.
    pub collision_seconds: f64,
    /// Wall time of the frame's steps, seconds.
    pub step_seconds: f64,
    /// Kinetic energy at the frame, J.
    pub kinetic_energy: f64,
    /// Largest edge length / rest length at the frame.
    pub max_stretch: f64,
    /// Smallest signed distance of a particle to a true obstacle surface at
    /// the frame (negative inside); `None` without obstacles.
    pub min_signed_distance: Option<f64>,
    /// Last step size used, seconds.
    pub dt: f64,
    /// Cloth–cloth pairs within the thickness that received a proximity
    /// impulse during the frame (summed over steps).
    #[serde(default)]
    pub self_contacts: usize,
    /// Cloth–cloth collisions found by the continuous tests and answered
    /// by impulses during the frame.
    #[serde(default)]
    pub self_collisions: usize,
    /// Rigid impact zones formed during the frame.
    #[serde(default)]
    pub impact_zones: usize,
    /// Steps of the frame that needed the fail-safe stop (every free
    /// particle kept where it was).
    #[serde(default)]
    pub self_failsafe_steps: usize,
    /// Self-collision wall time during the frame, seconds.
    #[serde(default)]
    pub self_collision_seconds: f64,
    /// Cloth edges through cloth triangles at the frame (the exact count
    /// of `selfcollision::count_crossings`), counted whether or not
    /// self-collision is on.
    #[serde(default)]
    pub self_crossings: usize,
    /// Obstacle edges through cloth triangles at the frame (the sharp
    /// edges of boxes and meshes, `sim::sharp`; 0 without them).
    #[serde(default)]
    pub obstacle_crossings: usize,
}

/// A whole run's statistics (`stats.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunStats {
    /// Scene name.
    pub name: String,
    /// Particles in the cloth.
    pub particles: usize,
    /// Frames written, including frame 0.
    pub frames: usize,
    /// Steps taken.
    pub steps: usize,
    /// Wall time of the run, seconds.
    pub wall_seconds: f64,
    /// Simulated time, seconds.
    pub sim_seconds: f64,
    /// CG iterations over the run.
    pub cg_iterations_total: usize,
    /// Largest CG iteration count of one step.
    pub cg_iterations_max: usize,
    /// Steps whose solve stopped before the tolerance.
    pub unconverged_solves: usize,
    /// Fixed steps redone as two halves because they overstretched or
    /// (BDF2 without obstacles or moving pins) gained energy.
    pub subdivided_steps: usize,
    /// Of those, the BDF2 steps that gained energy (`sim::energy`).
    pub energy_subdivided_steps: usize,
    /// Adaptive steps rejected and redone at half size.
    pub rejected_steps: usize,
    /// Adaptive steps over their error share at the finest step allowed
    /// (`per_frame[].error_missed_steps`): above zero, `solver.error` was
    /// not met there.
    pub error_missed_steps: usize,
    /// The largest of the frames' estimated added position errors
    /// (`per_frame[].local_error`), metres.
    pub local_error_max: f64,
    /// Collision stage wall time, seconds.
    pub collision_seconds: f64,
    /// `collision_seconds` / time in steps.
    pub collision_fraction: f64,
    /// Most particles in contact at a frame.
    pub contacts_max: usize,
    /// Contacts made over the run.
    pub contacts_new: usize,
    /// Contacts released over the run.
    pub contacts_released: usize,
    /// BVH nodes visited over the run.
    pub nodes_visited: u64,
    /// Solves redone because a particle crossed a surface mid-step.
    pub redone_solves: usize,
    /// Each obstacle's collision offset `delta`, metres.
    pub obstacle_offsets: Vec<f64>,
    /// The thickness cloth layers keep (`cloth.thickness` or its default),
    /// metres; `None` with self-collision off.
    pub cloth_thickness: Option<f64>,
    /// The time integrator that ran (`solver.integrator`): `"euler"` or
    /// `"bdf2"`.
    pub integrator: &'static str,
    /// Cloth–cloth proximity impulses over the run.
    pub self_contacts: usize,
    /// Cloth–cloth collisions answered by impulses over the run.
    pub self_collisions: usize,
    /// Rigid impact zones over the run.
    pub impact_zones: usize,
    /// Steps that needed self-collision's fail-safe stop.
    pub self_failsafe_steps: usize,
    /// Self-collision wall time, seconds.
    pub self_collision_seconds: f64,
    /// Most cloth edges through cloth triangles at any frame (0 with
    /// self-collision off, where it is not counted).
    pub self_crossings_max: usize,
    /// Most obstacle edges through cloth triangles at any frame.
    pub obstacle_crossings_max: usize,
    /// Smallest signed distance to a true obstacle surface over all frames
    /// (negative = inside); `None` without obstacles.
    pub min_signed_distance: Option<f64>,
    /// Largest edge length / rest length at the last frame.
    pub max_stretch: f64,
    /// Largest edge length / rest length over all frames.
    pub max_stretch_any_frame: f64,
    /// No NaN or infinity ever appeared.
    pub finite: bool,
    /// Wall time per stage, seconds, steps redone (halved, rejected)
    /// included.
    pub stage_seconds: StageTimes,
    /// Each frame's statistics.
    pub per_frame: Vec<FrameStats>,
}

/// Accumulates frame statistics into run statistics.
#[derive(Debug, Clone)]
pub struct StatsRecorder {
    stats: RunStats,
    step_seconds: f64,
}

impl StatsRecorder {
    /// An empty record for a run named `name` on `particles` particles.
    pub fn new(name: &str, particles: usize) -> Self {
        Self {
            stats: RunStats {
                name: name.to_owned(),
                particles,
                frames: 0,
                steps: 0,
                wall_seconds: 0.0,
                sim_seconds: 0.0,
                cg_iterations_total: 0,
                cg_iterations_max: 0,
                unconverged_solves: 0,
                subdivided_steps: 0,
                energy_subdivided_steps: 0,
                rejected_steps: 0,
                error_missed_steps: 0,
                local_error_max: 0.0,
                collision_seconds: 0.0,
                collision_fraction: 0.0,
                contacts_max: 0,
                contacts_new: 0,
                contacts_released: 0,
                nodes_visited: 0,
                redone_solves: 0,
                obstacle_offsets: Vec::new(),
                cloth_thickness: None,
                integrator: "euler",
                self_contacts: 0,
                self_collisions: 0,
                impact_zones: 0,
                self_failsafe_steps: 0,
                self_collision_seconds: 0.0,
                self_crossings_max: 0,
                obstacle_crossings_max: 0,
                min_signed_distance: None,
                max_stretch: 0.0,
                max_stretch_any_frame: 0.0,
                finite: true,
                stage_seconds: StageTimes::default(),
                per_frame: Vec::new(),
            },
            step_seconds: 0.0,
        }
    }

    /// Adds a frame and the stage times of its steps.
    pub fn record(&mut self, f: FrameStats, stages: &StageTimes) {
        let s = &mut self.stats;
        s.frames += 1;
        s.steps += f.steps;
        s.sim_seconds = f.time;
        s.cg_iterations_total += f.cg_iterations;
        s.cg_iterations_max = s.cg_iterations_max.max(f.cg_iterations_max);
        s.unconverged_solves += f.unconverged_solves;
        s.subdivided_steps += f.subdivided_steps;
        s.energy_subdivided_steps += f.energy_subdivided_steps;
        s.rejected_steps += f.rejected_steps;
        s.error_missed_steps += f.error_missed_steps;
        s.local_error_max = s.local_error_max.max(f.local_error);
        s.collision_seconds += f.collision_seconds;
        s.contacts_max = s.contacts_max.max(f.contacts);
        s.contacts_new += f.new_contacts;
        s.contacts_released += f.released_contacts;
        s.nodes_visited += f.nodes_visited;
        s.redone_solves += f.redone_solves;
        s.self_contacts += f.self_contacts;
        s.self_collisions += f.self_collisions;
        s.impact_zones += f.impact_zones;
        s.self_failsafe_steps += f.self_failsafe_steps;
        s.self_collision_seconds += f.self_collision_seconds;
        s.self_crossings_max = s.self_crossings_max.max(f.self_crossings);
        s.obstacle_crossings_max = s.obstacle_crossings_max.max(f.obstacle_crossings);
        s.min_signed_distance = match (s.min_signed_distance, f.min_signed_distance) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        s.max_stretch = f.max_stretch;
        s.max_stretch_any_frame = s.max_stretch_any_frame.max(f.max_stretch);
        s.stage_seconds.add(stages);
        self.step_seconds += f.step_seconds;
        s.per_frame.push(f);
    }

    /// Records the obstacles' collision offsets.
    pub fn set_obstacle_offsets(&mut self, offsets: Vec<f64>) {
        self.stats.obstacle_offsets = offsets;
    }

    /// Records the thickness cloth layers keep.
    pub fn set_cloth_thickness(&mut self, thickness: Option<f64>) {
        self.stats.cloth_thickness = thickness;
    }

    /// Records the time integrator that runs.
    pub fn set_integrator(&mut self, integrator: crate::spec::IntegratorKind) {
        self.stats.integrator = integrator.name();
    }

    /// Marks the run as having produced non-finite numbers.
    pub fn mark_non_finite(&mut self) {
        self.stats.finite = false;
    }

    /// The statistics so far, with `wall_seconds` for the whole run.
    pub fn finish(&self, wall_seconds: f64) -> RunStats {
        let mut s = self.stats.clone();
        s.wall_seconds = wall_seconds;
        s.collision_fraction = if self.step_seconds > 0.0 {
            s.collision_seconds / self.step_seconds
        } else {
            0.0
        };
        s
    }
}
