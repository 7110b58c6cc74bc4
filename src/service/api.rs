//! The REST handlers under `/v1` (DESIGN.md "Service"), each annotated for
//! the OpenAPI document. Each one extracts the request, calls [`Jobs`],
//! and turns the answer or the domain error into a response.
//!
//! [`Jobs`]: super::jobs::Jobs

use axum::Json;
use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{Extension, Path, Query, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Deserialize;
use utoipa::{IntoParams, ToSchema};

use super::error::{ApiError, ErrorResponse};
use super::error_code::ErrorCode;
use super::frame_bytes::{binary_frame, decode_positions};
use super::jobs::ListFilter;
use super::keys::Owner;
use super::results::Format;
use super::state::AppState;
use super::view::{Job, JobList};

/// Submit a job spec.
///
/// The spec is parsed and validated against the server's limits; a valid
/// one is stored and queued.
#[utoipa::path(
    post, path = "/v1/jobs", tag = "jobs",
    request_body(content = drapery_sim::spec::Spec, description = "A job spec (api/job.schema.json)", content_type = "application/json"),
    responses(
        (status = 201, description = "Queued", body = Job, headers(("Location" = String, description = "The job's URL"))),
        (status = 400, description = "Malformed JSON", body = ErrorResponse),
        (status = 401, description = "Missing or invalid API key", body = ErrorResponse),
        (status = 413, description = "Body larger than the server's limit", body = ErrorResponse),
        (status = 422, description = "Invalid spec; `path` names the field", body = ErrorResponse),
        (status = 429, description = "Queue full; see Retry-After", body = ErrorResponse),
    ),
    security(("api_key" = []))
)]
pub async fn submit(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, ApiError> {
    let body = body.map_err(|e| body_error(&e, state.config.max_body_bytes))?;
    let job = Job::from_row(&state.jobs.submit(&owner, body).await?);
    let mut headers = HeaderMap::new();
    if let Ok(v) = HeaderValue::from_str(&job.links.self_) {
        headers.insert(header::LOCATION, v);
    }
    Ok((StatusCode::CREATED, headers, Json(job)).into_response())
}

/// A body that could not be read: too large, or broken.
fn body_error(e: &BytesRejection, limit: usize) -> ApiError {
    match e {
        BytesRejection::FailedToBufferBody(_) if e.status() == StatusCode::PAYLOAD_TOO_LARGE => {
            ApiError::new(
                ErrorCode::PayloadTooLarge,
                format!(
                    "the body is larger than this server's limit of {limit} bytes (--max-body-bytes)"
                ),
            )
        }
        other => ApiError::bad_request(other.body_text()),
    }
}

/// Filters and paging of the job list.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct ListQuery {
    /// Only jobs in this status.
    status: Option<String>,
    /// Jobs per page, 1..=500 (default 50).
    limit: Option<usize>,
    /// `next_cursor` of the previous page.
    cursor: Option<String>,
}

/// List jobs, newest first.
#[utoipa::path(
    get, path = "/v1/jobs", tag = "jobs", params(ListQuery),
    responses(
        (status = 200, body = JobList),
        (status = 400, description = "Bad filter or cursor", body = ErrorResponse),
        (status = 401, body = ErrorResponse),
    ),
    security(("api_key" = []))
)]
pub async fn list(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Query(q): Query<ListQuery>,
) -> Result<Json<JobList>, ApiError> {
    let filter = ListFilter::parse(q.status.as_deref(), q.limit, q.cursor.as_deref())?;
    let page = state.jobs.list(&owner, filter).await?;
    Ok(Json(JobList::from_page(&page)))
}

/// A job's status, progress, timings, statistics and error.
#[utoipa::path(
    get, path = "/v1/jobs/{id}", tag = "jobs",
    params(("id" = String, Path, description = "Job id")),
    responses((status = 200, body = Job), (status = 404, body = ErrorResponse), (status = 401, body = ErrorResponse)),
    security(("api_key" = []))
)]
pub async fn get(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
) -> Result<Json<Job>, ApiError> {
    Ok(Json(Job::from_row(&state.jobs.get(&owner, &id).await?)))
}

/// Cancel a queued or running job.
///
/// A running job stops at its next solver step; the response comes when it
/// has (or after 5 s, still `running`). Frames stored so far stay.
#[utoipa::path(
    delete, path = "/v1/jobs/{id}", tag = "jobs",
    params(("id" = String, Path, description = "Job id")),
    responses(
        (status = 200, description = "Cancelled (or already)", body = Job),
        (status = 404, body = ErrorResponse),
        (status = 409, description = "The job already succeeded or failed", body = ErrorResponse),
        (status = 401, body = ErrorResponse),
    ),
    security(("api_key" = []))
)]
pub async fn cancel(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
) -> Result<Json<Job>, ApiError> {
    Ok(Json(Job::from_row(&state.jobs.cancel(&owner, &id).await?)))
}

/// Frame selector.
#[derive(Debug, Deserialize)]
pub struct FramePath {
    id: String,
    n: u64,
}

/// One frame as JSON.
#[derive(Debug, serde::Serialize, ToSchema)]
pub struct FrameJson {
    pub frame: u64,
    /// Simulated time, seconds.
    pub time: f64,
    /// Particle positions in grid order (index `i + j*nu`), metres.
    pub vertices: Vec<[f32; 3]>,
    /// The frame's statistics (as in the stream's `stats` message).
    #[schema(value_type = Object)]
    pub stats: serde_json::Value,
}

/// One stored frame: JSON, or the stream's binary frame with
/// `Accept: application/octet-stream` (header: frame u32, vertex count
/// u32, time f64, little-endian; then f32 x, y, z per particle).
#[utoipa::path(
    get, path = "/v1/jobs/{id}/frames/{n}", tag = "frames",
    params(("id" = String, Path, description = "Job id"), ("n" = u64, Path, description = "Frame index, from 0")),
    responses(
        (status = 200, body = FrameJson, content_type = "application/json"),
        (status = 200, description = "Binary frame", content_type = "application/octet-stream", body = Vec<u8>),
        (status = 404, description = "No such job, or the frame is not stored yet", body = ErrorResponse),
        (status = 401, body = ErrorResponse),
    ),
    security(("api_key" = []))
)]
pub async fn frame(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(p): Path<FramePath>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let f = state.jobs.frame(&owner, &p.id, p.n).await?;
    let binary = headers
        .get(header::ACCEPT)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.contains("application/octet-stream"));
    if binary {
        let body = binary_frame(f.n, f.time, &f.positions);
        return Ok(([(header::CONTENT_TYPE, "application/octet-stream")], body).into_response());
    }
    Ok(Json(FrameJson {
        frame: f.n,
        time: f.time,
        vertices: decode_positions(&f.positions),
        stats: serde_json::from_str(&f.stats).unwrap_or_default(),
    })
    .into_response())
}

/// Result format.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct ResultQuery {
    /// `obj` (zip of one OBJ per frame), `pc2` (point cache) or `glb`
    /// (binary glTF with the animation); default `obj`.
    format: Option<String>,
}

/// The whole animation as a download, once the job has ended.
#[utoipa::path(
    get, path = "/v1/jobs/{id}/result", tag = "frames",
    params(("id" = String, Path, description = "Job id"), ResultQuery),
    responses(
        (status = 200, description = "zip, PC2 or GLB file", content_type = "application/octet-stream", body = Vec<u8>),
        (status = 400, description = "Unknown format", body = ErrorResponse),
        (status = 404, body = ErrorResponse),
        (status = 409, description = "The job has not ended, or stored no frame", body = ErrorResponse),
        (status = 401, body = ErrorResponse),
    ),
    security(("api_key" = []))
)]
pub async fn result(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
    Query(q): Query<ResultQuery>,
) -> Result<Response, ApiError> {
    let name = q.format.as_deref().unwrap_or("obj");
    let format = Format::parse(name).ok_or_else(|| {
        ApiError::bad_request(format!("unknown format {name:?}; expected obj, pc2 or glb"))
            .with_path("format")
    })?;
    let (row, bytes) = state.jobs.download(&owner, &id, format).await?;
    let disposition = format!("attachment; filename=\"{}.{}\"", row.id, format.extension());
    Ok((
        [
            (header::CONTENT_TYPE, format.content_type().to_owned()),
            (header::CONTENT_DISPOSITION, disposition),
        ],
        bytes,
    )
        .into_response())
}
