//! Leases: how nodes sharing the database share its jobs.
//!
//! A worker claims the oldest job that is queued, or running under a
//! lease that lapsed (its node died or lost the database), with
//! `FOR UPDATE SKIP LOCKED`, so workers claiming at once never wait for
//! each other and never take the same job. The claim sets `node` and
//! `lease_until` on the database's clock; the node renews its leases
//! every second while it runs them. Every later write for the job (frames,
//! its end, a requeue) is fenced by `node`: a node whose lease was taken
//! over writes nothing more, and stops the run.

use super::jobs::{JOB_COLUMNS, job_id, job_row};
use super::pool::{NOW, Postgres};
use crate::service::job::{JobId, now};
use crate::service::store::error::{Result, StoreError};
use crate::service::store::{Ending, JobRow};

impl Postgres {
    /// Node `node` takes the oldest queued job, or the oldest running one
    /// whose lease lapsed, for `lease` seconds.
    pub fn claim(&self, node: &str, lease: f64) -> Result<Option<JobRow>> {
        let t = now();
        let row = self.with(async |c| {
            c.query_opt(
                &format!(
                    "WITH next AS (
                         SELECT seq FROM jobs
                         WHERE status = 'queued'
                            OR (status = 'running' AND lease_until < {NOW})
                         ORDER BY seq LIMIT 1
                         FOR UPDATE SKIP LOCKED)
                     UPDATE jobs SET status = 'running', attempts = attempts + 1,
                         started_at = COALESCE(started_at, $2), node = $1,
                         lease_until = {NOW} + $3
                     FROM next WHERE jobs.seq = next.seq
                     RETURNING {}",
                    prefixed(JOB_COLUMNS)
                ),
                &[&node, &t, &lease],
            )
            .await
        })?;
        row.as_ref().map(job_row).transpose()
    }

    /// Extends node `node`'s leases on `ids`; returns those it holds, with
    /// their cancel requests.
    pub fn renew(&self, node: &str, lease: f64, ids: &[JobId]) -> Result<Vec<(JobId, bool)>> {
        let ids: Vec<String> = ids.iter().map(ToString::to_string).collect();
        let rows = self.with(async |c| {
            c.query(
                &format!(
                    "UPDATE jobs SET lease_until = {NOW} + $2
                     WHERE id = ANY($3) AND node = $1 AND status = 'running'
                     RETURNING id, cancel_requested"
                ),
                &[&node, &lease, &ids],
            )
            .await
        })?;
        rows.iter()
            .map(|r| Ok((job_id(r.get(0))?, r.get(1))))
            .collect()
    }

    /// The job node `node` runs ended; its checkpoint goes.
    pub fn finish(&self, node: &str, id: JobId, end: &Ending<'_>) -> Result<()> {
        let key = id.to_string();
        let status = end.status.as_str();
        let held = self.with(async |c| {
            let tx = c.transaction().await?;
            let seq = tx
                .query_opt(
                    "UPDATE jobs SET status = $3, error = $4, stats = $5, finished_at = $6,
                     run_seconds = $7, lease_until = NULL
                     WHERE id = $1 AND node = $2 AND status = 'running' RETURNING seq",
                    &[
                        &key,
                        &node,
                        &status,
                        &end.error,
                        &end.stats,
                        &end.finished_at,
                        &end.run_seconds,
                    ],
                )
                .await?;
            if let Some(seq) = &seq {
                tx.execute(
                    "DELETE FROM checkpoints WHERE job = $1",
                    &[&seq.get::<_, i64>(0)],
                )
                .await?;
            }
            tx.commit().await?;
            Ok(seq.is_some())
        })?;
        held.then_some(()).ok_or(StoreError::LeaseLost(id))
    }

    /// A job node `node` ran was stopped by its shutdown: queued again.
    pub fn requeue(&self, node: &str, id: JobId, run_seconds: f64) -> Result<()> {
        let key = id.to_string();
        let n = self.with(async |c| {
            c.execute(
                "UPDATE jobs SET status = 'queued', run_seconds = $3, node = NULL,
                 lease_until = NULL WHERE id = $1 AND node = $2 AND status = 'running'",
                &[&key, &node, &run_seconds],
            )
            .await
        })?;
        (n == 1).then_some(()).ok_or(StoreError::LeaseLost(id))
    }
}

/// `a, b` as `jobs.a, jobs.b` (an `UPDATE … FROM` names its table).
fn prefixed(columns: &str) -> String {
    columns
        .split(',')
        .map(|c| format!("jobs.{}", c.trim()))
        .collect::<Vec<_>>()
        .join(", ")
}
