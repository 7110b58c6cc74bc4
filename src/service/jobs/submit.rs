//! Submission: a spec becomes a queued job, or is refused with the reason.

use std::sync::Arc;

use drapery_sim::spec::{MeshSource, Scene};
use tracing::info;

use super::error::{Fault, SubmitError};
use super::hello;
use super::lifecycle::Jobs;
use crate::service::cost;
use crate::service::job::{JobId, now};
use crate::service::keys::Owner;
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
        // Held by the check itself, which runs on even if the client goes
        // (never closed: the semaphore lives as long as `self`).
        let turn = Arc::clone(&self.checks).acquire_owned().await.ok();
        let row = self
            .blocking(move |jobs| {
                let _turn = turn;
                jobs.submit_now(&owner, body.as_ref())
            })
            .await?;
        info!(id = %row.id, name = %row.name, "job submitted");
        Ok(row)
    }

    fn submit_now(&self, owner: &str, body: &[u8]) -> Result<JobRow, SubmitError> {
        let text = std::str::from_utf8(body).map_err(SubmitError::NotUtf8)?;
        // Weighed against the budgets before its obstacles are built.
        let admit = |scene: &Scene| {
            let estimate = cost::estimate(scene, mesh_triangles(scene));
            let over = self.config.budgets.check(&estimate);
            if over.is_empty() {
                return Ok(());
            }
            self.metrics.rejected_over_budget.inc();
            Err(SubmitError::OverBudget(over))
        };
        let (scene, spec) = specfile::load_spec(text, &self.config.limits, admit)?;
        // The spec as read, not the body: as long as what it says.
        let stored = serde_json::to_string(&spec).unwrap_or_else(|_| text.to_owned());
        // NOTE: the hello itself is built when the job first starts: a job
        // cancelled while it waits never pays for it, in time or disk.
        hello::check(&scene).map_err(SubmitError::Undrawable)?;
        let id = JobId::generate();
        let _guard = self.submit_lock();
        if super::lifecycle::queued(&self.store.count_by_status()?) >= self.config.queue_capacity {
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
            spec: &stored,
            hello: "",
            frames_total: scene.frames as u64 + 1,
            created_at: now(),
        })?;
        self.wakeup.ring();
        self.metrics.submitted.inc();
        Ok(self.store.job(id)?.ok_or(Fault::Vanished(id))?)
    }
}

/// The triangles of the scene's obstacle meshes (primitives have none:
/// collision treats them exactly). Validation loaded each mesh already, so
/// none fails here.
fn mesh_triangles(scene: &Scene) -> u64 {
    // Validation parsed every mesh and bounded the sum: an OBJ is counted
    // from its faces and inline triangles as given, not parsed again.
    let count = |m: &MeshSource| match (&m.obj, &m.triangles) {
        (Some(obj), _) => drapery_sim::mesh::obj_triangles(obj),
        (None, Some(t)) => t.len(),
        (None, None) => drapery_sim::mesh::from_source(m).map_or(0, |m| m.triangles().len()),
    };
    scene
        .obstacles
        .iter()
        .filter_map(|o| o.mesh.as_ref())
        .map(|m| count(m) as u64)
        .sum()
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use crate::service::keys::Owner;

    const SPEC: &str = r#"{"cloth": {"grid": [3, 3], "size": [1, 1]}, "material": "cotton", "duration": 0.1, "fps": 10}"#;

    /// A submission is checked only in a turn of its own: with every turn
    /// taken it waits, and it goes through once one is given back.
    #[tokio::test]
    async fn a_submission_waits_for_a_turn_to_be_checked() {
        let jobs = super::super::jobs_for_tests("submit-turns");
        let turns = jobs.checks.available_permits() as u32;
        let taken = Arc::clone(&jobs.checks)
            .acquire_many_owned(turns)
            .await
            .expect("open");
        let submitting = tokio::spawn({
            let jobs = Arc::clone(&jobs);
            async move { jobs.submit(&Owner(None), SPEC.as_bytes()).await }
        });
        tokio::time::sleep(Duration::from_millis(300)).await;
        assert!(!submitting.is_finished(), "checked without a turn");
        drop(taken);
        let row = submitting.await.expect("joins").expect("submitted");
        assert_eq!(
            jobs.store.job(row.id).expect("reads").map(|r| r.id),
            Some(row.id)
        );
    }
}
