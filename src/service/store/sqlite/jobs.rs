//! The `jobs` table: a job's row through its life.

use rusqlite::{OptionalExtension, params};

use super::db::{Result, Sqlite};
use crate::service::job::{JobId, Status};
use crate::service::store::{JobRow, NewJob};

/// The columns [`job_row`] reads, in its order.
pub(super) const JOB_COLUMNS: &str = "seq, id, owner, name, status, spec, frames_total,
    frames_done, created_at, started_at, finished_at, run_seconds, attempts, error, stats,
    node, cancel_requested";

impl Sqlite {
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

    /// At start: every running job was this process's (one machine, one
    /// node), interrupted by a crash; it is queued again, to resume from
    /// its checkpoint. Returns how many jobs wait.
    pub fn recover(&self, _node: &str) -> Result<usize> {
        self.write(|c| {
            c.execute(
                "UPDATE jobs SET status = 'queued', node = NULL, lease_until = NULL
                 WHERE status = 'running'",
                [],
            )?;
            c.query_row(
                "SELECT COUNT(*) FROM jobs WHERE status = 'queued'",
                [],
                |r| r.get::<_, i64>(0),
            )
            .map(|n| n.max(0) as usize)
        })
    }

    /// Marks running job `id` to be cancelled by its worker.
    pub fn request_cancel(&self, id: JobId) -> Result<bool> {
        self.write(|c| {
            let n = c.execute(
                "UPDATE jobs SET cancel_requested = 1 WHERE id = ?1 AND status = 'running'",
                [id],
            )?;
            Ok(n == 1)
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

pub(super) fn job_row(r: &rusqlite::Row<'_>) -> rusqlite::Result<JobRow> {
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
        node: r.get(15)?,
        cancel_requested: r.get(16)?,
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
        let claimed = |s: &Sqlite| s.claim("n1", 10.0).expect("claim").map(|r| r.id);
        assert_eq!(claimed(&s), Some(a), "the oldest queued job first");
        assert_eq!(claimed(&s), Some(b));
        let row = s.job(b).expect("read").expect("exists");
        assert_eq!((row.status, row.attempts), (Status::Running, 1));
        assert_eq!(row.node.as_deref(), Some("n1"));
        assert_eq!(
            ids(s.list(None, Some(Status::Running), None, 10).expect("list")),
            [b, a]
        );
        assert!(s.cancel_queued(c, 3.0).expect("cancel"));
        assert!(!s.cancel_queued(b, 3.0).expect("cancel"), "b is running");
        assert_eq!(claimed(&s), None, "nothing is queued");
        assert_eq!(s.recover("n1").expect("recover"), 2, "a and b wait again");
        assert_eq!(s.job(a).expect("read").expect("exists").node, None);
        assert_eq!(s.job(JobId::generate()).expect("read"), None);
    }

    #[test]
    fn an_ended_job_keeps_its_error_and_summary() {
        let s = temp_store();
        let id = JobId::generate();
        s.insert_job(&new_job(id, "")).expect("insert");
        assert!(s.claim("n1", 10.0).expect("claim").is_some());
        s.finish(
            "n1",
            id,
            &crate::service::store::Ending {
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
