//! Checkpoints: everything a run needs to continue bit for bit from a
//! frame boundary, so a service can stop a job (shutdown, crash) and
//! resume it later without redoing finished frames.
//!
//! Besides positions and velocities this holds what makes the next steps
//! what they would have been: the pins' anchors, the contact set with its
//! friction states, the warm start of the next solve (also the collision
//! stage's prediction of the next path), and the adaptive controller's
//! level.

use serde::{Deserialize, Serialize};

use super::error::SimError;
use super::simulation::Simulation;
use crate::collision::Contact;
use crate::math::Vec3;
use crate::solver::ClothState;

/// A run's state at a frame boundary; plain data, serialisable with any
/// serde format.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    /// Frames finished.
    pub frame: usize,
    /// Steps taken.
    pub steps: usize,
    /// The cloth.
    pub state: ClothState,
    pub(crate) anchors: Vec<Vec3>,
    pub(crate) contacts: Vec<Contact>,
    pub(crate) warm_start: Vec<Vec3>,
    pub(crate) level: u32,
    pub(crate) easy_steps: u32,
}

impl Simulation {
    /// The run's state now, to continue later with [`Self::resume`]. Taken
    /// between frames (in a frame callback), it resumes exactly.
    pub fn checkpoint(&self) -> Checkpoint {
        let (level, easy_steps) = self.adaptive_state();
        Checkpoint {
            frame: self.frame(),
            steps: self.steps(),
            state: self.state().clone(),
            anchors: self.anchors().to_vec(),
            contacts: self
                .collision()
                .map_or_else(Vec::new, |c| c.contacts().to_vec()),
            warm_start: self.warm_start().to_vec(),
            level,
            easy_steps,
        }
    }

    /// Continues from `c`, a checkpoint of a run of the same scene. A
    /// checkpoint that does not fit the scene (another particle count,
    /// contacts with unknown particles or obstacles, a frame past the end)
    /// is refused, and the simulation is left as it was.
    pub fn resume(&mut self, c: Checkpoint) -> Result<(), SimError> {
        let n = self.grid().len();
        let bad = |m: String| Err(SimError::Checkpoint(m));
        if c.state.x.len() != n || c.state.v.len() != n || c.warm_start.len() != n {
            return bad(format!(
                "holds a cloth of another size (expected {n} particles)"
            ));
        }
        if c.anchors.len() != self.scene().cloth.pinned.len() {
            return bad("holds another number of pins".into());
        }
        if c.frame > self.scene().frames {
            return bad(format!(
                "is at frame {} of a run of {}",
                c.frame,
                self.scene().frames
            ));
        }
        let obstacles = self.collision().map_or(0, |s| s.colliders().len());
        if c.contacts
            .iter()
            .any(|k| k.particle as usize >= n || k.obstacle as usize >= obstacles)
        {
            return bad("holds a contact with an unknown particle or obstacle".into());
        }
        let finite = |v: &[Vec3]| v.iter().all(|p| p.iter().all(|x| x.is_finite()));
        if !(finite(&c.state.x) && finite(&c.state.v) && finite(&c.warm_start)) {
            return bad("holds non-finite numbers".into());
        }
        self.restore_checkpoint(c);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use crate::sim::{Control, Simulation};
    use crate::spec::{Limits, Spec};

    fn scene(json: &str) -> crate::spec::Scene {
        let spec: Spec = serde_json::from_str(json).expect("spec parses");
        spec.validate(&Limits::default()).expect("spec is valid")
    }

    /// A run stopped at frame 5 and resumed from its checkpoint (after a
    /// round trip through JSON) writes the same frames, bit for bit, as an
    /// uninterrupted run: the checkpoint holds everything the steps read.
    #[test]
    fn resumed_run_matches_uninterrupted_run() {
        let s = scene(
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
            second.collision().is_some_and(|c| !c.contacts().is_empty()),
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
        let small = scene(
            r#"{"cloth": {"grid": [3, 3], "size": [1, 1]}, "material": "cotton", "duration": 0.1, "fps": 10}"#,
        );
        let big = scene(
            r#"{"cloth": {"grid": [4, 3], "size": [1, 1]}, "material": "cotton", "duration": 0.1, "fps": 10}"#,
        );
        let c = Simulation::new(&small).expect("builds").checkpoint();
        let mut sim = Simulation::new(&big).expect("builds");
        let e = sim.resume(c).expect_err("refused");
        assert!(e.to_string().contains("12 particles"), "{e}");
    }
}
