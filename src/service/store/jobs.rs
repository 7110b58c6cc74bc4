//! The `jobs` table: a job's row through its life.

use drapery_sim::spec::{Limits, Scene};
use rusqlite::{OptionalExtension, params};

use super::db::{Result, Store};
use crate::service::job::{JobError, JobId, Status};
use crate::specfile::{self, SpecLoadError};

/// A job as stored.
#[derive(Debug, Clone, PartialEq)]
pub struct JobRow {
    /// Submission order (newest is largest): the list's order and cursor.
    pub seq: i64,
    pub id: JobId,
    pub owner: String,
    pub name: String,
    pub status: Status,
    pub spec: String,
    pub frames_total: u64,
    /// Frames stored, `0..frames_done` (contiguous).
    pub frames_done: u64,
    /// Unix seconds.
    pub created_at: f64,
    pub started_at: Option<f64>,
    pub finished_at: Option<f64>,
    /// Wall seconds spent running, over all attempts.
    pub run_seconds: f64,
    /// Times a worker started the job (more than 1 after a restart).
    pub attempts: u32,
    /// JSON `{"code", "message"}` of a failed job.
    pub error: Option<String>,
    /// JSON summary of the run's statistics, when it ended.
    pub stats: Option<String>,
}

impl JobRow {
    /// The job's scene, from its stored spec. Submission checked the spec
    /// against the service's limits; the core's own limits only guard
    /// against a corrupted store here.
    pub fn scene(&self) -> std::result::Result<Scene, SpecLoadError> {
        specfile::load(&self.spec, &Limits::default())
    }

    /// Why it failed, if it did.
    pub fn failure(&self) -> Option<JobError> {
        self.error
            .as_deref()
            .and_then(|s| serde_json::from_str(s).ok())
    }

    /// The run's statistics summary, once it ended.
    pub fn summary(&self) -> Option<serde_json::Value> {
        self.stats
            .as_deref()
            .and_then(|s| serde_json::from_str(s).ok())
    }
}

/// What a submission stores.
#[derive(Debug)]
pub struct NewJob<'a> {
    pub id: JobId,
    pub owner: &'a str,
    pub name: &'a str,
    pub spec: &'a str,
    pub hello: &'a str,
    pub frames_total: u64,
    pub created_at: f64,
}

/// How a job ended, as recorded.
#[derive(Debug)]
pub struct Ending<'a> {
    pub status: Status,
    pub error: Option<&'a str>,
    pub stats: Option<&'a str>,
    pub finished_at: f64,
    pub run_seconds: f64,
}

const JOB_COLUMNS: &str = "seq, id, owner, name, status, spec, frames_total, frames_done,
    created_at, started_at, finished_at, run_seconds, attempts, error, stats";

impl Store {
    /// Stores a submitted job as queued.
    pub fn insert_job(&self, job: &NewJob<'_>) -> Result<()> {
        self.write(|c| {
            c.execute(
                "INSERT INTO jobs (id, owner, name, status, spec, hello, frames_total, created_at)
                 VALUES (?1, ?2, ?3, 'queued', ?4, ?5, ?6, ?7)",
                params![
                    job.id,
                    job.owner,
                    job.name,
                    job.spec,
                    job.hello,
                    job.frames_total as i64,
                    job.created_at
                ],
            )
            .map(drop)
        })
    }

    /// The job with this id.
    pub fn job(&self, id: JobId) -> Result<Option<JobRow>> {
        self.read(|c| {
            c.query_row(
                &format!("SELECT {JOB_COLUMNS} FROM jobs WHERE id = ?1"),
                [id],
                job_row,
            )
            .optional()
        })
    }

    /// Jobs newest first: of `owner` if given, with `status` if given,
    /// older than the cursor `before` if given.
    pub fn list(
        &self,
        owner: Option<&str>,
        status: Option<Status>,
        before: Option<i64>,
        limit: usize,
    ) -> Result<Vec<JobRow>> {
        self.read(|c| {
            let mut stmt = c.prepare_cached(&format!(
                "SELECT {JOB_COLUMNS} FROM jobs
                 WHERE (?1 IS NULL OR owner = ?1) AND (?2 IS NULL OR status = ?2)
                   AND (?3 IS NULL OR seq < ?3)
                 ORDER BY seq DESC LIMIT ?4"
            ))?;
            let rows = stmt.query_map(params![owner, status, before, limit as i64], job_row)?;
            rows.collect()
        })
    }

    /// Jobs left queued or running by an earlier process, oldest first.
    pub fn unfinished(&self) -> Result<Vec<JobRow>> {
        self.read(|c| {
            let mut stmt = c.prepare(&format!(
                "SELECT {JOB_COLUMNS} FROM jobs WHERE status IN ('queued', 'running') ORDER BY seq"
            ))?;
            let rows = stmt.query_map([], job_row)?;
            rows.collect()
        })
    }

    /// Number of jobs in each status.
    pub fn count_by_status(&self) -> Result<Vec<(Status, u64)>> {
        self.read(|c| {
            let mut stmt = c.prepare_cached("SELECT status, COUNT(*) FROM jobs GROUP BY status")?;
            let rows = stmt.query_map([], |r| Ok((r.get(0)?, r.get::<_, i64>(1)? as u64)))?;
            rows.collect()
        })
    }

    /// The stream's hello message of a job.
    pub fn hello(&self, id: JobId) -> Result<Option<String>> {
        self.read(|c| {
            c.query_row("SELECT hello FROM jobs WHERE id = ?1", [id], |r| r.get(0))
                .optional()
        })
    }

    /// A worker starts the job: running, one more attempt. `false` if it
    /// is no longer queued (cancelled between the pop and the start).
    pub fn mark_running(&self, id: JobId, now: f64) -> Result<bool> {
        self.write(|c| {
            let n = c.execute(
                "UPDATE jobs SET status = 'running', attempts = attempts + 1,
                 started_at = COALESCE(started_at, ?2) WHERE id = ?1 AND status = 'queued'",
                params![id, now],
            )?;
            Ok(n == 1)
        })
    }

    /// The job ended (succeeded, failed or cancelled).
    pub fn finish(&self, id: JobId, end: &Ending<'_>) -> Result<()> {
        self.write(|c| {
            let tx = c.transaction()?;
            tx.execute(
                "UPDATE jobs SET status = ?2, error = ?3, stats = ?4, finished_at = ?5,
                 run_seconds = ?6 WHERE id = ?1",
                params![
                    id,
                    end.status,
                    end.error,
                    end.stats,
                    end.finished_at,
                    end.run_seconds
                ],
            )?;
            // The checkpoint only serves a resume; an ended job has none,
            // and its pages go back to the file system.
            tx.execute(
                "DELETE FROM checkpoints WHERE job = (SELECT seq FROM jobs WHERE id = ?1)",
                [id],
            )?;
            tx.commit()?;
            super::schema::reclaim(c)
        })
    }

    /// A running job was stopped by a shutdown: queued again, to resume.
    pub fn requeue(&self, id: JobId, run_seconds: f64) -> Result<()> {
        self.write(|c| {
            c.execute(
                "UPDATE jobs SET status = 'queued', run_seconds = ?2 WHERE id = ?1",
                params![id, run_seconds],
            )
            .map(drop)
        })
    }

    /// Cancels a job if it is still queued; `false` if it was not.
    pub fn cancel_queued(&self, id: JobId, now: f64) -> Result<bool> {
        self.write(|c| {
            let n = c.execute(
                "UPDATE jobs SET status = 'cancelled', finished_at = ?2
                 WHERE id = ?1 AND status = 'queued'",
                params![id, now],
            )?;
            Ok(n == 1)
        })
    }
}

fn job_row(r: &rusqlite::Row<'_>) -> rusqlite::Result<JobRow> {
    Ok(JobRow {
        seq: r.get(0)?,
        id: r.get(1)?,
        owner: r.get(2)?,
        name: r.get(3)?,
        status: r.get(4)?,
        spec: r.get(5)?,
        frames_total: r.get::<_, i64>(6)? as u64,
        frames_done: r.get::<_, i64>(7)? as u64,
        created_at: r.get(8)?,
        started_at: r.get(9)?,
        finished_at: r.get(10)?,
        run_seconds: r.get(11)?,
        attempts: r.get::<_, i64>(12)? as u32,
        error: r.get(13)?,
        stats: r.get(14)?,
    })
}

/// A submission of `id` by `owner`, as the store tests make them.
#[cfg(test)]
pub(super) fn new_job(id: JobId, owner: &str) -> NewJob<'_> {
    NewJob {
        id,
        owner,
        name: "t",
        spec: "{}",
        hello: "{}",
        frames_total: 3,
        created_at: 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::super::db::temp_store;
    use super::*;

    #[test]
    fn lists_newest_first_by_owner_and_status_with_a_cursor() {
        let s = temp_store();
        let [a, b, c] = [JobId::generate(), JobId::generate(), JobId::generate()];
        s.insert_job(&new_job(a, "alice")).expect("insert");
        s.insert_job(&new_job(b, "bob")).expect("insert");
        s.insert_job(&new_job(c, "alice")).expect("insert");
        let seq = |id| s.job(id).expect("read").expect("exists").seq;
        assert!(seq(a) < seq(b) && seq(b) < seq(c));
        let ids = |rows: Vec<JobRow>| rows.into_iter().map(|r| r.id).collect::<Vec<_>>();
        assert_eq!(ids(s.list(None, None, None, 10).expect("list")), [c, b, a]);
        assert_eq!(
            ids(s.list(Some("alice"), None, None, 10).expect("list")),
            [c, a]
        );
        assert_eq!(ids(s.list(None, None, Some(seq(c)), 1).expect("list")), [b]);
        assert!(s.mark_running(b, 2.0).expect("run"));
        assert!(
            !s.mark_running(b, 2.0).expect("run"),
            "only a queued job starts"
        );
        assert_eq!(
            ids(s.list(None, Some(Status::Running), None, 10).expect("list")),
            [b]
        );
        assert!(s.cancel_queued(a, 3.0).expect("cancel"));
        assert!(!s.cancel_queued(b, 3.0).expect("cancel"), "b is running");
        assert_eq!(ids(s.unfinished().expect("unfinished")), [b, c]);
        assert_eq!(s.job(JobId::generate()).expect("read"), None);
    }

    #[test]
    fn an_ended_job_keeps_its_error_and_summary() {
        let s = temp_store();
        let id = JobId::generate();
        s.insert_job(&new_job(id, "")).expect("insert");
        s.finish(
            id,
            &Ending {
                status: Status::Failed,
                error: Some(r#"{"code":"non_finite","message":"NaN"}"#),
                stats: Some(r#"{"steps":3}"#),
                finished_at: 5.0,
                run_seconds: 1.0,
            },
        )
        .expect("finish");
        let row = s.job(id).expect("read").expect("exists");
        assert_eq!(row.status, Status::Failed);
        assert_eq!(row.failure().map(|e| e.message), Some("NaN".to_owned()));
        assert_eq!(row.summary(), Some(serde_json::json!({"steps": 3})));
        assert_eq!(s.count_by_status().expect("count"), [(Status::Failed, 1)]);
    }
}
