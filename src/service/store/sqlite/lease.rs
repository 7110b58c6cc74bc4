//! A job's run on the one node of an SQLite store: claiming the oldest
//! queued job, renewing its lease, and recording how the run ended. The
//! same statements as the shared store's, so the service above runs one
//! protocol; with one node no lease is ever taken over, and the fence
//! (`node = ?`) only guards against a run that outlived its own end.

use rusqlite::{OptionalExtension, params};

use super::db::{Result, Sqlite};
use super::jobs::{JOB_COLUMNS, job_row};
use crate::service::job::{JobId, now};
use crate::service::store::{Ending, JobRow, StoreError};

impl Sqlite {
    /// Node `node` takes the oldest queued job for `lease` seconds.
    pub fn claim(&self, node: &str, lease: f64) -> Result<Option<JobRow>> {
        let t = now();
        self.write(|c| {
            c.query_row(
                &format!(
                    "UPDATE jobs SET status = 'running', attempts = attempts + 1,
                     started_at = COALESCE(started_at, ?2), node = ?1, lease_until = ?3
                     WHERE seq = (SELECT seq FROM jobs WHERE status = 'queued'
                                  ORDER BY seq LIMIT 1)
                     RETURNING {JOB_COLUMNS}"
                ),
                params![node, t, t + lease],
                job_row,
            )
            .optional()
        })
    }

    /// Extends node `node`'s leases on `ids`; returns those it holds, with
    /// their cancel requests.
    pub fn renew(&self, node: &str, lease: f64, ids: &[JobId]) -> Result<Vec<(JobId, bool)>> {
        let until = now() + lease;
        self.write(|c| {
            let mut stmt = c.prepare_cached(
                "UPDATE jobs SET lease_until = ?3
                 WHERE id = ?1 AND node = ?2 AND status = 'running'
                 RETURNING cancel_requested",
            )?;
            let mut held = Vec::with_capacity(ids.len());
            for id in ids {
                let cancel: Option<bool> = stmt
                    .query_row(params![id, node, until], |r| r.get(0))
                    .optional()?;
                if let Some(cancel) = cancel {
                    held.push((*id, cancel));
                }
            }
            Ok(held)
        })
    }

    /// The job node `node` runs ended; its checkpoint goes (it only serves
    /// a resume) and its pages go back to the file system.
    pub fn finish(&self, node: &str, id: JobId, end: &Ending<'_>) -> Result<()> {
        let held = self.write(|c| {
            let tx = c.transaction()?;
            let n = tx.execute(
                "UPDATE jobs SET status = ?3, error = ?4, stats = ?5, finished_at = ?6,
                 run_seconds = ?7, lease_until = NULL
                 WHERE id = ?1 AND node = ?2 AND status = 'running'",
                params![
                    id,
                    node,
                    end.status,
                    end.error,
                    end.stats,
                    end.finished_at,
                    end.run_seconds
                ],
            )?;
            if n == 1 {
                tx.execute(
                    "DELETE FROM checkpoints WHERE job = (SELECT seq FROM jobs WHERE id = ?1)",
                    [id],
                )?;
            }
            tx.commit()?;
            if n == 1 {
                super::schema::reclaim(c)?;
            }
            Ok(n == 1)
        })?;
        held.then_some(()).ok_or(StoreError::LeaseLost(id))
    }

    /// A job node `node` ran was stopped by its shutdown: queued again.
    pub fn requeue(&self, node: &str, id: JobId, run_seconds: f64) -> Result<()> {
        let n = self.write(|c| {
            c.execute(
                "UPDATE jobs SET status = 'queued', run_seconds = ?3, node = NULL,
                 lease_until = NULL WHERE id = ?1 AND node = ?2 AND status = 'running'",
                params![id, node, run_seconds],
            )
        })?;
        (n == 1).then_some(()).ok_or(StoreError::LeaseLost(id))
    }
}

#[cfg(test)]
mod tests {
    use super::super::db::temp_store;
    use super::super::jobs::new_job;
    use super::*;
    use crate::service::job::Status;

    #[test]
    fn only_the_holder_renews_finishes_or_requeues_and_cancels_reach_it() {
        let s = temp_store();
        let id = JobId::generate();
        s.insert_job(&new_job(id, "")).expect("insert");
        assert!(s.claim("a", 10.0).expect("claim").is_some());
        assert_eq!(s.renew("a", 10.0, &[id]).expect("renew"), [(id, false)]);
        assert!(s.renew("b", 10.0, &[id]).expect("renew").is_empty());
        assert!(s.request_cancel(id).expect("cancel"));
        assert_eq!(s.renew("a", 10.0, &[id]).expect("renew"), [(id, true)]);
        assert!(matches!(
            s.requeue("b", id, 1.0),
            Err(StoreError::LeaseLost(_))
        ));
        s.requeue("a", id, 1.0).expect("requeue");
        assert!(
            !s.request_cancel(id).expect("cancel"),
            "queued: not running"
        );
        let row = s.claim("a", 10.0).expect("claim").expect("queued again");
        assert_eq!((row.attempts, row.run_seconds), (2, 1.0));
        let end = Ending {
            status: Status::Succeeded,
            error: None,
            stats: None,
            finished_at: 2.0,
            run_seconds: 2.0,
        };
        assert!(matches!(
            s.finish("b", id, &end),
            Err(StoreError::LeaseLost(_))
        ));
        s.finish("a", id, &end).expect("finish");
        let row = s.job(id).expect("read").expect("exists");
        assert_eq!(
            (row.status, row.node.as_deref()),
            (Status::Succeeded, Some("a"))
        );
    }
}
