//! The job store: an embedded SQLite database in WAL mode under `--data`.
//!
//! Why SQLite: every write is a transaction that survives the process being
//! killed at any instant (the write-ahead log is replayed on open), readers
//! never block the one writer, and list queries (by owner, status, newest
//! first) are indexes rather than code. `synchronous = NORMAL` makes a
//! commit durable against a crash of the process, which is what the
//! service promises; a power cut may lose the last commits but never
//! corrupts the file.
//!
//! Frames are stored as the little-endian f32 xyz block the WebSocket
//! sends, with their statistics as JSON; a frame and the checkpoint taken
//! with it are written in one transaction, so a resumed job never sees a
//! checkpoint ahead of its frames.

use std::path::Path;
use std::sync::Mutex;

use rusqlite::{Connection, OptionalExtension, params};

use super::job::Status;

/// Readers kept open between requests.
const READER_POOL: usize = 8;

const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS jobs (
    seq          INTEGER PRIMARY KEY AUTOINCREMENT,
    id           TEXT NOT NULL UNIQUE,
    owner        TEXT NOT NULL,
    name         TEXT NOT NULL,
    status       TEXT NOT NULL,
    spec         TEXT NOT NULL,
    hello        TEXT NOT NULL,
    frames_total INTEGER NOT NULL,
    frames_done  INTEGER NOT NULL DEFAULT 0,
    created_at   REAL NOT NULL,
    started_at   REAL,
    finished_at  REAL,
    run_seconds  REAL NOT NULL DEFAULT 0,
    attempts     INTEGER NOT NULL DEFAULT 0,
    error        TEXT,
    stats        TEXT
);
CREATE INDEX IF NOT EXISTS jobs_by_owner ON jobs (owner, seq);
CREATE INDEX IF NOT EXISTS jobs_by_status ON jobs (status, seq);
CREATE TABLE IF NOT EXISTS frames (
    job       INTEGER NOT NULL REFERENCES jobs (seq),
    n         INTEGER NOT NULL,
    time      REAL NOT NULL,
    positions BLOB NOT NULL,
    stats     TEXT NOT NULL,
    PRIMARY KEY (job, n)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS checkpoints (
    job   INTEGER PRIMARY KEY REFERENCES jobs (seq),
    frame INTEGER NOT NULL,
    data  BLOB NOT NULL
);
";

/// A store error: the database failed (disk full, corrupt file).
#[derive(Debug, thiserror::Error)]
#[error("job store: {0}")]
pub struct StoreError(#[from] rusqlite::Error);

type Result<T> = std::result::Result<T, StoreError>;

/// A job as stored.
#[derive(Debug, Clone, PartialEq)]
pub struct JobRow {
    /// Submission order (newest is largest); the list cursor.
    pub seq: i64,
    pub id: String,
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
    pub fn scene(&self) -> anyhow::Result<drapery_sim::spec::Scene> {
        crate::specfile::load(&self.spec, &drapery_sim::spec::Limits::default())
            .map_err(|e| anyhow::anyhow!("stored spec no longer loads: {e}"))
    }
}

/// What a submission stores.
#[derive(Debug)]
pub struct NewJob<'a> {
    pub id: &'a str,
    pub owner: &'a str,
    pub name: &'a str,
    pub spec: &'a str,
    pub hello: &'a str,
    pub frames_total: u64,
    pub created_at: f64,
}

/// One stored frame.
#[derive(Debug, Clone)]
pub struct StoredFrame {
    pub n: u64,
    pub time: f64,
    /// f32 xyz per particle, little-endian.
    pub positions: Vec<u8>,
    /// The frame's statistics, JSON.
    pub stats: String,
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

/// The database: one writer connection, a pool of readers.
#[derive(Debug)]
pub struct Store {
    path: std::path::PathBuf,
    writer: Mutex<Connection>,
    readers: Mutex<Vec<Connection>>,
}

impl Store {
    /// Opens (creating if needed) the store in `dir`.
    pub fn open(dir: &Path) -> anyhow::Result<Self> {
        std::fs::create_dir_all(dir)
            .map_err(|e| anyhow::anyhow!("creating {}: {e}", dir.display()))?;
        let path = dir.join("drapery.sqlite3");
        let writer = open_connection(&path)?;
        writer.execute_batch(SCHEMA)?;
        Ok(Self {
            path,
            writer: Mutex::new(writer),
            readers: Mutex::new(Vec::new()),
        })
    }

    fn write<T>(&self, f: impl FnOnce(&mut Connection) -> rusqlite::Result<T>) -> Result<T> {
        let mut conn = self.writer.lock().unwrap_or_else(|p| p.into_inner());
        Ok(f(&mut conn)?)
    }

    fn read<T>(&self, f: impl FnOnce(&Connection) -> rusqlite::Result<T>) -> Result<T> {
        let pooled = self.readers.lock().unwrap_or_else(|p| p.into_inner()).pop();
        let conn = match pooled {
            Some(c) => c,
            None => open_connection(&self.path)?,
        };
        let out = f(&conn);
        let mut pool = self.readers.lock().unwrap_or_else(|p| p.into_inner());
        if pool.len() < READER_POOL {
            pool.push(conn);
        }
        Ok(out?)
    }

    /// Stores a submitted job as queued; returns its sequence number.
    pub fn insert_job(&self, job: &NewJob<'_>) -> Result<i64> {
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
            )?;
            Ok(c.last_insert_rowid())
        })
    }

    /// The job with this id.
    pub fn job(&self, id: &str) -> Result<Option<JobRow>> {
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
            let rows = stmt.query_map(
                params![owner, status.map(Status::as_str), before, limit as i64],
                job_row,
            )?;
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
            let rows = stmt.query_map([], |r| {
                Ok((
                    parse_status(&r.get::<_, String>(0)?)?,
                    r.get::<_, i64>(1)? as u64,
                ))
            })?;
            rows.collect()
        })
    }

    /// The stream's hello message of a job.
    pub fn hello(&self, seq: i64) -> Result<Option<String>> {
        self.read(|c| {
            c.query_row("SELECT hello FROM jobs WHERE seq = ?1", [seq], |r| r.get(0))
                .optional()
        })
    }

    /// A worker starts the job: running, one more attempt. `false` if it
    /// is no longer queued (cancelled between the pop and the start).
    pub fn mark_running(&self, seq: i64, now: f64) -> Result<bool> {
        self.write(|c| {
            let n = c.execute(
                "UPDATE jobs SET status = 'running', attempts = attempts + 1,
                 started_at = COALESCE(started_at, ?2) WHERE seq = ?1 AND status = 'queued'",
                params![seq, now],
            )?;
            Ok(n == 1)
        })
    }

    /// The job ended (succeeded, failed or cancelled).
    pub fn finish(&self, seq: i64, end: &Ending<'_>) -> Result<()> {
        self.write(|c| {
            let tx = c.transaction()?;
            tx.execute(
                "UPDATE jobs SET status = ?2, error = ?3, stats = ?4, finished_at = ?5,
                 run_seconds = ?6 WHERE seq = ?1",
                params![
                    seq,
                    end.status.as_str(),
                    end.error,
                    end.stats,
                    end.finished_at,
                    end.run_seconds
                ],
            )?;
            // The checkpoint only serves a resume; an ended job has none.
            tx.execute("DELETE FROM checkpoints WHERE job = ?1", [seq])?;
            tx.commit()
        })
    }

    /// A running job was stopped by a shutdown: queued again, to resume.
    pub fn requeue(&self, seq: i64, run_seconds: f64) -> Result<()> {
        self.write(|c| {
            c.execute(
                "UPDATE jobs SET status = 'queued', run_seconds = ?2 WHERE seq = ?1",
                params![seq, run_seconds],
            )
            .map(drop)
        })
    }

    /// Cancels a job if it is still queued; `false` if it was not.
    pub fn cancel_queued(&self, seq: i64, now: f64) -> Result<bool> {
        self.write(|c| {
            let n = c.execute(
                "UPDATE jobs SET status = 'cancelled', finished_at = ?2
                 WHERE seq = ?1 AND status = 'queued'",
                params![seq, now],
            )?;
            Ok(n == 1)
        })
    }

    /// Stores frame `f` (replacing an earlier copy: a resumed job redoes
    /// the frames after its checkpoint, identically) and, with it, the
    /// checkpoint if one is given.
    pub fn put_frame(&self, seq: i64, f: &StoredFrame, checkpoint: Option<&[u8]>) -> Result<()> {
        self.write(|c| {
            let tx = c.transaction()?;
            tx.execute(
                "INSERT OR REPLACE INTO frames (job, n, time, positions, stats)
                 VALUES (?1, ?2, ?3, ?4, ?5)",
                params![seq, f.n as i64, f.time, f.positions, f.stats],
            )?;
            tx.execute(
                "UPDATE jobs SET frames_done = MAX(frames_done, ?2) WHERE seq = ?1",
                params![seq, f.n as i64 + 1],
            )?;
            if let Some(data) = checkpoint {
                tx.execute(
                    "INSERT OR REPLACE INTO checkpoints (job, frame, data) VALUES (?1, ?2, ?3)",
                    params![seq, f.n as i64, data],
                )?;
            }
            tx.commit()
        })
    }

    /// Frame `n` of a job.
    pub fn frame(&self, seq: i64, n: u64) -> Result<Option<StoredFrame>> {
        self.read(|c| {
            c.query_row(
                "SELECT n, time, positions, stats FROM frames WHERE job = ?1 AND n = ?2",
                params![seq, n as i64],
                frame_row,
            )
            .optional()
        })
    }

    /// Every stored frame of a job, in order, handed to `each`.
    pub fn each_frame(
        &self,
        seq: i64,
        mut each: impl FnMut(StoredFrame) -> std::io::Result<()>,
    ) -> anyhow::Result<()> {
        self.read(|c| {
            let mut stmt = c.prepare(
                "SELECT n, time, positions, stats FROM frames WHERE job = ?1 ORDER BY n",
            )?;
            let rows = stmt.query_map([seq], frame_row)?;
            let mut out = Ok(());
            for row in rows {
                if let Err(e) = each(row?) {
                    out = Err(e);
                    break;
                }
            }
            Ok(out)
        })??;
        Ok(())
    }

    /// The latest checkpoint of a job: its frame and data.
    pub fn checkpoint(&self, seq: i64) -> Result<Option<(u64, Vec<u8>)>> {
        self.read(|c| {
            c.query_row(
                "SELECT frame, data FROM checkpoints WHERE job = ?1",
                [seq],
                |r| Ok((r.get::<_, i64>(0)? as u64, r.get(1)?)),
            )
            .optional()
        })
    }

    /// The statistics JSON of frames `0..=upto`, in order.
    pub fn frame_stats(&self, seq: i64, upto: u64) -> Result<Vec<String>> {
        self.read(|c| {
            let mut stmt =
                c.prepare("SELECT stats FROM frames WHERE job = ?1 AND n <= ?2 ORDER BY n")?;
            let rows = stmt.query_map(params![seq, upto as i64], |r| r.get(0))?;
            rows.collect()
        })
    }
}

const JOB_COLUMNS: &str = "seq, id, owner, name, status, spec, frames_total, frames_done,
    created_at, started_at, finished_at, run_seconds, attempts, error, stats";

fn job_row(r: &rusqlite::Row<'_>) -> rusqlite::Result<JobRow> {
    Ok(JobRow {
        seq: r.get(0)?,
        id: r.get(1)?,
        owner: r.get(2)?,
        name: r.get(3)?,
        status: parse_status(&r.get::<_, String>(4)?)?,
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

fn frame_row(r: &rusqlite::Row<'_>) -> rusqlite::Result<StoredFrame> {
    Ok(StoredFrame {
        n: r.get::<_, i64>(0)? as u64,
        time: r.get(1)?,
        positions: r.get(2)?,
        stats: r.get(3)?,
    })
}

fn parse_status(s: &str) -> rusqlite::Result<Status> {
    Status::parse(s).ok_or_else(|| {
        rusqlite::Error::FromSqlConversionFailure(
            4,
            rusqlite::types::Type::Text,
            format!("unknown job status {s:?}").into(),
        )
    })
}

fn open_connection(path: &Path) -> rusqlite::Result<Connection> {
    let c = Connection::open(path)?;
    c.busy_timeout(std::time::Duration::from_secs(10))?;
    c.pragma_update(None, "journal_mode", "WAL")?;
    c.pragma_update(None, "synchronous", "NORMAL")?;
    c.pragma_update(None, "foreign_keys", "ON")?;
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job<'a>(id: &'a str, owner: &'a str) -> NewJob<'a> {
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

    fn frame(n: u64) -> StoredFrame {
        StoredFrame {
            n,
            time: n as f64 * 0.1,
            positions: vec![n as u8; 12],
            stats: "{}".into(),
        }
    }

    #[test]
    fn lists_newest_first_by_owner_and_status_with_a_cursor() {
        let dir = tempdir();
        let s = Store::open(&dir).expect("opens");
        let a = s.insert_job(&job("a", "alice")).expect("insert");
        let b = s.insert_job(&job("b", "bob")).expect("insert");
        let c = s.insert_job(&job("c", "alice")).expect("insert");
        assert!(a < b && b < c);
        let ids = |rows: Vec<JobRow>| rows.into_iter().map(|r| r.id).collect::<Vec<_>>();
        assert_eq!(
            ids(s.list(None, None, None, 10).expect("list")),
            ["c", "b", "a"]
        );
        assert_eq!(
            ids(s.list(Some("alice"), None, None, 10).expect("list")),
            ["c", "a"]
        );
        assert_eq!(ids(s.list(None, None, Some(c), 1).expect("list")), ["b"]);
        assert!(s.mark_running(b, 2.0).expect("run"));
        assert!(
            !s.mark_running(b, 2.0).expect("run"),
            "only a queued job starts"
        );
        assert_eq!(
            ids(s.list(None, Some(Status::Running), None, 10).expect("list")),
            ["b"]
        );
        assert!(s.cancel_queued(a, 3.0).expect("cancel"));
        assert!(!s.cancel_queued(b, 3.0).expect("cancel"), "b is running");
        assert_eq!(ids(s.unfinished().expect("unfinished")), ["b", "c"]);
    }

    #[test]
    fn frames_and_checkpoints_survive_reopening() {
        let dir = tempdir();
        {
            let s = Store::open(&dir).expect("opens");
            let seq = s.insert_job(&job("a", "")).expect("insert");
            s.put_frame(seq, &frame(0), None).expect("frame");
            s.put_frame(seq, &frame(1), Some(b"cp1")).expect("frame");
            // A redone frame replaces its copy and does not move the count back.
            s.put_frame(seq, &frame(0), None).expect("frame");
        }
        let s = Store::open(&dir).expect("reopens");
        let row = s.job("a").expect("read").expect("exists");
        assert_eq!(row.frames_done, 2);
        assert_eq!(
            s.frame(row.seq, 1)
                .expect("read")
                .expect("stored")
                .positions,
            vec![1; 12]
        );
        assert_eq!(
            s.checkpoint(row.seq).expect("read"),
            Some((1, b"cp1".to_vec()))
        );
        let mut seen = Vec::new();
        s.each_frame(row.seq, |f| {
            seen.push(f.n);
            Ok(())
        })
        .expect("iterates");
        assert_eq!(seen, [0, 1]);
        s.finish(
            row.seq,
            &Ending {
                status: Status::Succeeded,
                error: None,
                stats: Some("{}"),
                finished_at: 5.0,
                run_seconds: 1.0,
            },
        )
        .expect("finish");
        assert_eq!(s.checkpoint(row.seq).expect("read"), None);
        assert_eq!(
            s.count_by_status().expect("count"),
            [(Status::Succeeded, 1)]
        );
    }

    fn tempdir() -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("drapery-store-{}", uuid::Uuid::now_v7()));
        std::fs::create_dir_all(&d).expect("temp dir");
        d
    }
}
