//! Cancellation: a queued job is cancelled at once; a running one is asked
//! to stop at its next solver step, and the answer waits (a while) for it.

use std::sync::Arc;
use std::time::Duration;

use super::error::JobsError;
use super::lifecycle::Jobs;
use super::running::StopReason;
use crate::service::job::{JobId, Status, now};
use crate::service::keys::Owner;
use crate::service::store::{JobRow, StoreError};

/// Longest wait for a running job to stop.
const CANCEL_WAIT: Duration = Duration::from_secs(5);

impl Jobs {
    /// Cancels job `id` of `owner` if it is queued or running; returns it
    /// as it is then (cancelled, or still running after 5 s). A job that
    /// already succeeded or failed cannot be; a cancelled one stays so.
    pub async fn cancel(self: &Arc<Self>, owner: &Owner, id: &str) -> Result<JobRow, JobsError> {
        // Subscribe before reading the job, so its end is not missed.
        let mut rx = JobId::parse(id).and_then(|id| self.hub.subscribe(id));
        let row = self.get(owner, id).await?;
        match row.status {
            Status::Succeeded | Status::Failed => return Err(JobsError::AlreadyEnded(row.status)),
            Status::Cancelled => return Ok(row),
            Status::Queued | Status::Running => {}
        }
        let job = row.id;
        let cancelled_queued = self
            .blocking(move |jobs| Ok::<_, JobsError>(jobs.cancel_if_queued(job)?))
            .await?;
        if !cancelled_queued {
            self.running.stop(job, StopReason::Cancelled);
            if let Some(rx) = &mut rx {
                let _ = tokio::time::timeout(CANCEL_WAIT, rx.wait_for(|l| l.status.is_terminal()))
                    .await;
            }
        }
        tracing::info!(id = %job, "job cancel requested");
        self.get(owner, id).await
    }

    /// Cancels job `id` if it is still queued (and frees its place in the
    /// queue); `false` if it was not.
    fn cancel_if_queued(&self, id: JobId) -> Result<bool, StoreError> {
        let done = self.store.cancel_queued(id, now())?;
        if done {
            self.queue.remove(id);
            self.hub.close(id, Status::Cancelled);
        }
        Ok(done)
    }
}
