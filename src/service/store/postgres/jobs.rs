//! The `jobs` table in PostgreSQL: submission, lookups, listing, counts,
//! cancellation of a waiting job, recovery at a node's start.

use tokio_postgres::Row;

use super::pool::Postgres;
use crate::service::job::{JobId, Status};
use crate::service::store::error::{Result, StoreError};
use crate::service::store::{JobRow, NewJob};

/// The columns [`job_row`] reads, in its order.
pub(super) const JOB_COLUMNS: &str = "seq, id, owner, name, status, spec, frames_total,
    frames_done, created_at, started_at, finished_at, run_seconds, attempts, error, stats,
    node, cancel_requested";

impl Postgres {
    /// Stores a submitted job as queued.
    pub fn insert_job(&self, job: &NewJob<'_>) -> Result<()> {
        let id = job.id.to_string();
        let total = job.frames_total as i64;
        self.with(async |c| {
            c.execute(
                "INSERT INTO jobs (id, owner, name, status, spec, hello, frames_total, created_at)
                 VALUES ($1, $2, $3, 'queued', $4, $5, $6, $7)",
                &[
                    &id,
                    &job.owner,
                    &job.name,
                    &job.spec,
                    &job.hello,
                    &total,
                    &job.created_at,
                ],
            )
            .await
        })
        .map(drop)
    }

    /// The job with this id.
    pub fn job(&self, id: JobId) -> Result<Option<JobRow>> {
        let id = id.to_string();
        let row = self.with(async |c| {
            c.query_opt(
                &format!("SELECT {JOB_COLUMNS} FROM jobs WHERE id = $1"),
                &[&id],
            )
            .await
        })?;
        row.as_ref().map(job_row).transpose()
    }

    /// Jobs newest first, filtered as [`Store::list`](crate::service::store::Store::list).
    pub fn list(
        &self,
        owner: Option<&str>,
        status: Option<Status>,
        before: Option<i64>,
        limit: usize,
    ) -> Result<Vec<JobRow>> {
        let status = status.map(Status::as_str);
        let limit = limit as i64;
        let rows = self.with(async |c| {
            c.query(
                &format!(
                    "SELECT {JOB_COLUMNS} FROM jobs
                     WHERE ($1::TEXT IS NULL OR owner = $1) AND ($2::TEXT IS NULL OR status = $2)
                       AND ($3::BIGINT IS NULL OR seq < $3)
                     ORDER BY seq DESC LIMIT $4"
                ),
                &[&owner, &status, &before, &limit],
            )
            .await
        })?;
        rows.iter().map(job_row).collect()
    }

    /// Number of jobs in each status.
    pub fn count_by_status(&self) -> Result<Vec<(Status, u64)>> {
        let rows = self.with(async |c| {
            c.query("SELECT status, COUNT(*) FROM jobs GROUP BY status", &[])
                .await
        })?;
        rows.iter()
            .map(|r| Ok((status(r.get(0))?, r.get::<_, i64>(1).max(0) as u64)))
            .collect()
    }

    /// At start: the jobs this node (by its name) left running in an
    /// earlier life are queued again at once, rather than after their
    /// leases lapse; other nodes' jobs are theirs. Returns how many jobs
    /// wait.
    pub fn recover(&self, node: &str) -> Result<usize> {
        let n = self.with(async |c| {
            c.execute(
                "UPDATE jobs SET status = 'queued', node = NULL, lease_until = NULL
                 WHERE status = 'running' AND node = $1",
                &[&node],
            )
            .await?;
            c.query_one("SELECT COUNT(*) FROM jobs WHERE status = 'queued'", &[])
                .await
        })?;
        Ok(n.get::<_, i64>(0).max(0) as usize)
    }

    /// Cancels a job if it is still queued; `false` if it was not.
    pub fn cancel_queued(&self, id: JobId, now: f64) -> Result<bool> {
        let id = id.to_string();
        let n = self.with(async |c| {
            c.execute(
                "UPDATE jobs SET status = 'cancelled', finished_at = $2
                 WHERE id = $1 AND status = 'queued'",
                &[&id, &now],
            )
            .await
        })?;
        Ok(n == 1)
    }

    /// Marks running job `id` to be cancelled by the node running it.
    pub fn request_cancel(&self, id: JobId) -> Result<bool> {
        let id = id.to_string();
        let n = self.with(async |c| {
            c.execute(
                "UPDATE jobs SET cancel_requested = TRUE WHERE id = $1 AND status = 'running'",
                &[&id],
            )
            .await
        })?;
        Ok(n == 1)
    }

    /// The stream's hello message of a job.
    pub fn hello(&self, id: JobId) -> Result<Option<String>> {
        let id = id.to_string();
        let row = self.with(async |c| {
            c.query_opt("SELECT hello FROM jobs WHERE id = $1", &[&id])
                .await
        })?;
        Ok(row.map(|r| r.get(0)))
    }

    /// Stores job `id`'s hello.
    pub fn set_hello(&self, id: JobId, hello: &str) -> Result<()> {
        let id = id.to_string();
        self.with(async |c| {
            c.execute("UPDATE jobs SET hello = $2 WHERE id = $1", &[&id, &hello])
                .await
        })
        .map(drop)
    }
}

/// A status as stored.
fn status(text: &str) -> Result<Status> {
    Status::parse(text).ok_or_else(|| StoreError::Corrupt(format!("unknown job status {text:?}")))
}

/// A job id as stored.
pub(super) fn job_id(text: &str) -> Result<JobId> {
    JobId::parse(text).ok_or_else(|| StoreError::Corrupt(format!("bad job id {text:?}")))
}

/// The row of [`JOB_COLUMNS`].
pub(super) fn job_row(r: &Row) -> Result<JobRow> {
    Ok(JobRow {
        seq: r.get(0),
        id: job_id(r.get(1))?,
        owner: r.get(2),
        name: r.get(3),
        status: status(r.get(4))?,
        spec: r.get(5),
        frames_total: r.get::<_, i64>(6).max(0) as u64,
        frames_done: r.get::<_, i64>(7).max(0) as u64,
        created_at: r.get(8),
        started_at: r.get(9),
        finished_at: r.get(10),
        run_seconds: r.get(11),
        attempts: r.get::<_, i32>(12).max(0) as u32,
        error: r.get(13),
        stats: r.get(14),
        node: r.get(15),
        cancel_requested: r.get(16),
    })
}
