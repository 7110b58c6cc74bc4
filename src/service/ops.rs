//! Operations endpoints: liveness, readiness, Prometheus metrics, the
//! OpenAPI document.

use std::sync::Arc;

use axum::Json;
use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde_json::json;

use super::error::ApiError;
use super::state::Shared;

/// Liveness: the process serves requests.
#[utoipa::path(get, path = "/healthz", tag = "operations",
    responses((status = 200, description = "Alive", content_type = "application/json", body = Object)))]
pub async fn healthz() -> Json<serde_json::Value> {
    Json(json!({ "status": "ok" }))
}

/// Readiness: the store answers and the server is not shutting down.
#[utoipa::path(get, path = "/readyz", tag = "operations",
    responses(
        (status = 200, description = "Ready", content_type = "application/json", body = Object),
        (status = 503, description = "Shutting down or store unavailable", content_type = "application/json", body = Object),
    ))]
pub async fn readyz(State(shared): State<Arc<Shared>>) -> Response {
    let s = Arc::clone(&shared);
    let store_ok = tokio::task::spawn_blocking(move || s.store.count_by_status().is_ok())
        .await
        .unwrap_or(false);
    let ready = store_ok && !shared.is_stopping();
    let status = if ready {
        StatusCode::OK
    } else {
        StatusCode::SERVICE_UNAVAILABLE
    };
    let body = json!({
        "status": if ready { "ready" } else { "not_ready" },
        "store": store_ok,
        "stopping": shared.is_stopping(),
        "workers": shared.config.workers,
        "queue_depth": shared.queue.len(),
        "queue_capacity": shared.config.queue_capacity,
    });
    (status, Json(body)).into_response()
}

/// Prometheus metrics (OpenMetrics text).
#[utoipa::path(get, path = "/metrics", tag = "operations",
    responses((status = 200, description = "OpenMetrics text", content_type = "application/openmetrics-text", body = String)))]
pub async fn metrics(State(shared): State<Arc<Shared>>) -> Result<Response, ApiError> {
    let s = Arc::clone(&shared);
    let counts = tokio::task::spawn_blocking(move || s.store.count_by_status()).await??;
    let busy = shared.running().len();
    let text = shared.metrics.render(&counts, shared.queue.len(), busy);
    Ok((
        [(
            header::CONTENT_TYPE,
            "application/openmetrics-text; version=1.0.0; charset=utf-8",
        )],
        text,
    )
        .into_response())
}

/// The OpenAPI document.
pub async fn openapi_json() -> Response {
    (
        [(header::CONTENT_TYPE, "application/json")],
        super::openapi::json(),
    )
        .into_response()
}

/// The job spec's JSON Schema.
pub async fn job_schema() -> Response {
    (
        [(header::CONTENT_TYPE, "application/schema+json")],
        super::openapi::job_schema(),
    )
        .into_response()
}
