//! A worker's side of a job: claim the next one from the store (a queued
//! job, or one whose node stopped renewing its lease), record its frames
//! as they come, and record how the attempt ended. The worker runs the
//! solver; everything it changes about the job goes through here.

use std::sync::Arc;
use std::time::{Duration, Instant};

use tracing::{error, info, warn};

use super::hub::Live;
use super::lifecycle::Jobs;
use super::running::{RunHandle, StopReason};
use super::wakeup::POLL;
use crate::service::error_code::ErrorCode;
use crate::service::job::{JobError, JobId, Status, now};
use crate::service::protocol::to_json;
use crate::service::store::{Ending, JobRow, StoreError, StoredFrame};

/// A job a worker has started.
#[derive(Debug)]
pub struct Attempt {
    /// The job as it was when it started.
    pub row: JobRow,
    /// Its stop flag and deadline.
    pub handle: Arc<RunHandle>,
}

/// How one attempt at a job ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Every frame is stored; the run's statistics summary.
    Succeeded(String),
    /// Why, and the statistics of the frames run.
    Failed(JobError, Option<String>),
    /// Its owner cancelled it.
    Cancelled(Option<String>),
    /// Shutdown: back to the queue, to resume from the checkpoint.
    Interrupted,
    /// The store went away or another node took the job over: nothing is
    /// recorded; the lease lapses (or has) and a node resumes the job
    /// from its checkpoint.
    Lost,
}

impl Jobs {
    /// Claims the next job for this node, waiting while there is none;
    /// `None` once shutting down. A store that does not answer is waited
    /// out the same way.
    pub fn next_attempt(&self) -> Option<Attempt> {
        // Said once per outage, not at every look.
        let mut failing = false;
        while !self.is_stopping() {
            let seen = self.wakeup.seen();
            match self.claim() {
                Ok(Some(attempt)) => return Some(attempt),
                Ok(None) => failing = false,
                Err(e) if !failing => {
                    warn!(error = %e, "claiming a job failed; trying again every {POLL:?}");
                    failing = true;
                }
                Err(e) => tracing::debug!(error = %e, "claiming a job failed again"),
            }
            self.wakeup.wait(seen, self.stopping_flag(), POLL);
        }
        None
    }

    /// Claims the oldest queued job (or one whose lease lapsed) for this
    /// node and starts it: a stop flag, a deadline for what is left of its
    /// wall time, its stream news, and its hello stored the first time.
    pub fn claim(&self) -> Result<Option<Attempt>, StoreError> {
        let Some(row) = self
            .store
            .claim(&self.config.node, self.config.lease_seconds)?
        else {
            return Ok(None);
        };
        let id = row.id;
        let left = (self.config.max_wall_seconds - row.run_seconds).max(0.0);
        let deadline =
            Instant::now() + Duration::try_from_secs_f64(left.min(1e9)).unwrap_or_default();
        let handle = Arc::new(RunHandle::new(deadline));
        if row.cancel_requested {
            // Cancelled while the node that ran it was stopping or dying.
            handle.stop(StopReason::Cancelled);
        }
        self.running.insert(id, Arc::clone(&handle));
        self.hub.open(
            id,
            Live {
                frames: row.frames_done,
                status: Status::Running,
            },
        );
        if let Err(e) = self.store_hello(&row) {
            // Its streams build it when they need it; the run itself
            // reports a spec that does not load.
            error!(%id, error = %e, "the job's hello could not be stored");
        }
        info!(%id, attempt = row.attempts, node = %self.config.node, "job started");
        Ok(Some(Attempt { row, handle }))
    }

    /// The latest checkpoint of job `id`: its frame and data.
    pub fn checkpoint(&self, id: JobId) -> Result<Option<(u64, Vec<u8>)>, StoreError> {
        self.store.checkpoint(id)
    }

    /// The bytes job `id` holds: hello, frames `0..=upto`, checkpoint.
    pub fn stored_bytes(&self, id: JobId, upto: Option<u64>) -> Result<u64, StoreError> {
        self.store.stored_bytes(id, upto)
    }

    /// The statistics JSON of frames `0..=upto` of job `id`.
    pub fn frame_stats(&self, id: JobId, upto: u64) -> Result<Vec<String>, StoreError> {
        self.store.frame_stats(id, upto)
    }

    /// Stores a frame (with the checkpoint taken at it, if any) and the
    /// job's running time so far, counts the frame and its solver time per
    /// step, and tells the job's streams.
    pub fn record_frame(
        &self,
        id: JobId,
        frame: &StoredFrame,
        checkpoint: Option<&[u8]>,
        seconds_per_step: Option<f64>,
        run_seconds: f64,
    ) -> Result<(), StoreError> {
        self.store
            .put_frame(&self.config.node, id, frame, checkpoint, run_seconds)?;
        self.metrics.frames.inc();
        if let Some(s) = seconds_per_step {
            self.metrics.step_seconds.observe(s);
        }
        self.hub
            .update(id, |l| l.frames = l.frames.max(frame.n + 1));
        Ok(())
    }

    /// Records how `attempt` ended after `run_seconds` of running over all
    /// attempts, and tells its streams.
    pub fn conclude(
        &self,
        attempt: &Attempt,
        outcome: Outcome,
        run_seconds: f64,
    ) -> Result<(), StoreError> {
        let id = attempt.row.id;
        let node = &self.config.node;
        self.running.remove(id);
        let (status, error, stats) = match outcome {
            Outcome::Interrupted => {
                // Its streams here follow it in the store from now on.
                self.hub.drop_job(id);
                self.store.requeue(node, id, run_seconds)?;
                info!("job interrupted by shutdown; it resumes at the next start");
                return Ok(());
            }
            Outcome::Lost => {
                self.hub.drop_job(id);
                warn!("job left to its lease: the store was lost or another node took it over");
                return Ok(());
            }
            Outcome::Succeeded(stats) => (Status::Succeeded, None, Some(stats)),
            Outcome::Cancelled(stats) => (Status::Cancelled, None, stats),
            Outcome::Failed(e, stats) => (Status::Failed, Some(e), stats),
        };
        let error = error.map(|e| to_json(&e));
        self.store.finish(
            node,
            id,
            &Ending {
                status,
                error: error.as_deref(),
                stats: stats.as_deref(),
                finished_at: now(),
                run_seconds,
            },
        )?;
        self.hub.close(id, status);
        info!(status = status.as_str(), run_seconds, "job ended");
        Ok(())
    }

    /// Fails job `id` for a reason of the service's own (a panic, an end
    /// that could not be recorded), as well as the store still allows.
    pub fn fail(&self, id: JobId, message: &str) {
        self.running.remove(id);
        let error = to_json(&JobError {
            code: ErrorCode::Internal,
            message: message.to_owned(),
        });
        let ending = Ending {
            status: Status::Failed,
            error: Some(&error),
            stats: None,
            finished_at: now(),
            run_seconds: 0.0,
        };
        match self.store.finish(&self.config.node, id, &ending) {
            Ok(()) => self.hub.close(id, Status::Failed),
            Err(e) => {
                error!(error = %e, "could not record the failure either");
                self.hub.drop_job(id);
            }
        }
    }

    /// Lets go of job `id` without recording anything: the store is
    /// unreachable or the job is another node's now. Its lease lapses (or
    /// has), and a node resumes it from its checkpoint.
    pub fn release(&self, id: JobId) {
        self.running.remove(id);
        self.hub.drop_job(id);
    }
}
