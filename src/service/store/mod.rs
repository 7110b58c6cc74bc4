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
//! Jobs are found by their [`JobId`](super::job::JobId); the `seq` column
//! only orders the list and is its cursor. Frames are stored as the
//! little-endian f32 xyz block the WebSocket sends, with their statistics
//! as JSON; a frame and the checkpoint taken with it are written in one
//! transaction, so a resumed job never sees a checkpoint ahead of its
//! frames.

mod db;
mod frames;
mod jobs;
mod retention;
mod schema;

pub use db::{Store, StoreError};
pub use frames::StoredFrame;
pub use jobs::{Ending, JobRow, NewJob};
