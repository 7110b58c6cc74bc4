//! API errors: every failure is `{"error": {"code", "message", "path"}}`
//! with the HTTP status its [`ErrorCode`] stands for. Domain errors become
//! `ApiError`s here, in one place per error type.
//!
//! A client's mistake is answered and logged at most at debug level; a
//! failure of the service's own is logged as an error with its cause and
//! answered `internal` without it.

use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::error_code::ErrorCode;
use super::jobs::{Fault, JobsError, ListError, SubmitError};
use crate::specfile::SpecLoadError;

/// Seconds a client is asked to wait when the queue is full or the server
/// is stopping.
const RETRY_AFTER_SECONDS: u32 = 5;

/// One problem, with the spec field it concerns.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ErrorDetail {
    /// Path of the offending field (`cloth.grid[0]`); empty for the whole
    /// document.
    pub path: String,
    pub message: String,
}

/// The body of every error response.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ErrorBody {
    /// Machine-readable.
    pub code: ErrorCode,
    /// The first (or only) problem, for people.
    pub message: String,
    /// The first problem's field path, when it concerns one.
    pub path: Option<String>,
    /// Every problem, when a spec has several.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub details: Vec<ErrorDetail>,
}

/// `{"error": ...}`.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ErrorResponse {
    pub error: ErrorBody,
}

/// An error on its way to the client.
#[derive(Debug)]
pub struct ApiError {
    pub body: ErrorBody,
    /// Seconds for a `Retry-After` header (429, 503).
    pub retry_after: Option<u32>,
}

impl ApiError {
    pub fn new(code: ErrorCode, message: impl Into<String>) -> Self {
        Self {
            body: ErrorBody {
                code,
                message: message.into(),
                path: None,
                details: Vec::new(),
            },
            retry_after: None,
        }
    }

    /// `not_found`: "no {what}".
    pub fn not_found(what: &str) -> Self {
        Self::new(ErrorCode::NotFound, format!("no {what}"))
    }

    pub fn bad_request(message: impl Into<String>) -> Self {
        Self::new(ErrorCode::BadRequest, message)
    }

    pub fn with_path(mut self, path: impl Into<String>) -> Self {
        self.body.path = Some(path.into());
        self
    }

    fn retry_later(mut self) -> Self {
        self.retry_after = Some(RETRY_AFTER_SECONDS);
        self
    }

    /// The HTTP status of the error's code.
    pub fn status(&self) -> StatusCode {
        status_of(self.body.code)
    }
}

/// The status each code answers with.
fn status_of(code: ErrorCode) -> StatusCode {
    match code {
        ErrorCode::MalformedJson | ErrorCode::BadRequest => StatusCode::BAD_REQUEST,
        ErrorCode::InvalidSpec | ErrorCode::OverBudget => StatusCode::UNPROCESSABLE_ENTITY,
        ErrorCode::NotFound => StatusCode::NOT_FOUND,
        ErrorCode::Unauthorized => StatusCode::UNAUTHORIZED,
        ErrorCode::Forbidden => StatusCode::FORBIDDEN,
        ErrorCode::MethodNotAllowed => StatusCode::METHOD_NOT_ALLOWED,
        ErrorCode::RequestTimeout => StatusCode::REQUEST_TIMEOUT,
        ErrorCode::PayloadTooLarge => StatusCode::PAYLOAD_TOO_LARGE,
        ErrorCode::UnsupportedMediaType => StatusCode::UNSUPPORTED_MEDIA_TYPE,
        ErrorCode::QueueFull => StatusCode::TOO_MANY_REQUESTS,
        ErrorCode::Conflict => StatusCode::CONFLICT,
        ErrorCode::ShuttingDown | ErrorCode::StoreUnavailable => StatusCode::SERVICE_UNAVAILABLE,
        // A job's failure codes never answer a request; were one to, it
        // would be the server's fault.
        ErrorCode::Internal | ErrorCode::NonFinite | ErrorCode::LimitExceeded => {
            StatusCode::INTERNAL_SERVER_ERROR
        }
    }
}

/// The code of an error answer that another layer made (a `404` of no
/// route, a `405`): the one its status stands for.
pub fn code_for_status(status: StatusCode) -> ErrorCode {
    match status {
        StatusCode::NOT_FOUND => ErrorCode::NotFound,
        StatusCode::METHOD_NOT_ALLOWED => ErrorCode::MethodNotAllowed,
        StatusCode::UNAUTHORIZED => ErrorCode::Unauthorized,
        StatusCode::FORBIDDEN => ErrorCode::Forbidden,
        StatusCode::REQUEST_TIMEOUT => ErrorCode::RequestTimeout,
        StatusCode::PAYLOAD_TOO_LARGE => ErrorCode::PayloadTooLarge,
        StatusCode::UNSUPPORTED_MEDIA_TYPE => ErrorCode::UnsupportedMediaType,
        StatusCode::TOO_MANY_REQUESTS => ErrorCode::QueueFull,
        StatusCode::SERVICE_UNAVAILABLE => ErrorCode::ShuttingDown,
        s if s.is_server_error() => ErrorCode::Internal,
        // Any other client error: the request as sent cannot be served.
        _ => ErrorCode::BadRequest,
    }
}

impl From<Fault> for ApiError {
    fn from(e: Fault) -> Self {
        if let Fault::Store(store) = &e
            && store.is_unavailable()
        {
            tracing::warn!(error = %e, "job store unavailable");
            return Self::new(
                ErrorCode::StoreUnavailable,
                "the job store cannot be reached now; try again shortly",
            )
            .retry_later();
        }
        tracing::error!(error = %e, "internal failure");
        Self::new(
            ErrorCode::Internal,
            "internal error; the server's log has the details",
        )
    }
}

impl From<SubmitError> for ApiError {
    fn from(e: SubmitError) -> Self {
        let message = e.to_string();
        match e {
            SubmitError::NotUtf8(_) => Self::new(ErrorCode::MalformedJson, message),
            SubmitError::Spec(e) => spec_error(e),
            SubmitError::Undrawable(e) => {
                Self::new(ErrorCode::InvalidSpec, message).with_path(e.path)
            }
            SubmitError::OverBudget(over) => {
                let mut err = Self::new(ErrorCode::OverBudget, message);
                err.body.details = over
                    .iter()
                    .map(|o| ErrorDetail {
                        path: String::new(),
                        message: o.to_string(),
                    })
                    .collect();
                err
            }
            SubmitError::QueueFull { .. } => Self::new(ErrorCode::QueueFull, message).retry_later(),
            SubmitError::ShuttingDown => Self::new(ErrorCode::ShuttingDown, message).retry_later(),
            SubmitError::Fault(f) => f.into(),
        }
    }
}

/// A spec that does not load: malformed JSON, or every rule it breaks with
/// the first one's path.
fn spec_error(e: SpecLoadError) -> ApiError {
    match e {
        SpecLoadError::Malformed(_) => ApiError::new(ErrorCode::MalformedJson, e.to_string()),
        SpecLoadError::Invalid(errors) => {
            let details: Vec<ErrorDetail> = errors
                .0
                .iter()
                .map(|e| ErrorDetail {
                    path: e.path.clone(),
                    message: e.message.clone(),
                })
                .collect();
            let first = details.first().cloned().unwrap_or(ErrorDetail {
                path: String::new(),
                message: "invalid spec".into(),
            });
            let message = if first.path.is_empty() {
                first.message.clone()
            } else {
                format!("{}: {}", first.path, first.message)
            };
            let mut err = ApiError::new(ErrorCode::InvalidSpec, message).with_path(first.path);
            err.body.details = details;
            err
        }
    }
}

impl From<JobsError> for ApiError {
    fn from(e: JobsError) -> Self {
        let message = e.to_string();
        match e {
            JobsError::NotFound | JobsError::FrameNotStored { .. } => {
                Self::new(ErrorCode::NotFound, message)
            }
            JobsError::AlreadyEnded(_) | JobsError::NotEnded(_) | JobsError::NoFrames => {
                Self::new(ErrorCode::Conflict, message)
            }
            JobsError::DownloadsBusy { .. } => {
                Self::new(ErrorCode::QueueFull, message).retry_later()
            }
            JobsError::Fault(f) => f.into(),
        }
    }
}

impl From<ListError> for ApiError {
    fn from(e: ListError) -> Self {
        Self::bad_request(e.to_string()).with_path(e.parameter())
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let status = self.status();
        let mut r = (status, axum::Json(ErrorResponse { error: self.body })).into_response();
        if let Some(s) = self.retry_after {
            r.headers_mut()
                .insert(header::RETRY_AFTER, HeaderValue::from(s));
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::job::Status;

    fn body(e: ApiError) -> (StatusCode, serde_json::Value) {
        let status = e.status();
        let retry = e.retry_after;
        let mut v = serde_json::to_value(ErrorResponse { error: e.body }).expect("JSON");
        if let Some(r) = retry {
            v["retry_after"] = r.into();
        }
        (status, v)
    }

    #[test]
    fn domain_errors_keep_their_status_code_and_message() {
        let (s, v) = body(SubmitError::QueueFull { capacity: 1 }.into());
        assert_eq!(s, StatusCode::TOO_MANY_REQUESTS);
        assert_eq!(v["error"]["code"], "queue_full");
        assert_eq!(
            v["error"]["message"],
            "1 jobs are already waiting (--queue-capacity); try again later"
        );
        assert_eq!(v["retry_after"], 5);
        let (s, v) = body(SubmitError::ShuttingDown.into());
        assert_eq!(s, StatusCode::SERVICE_UNAVAILABLE);
        assert_eq!(v["error"]["code"], "shutting_down");
        let (s, v) = body(JobsError::NotFound.into());
        assert_eq!(s, StatusCode::NOT_FOUND);
        assert_eq!(v["error"]["message"], "no such job");
        assert_eq!(v["error"]["path"], serde_json::Value::Null);
        let (s, v) = body(JobsError::AlreadyEnded(Status::Succeeded).into());
        assert_eq!(s, StatusCode::CONFLICT);
        assert_eq!(v["error"]["message"], "the job already succeeded");
        let (s, v) = body(
            JobsError::FrameNotStored {
                n: 9,
                done: 2,
                total: 5,
            }
            .into(),
        );
        assert_eq!(s, StatusCode::NOT_FOUND);
        assert_eq!(
            v["error"]["message"],
            "no frame 9: 2 of 5 frames are stored"
        );
        let (s, v) = body(ListError::Cursor.into());
        assert_eq!(s, StatusCode::BAD_REQUEST);
        assert_eq!(v["error"]["path"], "cursor");
        let (s, v) = body(SubmitError::Spec(SpecLoadError::Malformed("EOF".into())).into());
        assert_eq!(s, StatusCode::BAD_REQUEST);
        assert_eq!(v["error"]["message"], "malformed JSON: EOF");
    }

    /// A failure of the service's own says `internal` and nothing more.
    #[test]
    fn internal_details_stay_in_the_log() {
        let (s, v) = body(Fault::Vanished(crate::service::job::JobId::generate()).into());
        assert_eq!(s, StatusCode::INTERNAL_SERVER_ERROR);
        assert_eq!(v["error"]["code"], "internal");
        assert!(
            !v["error"]["message"]
                .as_str()
                .unwrap_or("")
                .contains("vanished")
        );
    }
}
