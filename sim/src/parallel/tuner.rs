//! Whether sharing a run's loops with the team pays, measured as it runs.
//!
//! On the 2-core benchmark VM the same binary, on the same scene, ran
//! sphere-drape-30 in 1.34 s on two threads against 1.56 s on one, and a
//! quarter of an hour later in 1.64–1.98 s on two against 1.32–1.36 s on
//! one (docs/benchmarks.md, section 1o): how much a second virtual core
//! gives depends on the host, and changes within minutes. The loops'
//! results are bit for bit the same on any number of threads, so a run
//! may switch at any step; the tuner times its steps both ways and keeps
//! the faster.
//!
//! A cycle of [`CYCLE`] steps begins with [`PAIRS`] pairs of epochs of
//! [`EPOCH`] steps, shared then alone, and runs the rest the way whose
//! steps took less time in them: a twentieth of the steps run the slower
//! way, and within a cycle (320 steps, 1.3 s simulated at 1/240 s) the
//! run follows the machine. Where a second thread gives nothing, the run
//! gets back what the team's synchronisation cost it.

use std::time::{Duration, Instant};

use super::team;

/// Steps of one epoch.
pub const EPOCH: u64 = 8;
/// Pairs of epochs (shared, alone) measured per cycle.
pub const PAIRS: u64 = 2;
/// Steps of a cycle: measured, then the faster way.
pub const CYCLE: u64 = 40 * EPOCH;

/// The tuner of one run's steps (see the module doc).
#[derive(Debug, Clone, Default)]
pub struct Tuner {
    /// Steps into the cycle.
    step: u64,
    shared: Duration,
    alone: Duration,
    /// The faster way of the last measurement (`true`: alone).
    choice: bool,
    started: Option<(Instant, bool)>,
}

impl Tuner {
    /// Before a step: this thread's loops run alone or shared, as the
    /// cycle says (a team without helpers runs them alone either way).
    pub fn begin(&mut self) {
        let epoch = self.step / EPOCH;
        let alone = if epoch < 2 * PAIRS {
            epoch % 2 == 1
        } else {
            self.choice
        };
        team::set_alone(alone);
        self.started = Some((Instant::now(), alone));
    }

    /// After the step [`Tuner::begin`] started.
    pub fn end(&mut self) {
        if let Some((started, alone)) = self.started.take() {
            self.record(started.elapsed(), alone);
        }
    }

    /// Counts a step that took `took`, run `alone` or shared.
    fn record(&mut self, took: Duration, alone: bool) {
        if self.step < 2 * PAIRS * EPOCH {
            if alone {
                self.alone += took;
            } else {
                self.shared += took;
            }
        }
        self.step += 1;
        if self.step == 2 * PAIRS * EPOCH {
            let choice = self.alone < self.shared;
            if choice != self.choice {
                tracing::debug!(
                    alone = choice,
                    shared_ms = self.shared.as_secs_f64() * 1e3,
                    alone_ms = self.alone.as_secs_f64() * 1e3,
                    "parallel loops switched"
                );
            }
            self.choice = choice;
        }
        if self.step == CYCLE {
            (self.step, self.shared, self.alone) = (0, Duration::ZERO, Duration::ZERO);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Under a team of two, the tuner runs its measuring epochs shared
    /// then alone, and keeps the way it measured faster, in every cycle;
    /// this thread's loops run alone exactly when it says so.
    #[test]
    fn the_tuner_alternates_then_keeps_the_faster_way() {
        super::super::with_threads(2, || {
            let mut tuner = Tuner::default();
            // Alone slower in the first cycle, faster in the second.
            for alone_us in [300, 100] {
                let mut ways = Vec::new();
                for _ in 0..CYCLE {
                    tuner.begin();
                    let alone = team::alone();
                    ways.push(alone);
                    let took = Duration::from_micros(if alone { alone_us } else { 200 });
                    tuner.started = None;
                    tuner.record(took, alone);
                }
                let measured = (2 * PAIRS * EPOCH) as usize;
                for (k, &alone) in ways[..measured].iter().enumerate() {
                    assert_eq!(alone, (k as u64 / EPOCH) % 2 == 1, "step {k}");
                }
                let keep = alone_us < 200;
                assert!(ways[measured..].iter().all(|&a| a == keep), "{alone_us} µs");
            }
        });
        team::set_alone(false);
    }
}
