//! The SQLite database handle: one writer connection and one reader
//! connection.
//!
//! NOTE: not a pool. `r2d2_sqlite` (the pool crate for SQLite) is built on
//! `rusqlite` 0.40 and this crate uses 0.41, so it would bring a second
//! SQLite. One reader behind a mutex serves the short reads (a job row, a
//! frame); the one long read, a whole job's frames for a download, opens
//! its own connection so it holds up no one (WAL readers do not block each
//! other or the writer).

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use rusqlite::Connection;
use rusqlite::types::{FromSql, FromSqlError, FromSqlResult, ToSql, ToSqlOutput, ValueRef};

use super::schema::{enable_incremental_vacuum, migrate, open_connection};
use crate::service::job::{JobId, Status};
pub(super) use crate::service::store::error::Result;
use crate::service::store::error::StoreError;

/// The database.
#[derive(Debug)]
pub struct Sqlite {
    path: PathBuf,
    writer: Mutex<Connection>,
    reader: Mutex<Connection>,
}

impl Sqlite {
    /// Opens (creating if needed) the store in `dir`.
    pub fn open(dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(dir).map_err(|error| StoreError::CreateDir {
            dir: dir.to_owned(),
            error,
        })?;
        let path = dir.join("drapery.sqlite3");
        let writer = open_connection(&path).map_err(StoreError::Open)?;
        enable_incremental_vacuum(&writer).map_err(StoreError::Open)?;
        migrate(&writer).map_err(StoreError::Open)?;
        let reader = open_connection(&path).map_err(StoreError::Open)?;
        Ok(Self {
            path,
            writer: Mutex::new(writer),
            reader: Mutex::new(reader),
        })
    }

    /// Runs `f` on the writer connection.
    pub(super) fn write<T>(
        &self,
        f: impl FnOnce(&mut Connection) -> rusqlite::Result<T>,
    ) -> Result<T> {
        let mut conn = self.writer.lock().unwrap_or_else(|p| p.into_inner());
        Ok(f(&mut conn)?)
    }

    /// Runs `f` on the reader connection.
    pub(super) fn read<T>(&self, f: impl FnOnce(&Connection) -> rusqlite::Result<T>) -> Result<T> {
        let conn = self.reader.lock().unwrap_or_else(|p| p.into_inner());
        Ok(f(&conn)?)
    }

    /// A connection of its own, for a read that takes long.
    pub(super) fn own_reader(&self) -> Result<Connection> {
        Ok(open_connection(&self.path)?)
    }
}

/// Ids are stored as the text the API shows.
impl ToSql for JobId {
    fn to_sql(&self) -> rusqlite::Result<ToSqlOutput<'_>> {
        Ok(ToSqlOutput::from(self.to_string()))
    }
}

impl FromSql for JobId {
    fn column_result(value: ValueRef<'_>) -> FromSqlResult<Self> {
        let text = value.as_str()?;
        JobId::parse(text).ok_or_else(|| FromSqlError::Other(format!("bad job id {text:?}").into()))
    }
}

impl ToSql for Status {
    fn to_sql(&self) -> rusqlite::Result<ToSqlOutput<'_>> {
        Ok(ToSqlOutput::from(self.as_str()))
    }
}

impl FromSql for Status {
    fn column_result(value: ValueRef<'_>) -> FromSqlResult<Self> {
        let text = value.as_str()?;
        Status::parse(text)
            .ok_or_else(|| FromSqlError::Other(format!("unknown job status {text:?}").into()))
    }
}

/// A fresh store in a temporary directory.
#[cfg(test)]
pub(super) fn temp_store() -> Sqlite {
    let d = crate::test_dir("store");
    Sqlite::open(&d).expect("opens")
}
