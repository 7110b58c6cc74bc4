//! The job store: jobs, their frames and checkpoints, and the leases that
//! say which node runs a job. One interface, [`Store`], over two backends:
//!
//! - `sqlite` (the default): an embedded database in WAL mode under
//!   `--data`, for one machine. Every write is a transaction that survives
//!   the process being killed at any instant; readers never block the one
//!   writer.
//! - `postgres` (`--store postgres://…`): a database that several nodes
//!   share, which is then also the queue: a worker claims the oldest
//!   queued job, or a running one whose lease lapsed, with
//!   `SELECT … FOR UPDATE SKIP LOCKED`, and renews the lease while it
//!   runs (ARCHITECTURE.md "Leases").
//!
//! Both keep the same rows ([`JobRow`]) with the same meaning, and both
//! version their schema and migrate it at start. Jobs are found by their
//! [`JobId`](super::job::JobId); the `seq` column only orders the list and
//! is its cursor. Frames are stored as the little-endian f32 xyz block the
//! WebSocket sends, with their statistics as JSON; a frame and the
//! checkpoint taken with it are written in one transaction, so a resumed
//! job never sees a checkpoint ahead of its frames. Writes for a running
//! job are fenced by its node: a node that lost a job's lease writes
//! nothing more for it ([`StoreError::LeaseLost`]).
//!
//! Every method blocks (the async callers run it on tokio's blocking
//! pool); none may be called on the async executor itself.

mod error;
mod postgres;
mod rows;
mod sqlite;

use std::path::Path;

pub use error::StoreError;
pub use rows::{Ending, JobRow, NewJob, StoredFrame};

use crate::service::job::{JobId, Status};
use error::Result;
use postgres::Postgres;
use sqlite::Sqlite;

/// The job store of this service.
#[derive(Debug)]
pub enum Store {
    /// One machine's embedded database.
    Sqlite(Sqlite),
    /// A database several nodes share.
    Postgres(Postgres),
}

/// Calls the same method on whichever backend this is.
macro_rules! each {
    ($self:ident, $s:ident => $call:expr) => {
        match $self {
            Store::Sqlite($s) => $call,
            Store::Postgres($s) => $call,
        }
    };
}

impl Store {
    /// Opens (creating if needed) the SQLite store in `dir`.
    pub fn open(dir: &Path) -> Result<Self> {
        Sqlite::open(dir).map(Self::Sqlite)
    }

    /// Connects to the PostgreSQL store at `url` (`postgres://USER@HOST/DB`)
    /// with at most `connections` connections, and migrates its schema.
    pub fn connect(url: &str, connections: usize) -> Result<Self> {
        Postgres::connect(url, connections).map(Self::Postgres)
    }

    /// Other nodes may share this store.
    pub fn is_shared(&self) -> bool {
        matches!(self, Self::Postgres(_))
    }

    /// Stores a submitted job as queued.
    pub fn insert_job(&self, job: &NewJob<'_>) -> Result<()> {
        each!(self, s => s.insert_job(job))
    }

    /// The job with this id.
    pub fn job(&self, id: JobId) -> Result<Option<JobRow>> {
        each!(self, s => s.job(id))
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
        each!(self, s => s.list(owner, status, before, limit))
    }

    /// Number of jobs in each status.
    pub fn count_by_status(&self) -> Result<Vec<(Status, u64)>> {
        each!(self, s => s.count_by_status())
    }

    /// At start: queues again the jobs an earlier process of node `node`
    /// left running (on SQLite, every running job: it has one node);
    /// returns how many jobs wait now.
    pub fn recover(&self, node: &str) -> Result<usize> {
        each!(self, s => s.recover(node))
    }

    /// Node `node` takes the oldest queued job (or, shared, a running one
    /// whose lease lapsed) for `lease` seconds: running, one more attempt.
    pub fn claim(&self, node: &str, lease: f64) -> Result<Option<JobRow>> {
        each!(self, s => s.claim(node, lease))
    }

    /// Extends node `node`'s leases on the jobs `ids` by `lease` seconds;
    /// returns those it still holds, each with whether its owner asked to
    /// cancel it. A job missing from the answer was lost to another node.
    pub fn renew(&self, node: &str, lease: f64, ids: &[JobId]) -> Result<Vec<(JobId, bool)>> {
        each!(self, s => s.renew(node, lease, ids))
    }

    /// Marks running job `id` to be cancelled by the node that runs it;
    /// `false` if it is not running.
    pub fn request_cancel(&self, id: JobId) -> Result<bool> {
        each!(self, s => s.request_cancel(id))
    }

    /// The job node `node` runs ended (succeeded, failed or cancelled).
    pub fn finish(&self, node: &str, id: JobId, end: &Ending<'_>) -> Result<()> {
        each!(self, s => s.finish(node, id, end))
    }

    /// A job node `node` ran was stopped by its shutdown: queued again, to
    /// resume.
    pub fn requeue(&self, node: &str, id: JobId, run_seconds: f64) -> Result<()> {
        each!(self, s => s.requeue(node, id, run_seconds))
    }

    /// Cancels a job if it is still queued; `false` if it was not.
    pub fn cancel_queued(&self, id: JobId, now: f64) -> Result<bool> {
        each!(self, s => s.cancel_queued(id, now))
    }

    /// The stream's hello message of a job.
    pub fn hello(&self, id: JobId) -> Result<Option<String>> {
        each!(self, s => s.hello(id))
    }

    /// Stores job `id`'s hello (written when it first starts).
    pub fn set_hello(&self, id: JobId, hello: &str) -> Result<()> {
        each!(self, s => s.set_hello(id, hello))
    }

    /// Stores frame `f` of the job node `node` runs (replacing an earlier
    /// copy: a resumed job redoes the frames after its checkpoint,
    /// identically) and, with it, the checkpoint if one is given and the
    /// job's `run_seconds` so far over every attempt (so a running job
    /// shows its time, and a node that dies leaves its attempt's time
    /// counted up to its last frame).
    pub fn put_frame(
        &self,
        node: &str,
        id: JobId,
        f: &StoredFrame,
        checkpoint: Option<&[u8]>,
        run_seconds: f64,
    ) -> Result<()> {
        each!(self, s => s.put_frame(node, id, f, checkpoint, run_seconds))
    }

    /// Frame `n` of a job.
    pub fn frame(&self, id: JobId, n: u64) -> Result<Option<StoredFrame>> {
        each!(self, s => s.frame(id, n))
    }

    /// Every stored frame of a job, in order, handed to `each`; the first
    /// error, the store's or `each`'s, ends the walk.
    pub fn each_frame<E: From<StoreError>>(
        &self,
        id: JobId,
        each: impl FnMut(StoredFrame) -> std::result::Result<(), E>,
    ) -> std::result::Result<(), E> {
        each!(self, s => s.each_frame(id, each))
    }

    /// The latest checkpoint of a job: its frame and data.
    pub fn checkpoint(&self, id: JobId) -> Result<Option<(u64, Vec<u8>)>> {
        each!(self, s => s.checkpoint(id))
    }

    /// The statistics JSON of frames `0..=upto`, in order.
    pub fn frame_stats(&self, id: JobId, upto: u64) -> Result<Vec<String>> {
        each!(self, s => s.frame_stats(id, upto))
    }

    /// Deletes an ended job with its frames and checkpoint, and gives the
    /// space back; `false` if there is no such ended job.
    pub fn delete_ended(&self, id: JobId) -> Result<bool> {
        each!(self, s => s.delete_ended(id))
    }

    /// Ended jobs that finished before `cutoff` (unix seconds).
    pub fn ended_before(&self, cutoff: f64) -> Result<Vec<JobId>> {
        each!(self, s => s.ended_before(cutoff))
    }

    /// Ended jobs beyond the `keep` that finished last.
    pub fn ended_beyond(&self, keep: usize) -> Result<Vec<JobId>> {
        each!(self, s => s.ended_beyond(keep))
    }

    /// The bytes job `id` holds in the store: its hello, its frames up to
    /// frame `upto` (none if `None`) and its checkpoint.
    pub fn stored_bytes(&self, id: JobId, upto: Option<u64>) -> Result<u64> {
        each!(self, s => s.stored_bytes(id, upto))
    }
}
