//! The stages of a step, named once, and the one place that times and
//! traces them (avian's `schedule`, rapier's `counters`).

use std::time::Instant;

use serde::ser::SerializeMap;
use serde::{Serialize, Serializer};

/// A stage of one step, in the order the step runs them
/// (`sim::step::step`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Pins write their filters, targets and corrections.
    Constrain,
    /// Contacts and predicted crossings become constraints (method.md §4).
    CollisionPrepare,
    /// Forces and Jacobians into `A dv = b` (eq. [20]).
    Assemble,
    /// The preconditioner is rebuilt from `A`.
    Precondition,
    /// The modified PCG.
    Solve,
    /// `v += dv`, `x += p + h' v + y`, finiteness.
    Update,
    /// BDF2: the residual of the nonlinear step at its end, for one
    /// Newton correction (solved and applied by `Solve` and `Update`).
    Correct,
    /// The path taken is tested; the step is accepted (contacts released,
    /// friction switched) or redone with the new contacts.
    CollisionResolve,
    /// The accepted motion is kept from passing the cloth through itself
    /// (`selfcollision`).
    SelfCollision,
    /// Cloth edges and triangles are kept off obstacles' sharp corners and
    /// edges (`sim::sharp`).
    SharpFeatures,
}

impl Stage {
    /// Every stage, in step order.
    pub const ALL: [Stage; 10] = [
        Stage::Constrain,
        Stage::CollisionPrepare,
        Stage::Assemble,
        Stage::Precondition,
        Stage::Solve,
        Stage::Update,
        Stage::Correct,
        Stage::CollisionResolve,
        Stage::SelfCollision,
        Stage::SharpFeatures,
    ];

    /// The stage's name in traces and `stats.json`.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Constrain => "constrain",
            Stage::CollisionPrepare => "collision_prepare",
            Stage::Assemble => "assemble",
            Stage::Precondition => "precondition",
            Stage::Solve => "solve",
            Stage::Update => "update",
            Stage::Correct => "correct",
            Stage::CollisionResolve => "collision_resolve",
            Stage::SelfCollision => "self_collision",
            Stage::SharpFeatures => "sharp_features",
        }
    }

    /// Whether the stage belongs to collision handling.
    pub fn is_collision(self) -> bool {
        matches!(
            self,
            Stage::CollisionPrepare | Stage::CollisionResolve | Stage::SharpFeatures
        )
    }
}

/// Wall time of each stage, seconds.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes([f64; Stage::ALL.len()]);

impl StageTimes {
    /// The time of `stage`.
    pub fn get(&self, stage: Stage) -> f64 {
        self.0[stage as usize]
    }

    /// Both collision stages together.
    pub fn collision(&self) -> f64 {
        Stage::ALL
            .iter()
            .filter(|s| s.is_collision())
            .map(|s| self.get(*s))
            .sum()
    }

    /// Sum over stages.
    pub fn total(&self) -> f64 {
        self.0.iter().sum()
    }

    /// Adds another step's times.
    pub fn add(&mut self, other: &StageTimes) {
        for (a, b) in self.0.iter_mut().zip(&other.0) {
            *a += b;
        }
    }
}

/// `{"constrain": s, ..., "collision": s}`: every stage by name, and
/// `collision` (both collision stages) as `stats.json` has always had it.
impl Serialize for StageTimes {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(Stage::ALL.len() + 1))?;
        for stage in Stage::ALL {
            map.serialize_entry(stage.name(), &self.get(stage))?;
        }
        map.serialize_entry("collision", &self.collision())?;
        map.end()
    }
}

/// Runs stages, each in its own trace span, and adds up their wall times.
#[derive(Debug, Default)]
pub struct StageClock {
    times: StageTimes,
}

impl StageClock {
    /// Runs `f` as `stage`.
    #[inline]
    pub fn run<T>(&mut self, stage: Stage, f: impl FnOnce() -> T) -> T {
        let _span = tracing::trace_span!("stage", stage = stage.name()).entered();
        let start = Instant::now();
        let out = f();
        self.times.0[stage as usize] += start.elapsed().as_secs_f64();
        out
    }

    /// Adds the times of a clock that ran stages beside this one.
    pub fn merge(&mut self, other: &StageClock) {
        self.times.add(&other.times);
    }

    /// The times so far.
    pub fn times(&self) -> StageTimes {
        self.times
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clock_adds_each_stage_and_serialises_by_name() {
        let mut clock = StageClock::default();
        let x = clock.run(Stage::Solve, || {
            std::thread::sleep(std::time::Duration::from_millis(2));
            7
        });
        assert_eq!(x, 7);
        clock.run(Stage::CollisionPrepare, || ());
        let t = clock.times();
        assert!(t.get(Stage::Solve) >= 0.002);
        assert_eq!(t.get(Stage::Assemble), 0.0);
        assert_eq!(t.total(), t.get(Stage::Solve) + t.collision());
        let json = serde_json::to_value(t).expect("serialises");
        for stage in Stage::ALL {
            assert!(json.get(stage.name()).is_some(), "{json}");
        }
        assert_eq!(json["collision"], serde_json::json!(t.collision()));
    }
}
