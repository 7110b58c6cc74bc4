//! What both stores keep and hand back: a job's row, a submission, an
//! ending, a frame. The backends (`sqlite`, `postgres`) map these to their
//! tables; nothing above the store sees SQL.

use drapery_sim::spec::Scene;

use crate::service::job::{JobError, JobId, Status};
use crate::specfile::{self, SpecLoadError};

/// A job as stored.
#[derive(Debug, Clone, PartialEq)]
pub struct JobRow {
    /// Submission order (newest is largest): the list's order and cursor.
    pub seq: i64,
    pub id: JobId,
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
    /// The node running the job (holding its lease), or that ran it last;
    /// `None` while it waits.
    pub node: Option<String>,
    /// Its owner asked to cancel it while it ran: the node running it
    /// stops it at its next lease renewal.
    pub cancel_requested: bool,
}

impl JobRow {
    /// The job's scene, from its stored spec. Submission checked the spec
    /// against the service's limits; the core's own limits only guard
    /// against a corrupted store here.
    pub fn scene(&self) -> std::result::Result<Scene, SpecLoadError> {
        specfile::load_stored(&self.spec)
    }

    /// Why it failed, if it did.
    pub fn failure(&self) -> Option<JobError> {
        self.error
            .as_deref()
            .and_then(|s| serde_json::from_str(s).ok())
    }

    /// The run's statistics summary, once it ended.
    pub fn summary(&self) -> Option<serde_json::Value> {
        self.stats
            .as_deref()
            .and_then(|s| serde_json::from_str(s).ok())
    }
}

/// What a submission stores.
#[derive(Debug)]
pub struct NewJob<'a> {
    pub id: JobId,
    pub owner: &'a str,
    pub name: &'a str,
    pub spec: &'a str,
    pub hello: &'a str,
    pub frames_total: u64,
    pub created_at: f64,
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
