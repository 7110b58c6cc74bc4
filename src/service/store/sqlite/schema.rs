//! The tables, their versions, and how every connection is opened.

use std::path::Path;

use rusqlite::Connection;

/// Version 1: the tables as the first release made them (created if
/// missing, so a data directory of any release opens).
const V1: &str = "
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

/// Version 2: leases (the node running a job, until when) and cancel
/// requests, which the worker running a job reads as it renews its lease.
const V2: &str = "
ALTER TABLE jobs ADD COLUMN node TEXT;
ALTER TABLE jobs ADD COLUMN lease_until REAL;
ALTER TABLE jobs ADD COLUMN cancel_requested INTEGER NOT NULL DEFAULT 0;
";

/// The migrations in order; the database's `user_version` is how many
/// of them it has.
const MIGRATIONS: [&str; 2] = [V1, V2];

/// Brings the database's schema to the newest version, each migration in
/// a transaction with the version it reaches. A database newer than this
/// program is refused rather than misread.
pub fn migrate(c: &Connection) -> rusqlite::Result<()> {
    let version: i64 = c.pragma_query_value(None, "user_version", |r| r.get(0))?;
    if version > MIGRATIONS.len() as i64 {
        return Err(rusqlite::Error::InvalidParameterName(format!(
            "the database's schema is version {version}; this drapery knows up to {}: upgrade it",
            MIGRATIONS.len()
        )));
    }
    for (k, sql) in MIGRATIONS.iter().enumerate().skip(version.max(0) as usize) {
        c.execute_batch(&format!(
            "BEGIN; {sql} PRAGMA user_version = {}; COMMIT;",
            k + 1
        ))?;
    }
    Ok(())
}

/// The write-ahead log is cut back to this size when a checkpoint empties
/// it (a large frame's transaction may grow it far beyond).
const WAL_LIMIT_BYTES: i64 = 16 << 20;

/// A connection to the database at `path`: WAL (cut back to 16 MiB after
/// each checkpoint), `synchronous = NORMAL`, foreign keys on, and a wait of
/// up to 10 s for a lock.
pub fn open_connection(path: &Path) -> rusqlite::Result<Connection> {
    let c = Connection::open(path)?;
    c.busy_timeout(std::time::Duration::from_secs(10))?;
    c.pragma_update(None, "journal_mode", "WAL")?;
    c.pragma_update(None, "synchronous", "NORMAL")?;
    c.pragma_update(None, "foreign_keys", "ON")?;
    c.pragma_update(None, "journal_size_limit", WAL_LIMIT_BYTES)?;
    Ok(c)
}

/// Makes the file give deleted jobs' pages back to the file system:
/// `auto_vacuum = INCREMENTAL`, which a database takes only before its
/// first table or through one `VACUUM` (done once, on the first open of a
/// directory an earlier version made). Freed pages then go back with
/// `PRAGMA incremental_vacuum` ([`reclaim`]).
pub fn enable_incremental_vacuum(c: &Connection) -> rusqlite::Result<()> {
    const INCREMENTAL: i64 = 2;
    let mode: i64 = c.pragma_query_value(None, "auto_vacuum", |r| r.get(0))?;
    if mode != INCREMENTAL {
        c.pragma_update(None, "auto_vacuum", INCREMENTAL)?;
        c.execute_batch("VACUUM")?;
    }
    Ok(())
}

/// Gives free pages back to the file system and empties the write-ahead
/// log into the database, which `journal_size_limit` then truncates.
pub fn reclaim(c: &Connection) -> rusqlite::Result<()> {
    // Stepped to its end: each step frees one page.
    let mut vacuum = c.prepare("PRAGMA incremental_vacuum")?;
    let mut steps = vacuum.query([])?;
    while steps.next()?.is_some() {}
    // Busy (a reader holds an old snapshot) is not an error: the next
    // checkpoint does it.
    c.query_row("PRAGMA wal_checkpoint(TRUNCATE)", [], |_| Ok(()))
}
