//! The tables, and how every connection is opened.

use std::path::Path;

use rusqlite::Connection;

/// Created if missing; unchanged since the first version, so any data
/// directory opens.
pub const SCHEMA: &str = "
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

/// A connection to the database at `path`: WAL, `synchronous = NORMAL`,
/// foreign keys on, and a wait of up to 10 s for a lock.
pub fn open_connection(path: &Path) -> rusqlite::Result<Connection> {
    let c = Connection::open(path)?;
    c.busy_timeout(std::time::Duration::from_secs(10))?;
    c.pragma_update(None, "journal_mode", "WAL")?;
    c.pragma_update(None, "synchronous", "NORMAL")?;
    c.pragma_update(None, "foreign_keys", "ON")?;
    Ok(c)
}
