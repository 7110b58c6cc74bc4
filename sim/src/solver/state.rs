//! The cloth's dynamic state: time, positions, velocities.

use serde::{Deserialize, Serialize};

use crate::math::{Real, Vec3};

/// The cloth's state: serialisable so a run can checkpoint and resume.
#[derive(Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ClothState {
    /// Simulated time, seconds.
    pub time: Real,
    /// Positions.
    pub x: Vec<Vec3>,
    /// Velocities.
    pub v: Vec<Vec3>,
}

// PERF: written out so `clone_from` reuses the vectors' storage: rollback
// buffers are refilled every step and must not allocate.
impl Clone for ClothState {
    fn clone(&self) -> Self {
        Self {
            time: self.time,
            x: self.x.clone(),
            v: self.v.clone(),
        }
    }

    fn clone_from(&mut self, source: &Self) {
        self.time = source.time;
        self.x.clone_from(&source.x);
        self.v.clone_from(&source.v);
    }
}
