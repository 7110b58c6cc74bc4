//! The REST handlers under `/v1` (DESIGN.md "Service"), each annotated for
//! the OpenAPI document.

use std::sync::Arc;
use std::time::Duration;

use axum::Json;
use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{Extension, Path, Query, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Deserialize;
use utoipa::{IntoParams, ToSchema};

use super::auth::Owner;
use super::error::{ApiError, ErrorDetail, ErrorResponse};
use super::hello;
use super::hub::Live;
use super::job::{Job, JobList, Status, now};
use super::queue::Queued;
use super::results::{self, Format};
use super::state::{Shared, StopReason};
use super::store::{JobRow, NewJob};
use crate::specfile::{self, SpecLoadError};

/// Seconds a client is asked to wait when the queue is full.
const RETRY_AFTER_SECONDS: u32 = 5;
/// Longest wait of `DELETE` for a running job to stop.
const CANCEL_WAIT: Duration = Duration::from_secs(5);

/// Runs blocking store work off the async executor.
async fn blocking<T: Send + 'static>(
    shared: &Arc<Shared>,
    f: impl FnOnce(&Shared) -> Result<T, ApiError> + Send + 'static,
) -> Result<T, ApiError> {
    let shared = Arc::clone(shared);
    tokio::task::spawn_blocking(move || f(&shared)).await?
}

/// The job `id` if the caller may see it.
pub(super) async fn visible_job(
    shared: &Arc<Shared>,
    owner: &Owner,
    id: String,
) -> Result<JobRow, ApiError> {
    let row = blocking(shared, move |s| Ok(s.store.job(&id)?)).await?;
    match row {
        Some(r) if owner.may_see(&r.owner) => Ok(r),
        _ => Err(ApiError::not_found("such job")),
    }
}

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
    State(shared): State<Arc<Shared>>,
    Extension(owner): Extension<Owner>,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, ApiError> {
    let body = body.map_err(|e| match e {
        BytesRejection::FailedToBufferBody(_) if e.status() == StatusCode::PAYLOAD_TOO_LARGE => {
            ApiError::new(
                StatusCode::PAYLOAD_TOO_LARGE,
                "payload_too_large",
                format!(
                    "the body is larger than this server's limit of {} bytes (--max-body-bytes)",
                    shared.config.max_body_bytes
                ),
            )
        }
        other => ApiError::bad_request(other.body_text()),
    })?;
    let limits = shared.config.limits;
    let owner = owner.name().to_owned();
    let job = blocking(&shared, move |s| {
        let text = std::str::from_utf8(&body).map_err(|e| {
            ApiError::new(
                StatusCode::BAD_REQUEST,
                "malformed_json",
                format!("the body is not UTF-8: {e}"),
            )
        })?;
        let scene = specfile::load(text, &limits).map_err(spec_error)?;
        let id = uuid::Uuid::now_v7().to_string();
        let hello_json = hello::build(&scene, &id).map_err(|e| {
            ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, "invalid_spec", e.message)
                .with_path(e.path)
        })?;
        // One submission at a time between the capacity check and the
        // push, so the queue never holds more than its capacity.
        let _guard = s.submit_lock();
        if s.queue.len() >= s.config.queue_capacity {
            s.metrics.rejected_queue_full.inc();
            let mut e = ApiError::new(
                StatusCode::TOO_MANY_REQUESTS,
                "queue_full",
                format!(
                    "{} jobs are already waiting (--queue-capacity); try again later",
                    s.config.queue_capacity
                ),
            );
            e.retry_after = Some(RETRY_AFTER_SECONDS);
            return Err(e);
        }
        if s.is_stopping() {
            let mut e = ApiError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "shutting_down",
                "the server is shutting down",
            );
            e.retry_after = Some(RETRY_AFTER_SECONDS);
            return Err(e);
        }
        let seq = s.store.insert_job(&NewJob {
            id: &id,
            owner: &owner,
            name: &scene.name,
            spec: text,
            hello: &hello_json,
            frames_total: scene.frames as u64 + 1,
            created_at: now(),
        })?;
        s.hub.open(
            &id,
            Live {
                frames: 0,
                status: Status::Queued,
            },
        );
        s.queue.push(Queued {
            seq,
            id: id.clone(),
        });
        s.metrics.submitted.inc();
        let row = s
            .store
            .job(&id)?
            .ok_or_else(|| ApiError::internal("job vanished"))?;
        Ok(Job::from_row(&row))
    })
    .await?;
    tracing::info!(id = %job.id, name = %job.name, "job submitted");
    let mut headers = HeaderMap::new();
    if let Ok(v) = HeaderValue::from_str(&job.links.self_) {
        headers.insert(header::LOCATION, v);
    }
    Ok((StatusCode::CREATED, headers, Json(job)).into_response())
}

fn spec_error(e: SpecLoadError) -> ApiError {
    match e {
        SpecLoadError::Malformed(m) => ApiError::new(
            StatusCode::BAD_REQUEST,
            "malformed_json",
            format!("malformed JSON: {m}"),
        ),
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
            let mut err = ApiError::new(
                StatusCode::UNPROCESSABLE_ENTITY,
                "invalid_spec",
                if first.path.is_empty() {
                    first.message.clone()
                } else {
                    format!("{}: {}", first.path, first.message)
                },
            )
            .with_path(first.path);
            err.body.details = details;
            err
        }
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
    State(shared): State<Arc<Shared>>,
    Extension(owner): Extension<Owner>,
    Query(q): Query<ListQuery>,
) -> Result<Json<JobList>, ApiError> {
    let status = match q.status.as_deref() {
        None => None,
        Some(s) => Some(Status::parse(s).ok_or_else(|| {
            ApiError::bad_request(format!(
                "unknown status {s:?}; expected queued, running, succeeded, failed or cancelled"
            ))
            .with_path("status")
        })?),
    };
    let limit = q.limit.unwrap_or(50);
    if !(1..=500).contains(&limit) {
        return Err(ApiError::bad_request("must be between 1 and 500").with_path("limit"));
    }
    let before = match q.cursor.as_deref() {
        None => None,
        Some(c) => Some(c.parse::<i64>().map_err(|_| {
            ApiError::bad_request("not a cursor from this API").with_path("cursor")
        })?),
    };
    let mine = owner.0.clone();
    let rows = blocking(&shared, move |s| {
        Ok(s.store.list(mine.as_deref(), status, before, limit + 1)?)
    })
    .await?;
    let more = rows.len() > limit;
    let rows = &rows[..rows.len().min(limit)];
    Ok(Json(JobList {
        jobs: rows.iter().map(Job::from_row).collect(),
        next_cursor: more
            .then(|| rows.last().map(|r| r.seq.to_string()))
            .flatten(),
    }))
}

/// A job's status, progress, timings, statistics and error.
#[utoipa::path(
    get, path = "/v1/jobs/{id}", tag = "jobs",
    params(("id" = String, Path, description = "Job id")),
    responses((status = 200, body = Job), (status = 404, body = ErrorResponse), (status = 401, body = ErrorResponse)),
    security(("api_key" = []))
)]
pub async fn get(
    State(shared): State<Arc<Shared>>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
) -> Result<Json<Job>, ApiError> {
    Ok(Json(Job::from_row(
        &visible_job(&shared, &owner, id).await?,
    )))
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
    State(shared): State<Arc<Shared>>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
) -> Result<Json<Job>, ApiError> {
    let mut rx = shared.hub.subscribe(&id);
    let row = visible_job(&shared, &owner, id.clone()).await?;
    match row.status {
        Status::Succeeded | Status::Failed => {
            return Err(ApiError::conflict(format!(
                "the job already {}",
                row.status.as_str()
            )));
        }
        Status::Cancelled => return Ok(Json(Job::from_row(&row))),
        Status::Queued | Status::Running => {}
    }
    let seq = row.seq;
    let id2 = id.clone();
    let cancelled_queued = blocking(&shared, move |s| {
        let done = s.store.cancel_queued(seq, now())?;
        if done {
            s.queue.remove(seq);
            s.hub.close(&id2, Status::Cancelled);
        }
        Ok(done)
    })
    .await?;
    if !cancelled_queued {
        if let Some(h) = shared.running().get(&id) {
            h.stop(StopReason::Cancelled);
        }
        if let Some(rx) = &mut rx {
            let _ =
                tokio::time::timeout(CANCEL_WAIT, rx.wait_for(|l| l.status.is_terminal())).await;
        }
    }
    tracing::info!(%id, "job cancel requested");
    let row = visible_job(&shared, &owner, id).await?;
    Ok(Json(Job::from_row(&row)))
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
    State(shared): State<Arc<Shared>>,
    Extension(owner): Extension<Owner>,
    Path(p): Path<FramePath>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let row = visible_job(&shared, &owner, p.id).await?;
    let (seq, n) = (row.seq, p.n);
    let f = blocking(&shared, move |s| Ok(s.store.frame(seq, n)?))
        .await?
        .ok_or_else(|| {
            ApiError::not_found(&format!(
                "frame {n}: {} of {} frames are stored",
                row.frames_done, row.frames_total
            ))
        })?;
    let binary = headers
        .get(header::ACCEPT)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.contains("application/octet-stream"));
    if binary {
        let body = results::binary_frame(f.n, f.time, &f.positions);
        return Ok(([(header::CONTENT_TYPE, "application/octet-stream")], body).into_response());
    }
    Ok(Json(FrameJson {
        frame: f.n,
        time: f.time,
        vertices: results::decode_positions(&f.positions),
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
    State(shared): State<Arc<Shared>>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
    Query(q): Query<ResultQuery>,
) -> Result<Response, ApiError> {
    let format = match q.format.as_deref().unwrap_or("obj") {
        "obj" => Format::Obj,
        "pc2" => Format::Pc2,
        "glb" => Format::Glb,
        other => {
            return Err(ApiError::bad_request(format!(
                "unknown format {other:?}; expected obj, pc2 or glb"
            ))
            .with_path("format"));
        }
    };
    let row = visible_job(&shared, &owner, id).await?;
    if !row.status.is_terminal() {
        return Err(ApiError::conflict(format!(
            "the job is {}; results are available once it ends (frames stream live)",
            row.status.as_str()
        )));
    }
    if row.frames_done == 0 {
        return Err(ApiError::conflict("the job stored no frame"));
    }
    let name = row.id.clone();
    let bytes = blocking(&shared, move |s| {
        results::build(&s.store, &row, format).map_err(|e| ApiError::internal(format!("{e:#}")))
    })
    .await?;
    let disposition = format!("attachment; filename=\"{name}.{}\"", format.extension());
    Ok((
        [
            (header::CONTENT_TYPE, format.content_type().to_owned()),
            (header::CONTENT_DISPOSITION, disposition),
        ],
        bytes,
    )
        .into_response())
}
