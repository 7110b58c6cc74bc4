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
