//! The REST handlers under `/v1` (DESIGN.md "Service"), each annotated for
//! the OpenAPI document. Each one extracts the request, calls [`Jobs`],
//! and turns the answer or the domain error into a response.
//!
//! [`Jobs`]: super::jobs::Jobs

use axum::Json;
use axum::body::Body;
use axum::extract::{Extension, Path, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Deserialize;
use utoipa::{IntoParams, ToSchema};

use super::error::{ApiError, ErrorResponse};
use super::extract::{JsonBody, Query};
use super::frame_bytes::{binary_frame, decode_positions};
use super::held_body::HeldBody;
use super::jobs::ListFilter;
use super::keys::Owner;
use super::results::Format;
use super::state::AppState;
use super::view::{Job, JobList};

/// A file's bytes: a download, or a binary frame.
#[derive(Debug)]
pub struct FileBytes;

impl utoipa::PartialSchema for FileBytes {
    fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
        use utoipa::openapi::schema::{KnownFormat, ObjectBuilder, SchemaFormat, Type};
        ObjectBuilder::new()
            .schema_type(Type::String)
            .format(Some(SchemaFormat::KnownFormat(KnownFormat::Binary)))
            .into()
    }
}

impl ToSchema for FileBytes {}

/// Submit a job spec.
///
/// The spec is parsed and validated against the server's limits, and its
/// estimated memory, disk and wall time against the per-job budgets; a
/// valid one within them is stored and queued.
#[utoipa::path(
    post, path = "/v1/jobs", tag = "jobs",
    request_body(content = drapery_sim::spec::Spec, description = "A job spec (api/job.schema.json), as `Content-Type: application/json`", content_type = "application/json"),
    responses(
        (status = 201, description = "Queued", body = Job, headers(("Location" = String, description = "The job's URL"))),
        (status = 400, description = "Malformed JSON (`malformed_json`), or trailing data after it", body = ErrorResponse),
        (status = 401, description = "Missing or invalid API key", body = ErrorResponse),
        (status = 408, description = "The body did not arrive within --body-timeout", body = ErrorResponse),
        (status = 413, description = "Body larger than the server's limit", body = ErrorResponse),
        (status = 415, description = "The body is not `application/json`", body = ErrorResponse),
        (status = 422, description = "Invalid spec (`invalid_spec`; `path` names the field), or beyond a per-job budget (`over_budget`; the message names the budget and the estimate)", body = ErrorResponse),
        (status = 429, description = "Queue full", body = ErrorResponse, headers(("Retry-After" = u32, description = "Seconds to wait"))),
        (status = 503, description = "The server is shutting down", body = ErrorResponse, headers(("Retry-After" = u32, description = "Seconds to wait"))),
    ),
    security(("api_key" = []))
)]
pub async fn submit(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    JsonBody(body): JsonBody,
) -> Result<Response, ApiError> {
    let job = Job::from_row(&state.jobs.submit(&owner, body).await?);
    let mut headers = HeaderMap::new();
    if let Ok(v) = HeaderValue::from_str(&job.links.self_) {
        headers.insert(header::LOCATION, v);
    }
    Ok((StatusCode::CREATED, headers, Json(job)).into_response())
}

/// Filters and paging of the job list.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct ListQuery {
    /// Only jobs in this status.
    #[param(inline, value_type = Option<super::job::Status>)]
    status: Option<String>,
    /// Jobs per page, 1..=500 (default 50).
    #[param(minimum = 1, maximum = 500)]
    limit: Option<usize>,
    /// `next_cursor` of the previous page.
    #[param(pattern = "^[0-9]{1,18}$")]
    cursor: Option<String>,
}

/// List jobs, newest first.
#[utoipa::path(
    get, path = "/v1/jobs", tag = "jobs", params(ListQuery),
    responses(
        (status = 200, description = "A page of jobs", body = JobList),
        (status = 400, description = "Bad filter or cursor; `path` names the parameter", body = ErrorResponse),
        (status = 401, description = "Missing or invalid API key", body = ErrorResponse),
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
    responses(
        (status = 200, description = "The job", body = Job),
        (status = 401, description = "Missing or invalid API key", body = ErrorResponse),
        (status = 404, description = "No such job", body = ErrorResponse),
    ),
    security(("api_key" = []))
)]
pub async fn get(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
) -> Result<Json<Job>, ApiError> {
    Ok(Json(Job::from_row(&state.jobs.get(&owner, &id).await?)))
}

/// Cancel a queued or running job; delete an ended one.
///
/// A queued job is cancelled at once. A running job stops at its next
/// solver step; the response comes when it has (or after 5 s, still
/// `running`); frames stored so far stay. An ended job (succeeded, failed
/// or cancelled) is deleted with its frames and checkpoint, and the answer
/// is the job as it was; it is `404` from then on.
#[utoipa::path(
    delete, path = "/v1/jobs/{id}", tag = "jobs",
    params(("id" = String, Path, description = "Job id")),
    responses(
        (status = 200, description = "Cancelled, or deleted (the job as it was)", body = Job),
        (status = 401, description = "Missing or invalid API key", body = ErrorResponse),
        (status = 404, description = "No such job", body = ErrorResponse),
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

/// Frame selector (`n` is read by the handler: a segment that is no frame
/// index names no frame, `404` in the error envelope naming `n`).
#[derive(Debug, Deserialize)]
pub struct FramePath {
    id: String,
    n: String,
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
    params(("id" = String, Path, description = "Job id"), ("n" = u64, Path, minimum = 0, maximum = 9_007_199_254_740_991_u64, description = "Frame index, from 0")),
    responses(
        (status = 200, description = "The frame: JSON, or the binary frame with `Accept: application/octet-stream`",
            content((FrameJson = "application/json"), (FileBytes = "application/octet-stream"))),
        (status = 401, description = "Missing or invalid API key", body = ErrorResponse),
        (status = 404, description = "No such job, no such frame (`n` is not a frame index), or the frame is not stored yet", body = ErrorResponse),
    ),
    security(("api_key" = []))
)]
pub async fn frame(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(p): Path<FramePath>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let n: u64 = p.n.parse().map_err(|_| {
        ApiError::not_found(&format!(
            "frame {:?}: frames are numbered 0, 1, 2, ...",
            p.n
        ))
        .with_path("n")
    })?;
    let f = state.jobs.frame(&owner, &p.id, n).await?;
    let binary = headers
        .get(header::ACCEPT)
        .and_then(|v| v.to_str().ok())
        .is_some_and(super::accept::prefers_binary);
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
    #[param(inline)]
    format: Option<Format>,
    /// The API key, for a download link (a browser sets no header on it).
    #[allow(dead_code)]
    access_token: Option<String>,
}

/// The whole animation as a download, once the job has ended.
#[utoipa::path(
    get, path = "/v1/jobs/{id}/result", tag = "frames",
    params(("id" = String, Path, description = "Job id"), ResultQuery),
    responses(
        (status = 200, description = "A zip of OBJ files (`obj`), a PC2 point cache (`pc2`) or a binary glTF (`glb`)",
            content((FileBytes = "application/zip"), (FileBytes = "application/octet-stream"), (FileBytes = "model/gltf-binary")),
            headers(("Content-Disposition" = String, description = "attachment; the file's name"))),
        (status = 400, description = "Unknown or repeated `format`", body = ErrorResponse),
        (status = 401, description = "Missing or invalid API key", body = ErrorResponse),
        (status = 404, description = "No such job", body = ErrorResponse),
        (status = 409, description = "The job has not ended, or stored no frame", body = ErrorResponse),
        (status = 429, description = "Every download turn (`--max-downloads`) stayed taken for 10 s; see `Retry-After`", body = ErrorResponse),
    ),
    security(("api_key" = []))
)]
pub async fn result(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
    Query(q): Query<ResultQuery>,
) -> Result<Response, ApiError> {
    let format = q.format.unwrap_or(Format::Obj);
    let (row, bytes, turn) = state.jobs.download(&owner, &id, format).await?;
    let disposition = format!("attachment; filename=\"{}.{}\"", row.id, format.extension());
    Ok((
        [
            (header::CONTENT_TYPE, format.content_type().to_owned()),
            (header::CONTENT_DISPOSITION, disposition),
        ],
        Body::new(HeldBody::new(bytes, turn)),
    )
        .into_response())
}
