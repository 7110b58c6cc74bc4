//! One attempt at a job, in the core's terms: build the `Simulation`,
//! resume it from the stored checkpoint, run it frame by frame, and say
//! how it ended. NOTE: this is the only service module that calls the
//! core's simulation API (`Simulation`, `Checkpoint`, `Control`,
//! `StatsRecorder`, `FrameStats`, `SimError`); keep it that way.

use std::time::{Duration, Instant};

use drapery_sim::sim::{Checkpoint, Control, FrameStats, SimError, Simulation, StatsRecorder};
use serde_json::{Map, Value};
use tracing::{info, warn};

use crate::service::cost;
use crate::service::error_code::ErrorCode;
use crate::service::frame_bytes::encode_positions;
use crate::service::job::JobError;
use crate::service::jobs::{Attempt, Jobs, Outcome, StopReason};
use crate::service::protocol::{FrameReport, Pose, to_json};
use crate::service::store::{StoreError, StoredFrame};
use crate::specfile::SpecLoadError;

/// Why an attempt could not run at all.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("stored spec no longer loads: {0}")]
    Scene(SpecLoadError),
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The stored checkpoint or a stored frame's statistics do not parse.
    #[error(transparent)]
    Stored(#[from] serde_json::Error),
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// Runs `attempt` to its end (or its stop), storing every frame.
///
/// The disk budget holds in fact: the bytes the job holds in the store
/// (hello, frames, the latest checkpoint) are counted as frames are
/// written, and the frame that would take them past `--job-disk-budget`
/// is not stored; the job fails with `limit_exceeded`.
pub fn simulate(jobs: &Jobs, attempt: &Attempt) -> Result<Outcome, RunError> {
    let row = &attempt.row;
    let scene = row.scene().map_err(RunError::Scene)?;
    let mut sim = Simulation::new(&scene)?;
    let mut rec = sim.recorder();
    let resumed = jobs.checkpoint(row.id)?.filter(|(frame, _)| *frame > 0);
    let mut disk = DiskUse {
        stored: jobs.stored_bytes(row.id, resumed.as_ref().map(|(frame, _)| *frame))?,
        checkpoint: resumed.as_ref().map_or(0, |(_, data)| data.len() as u64),
        budget: jobs.config().budgets.disk_bytes,
    };
    if let Some((frame, data)) = resumed {
        let checkpoint: Checkpoint = serde_json::from_slice(&data)?;
        sim.resume(checkpoint)?;
        for s in jobs.frame_stats(row.id, frame)? {
            rec.record(serde_json::from_str(&s)?, &Default::default());
        }
        info!(frame, "resumed from checkpoint");
    }

    let control = Control {
        cancel: Some(&attempt.handle.cancel),
        progress: None,
    };
    let config = jobs.config();
    let interval =
        Duration::try_from_secs_f64(config.checkpoint_seconds.max(0.0)).unwrap_or(Duration::MAX);
    let mut last_checkpoint = Instant::now();
    let started = Instant::now();
    // The store was lost under a frame: the job is left to its lease.
    let mut lost = false;
    let result = sim.run(&control, &mut rec, |s, stats| {
        let stopping = jobs.is_stopping();
        let checkpoint = (stopping || last_checkpoint.elapsed() >= interval)
            .then(|| serde_json::to_vec(&s.checkpoint()))
            .transpose()
            .map_err(|e| e.to_string())?;
        if checkpoint.is_some() {
            last_checkpoint = Instant::now();
        }
        let frame = StoredFrame {
            n: stats.frame as u64,
            time: stats.time,
            positions: encode_positions(&s.state().x),
            stats: frame_report(s, stats),
        };
        disk.add(&frame, checkpoint.as_deref())?;
        let per_step = (stats.steps > 0).then(|| stats.step_seconds / stats.steps as f64);
        let run_seconds = row.run_seconds + started.elapsed().as_secs_f64();
        jobs.record_frame(row.id, &frame, checkpoint.as_deref(), per_step, run_seconds)
            .map_err(|e| {
                lost = is_lost(&e);
                e.to_string()
            })?;
        if stopping {
            return Err("interrupted by shutdown".to_owned());
        }
        Ok(())
    });
    let summary =
        |rec: &StatsRecorder| run_summary(rec, row.run_seconds + started.elapsed().as_secs_f64());
    Ok(match result {
        Ok(()) => Outcome::Succeeded(summary(&rec)),
        Err(SimError::Output(_)) if lost => Outcome::Lost,
        Err(SimError::Output(_)) if disk.over() => Outcome::Failed(
            JobError {
                code: ErrorCode::LimitExceeded,
                message: format!(
                    "disk budget of {} reached: the job's next frame would store more (--job-disk-budget)",
                    cost::bytes(disk.budget as f64)
                ),
            },
            Some(summary(&rec)),
        ),
        Err(SimError::Cancelled { .. }) => match attempt.handle.reason() {
            StopReason::WallTime => Outcome::Failed(
                JobError {
                    code: ErrorCode::LimitExceeded,
                    message: format!(
                        "wall time limit of {} s reached (--max-wall-seconds)",
                        config.max_wall_seconds
                    ),
                },
                Some(summary(&rec)),
            ),
            StopReason::Shutdown => Outcome::Interrupted,
            StopReason::LeaseLost => Outcome::Lost,
            StopReason::Cancelled | StopReason::None => Outcome::Cancelled(Some(summary(&rec))),
        },
        Err(SimError::Output(_)) if jobs.is_stopping() => Outcome::Interrupted,
        Err(e @ SimError::NonFinite { .. }) => Outcome::Failed(
            JobError {
                code: ErrorCode::NonFinite,
                message: e.to_string(),
            },
            Some(summary(&rec)),
        ),
        Err(e @ (SimError::Obstacle { .. } | SimError::Checkpoint(_) | SimError::Output(_))) => {
            warn!(error = %e, "job failed");
            Outcome::Failed(
                JobError {
                    code: ErrorCode::Internal,
                    message: e.to_string(),
                },
                Some(summary(&rec)),
            )
        }
    })
}

/// The store cannot be reached, or the job is another node's now:
/// nothing about the job is to be recorded by this node.
pub fn is_lost(e: &StoreError) -> bool {
    matches!(e, StoreError::Unavailable(_) | StoreError::LeaseLost(_))
}

/// What a job holds in the store, against its disk budget.
#[derive(Debug)]
struct DiskUse {
    /// Hello, frames and the latest checkpoint, bytes.
    stored: u64,
    /// The latest checkpoint's bytes (a new one replaces it).
    checkpoint: u64,
    budget: u64,
}

impl DiskUse {
    /// Counts `frame` and `checkpoint` in, or refuses them past the budget.
    fn add(&mut self, frame: &StoredFrame, checkpoint: Option<&[u8]>) -> Result<(), String> {
        let checkpoint = checkpoint.map_or(self.checkpoint, |c| c.len() as u64);
        let stored = self.stored.saturating_sub(self.checkpoint)
            + checkpoint
            + (frame.positions.len() + frame.stats.len()) as u64;
        if stored > self.budget {
            self.stored = stored;
            return Err("disk budget exceeded".to_owned());
        }
        self.stored = stored;
        self.checkpoint = checkpoint;
        Ok(())
    }

    fn over(&self) -> bool {
        self.stored > self.budget
    }
}

/// The run's statistics without the per-frame list, as JSON.
fn run_summary(rec: &StatsRecorder, wall_seconds: f64) -> String {
    let mut v = serde_json::to_value(rec.finish(wall_seconds)).unwrap_or_default();
    if let Some(o) = v.as_object_mut() {
        o.remove("per_frame");
    }
    v.to_string()
}

/// A frame's statistics as stored and streamed ([`FrameReport`]): the
/// core's [`FrameStats`], with obstacles their poses at the frame and the
/// particles in contact, and with self-collision the particles in self
/// contact.
fn frame_report(sim: &Simulation, stats: &FrameStats) -> String {
    let solver = match serde_json::to_value(stats) {
        Ok(Value::Object(m)) => m,
        Ok(_) | Err(_) => Map::new(),
    };
    let mut report = FrameReport {
        solver,
        obstacles: None,
        contact_particles: None,
        self_contact_particles: sim.self_contact_particles(),
    };
    // A scene with obstacles reports their poses and the particles they
    // hold; one without has neither field.
    if !sim.obstacles().is_empty() {
        report.obstacles = Some(
            sim.obstacles()
                .iter()
                .map(|c| {
                    let p = c.trajectory.pose(stats.time);
                    let q = p.rotation.coords;
                    Pose {
                        translation: [p.translation.x, p.translation.y, p.translation.z],
                        rotation: [q.x, q.y, q.z, q.w],
                    }
                })
                .collect(),
        );
        report.contact_particles = Some(sim.contacts().iter().map(|c| c.particle).collect());
    }
    to_json(&report)
}
