//! Two middlewares that hold for every route.
//!
//! - [`read_body`] (on `/v1`, after the key check): a body announced
//!   larger than `--max-body-bytes` is refused with `413` before a byte of
//!   it is read, and a body must arrive whole within `--body-timeout`
//!   (`408` otherwise), however slowly it trickles. The handler then gets
//!   the body already in memory.
//! - [`envelope`] (outermost): any `4xx`/`5xx` that is not already JSON —
//!   an unknown route's `404`, a `405` (its `Allow` header kept), a layer's
//!   refusal — is rewritten as `{"error": {...}}` with the code its status
//!   stands for, so the README's promise holds for every answer.

use std::time::Duration;

use axum::body::{Body, to_bytes};
use axum::extract::{Request, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use http_body_util::BodyExt;

use super::error::{ApiError, code_for_status};
use super::error_code::ErrorCode;
use super::state::AppState;

/// The longest error text of another layer that is kept as the message.
const MAX_MESSAGE: usize = 1000;

/// Reads the request's body within the size limit and the time limit.
pub async fn read_body(State(state): State<AppState>, req: Request, next: Next) -> Response {
    let limit = state.config.max_body_bytes;
    let announced = req
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<u64>().ok());
    if announced.is_some_and(|n| n > limit as u64) {
        return too_large(limit);
    }
    let (parts, body) = req.into_parts();
    let timeout = state.config.body_timeout;
    let read = http_body_util::Limited::new(body, limit).collect();
    let bytes = match tokio::time::timeout(timeout, read).await {
        Ok(Ok(collected)) => collected.to_bytes(),
        Ok(Err(e)) if e.is::<http_body_util::LengthLimitError>() => return too_large(limit),
        Ok(Err(e)) => {
            return ApiError::bad_request(format!("the body could not be read: {e}"))
                .into_response();
        }
        Err(_) => return timed_out(timeout),
    };
    next.run(Request::from_parts(parts, Body::from(bytes)))
        .await
}

fn too_large(limit: usize) -> Response {
    closing(ApiError::new(
        ErrorCode::PayloadTooLarge,
        format!("the body is larger than this server's limit of {limit} bytes (--max-body-bytes)"),
    ))
}

fn timed_out(timeout: Duration) -> Response {
    closing(ApiError::new(
        ErrorCode::RequestTimeout,
        format!(
            "the body did not arrive within {} s (--body-timeout)",
            timeout.as_secs_f64()
        ),
    ))
}

/// An error after which the connection is closed: the rest of the body
/// is not read, so nothing else can follow on it.
fn closing(e: ApiError) -> Response {
    let mut r = e.into_response();
    r.headers_mut()
        .insert(header::CONNECTION, HeaderValue::from_static("close"));
    r
}

/// Rewrites an error answer that is not JSON into the error envelope.
pub async fn envelope(req: Request, next: Next) -> Response {
    let response = next.run(req).await;
    let status = response.status();
    let is_json = response
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with("application/json"));
    if !(status.is_client_error() || status.is_server_error()) || is_json {
        return response;
    }
    let (parts, body) = response.into_parts();
    let text = to_bytes(body, MAX_MESSAGE * 4).await.unwrap_or_default();
    let text = String::from_utf8_lossy(&text);
    let text = text.trim();
    let message = if text.is_empty() {
        status.canonical_reason().unwrap_or("error").to_lowercase()
    } else {
        text.chars().take(MAX_MESSAGE).collect()
    };
    let code = code_for_status(status);
    let mut rewritten = ApiError::new(code, message).into_response();
    *rewritten.status_mut() = status;
    for (name, value) in &parts.headers {
        if name != header::CONTENT_TYPE && name != header::CONTENT_LENGTH {
            rewritten.headers_mut().append(name, value.clone());
        }
    }
    if status == StatusCode::INTERNAL_SERVER_ERROR {
        tracing::error!(body = %text, "a layer answered 500 outside the error envelope");
    }
    rewritten
}
