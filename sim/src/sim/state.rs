//! The run's state: everything the next steps read that a step changes.
//! It is the checkpoint: serialisable with any serde format, and a run
//! continued from a copy taken between frames is bit for bit the
//! uninterrupted one.
//!
//! Besides positions and velocities it holds what makes the next steps
//! what they would have been: the pins' anchors, the contact set with its
//! friction states, the last velocity change (the next solve's warm start
//! and the collision stage's prediction of the next path), and the
//! adaptive controller's level.

use serde::{Deserialize, Serialize};

use super::error::SimError;
use super::world::World;
use crate::collision::Contact;
use crate::math::{Real, Vec3, is_finite};
use crate::solver::ClothState;
use crate::spec::TimeStepping;

/// A run's state (and its checkpoint).
#[derive(Debug, PartialEq, Serialize, Deserialize)]
pub struct RunState {
    /// Frames finished.
    pub frame: usize,
    /// Steps taken.
    pub steps: usize,
    /// The cloth.
    pub state: ClothState,
    /// Where the pins hold their particles (`Pins::anchors`).
    pub(crate) anchors: Vec<Vec3>,
    /// Particles held by obstacles, sorted by particle then obstacle.
    pub(crate) contacts: Vec<Contact>,
    /// The last step's velocity change.
    pub(crate) warm_start: Vec<Vec3>,
    /// Adaptive stepping: the current subdivision level...
    pub(crate) level: u32,
    /// ...and the run of easy steps at it.
    pub(crate) easy_steps: u32,
    /// The last accepted step's displacement of each particle (what the
    /// next step's self-collision plan reckons with)...
    #[serde(default)]
    pub(crate) last_moved: Vec<Vec3>,
    /// ...its velocity change...
    #[serde(default)]
    pub(crate) last_dv: Vec<Vec3>,
    /// ...BDF2's memory of each particle's `x0 - x_prev`: the last step's
    /// displacement as its solve left it, before the self-collision
    /// response and the sharp-feature stage corrected it. Their jumps are
    /// no smooth path's: carried on, a third of each (at a constant step)
    /// was repeated in the next step, into the layer or feature that had
    /// stopped it (ARCHITECTURE.md, "The time scheme"). Empty under
    /// backward Euler, and in checkpoints from before it was kept, from
    /// which a BDF2 run restarts by backward Euler...
    #[serde(default)]
    pub(crate) last_dx: Vec<Vec3>,
    /// ...and its size (0 before the first step, or after the cloth was
    /// replaced): BDF2's memory.
    #[serde(default)]
    pub(crate) last_h: Real,
    /// The last step's local error estimate (metres; 0 before the first
    /// step): the scale of the next solve's error under
    /// `stopping: "error"`.
    #[serde(default)]
    pub(crate) last_error: Real,
}

/// A run's state taken between frames, to continue later.
pub type Checkpoint = RunState;

// PERF: written out so `clone_from` reuses every vector's storage: a
// rejected step restores the state from a buffer filled before it.
impl Clone for RunState {
    fn clone(&self) -> Self {
        Self {
            frame: self.frame,
            steps: self.steps,
            state: self.state.clone(),
            anchors: self.anchors.clone(),
            contacts: self.contacts.clone(),
            warm_start: self.warm_start.clone(),
            level: self.level,
            easy_steps: self.easy_steps,
            last_moved: self.last_moved.clone(),
            last_dv: self.last_dv.clone(),
            last_dx: self.last_dx.clone(),
            last_h: self.last_h,
            last_error: self.last_error,
        }
    }

    fn clone_from(&mut self, source: &Self) {
        self.frame = source.frame;
        self.steps = source.steps;
        self.state.clone_from(&source.state);
        self.anchors.clone_from(&source.anchors);
        self.contacts.clone_from(&source.contacts);
        self.warm_start.clone_from(&source.warm_start);
        self.level = source.level;
        self.easy_steps = source.easy_steps;
        self.last_moved.clone_from(&source.last_moved);
        self.last_dv.clone_from(&source.last_dv);
        self.last_dx.clone_from(&source.last_dx);
        self.last_h = source.last_h;
        self.last_error = source.last_error;
    }
}

impl RunState {
    /// The state at the start of a run of `world`: the flat grid at rest.
    pub fn new(world: &World) -> Self {
        let n = world.grid.len();
        let level = match world.scene.solver.stepping {
            TimeStepping::Fixed { .. } => 0,
            // Start near 1/240 s and let the controller find its way.
            TimeStepping::Adaptive { max_level, .. } => {
                ((world.scene.frame_dt() * 240.0).log2().ceil().max(0.0) as u32).min(max_level)
            }
        };
        Self {
            frame: 0,
            steps: 0,
            state: ClothState {
                time: 0.0,
                x: world.grid.rest.clone(),
                v: vec![Vec3::zeros(); n],
            },
            anchors: world.pins.anchors(&world.grid.rest, 0.0),
            contacts: Vec::new(),
            warm_start: vec![Vec3::zeros(); n],
            level,
            easy_steps: 0,
            last_moved: vec![Vec3::zeros(); n],
            last_dv: vec![Vec3::zeros(); n],
            last_dx: Vec::new(),
            last_h: 0.0,
            last_error: 0.0,
        }
    }

    /// The contact set.
    pub fn contacts(&self) -> &[Contact] {
        &self.contacts
    }

    /// Kinetic energy `1/2 Σ m v²` with masses `mass`.
    pub fn kinetic_energy(&self, mass: &[Real]) -> Real {
        self.state
            .v
            .iter()
            .zip(mass)
            .map(|(v, m)| 0.5 * m * v.norm_squared())
            .sum()
    }

    /// Replaces the cloth (a start other than the flat grid): pins are
    /// re-anchored where the new state puts them, the warm start is
    /// forgotten, and contacts, which belong to the old state, are dropped
    /// and found again.
    pub(crate) fn replace_cloth(&mut self, world: &World, state: ClothState) {
        self.anchors = world.pins.anchors(&state.x, state.time);
        self.state = state;
        self.warm_start.fill(Vec3::zeros());
        self.contacts.clear();
        self.last_h = 0.0;
        self.last_error = 0.0;
    }

    /// Checks that this state can continue a run of `world`: the same
    /// particle count and pins, contacts with known particles and
    /// obstacles, a frame and a step level within the run, finite numbers.
    pub(crate) fn check_fits(&self, world: &World) -> Result<(), SimError> {
        let n = world.grid.len();
        let bad = |m: String| Err(SimError::Checkpoint(m));
        if self.state.x.len() != n || self.state.v.len() != n || self.warm_start.len() != n {
            return bad(format!(
                "holds a cloth of another size (expected {n} particles)"
            ));
        }
        if self.anchors.len() != world.pins.len() {
            return bad("holds another number of pins".into());
        }
        if self.frame > world.scene.frames {
            return bad(format!(
                "is at frame {} of a run of {}",
                self.frame, world.scene.frames
            ));
        }
        let max_level = match world.scene.solver.stepping {
            TimeStepping::Fixed { .. } => 0,
            TimeStepping::Adaptive { max_level, .. } => max_level,
        };
        if self.level > max_level {
            // Steps of `frame_dt / 2^level` count down `2^(max_level - level)`.
            return bad(format!(
                "is at step level {} of a run of at most {max_level}",
                self.level
            ));
        }
        let obstacles = world.obstacles.as_ref().map_or(0, |o| o.colliders().len());
        if self
            .contacts
            .iter()
            .any(|k| k.particle as usize >= n || k.obstacle as usize >= obstacles)
        {
            return bad("holds a contact with an unknown particle or obstacle".into());
        }
        let history = self.last_h == 0.0
            || (self.last_moved.len() == n
                && self.last_dv.len() == n
                && (self.last_dx.is_empty() || self.last_dx.len() == n)
                && self.last_h > 0.0);
        if !history {
            return bad("holds a last step of another size".into());
        }
        let finite = |v: &[Vec3]| v.iter().all(is_finite);
        if !(finite(&self.state.x)
            && finite(&self.state.v)
            && finite(&self.warm_start)
            && finite(&self.last_moved)
            && finite(&self.last_dv)
            && finite(&self.last_dx)
            && self.last_h.is_finite()
            && self.last_error.is_finite())
        {
            return bad("holds non-finite numbers".into());
        }
        Ok(())
    }
}
