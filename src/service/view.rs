//! A job as the API shows it: status, progress, timings, statistics,
//! error, links.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::job::{JobError, Status};
use super::jobs::Page;
use super::store::JobRow;

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
    /// Seconds of simulation, over every attempt; while the job runs, up
    /// to its last stored frame.
    pub run_seconds: f64,
    /// Times a worker started the job (more than 1 after a restart).
    pub attempts: u32,
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
    /// The node running the job, or that ran it last; null while it waits
    /// for its first (or next) run.
    pub node: Option<String>,
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
            id: row.id.to_string(),
            name: row.name.clone(),
            status: row.status,
            node: row.node.clone(),
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
            stats: row.summary(),
            error: row.failure(),
            links: Links {
                stream: format!("{base}/stream"),
                frames: format!("{base}/frames/{{n}}"),
                result: format!("{base}/result"),
                self_: base,
            },
        }
    }
}

impl JobList {
    /// The API view of a page of jobs.
    pub fn from_page(page: &Page) -> Self {
        Self {
            jobs: page.jobs.iter().map(Job::from_row).collect(),
            next_cursor: page.next_cursor.clone(),
        }
    }
}

/// Unix seconds as RFC 3339 UTC with milliseconds.
pub fn rfc3339(unix: f64) -> String {
    let t = std::time::UNIX_EPOCH + std::time::Duration::from_secs_f64(unix.max(0.0));
    humantime::format_rfc3339_millis(t).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timestamps_are_rfc3339_utc() {
        assert_eq!(rfc3339(0.0), "1970-01-01T00:00:00.000Z");
        assert_eq!(rfc3339(1_700_000_000.25), "2023-11-14T22:13:20.250Z");
    }
}
