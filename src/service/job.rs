//! The words every part of the service uses about a job: its id, its
//! status, why it failed. No behaviour here beyond naming and parsing.

use std::fmt;

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;
use uuid::Uuid;

use super::error_code::ErrorCode;

/// A job's one key, inside the service and in the API: a UUID v7
/// (time-ordered), written hyphenated in lower case. The store's `seq`
/// column only orders the list and serves as its cursor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct JobId(Uuid);

impl JobId {
    /// A fresh id for a submission.
    pub fn generate() -> Self {
        Self(Uuid::now_v7())
    }

    /// The id written as `s`, if `s` is one exactly as this API writes ids;
    /// other spellings of a UUID (upper case, no hyphens, braces) name no
    /// job, as they never did.
    pub fn parse(s: &str) -> Option<Self> {
        let id = Self(Uuid::try_parse(s).ok()?);
        (id.to_string() == s).then_some(id)
    }
}

impl fmt::Display for JobId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.0.hyphenated(), f)
    }
}

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
        match self {
            Status::Succeeded | Status::Failed | Status::Cancelled => true,
            Status::Queued | Status::Running => false,
        }
    }
}

/// Why a job failed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct JobError {
    /// Machine-readable: `non_finite`, `limit_exceeded` or `internal`.
    pub code: ErrorCode,
    /// For people.
    pub message: String,
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
    fn ids_parse_only_as_written() {
        let id = JobId::generate();
        let text = id.to_string();
        assert_eq!(text.len(), 36);
        assert_eq!(JobId::parse(&text), Some(id));
        assert_eq!(JobId::parse(&text.to_uppercase()), None);
        assert_eq!(JobId::parse(&text.replace('-', "")), None);
        assert_eq!(JobId::parse("not-an-id"), None);
    }

    #[test]
    fn a_job_error_is_a_code_and_a_message() {
        let e = JobError {
            code: ErrorCode::LimitExceeded,
            message: "too long".into(),
        };
        assert_eq!(
            serde_json::to_string(&e).expect("serialises"),
            r#"{"code":"limit_exceeded","message":"too long"}"#
        );
    }
}
