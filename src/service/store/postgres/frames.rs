//! Frames and checkpoints in PostgreSQL, and the deletion of ended jobs.

use super::jobs::job_id;
use super::pool::Postgres;
use crate::service::job::JobId;
use crate::service::store::StoredFrame;
use crate::service::store::error::{Result, StoreError};

/// Frames read per round trip by a walk over a whole job.
const WALK_BATCH: i64 = 32;

/// Statuses of ended jobs, as SQL.
const ENDED: &str = "('succeeded', 'failed', 'cancelled')";

impl Postgres {
    /// Stores frame `f` of the job node `node` runs, with its checkpoint,
    /// and the job's running time so far.
    pub fn put_frame(
        &self,
        node: &str,
        id: JobId,
        f: &StoredFrame,
        checkpoint: Option<&[u8]>,
        run_seconds: f64,
    ) -> Result<()> {
        let key = id.to_string();
        let n = f.n as i64;
        let held = self.with(async |c| {
            let tx = c.transaction().await?;
            let seq = tx
                .query_opt(
                    "UPDATE jobs SET frames_done = GREATEST(frames_done, $3),
                         run_seconds = GREATEST(run_seconds, $4)
                     WHERE id = $1 AND node = $2 AND status = 'running' RETURNING seq",
                    &[&key, &node, &(n + 1), &run_seconds],
                )
                .await?;
            let Some(seq) = seq.map(|r| r.get::<_, i64>(0)) else {
                return Ok(false);
            };
            tx.execute(
                "INSERT INTO frames (job, n, time, positions, stats) VALUES ($1, $2, $3, $4, $5)
                 ON CONFLICT (job, n) DO UPDATE SET time = EXCLUDED.time,
                     positions = EXCLUDED.positions, stats = EXCLUDED.stats",
                &[&seq, &n, &f.time, &f.positions, &f.stats],
            )
            .await?;
            if let Some(data) = checkpoint {
                tx.execute(
                    "INSERT INTO checkpoints (job, frame, data) VALUES ($1, $2, $3)
                     ON CONFLICT (job) DO UPDATE SET frame = EXCLUDED.frame, data = EXCLUDED.data",
                    &[&seq, &n, &data],
                )
                .await?;
            }
            tx.commit().await?;
            Ok(true)
        })?;
        held.then_some(()).ok_or(StoreError::LeaseLost(id))
    }

    /// Frame `n` of a job.
    pub fn frame(&self, id: JobId, n: u64) -> Result<Option<StoredFrame>> {
        Ok(self.frames_from(id, n, 1)?.into_iter().find(|f| f.n == n))
    }

    /// Up to `limit` stored frames of job `id` from frame `from`, in order.
    fn frames_from(&self, id: JobId, from: u64, limit: i64) -> Result<Vec<StoredFrame>> {
        let key = id.to_string();
        let from = from as i64;
        let rows = self.with(async |c| {
            c.query(
                "SELECT f.n, f.time, f.positions, f.stats FROM frames f
                 JOIN jobs j ON j.seq = f.job WHERE j.id = $1 AND f.n >= $2
                 ORDER BY f.n LIMIT $3",
                &[&key, &from, &limit],
            )
            .await
        })?;
        Ok(rows
            .iter()
            .map(|r| StoredFrame {
                n: r.get::<_, i64>(0).max(0) as u64,
                time: r.get(1),
                positions: r.get(2),
                stats: r.get(3),
            })
            .collect())
    }

    /// Every stored frame of a job, in order, a batch per round trip (so
    /// no connection is held while `each` works).
    pub fn each_frame<E: From<StoreError>>(
        &self,
        id: JobId,
        mut each: impl FnMut(StoredFrame) -> std::result::Result<(), E>,
    ) -> std::result::Result<(), E> {
        let mut next = 0;
        loop {
            let batch = self.frames_from(id, next, WALK_BATCH)?;
            let full = batch.len() as i64 == WALK_BATCH;
            for f in batch {
                next = f.n + 1;
                each(f)?;
            }
            if !full {
                return Ok(());
            }
        }
    }

    /// The latest checkpoint of a job.
    pub fn checkpoint(&self, id: JobId) -> Result<Option<(u64, Vec<u8>)>> {
        let key = id.to_string();
        let row = self.with(async |c| {
            c.query_opt(
                "SELECT c.frame, c.data FROM checkpoints c JOIN jobs j ON j.seq = c.job
                 WHERE j.id = $1",
                &[&key],
            )
            .await
        })?;
        Ok(row.map(|r| (r.get::<_, i64>(0).max(0) as u64, r.get(1))))
    }

    /// The statistics JSON of frames `0..=upto`, in order.
    pub fn frame_stats(&self, id: JobId, upto: u64) -> Result<Vec<String>> {
        let key = id.to_string();
        let upto = upto as i64;
        let rows = self.with(async |c| {
            c.query(
                "SELECT f.stats FROM frames f JOIN jobs j ON j.seq = f.job
                 WHERE j.id = $1 AND f.n <= $2 ORDER BY f.n",
                &[&key, &upto],
            )
            .await
        })?;
        Ok(rows.iter().map(|r| r.get(0)).collect())
    }

    /// Deletes an ended job with its frames and checkpoint (the space is
    /// the database's to reuse, through autovacuum).
    pub fn delete_ended(&self, id: JobId) -> Result<bool> {
        let key = id.to_string();
        self.with(async |c| {
            let tx = c.transaction().await?;
            let seq = tx
                .query_opt(
                    &format!("SELECT seq FROM jobs WHERE id = $1 AND status IN {ENDED} FOR UPDATE"),
                    &[&key],
                )
                .await?;
            let Some(seq) = seq.map(|r| r.get::<_, i64>(0)) else {
                return Ok(false);
            };
            tx.execute("DELETE FROM frames WHERE job = $1", &[&seq])
                .await?;
            tx.execute("DELETE FROM checkpoints WHERE job = $1", &[&seq])
                .await?;
            tx.execute("DELETE FROM jobs WHERE seq = $1", &[&seq])
                .await?;
            tx.commit().await?;
            Ok(true)
        })
    }

    /// Ended jobs that finished before `cutoff`.
    pub fn ended_before(&self, cutoff: f64) -> Result<Vec<JobId>> {
        let rows = self.with(async |c| {
            c.query(
                &format!(
                    "SELECT id FROM jobs WHERE status IN {ENDED} AND finished_at < $1
                     ORDER BY seq"
                ),
                &[&cutoff],
            )
            .await
        })?;
        rows.iter().map(|r| job_id(r.get(0))).collect()
    }

    /// Ended jobs beyond the `keep` that finished last.
    pub fn ended_beyond(&self, keep: usize) -> Result<Vec<JobId>> {
        let keep = keep as i64;
        let rows = self.with(async |c| {
            c.query(
                &format!(
                    "SELECT id FROM jobs WHERE status IN {ENDED}
                     ORDER BY finished_at DESC, seq DESC OFFSET $1"
                ),
                &[&keep],
            )
            .await
        })?;
        rows.iter().map(|r| job_id(r.get(0))).collect()
    }

    /// The bytes job `id` holds: hello, frames `0..=upto`, checkpoint.
    pub fn stored_bytes(&self, id: JobId, upto: Option<u64>) -> Result<u64> {
        let key = id.to_string();
        let upto = upto.map_or(-1, |n| n as i64);
        let row = self.with(async |c| {
            c.query_opt(
                "SELECT (octet_length(j.hello)
                   + COALESCE((SELECT SUM(octet_length(positions) + octet_length(stats))
                               FROM frames WHERE job = j.seq AND n <= $2), 0)
                   + COALESCE((SELECT octet_length(data) FROM checkpoints
                               WHERE job = j.seq), 0))::BIGINT
                 FROM jobs j WHERE j.id = $1",
                &[&key, &upto],
            )
            .await
        })?;
        Ok(row.map_or(0, |r| r.get::<_, Option<i64>>(0).unwrap_or(0).max(0) as u64))
    }
}
