//! A job as the API shows it: status, progress, timings, statistics,
//! error, links.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::store::JobRow;

/// Where a job is in its life.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Waiting for a worker.
    Queued,
    /// A worker is simulating it.
    Running,
    /// Every frame is stored.
    Succeeded,
    /// Stopped by an error (see `error`).
    Failed,
    /// Cancelled by its owner.
    Cancelled,
}

impl Status {
    /// Every status, for metrics.
    pub const ALL: [Status; 5] = [
        Status::Queued,
        Status::Running,
        Status::Succeeded,
        Status::Failed,
        Status::Cancelled,
    ];

    /// The name used in JSON, the database and metrics.
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Queued => "queued",
            Status::Running => "running",
            Status::Succeeded => "succeeded",
            Status::Failed => "failed",
            Status::Cancelled => "cancelled",
        }
    }

    /// The inverse of [`Self::as_str`].
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|x| x.as_str() == s)
    }

    /// The job will not change any more.
    pub fn is_terminal(self) -> bool {
        matches!(self, Status::Succeeded | Status::Failed | Status::Cancelled)
    }
}

/// Frames done out of the total.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Progress {
    /// Frames stored (frame 0, the initial state, included).
    pub frames_done: u64,
    /// Frames the job will have.
    pub frames_total: u64,
    /// `frames_done / frames_total`.
    pub fraction: f64,
}

/// When things happened (RFC 3339, UTC) and how long they took.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Timings {
    pub created_at: String,
    pub started_at: Option<String>,
    pub finished_at: Option<String>,
    /// Seconds from submission to the first start.
    pub queued_seconds: Option<f64>,
    /// Seconds of simulation, over every attempt.
    pub run_seconds: f64,
    /// Times a worker started the job (more than 1 after a restart).
    pub attempts: u32,
}

/// Why a job failed.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct JobError {
    /// Machine-readable: `non_finite`, `limit_exceeded`, `internal`, ...
    pub code: String,
    /// For people.
    pub message: String,
}

/// Where to go next.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Links {
    #[serde(rename = "self")]
    pub self_: String,
    pub stream: String,
    pub frames: String,
    pub result: String,
}

/// A job.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Job {
    pub id: String,
    /// The spec's name.
    pub name: String,
    pub status: Status,
    pub progress: Progress,
    pub timings: Timings,
    /// The run's statistics without the per-frame list (the fields of
    /// `stats.json`), once it ended.
    #[schema(value_type = Option<Object>)]
    pub stats: Option<serde_json::Value>,
    pub error: Option<JobError>,
    pub links: Links,
}

/// A page of jobs, newest first.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct JobList {
    pub jobs: Vec<Job>,
    /// Pass as `cursor` for the next page; absent on the last page.
    pub next_cursor: Option<String>,
}

impl Job {
    /// The API view of a stored job.
    pub fn from_row(row: &JobRow) -> Self {
        let base = format!("/v1/jobs/{}", row.id);
        Job {
            id: row.id.clone(),
            name: row.name.clone(),
            status: row.status,
            progress: Progress {
                frames_done: row.frames_done,
                frames_total: row.frames_total,
                fraction: if row.frames_total > 0 {
                    row.frames_done as f64 / row.frames_total as f64
                } else {
                    0.0
                },
            },
            timings: Timings {
                created_at: rfc3339(row.created_at),
                started_at: row.started_at.map(rfc3339),
                finished_at: row.finished_at.map(rfc3339),
                queued_seconds: row.started_at.map(|s| (s - row.created_at).max(0.0)),
                run_seconds: row.run_seconds,
                attempts: row.attempts,
            },
            stats: row
                .stats
                .as_deref()
                .and_then(|s| serde_json::from_str(s).ok()),
            error: row
                .error
                .as_deref()
                .and_then(|s| serde_json::from_str(s).ok()),
            links: Links {
                stream: format!("{base}/stream"),
                frames: format!("{base}/frames/{{n}}"),
                result: format!("{base}/result"),
                self_: base,
            },
        }
    }
}

/// Unix seconds as RFC 3339 UTC with milliseconds.
pub fn rfc3339(unix: f64) -> String {
    let t = std::time::UNIX_EPOCH + std::time::Duration::from_secs_f64(unix.max(0.0));
    humantime::format_rfc3339_millis(t).to_string()
}

/// Now, in unix seconds.
pub fn now() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_names_round_trip() {
        for s in Status::ALL {
            assert_eq!(Status::parse(s.as_str()), Some(s));
            assert_eq!(
                serde_json::to_value(s).expect("serialises"),
                serde_json::json!(s.as_str())
            );
        }
        assert_eq!(Status::parse("done"), None);
    }

    #[test]
    fn timestamps_are_rfc3339_utc() {
        assert_eq!(rfc3339(0.0), "1970-01-01T00:00:00.000Z");
        assert_eq!(rfc3339(1_700_000_000.25), "2023-11-14T22:13:20.250Z");
    }
}
