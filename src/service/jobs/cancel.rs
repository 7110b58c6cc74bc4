//! `DELETE` of a job: a queued job is cancelled at once; a running one is
//! asked to stop at its next solver step (through the store, so the
//! request reaches whichever node runs it, at its next lease renewal), and
//! the answer waits (a while) for it; an ended one (succeeded, failed or cancelled) is deleted with
//! its frames and checkpoint, and its space given back. Retention
//! (`--retention`) deletes ended jobs the same way.

use std::sync::Arc;
use std::time::Duration;

use super::error::JobsError;
use super::lifecycle::Jobs;
use super::running::StopReason;
use crate::cli::Retention;
use crate::service::job::{JobId, Status, now};
use crate::service::keys::Owner;
use crate::service::store::{JobRow, StoreError};

/// Longest wait for a running job to stop.
const CANCEL_WAIT: Duration = Duration::from_secs(5);
/// How often that wait looks at the job.
const CANCEL_POLL: Duration = Duration::from_millis(100);

impl Jobs {
    /// Cancels job `id` of `owner` if it is queued or running, and returns
    /// it as it is then (cancelled, or still running after 5 s); deletes it
    /// if it has ended, and returns it as it was.
    pub async fn cancel(self: &Arc<Self>, owner: &Owner, id: &str) -> Result<JobRow, JobsError> {
        let row = self.get(owner, id).await?;
        match row.status {
            Status::Succeeded | Status::Failed | Status::Cancelled => {
                let job = row.id;
                let deleted = self
                    .blocking(move |jobs| Ok::<_, JobsError>(jobs.delete(job)?))
                    .await?;
                return if deleted {
                    Ok(row)
                } else {
                    Err(JobsError::NotFound)
                };
            }
            Status::Queued | Status::Running => {}
        }
        let job = row.id;
        let cancelled_queued = self
            .blocking(move |jobs| Ok::<_, JobsError>(jobs.cancel_if_queued(job)?))
            .await?;
        if !cancelled_queued {
            self.blocking(move |jobs| Ok::<_, JobsError>(jobs.store.request_cancel(job)?))
                .await?;
            // At once if it runs here; elsewhere at that node's renewal.
            self.running.stop(job, StopReason::Cancelled);
            let waited = tokio::time::Instant::now();
            while waited.elapsed() < CANCEL_WAIT {
                tokio::time::sleep(CANCEL_POLL).await;
                if self.get(owner, id).await?.status.is_terminal() {
                    break;
                }
            }
        }
        tracing::info!(id = %job, "job cancel requested");
        self.get(owner, id).await
    }

    /// Deletes ended job `id`; `false` if it is not (any more) an ended
    /// job.
    fn delete(&self, id: JobId) -> Result<bool, StoreError> {
        let deleted = self.store.delete_ended(id)?;
        if deleted {
            self.metrics.deleted.inc();
            tracing::info!(%id, "job deleted");
        }
        Ok(deleted)
    }

    /// Deletes the ended jobs `--retention` no longer keeps; returns how
    /// many. Blocking: called on a timer, off the async executor.
    pub fn apply_retention(&self) -> Result<usize, StoreError> {
        let mut deleted = 0;
        for rule in &self.config.retention {
            let ids = match *rule {
                Retention::Age(age) => self.store.ended_before(now() - age.as_secs_f64())?,
                Retention::Count(keep) => self.store.ended_beyond(keep)?,
            };
            for id in ids {
                deleted += usize::from(self.delete(id)?);
            }
        }
        Ok(deleted)
    }

    /// Cancels job `id` if it is still queued; `false` if it was not.
    fn cancel_if_queued(&self, id: JobId) -> Result<bool, StoreError> {
        self.store.cancel_queued(id, now())
    }
}
