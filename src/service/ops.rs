//! Operations endpoints: liveness, readiness, Prometheus metrics.

use axum::Json;
use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde_json::json;

use super::error::{ApiError, ErrorResponse};
use super::error_code::ErrorCode;
use super::jobs::Fault;
use super::state::AppState;

/// Liveness: the process serves requests. Open with API keys too.
#[utoipa::path(get, path = "/healthz", tag = "operations",
    responses((status = 200, description = "Alive", content_type = "application/json", body = Object)))]
pub async fn healthz() -> Json<serde_json::Value> {
    Json(json!({ "status": "ok" }))
}

/// Readiness: the store answers and the server is not shutting down.
/// Open with API keys too: a probe carries no secret, and the answer says
/// nothing about any owner's jobs.
#[utoipa::path(get, path = "/readyz", tag = "operations",
    responses(
        (status = 200, description = "Ready", content_type = "application/json", body = Object),
        (status = 503, description = "Shutting down or store unavailable: the error envelope, with the readiness fields beside it", content_type = "application/json", body = ErrorResponse),
    ))]
pub async fn readyz(State(state): State<AppState>) -> Response {
    let jobs = &state.jobs;
    // Counting the queue is the store's answer to the probe.
    let queued = {
        let jobs = std::sync::Arc::clone(jobs);
        tokio::task::spawn_blocking(move || jobs.queued_count())
            .await
            .unwrap_or(None)
    };
    let store_ok = queued.is_some();
    let ready = store_ok && !jobs.is_stopping();
    let status = if ready {
        StatusCode::OK
    } else {
        StatusCode::SERVICE_UNAVAILABLE
    };
    let mut body = json!({
        "status": if ready { "ready" } else { "not_ready" },
        "store": store_ok,
        "stopping": jobs.is_stopping(),
        "node": state.config.node,
        "workers": state.config.workers,
        "queue_depth": queued,
        "queue_capacity": state.config.queue_capacity,
    });
    if !ready {
        let error = if jobs.is_stopping() {
            ApiError::new(ErrorCode::ShuttingDown, "the server is shutting down")
        } else {
            ApiError::new(ErrorCode::StoreUnavailable, "the job store does not answer")
        };
        body["error"] = serde_json::to_value(&error.body).unwrap_or_default();
    }
    (status, Json(body)).into_response()
}

/// Prometheus metrics (OpenMetrics text). With API keys, any key may
/// read them (they count every owner's jobs, so they are not open).
#[utoipa::path(get, path = "/metrics", tag = "operations",
    responses(
        (status = 200, description = "OpenMetrics text", content_type = "application/openmetrics-text", body = String),
        (status = 401, description = "Missing or invalid API key", body = ErrorResponse),
    ),
    security(("api_key" = [])))]
pub async fn metrics(State(state): State<AppState>) -> Result<Response, ApiError> {
    let jobs = std::sync::Arc::clone(&state.jobs);
    let text = tokio::task::spawn_blocking(move || jobs.metrics_text())
        .await
        .map_err(Fault::from)?
        .map_err(Fault::from)?;
    Ok((
        [(
            header::CONTENT_TYPE,
            "application/openmetrics-text; version=1.0.0; charset=utf-8",
        )],
        text,
    )
        .into_response())
}
