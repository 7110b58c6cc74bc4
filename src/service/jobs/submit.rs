//! Submission: a spec becomes a queued job, or is refused with the reason.

use std::sync::Arc;

use tracing::info;

use super::error::{Fault, SubmitError};
use super::hello;
use super::hub::Live;
use super::lifecycle::Jobs;
use crate::service::job::{JobId, Status, now};
use crate::service::keys::Owner;
use crate::service::protocol::StreamMessage;
use crate::service::store::{JobRow, NewJob};
use crate::specfile;

impl Jobs {
    /// Parses and validates `body` against the server's limits; stores a
    /// valid spec as a job of `owner` and queues it.
    pub async fn submit(
        self: &Arc<Self>,
        owner: &Owner,
        body: impl AsRef<[u8]> + Send + 'static,
    ) -> Result<JobRow, SubmitError> {
        let owner = owner.name().to_owned();
        let row = self
            .blocking(move |jobs| jobs.submit_now(&owner, body.as_ref()))
            .await?;
        info!(id = %row.id, name = %row.name, "job submitted");
        Ok(row)
    }

    fn submit_now(&self, owner: &str, body: &[u8]) -> Result<JobRow, SubmitError> {
        let text = std::str::from_utf8(body).map_err(SubmitError::NotUtf8)?;
        let scene = specfile::load(text, &self.config.limits).map_err(SubmitError::Spec)?;
        let id = JobId::generate();
        let hello = hello::build(&scene, id).map_err(SubmitError::Undrawable)?;
        let hello = StreamMessage::Hello(hello).to_json();
        let _guard = self.submit_lock();
        if self.queue.len() >= self.config.queue_capacity {
            self.metrics.rejected_queue_full.inc();
            return Err(SubmitError::QueueFull {
                capacity: self.config.queue_capacity,
            });
        }
        if self.is_stopping() {
            return Err(SubmitError::ShuttingDown);
        }
        self.store.insert_job(&NewJob {
            id,
            owner,
            name: &scene.name,
            spec: text,
            hello: &hello,
            frames_total: scene.frames as u64 + 1,
            created_at: now(),
        })?;
        self.hub.open(
            id,
            Live {
                frames: 0,
                status: Status::Queued,
            },
        );
        self.queue.push(id);
        self.metrics.submitted.inc();
        Ok(self.store.job(id)?.ok_or(Fault::Vanished(id))?)
    }
}
