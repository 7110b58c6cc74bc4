//! What can go wrong with a job operation, by operation. The HTTP layer
//! turns each into a status and an error code (`ApiError`); nothing here
//! knows about HTTP.

use drapery_sim::spec::SpecError;

use crate::service::cost::OverBudget;
use crate::service::job::{JobId, Status};
use crate::service::results::ExportError;
use crate::service::store::StoreError;
use crate::specfile::SpecLoadError;

/// A failure that is not the caller's: the store, a task that died, a job
/// whose records disagree.
#[derive(Debug, thiserror::Error)]
pub enum Fault {
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error("request task failed: {0}")]
    Task(tokio::task::JoinError),
    #[error(transparent)]
    Export(#[from] ExportError),
    /// A job just stored cannot be read back.
    #[error("job {0} vanished")]
    Vanished(JobId),
    /// A stored spec no longer loads or draws.
    #[error("job {id}: the stored spec cannot make a hello: {message}")]
    Hello { id: JobId, message: String },
}

impl From<tokio::task::JoinError> for Fault {
    fn from(e: tokio::task::JoinError) -> Self {
        Self::Task(e)
    }
}

/// Why a submission was refused.
#[derive(Debug, thiserror::Error)]
pub enum SubmitError {
    #[error("the body is not UTF-8: {0}")]
    NotUtf8(std::str::Utf8Error),
    /// Not JSON, or not a valid spec.
    #[error(transparent)]
    Spec(#[from] SpecLoadError),
    /// A valid spec with an obstacle that cannot be drawn for the stream.
    #[error("{}", .0.message)]
    Undrawable(SpecError),
    /// A valid spec whose estimate is beyond one or more budgets.
    #[error("{}", .0.first().map(ToString::to_string).unwrap_or_default())]
    OverBudget(Vec<OverBudget>),
    #[error("{capacity} jobs are already waiting (--queue-capacity); try again later")]
    QueueFull { capacity: usize },
    #[error("the server is shutting down")]
    ShuttingDown,
    #[error(transparent)]
    Fault(#[from] Fault),
}

/// Why an operation on one job was refused.
#[derive(Debug, thiserror::Error)]
pub enum JobsError {
    /// No such job, or another owner's.
    #[error("no such job")]
    NotFound,
    #[error("no frame {n}: {done} of {total} frames are stored")]
    FrameNotStored { n: u64, done: u64, total: u64 },
    /// Cancelling a job that succeeded or failed.
    #[error("the job already {}", .0.as_str())]
    AlreadyEnded(Status),
    /// Downloading a job that has not ended.
    #[error("the job is {}; results are available once it ends (frames stream live)", .0.as_str())]
    NotEnded(Status),
    /// Downloading a job that ended before its first frame.
    #[error("the job stored no frame")]
    NoFrames,
    /// Every download turn stayed taken for the whole wait.
    #[error("{turns} downloads are being built or sent (--max-downloads); try again later")]
    DownloadsBusy { turns: usize },
    #[error(transparent)]
    Fault(#[from] Fault),
}

/// A job listing's filter or page that cannot be.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ListError {
    #[error("unknown status {0:?}; expected queued, running, succeeded, failed or cancelled")]
    Status(String),
    #[error("must be between 1 and 500")]
    Limit,
    #[error("not a cursor from this API")]
    Cursor,
}

impl ListError {
    /// The query parameter at fault.
    pub fn parameter(&self) -> &'static str {
        match self {
            ListError::Status(_) => "status",
            ListError::Limit => "limit",
            ListError::Cursor => "cursor",
        }
    }
}

impl From<StoreError> for SubmitError {
    fn from(e: StoreError) -> Self {
        Self::Fault(e.into())
    }
}

impl From<StoreError> for JobsError {
    fn from(e: StoreError) -> Self {
        Self::Fault(e.into())
    }
}

impl From<tokio::task::JoinError> for SubmitError {
    fn from(e: tokio::task::JoinError) -> Self {
        Self::Fault(e.into())
    }
}

impl From<tokio::task::JoinError> for JobsError {
    fn from(e: tokio::task::JoinError) -> Self {
        Self::Fault(e.into())
    }
}
