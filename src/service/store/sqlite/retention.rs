//! Deleting ended jobs and giving their space back; the bytes a job has
//! stored; the hello written when a job first starts.

use rusqlite::{OptionalExtension, params};

use super::db::{Result, Sqlite};
use super::schema::reclaim;
use crate::service::job::JobId;

impl Sqlite {
    /// Deletes an ended job with its frames and checkpoint, and gives the
    /// space back; `false` if there is no such ended job (a queued or
    /// running one is never deleted).
    pub fn delete_ended(&self, id: JobId) -> Result<bool> {
        let deleted = self.write(|c| {
            let tx = c.transaction()?;
            let seq: Option<i64> = tx
                .query_row(
                    "SELECT seq FROM jobs WHERE id = ?1
                     AND status IN ('succeeded', 'failed', 'cancelled')",
                    [id],
                    |r| r.get(0),
                )
                .optional()?;
            let Some(seq) = seq else {
                return Ok(false);
            };
            tx.execute("DELETE FROM frames WHERE job = ?1", [seq])?;
            tx.execute("DELETE FROM checkpoints WHERE job = ?1", [seq])?;
            tx.execute("DELETE FROM jobs WHERE seq = ?1", [seq])?;
            tx.commit()?;
            Ok(true)
        })?;
        if deleted {
            self.write(|c| reclaim(c))?;
        }
        Ok(deleted)
    }

    /// Ended jobs that finished before `cutoff` (unix seconds).
    pub fn ended_before(&self, cutoff: f64) -> Result<Vec<JobId>> {
        self.read(|c| {
            let mut stmt = c.prepare(
                "SELECT id FROM jobs WHERE status IN ('succeeded', 'failed', 'cancelled')
                 AND finished_at < ?1 ORDER BY seq",
            )?;
            let rows = stmt.query_map([cutoff], |r| r.get(0))?;
            rows.collect()
        })
    }

    /// Ended jobs beyond the `keep` that finished last.
    pub fn ended_beyond(&self, keep: usize) -> Result<Vec<JobId>> {
        self.read(|c| {
            let mut stmt = c.prepare(
                "SELECT id FROM jobs WHERE status IN ('succeeded', 'failed', 'cancelled')
                 ORDER BY finished_at DESC, seq DESC LIMIT -1 OFFSET ?1",
            )?;
            let rows = stmt.query_map([keep as i64], |r| r.get(0))?;
            rows.collect()
        })
    }

    /// Stores job `id`'s hello (written when it first starts).
    pub fn set_hello(&self, id: JobId, hello: &str) -> Result<()> {
        self.write(|c| {
            c.execute(
                "UPDATE jobs SET hello = ?2 WHERE id = ?1",
                params![id, hello],
            )
            .map(drop)
        })
    }

    /// The bytes job `id` holds in the store: its hello, its frames up to
    /// frame `upto` (none if `None`) and its checkpoint.
    pub fn stored_bytes(&self, id: JobId, upto: Option<u64>) -> Result<u64> {
        let upto = upto.map_or(-1, |n| n as i64);
        self.read(|c| {
            c.query_row(
                "SELECT length(j.hello)
                   + COALESCE((SELECT SUM(length(positions) + length(stats))
                               FROM frames WHERE job = j.seq AND n <= ?2), 0)
                   + COALESCE((SELECT length(data) FROM checkpoints WHERE job = j.seq), 0)
                 FROM jobs j WHERE j.id = ?1",
                params![id, upto],
                |r| r.get::<_, Option<i64>>(0),
            )
            .optional()
            .map(|b| b.flatten().unwrap_or(0).max(0) as u64)
        })
    }

    /// The database's size in pages in use and free: what deleting a job
    /// gives back shows here (and in the file's size).
    #[cfg(test)]
    pub fn pages(&self) -> Result<(u64, u64)> {
        self.read(|c| {
            let count: i64 = c.pragma_query_value(None, "page_count", |r| r.get(0))?;
            let free: i64 = c.pragma_query_value(None, "freelist_count", |r| r.get(0))?;
            Ok(((count - free).max(0) as u64, free.max(0) as u64))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::db::temp_store;
    use super::super::jobs::new_job;
    use super::*;
    use crate::service::job::Status;
    use crate::service::store::{Ending, StoredFrame};

    fn end(s: &Sqlite, id: JobId, at: f64) {
        s.finish(
            "n",
            id,
            &Ending {
                status: Status::Succeeded,
                error: None,
                stats: None,
                finished_at: at,
                run_seconds: 1.0,
            },
        )
        .expect("finish");
    }

    /// Deleting a job with a megabyte of frames gives the file its pages
    /// back: the database shrinks to what it was before the job.
    #[test]
    fn deleting_an_ended_job_reclaims_its_pages() {
        let s = temp_store();
        let before = s.pages().expect("pages").0;
        let id = JobId::generate();
        s.insert_job(&new_job(id, "")).expect("insert");
        assert!(s.claim("n", 10.0).expect("claim").is_some());
        for n in 0..8 {
            let f = StoredFrame {
                n,
                time: 0.0,
                positions: vec![7; 128 << 10],
                stats: "{}".into(),
            };
            s.put_frame("n", id, &f, Some(&[1; 1000]), 0.0)
                .expect("frame");
        }
        assert!(s.stored_bytes(id, Some(7)).expect("bytes") >= 8 * (128 << 10));
        assert!(s.stored_bytes(id, None).expect("bytes") < 128 << 10);
        assert!(!s.delete_ended(id).expect("delete"), "a queued job stays");
        end(&s, id, 5.0);
        let full = s.pages().expect("pages").0;
        assert!(full > before + 200, "{before} -> {full}");
        assert!(s.delete_ended(id).expect("delete"));
        assert_eq!(s.job(id).expect("read"), None);
        assert_eq!(s.frame(id, 0).expect("read").map(|f| f.n), None);
        let (used, free) = s.pages().expect("pages");
        assert!(
            used <= before + 2 && free == 0,
            "{before} -> {used} + {free} free"
        );
        assert!(!s.delete_ended(id).expect("delete"), "only once");
    }

    #[test]
    fn retention_finds_old_and_surplus_ended_jobs() {
        let s = temp_store();
        let ids: Vec<JobId> = (0..4).map(|_| JobId::generate()).collect();
        for (k, id) in ids.iter().enumerate() {
            s.insert_job(&new_job(*id, "")).expect("insert");
            assert!(s.claim("n", 10.0).expect("claim").is_some());
            if k < 3 {
                end(&s, *id, 10.0 * k as f64);
            }
        }
        assert_eq!(s.ended_before(15.0).expect("old"), [ids[0], ids[1]]);
        assert_eq!(s.ended_beyond(1).expect("surplus"), [ids[1], ids[0]]);
        assert!(s.ended_beyond(5).expect("none").is_empty());
    }
}
