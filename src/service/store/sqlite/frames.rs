//! The `frames` and `checkpoints` tables: what a running job produces.

use rusqlite::{OptionalExtension, params};

use super::db::{Result, Sqlite};
use crate::service::job::JobId;
use crate::service::store::{StoreError, StoredFrame};

/// The `seq` of job `id`, for the tables keyed by it.
const SEQ_OF: &str = "(SELECT seq FROM jobs WHERE id = ?1)";

impl Sqlite {
    /// Stores frame `f` of the job node `node` runs, and with it the
    /// checkpoint if one is given and the job's running time so far.
    pub fn put_frame(
        &self,
        node: &str,
        id: JobId,
        f: &StoredFrame,
        checkpoint: Option<&[u8]>,
        run_seconds: f64,
    ) -> Result<()> {
        let held = self.write(|c| {
            let tx = c.transaction()?;
            let seq: Option<i64> = tx
                .query_row(
                    "UPDATE jobs SET frames_done = MAX(frames_done, ?3),
                         run_seconds = MAX(run_seconds, ?4)
                     WHERE id = ?1 AND node = ?2 AND status = 'running' RETURNING seq",
                    params![id, node, f.n as i64 + 1, run_seconds],
                    |r| r.get(0),
                )
                .optional()?;
            let Some(seq) = seq else {
                return Ok(false);
            };
            tx.execute(
                "INSERT OR REPLACE INTO frames (job, n, time, positions, stats)
                 VALUES (?1, ?2, ?3, ?4, ?5)",
                params![seq, f.n as i64, f.time, f.positions, f.stats],
            )?;
            if let Some(data) = checkpoint {
                tx.execute(
                    "INSERT OR REPLACE INTO checkpoints (job, frame, data) VALUES (?1, ?2, ?3)",
                    params![seq, f.n as i64, data],
                )?;
            }
            tx.commit()?;
            Ok(true)
        })?;
        held.then_some(()).ok_or(StoreError::LeaseLost(id))
    }

    /// Frame `n` of a job.
    pub fn frame(&self, id: JobId, n: u64) -> Result<Option<StoredFrame>> {
        self.read(|c| {
            c.query_row(
                &format!(
                    "SELECT n, time, positions, stats FROM frames WHERE job = {SEQ_OF} AND n = ?2"
                ),
                params![id, n as i64],
                frame_row,
            )
            .optional()
        })
    }

    /// Every stored frame of a job, in order, handed to `each`; the first
    /// error, the store's or `each`'s, ends the walk.
    pub fn each_frame<E: From<StoreError>>(
        &self,
        id: JobId,
        mut each: impl FnMut(StoredFrame) -> std::result::Result<(), E>,
    ) -> std::result::Result<(), E> {
        // PERF: a download reads every frame; its own connection keeps the
        // shared reader free for the requests meanwhile.
        let c = self.own_reader()?;
        let mut stmt = c
            .prepare(&format!(
                "SELECT n, time, positions, stats FROM frames WHERE job = {SEQ_OF} ORDER BY n"
            ))
            .map_err(StoreError::from)?;
        let rows = stmt.query_map([id], frame_row).map_err(StoreError::from)?;
        for row in rows {
            each(row.map_err(StoreError::from)?)?;
        }
        Ok(())
    }

    /// The latest checkpoint of a job: its frame and data.
    pub fn checkpoint(&self, id: JobId) -> Result<Option<(u64, Vec<u8>)>> {
        self.read(|c| {
            c.query_row(
                &format!("SELECT frame, data FROM checkpoints WHERE job = {SEQ_OF}"),
                [id],
                |r| Ok((r.get::<_, i64>(0)? as u64, r.get(1)?)),
            )
            .optional()
        })
    }

    /// The statistics JSON of frames `0..=upto`, in order.
    pub fn frame_stats(&self, id: JobId, upto: u64) -> Result<Vec<String>> {
        self.read(|c| {
            let mut stmt = c.prepare(&format!(
                "SELECT stats FROM frames WHERE job = {SEQ_OF} AND n <= ?2 ORDER BY n"
            ))?;
            let rows = stmt.query_map(params![id, upto as i64], |r| r.get(0))?;
            rows.collect()
        })
    }
}

fn frame_row(r: &rusqlite::Row<'_>) -> rusqlite::Result<StoredFrame> {
    Ok(StoredFrame {
        n: r.get::<_, i64>(0)? as u64,
        time: r.get(1)?,
        positions: r.get(2)?,
        stats: r.get(3)?,
    })
}

#[cfg(test)]
mod tests {
    use super::super::jobs::new_job;
    use super::*;
    use crate::service::job::Status;
    use crate::service::store::Ending;

    fn frame(n: u64) -> StoredFrame {
        StoredFrame {
            n,
            time: n as f64 * 0.1,
            positions: vec![n as u8; 12],
            stats: "{}".into(),
        }
    }

    #[test]
    fn frames_and_checkpoints_survive_reopening() {
        let dir = crate::test_dir("store");
        let id = JobId::generate();
        {
            let s = Sqlite::open(&dir).expect("opens");
            s.insert_job(&new_job(id, "")).expect("insert");
            assert!(s.claim("n", 10.0).expect("claim").is_some());
            s.put_frame("n", id, &frame(0), None, 0.5).expect("frame");
            s.put_frame("n", id, &frame(1), Some(b"cp1"), 1.5)
                .expect("frame");
            // A redone frame replaces its copy and does not move the count
            // or the running time back.
            s.put_frame("n", id, &frame(0), None, 1.0).expect("frame");
            assert!(matches!(
                s.put_frame("other", id, &frame(2), None, 9.0),
                Err(StoreError::LeaseLost(_))
            ));
        }
        let s = Sqlite::open(&dir).expect("reopens");
        let row = s.job(id).expect("read").expect("exists");
        assert_eq!((row.frames_done, row.run_seconds), (2, 1.5));
        assert_eq!(
            s.frame(id, 1).expect("read").expect("stored").positions,
            vec![1; 12]
        );
        assert_eq!(s.checkpoint(id).expect("read"), Some((1, b"cp1".to_vec())));
        let mut seen = Vec::new();
        s.each_frame(id, |f| {
            seen.push(f.n);
            Ok::<_, StoreError>(())
        })
        .expect("iterates");
        assert_eq!(seen, [0, 1]);
        assert_eq!(s.frame_stats(id, 0).expect("read"), ["{}"]);
        s.finish(
            "n",
            id,
            &Ending {
                status: Status::Succeeded,
                error: None,
                stats: Some("{}"),
                finished_at: 5.0,
                run_seconds: 1.0,
            },
        )
        .expect("finish");
        assert_eq!(s.checkpoint(id).expect("read"), None);
        assert_eq!(
            s.count_by_status().expect("count"),
            [(Status::Succeeded, 1)]
        );
    }

    #[test]
    fn a_frame_of_an_unknown_job_is_refused() {
        let s = super::super::db::temp_store();
        assert!(
            s.put_frame("n", JobId::generate(), &frame(0), None, 0.0)
                .is_err()
        );
        assert!(s.frame(JobId::generate(), 0).expect("read").is_none());
    }
}
