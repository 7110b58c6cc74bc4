//! Why the store failed, with the one distinction callers act on: a store
//! that cannot be reached now (PostgreSQL down or restarting) is
//! [`StoreError::is_unavailable`], which the API answers with `503` and a
//! running job survives (its lease lapses and it resumes), while any other
//! failure is the server's fault.

use std::path::PathBuf;

use crate::service::job::JobId;

/// Why the store failed.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// The data directory cannot be created.
    #[error("creating {}: {error}", dir.display())]
    CreateDir { dir: PathBuf, error: std::io::Error },
    /// The database cannot be opened (not a database, locked, no space).
    #[error("{0}")]
    Open(rusqlite::Error),
    /// A query failed (disk full, corrupt file).
    #[error("job store: {0}")]
    Sqlite(rusqlite::Error),
    /// `--store` is not a PostgreSQL URL this service can use.
    #[error("--store: {0}")]
    Url(String),
    /// PostgreSQL cannot be reached, or is shutting down or starting up.
    #[error("job store unavailable: {0}")]
    Unavailable(String),
    /// PostgreSQL refused a statement.
    #[error("job store: {0}")]
    Postgres(String),
    /// The schema is newer than this program knows.
    #[error("job store schema is version {found}; this drapery knows up to {known}: upgrade it")]
    Newer { found: i64, known: i64 },
    /// A stored value does not decode (a corrupt row).
    #[error("job store: {0}")]
    Corrupt(String),
    /// The job's lease went to another node (this one stopped renewing
    /// it); this node must write nothing more for it.
    #[error("job {0} is no longer leased to this node")]
    LeaseLost(JobId),
}

impl StoreError {
    /// The store cannot be reached now; the same call may work later.
    pub fn is_unavailable(&self) -> bool {
        matches!(self, Self::Unavailable(_))
    }
}

impl From<rusqlite::Error> for StoreError {
    fn from(e: rusqlite::Error) -> Self {
        Self::Sqlite(e)
    }
}

impl From<tokio_postgres::Error> for StoreError {
    /// A lost or refused connection, and the server's shutdown and
    /// start-up codes (class 08, 57P01..57P03), are unavailability; any
    /// other error is the statement's.
    fn from(e: tokio_postgres::Error) -> Self {
        let text = match e.as_db_error() {
            Some(db) => format!("{}: {}", db.code().code(), db.message()),
            None => {
                let mut text = e.to_string();
                let mut source = std::error::Error::source(&e);
                while let Some(s) = source {
                    text = format!("{text}: {s}");
                    source = s.source();
                }
                text
            }
        };
        let unavailable = e.is_closed()
            || match e.code() {
                Some(code) => {
                    let c = code.code();
                    c.starts_with("08") || matches!(c, "57P01" | "57P02" | "57P03")
                }
                // No server answer: the socket failed, or connecting
                // timed out (conversion errors are no I/O and stay faults).
                None => {
                    std::error::Error::source(&e).is_some_and(|s| s.is::<std::io::Error>())
                        || text.contains("timeout")
                }
            };
        if unavailable {
            Self::Unavailable(text)
        } else {
            Self::Postgres(text)
        }
    }
}

pub(super) type Result<T> = std::result::Result<T, StoreError>;
