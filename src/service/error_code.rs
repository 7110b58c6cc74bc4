//! The one list of machine-readable error codes. An API error's
//! `error.code` and a failed job's `error.code` both take their values
//! from [`ErrorCode`], so a client matches on one closed set, and the
//! OpenAPI document lists it as an enum.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// Machine-readable error code. Answers to requests: `malformed_json`
/// (the body is not JSON, 400), `invalid_spec` (JSON but not a valid spec;
/// `path` names the field, 422), `over_budget` (a valid spec whose
/// estimated memory, disk or time is beyond this server's per-job budget,
/// 422), `not_found` (404), `unauthorized` (401), `forbidden` (403: a
/// WebSocket from an origin that is not allowed), `method_not_allowed`
/// (405, see `Allow`), `request_timeout` (408: the request's body did not
/// arrive in time), `payload_too_large` (413), `unsupported_media_type`
/// (415: a body that is not `application/json`), `queue_full` (429, see
/// `Retry-After`), `conflict` (409), `bad_request` (400), `shutting_down`
/// (503), `store_unavailable` (503: the job store, PostgreSQL, cannot be
/// reached now; see `Retry-After`), `internal` (500). Failed jobs: `non_finite` (the solver produced
/// NaN or infinity), `limit_exceeded` (the wall-time limit or the disk
/// budget), `internal`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum ErrorCode {
    MalformedJson,
    InvalidSpec,
    OverBudget,
    NotFound,
    Unauthorized,
    Forbidden,
    MethodNotAllowed,
    RequestTimeout,
    PayloadTooLarge,
    UnsupportedMediaType,
    QueueFull,
    Conflict,
    BadRequest,
    ShuttingDown,
    StoreUnavailable,
    Internal,
    NonFinite,
    LimitExceeded,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_snake_case_strings() {
        let names = [
            (ErrorCode::MalformedJson, "malformed_json"),
            (ErrorCode::InvalidSpec, "invalid_spec"),
            (ErrorCode::NotFound, "not_found"),
            (ErrorCode::Unauthorized, "unauthorized"),
            (ErrorCode::PayloadTooLarge, "payload_too_large"),
            (ErrorCode::OverBudget, "over_budget"),
            (ErrorCode::Forbidden, "forbidden"),
            (ErrorCode::MethodNotAllowed, "method_not_allowed"),
            (ErrorCode::RequestTimeout, "request_timeout"),
            (ErrorCode::UnsupportedMediaType, "unsupported_media_type"),
            (ErrorCode::QueueFull, "queue_full"),
            (ErrorCode::Conflict, "conflict"),
            (ErrorCode::BadRequest, "bad_request"),
            (ErrorCode::ShuttingDown, "shutting_down"),
            (ErrorCode::StoreUnavailable, "store_unavailable"),
            (ErrorCode::Internal, "internal"),
            (ErrorCode::NonFinite, "non_finite"),
            (ErrorCode::LimitExceeded, "limit_exceeded"),
        ];
        for (code, name) in names {
            assert_eq!(
                serde_json::to_value(code).expect("serialises"),
                serde_json::json!(name)
            );
            let back: ErrorCode = serde_json::from_value(serde_json::json!(name)).expect("parses");
            assert_eq!(back, code);
        }
    }
}
