//! One simulation run for a study: its statistics, optionally every
//! frame's positions, and how it ended.

use drapery_sim::math::Vec3;
use drapery_sim::sim::{Control, RunStats, SimError, Simulation};
use drapery_sim::spec::Scene;

use crate::stress::crumple;

/// Where the cloth starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Start {
    /// The scene's flat grid, at rest.
    #[default]
    Rest,
    /// The grid crumpled by [`crumple`] with this seed, at rest.
    Crumpled(u64),
}

/// What to keep of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RunOptions {
    /// The cloth's first state.
    pub start: Start,
    /// Keep every frame's positions.
    pub capture: bool,
}

/// What one run produced.
#[derive(Debug)]
pub struct Outcome {
    /// Statistics of the frames that were finished, `wall_seconds` for the
    /// whole run; `finite: false` if a step produced NaN or infinity.
    pub stats: RunStats,
    /// Positions of every frame (frame 0 first), when asked for.
    pub frames: Vec<Vec<Vec3>>,
    /// Why the run stopped early, if it did.
    pub error: Option<SimError>,
}

/// Runs `scene` to the end (or its first error). An error building the
/// simulation is returned as such; an error while running is kept in the
/// outcome with the statistics of the frames before it.
pub fn simulate(scene: &Scene, options: RunOptions) -> Result<Outcome, SimError> {
    let mut sim = Simulation::new(scene)?;
    if let Start::Crumpled(seed) = options.start {
        let mut state = sim.state().clone();
        let up = -sim.scene().gravity;
        state.x = crumple(sim.grid(), &sim.model().stretch, up, seed);
        sim.set_state(state)?;
    }
    let mut frames = Vec::new();
    let (stats, result) = sim.run_recorded(&Control::default(), |s, _| {
        if options.capture {
            frames.push(s.state().x.clone());
        }
        Ok::<(), String>(())
    });
    Ok(Outcome {
        stats,
        frames,
        error: result.err(),
    })
}
