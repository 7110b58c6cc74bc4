//! `GET /v1/jobs/{id}/stream`: the WebSocket protocol of DESIGN.md.
//!
//! `hello`, then per frame a `stats` text message and a binary frame, then
//! `done`, `failed` or `cancelled`. Every client reads frames from the
//! store at its own pace, starting at `?from=N`, and waits on the job's
//! watch channel only when it has caught up; so a stalled client holds
//! nothing but its own socket, and no client can miss a frame.

use std::sync::Arc;

use axum::extract::ws::rejection::WebSocketUpgradeRejection;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Extension, Path, Query, State};
use axum::response::IntoResponse;
use axum::response::Response;
use serde::Deserialize;
use serde_json::json;
use utoipa::IntoParams;

use super::api::visible_job;
use super::auth::Owner;
use super::error::{ApiError, ErrorResponse};
use super::job::{Job, Status};
use super::results::binary_frame;
use super::state::Shared;

/// Where to start.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct StreamQuery {
    /// First frame to send (default 0): stored frames from here are
    /// replayed, then the stream goes live.
    from: Option<u64>,
}

/// Stream a job's frames over WebSocket (live, or replayed when ended).
#[utoipa::path(
    get, path = "/v1/jobs/{id}/stream", tag = "frames",
    params(("id" = String, Path, description = "Job id"), StreamQuery),
    responses(
        (status = 101, description = "Switching to WebSocket: hello, then stats + binary frame per frame, then done/failed/cancelled"),
        (status = 404, body = ErrorResponse),
        (status = 401, body = ErrorResponse),
    ),
    security(("api_key" = []))
)]
pub async fn stream(
    State(shared): State<Arc<Shared>>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
    Query(q): Query<StreamQuery>,
    ws: Result<WebSocketUpgrade, WebSocketUpgradeRejection>,
) -> Result<Response, ApiError> {
    // Subscribe before reading the job, so an end between the two is seen.
    let live = shared.hub.subscribe(&id);
    let row = visible_job(&shared, &owner, id).await?;
    let from = q.from.unwrap_or(0);
    // The job is checked first, so a missing one is 404 for any client.
    let ws = match ws {
        Ok(ws) => ws,
        Err(e) => return Ok(e.into_response()),
    };
    Ok(ws.on_upgrade(move |socket| async move {
        if let Err(e) = serve(socket, &shared, row.seq, row.id.clone(), from, live).await {
            tracing::debug!(id = %row.id, error = %e, "stream ended early");
        }
    }))
}

async fn serve(
    mut socket: WebSocket,
    shared: &Arc<Shared>,
    seq: i64,
    id: String,
    from: u64,
    mut live: Option<tokio::sync::watch::Receiver<super::hub::Live>>,
) -> anyhow::Result<()> {
    let s = Arc::clone(shared);
    let hello = tokio::task::spawn_blocking(move || s.store.hello(seq)).await??;
    socket
        .send(Message::Text(hello.unwrap_or_default().into()))
        .await?;
    let mut next = from;
    loop {
        // What is stored now, and whether more can come.
        let (frames, status) = match &mut live {
            Some(rx) => {
                let l = *rx.borrow_and_update();
                (l.frames, l.status)
            }
            None => {
                let s = Arc::clone(shared);
                let id = id.clone();
                let row = tokio::task::spawn_blocking(move || s.store.job(&id))
                    .await??
                    .ok_or_else(|| anyhow::anyhow!("job vanished"))?;
                (row.frames_done, row.status)
            }
        };
        while next < frames {
            let s = Arc::clone(shared);
            let n = next;
            let Some(f) = tokio::task::spawn_blocking(move || s.store.frame(seq, n)).await?? else {
                break;
            };
            let mut stats: serde_json::Value = serde_json::from_str(&f.stats).unwrap_or_default();
            stats["type"] = json!("stats");
            stats["frame"] = json!(f.n);
            socket.send(Message::Text(stats.to_string().into())).await?;
            socket
                .send(Message::Binary(
                    binary_frame(f.n, f.time, &f.positions).into(),
                ))
                .await?;
            next += 1;
        }
        if status.is_terminal() && next >= frames {
            let s = Arc::clone(shared);
            let id = id.clone();
            let row = tokio::task::spawn_blocking(move || s.store.job(&id)).await??;
            let job = row.as_ref().map(Job::from_row);
            // The protocol names success `done`; the other ends keep the
            // status's name.
            let kind = match status {
                Status::Succeeded => "done",
                other => other.as_str(),
            };
            let end = json!({
                "type": kind,
                "status": status,
                "frames": frames,
                "error": job.as_ref().and_then(|j| j.error.clone()),
                "stats": job.as_ref().and_then(|j| j.stats.clone()),
            });
            socket.send(Message::Text(end.to_string().into())).await?;
            socket.send(Message::Close(None)).await?;
            return Ok(());
        }
        let closed = match &mut live {
            Some(rx) => rx.changed().await.is_err(),
            None => false,
        };
        match &live {
            // The channel closed: the job ended (its last value says so)
            // or the server is shutting down.
            Some(rx) if closed => {
                if !rx.borrow().status.is_terminal() {
                    let bye = json!({"type": "interrupted", "message": "the server is shutting down; reconnect with ?from=N"});
                    socket.send(Message::Text(bye.to_string().into())).await?;
                    socket.send(Message::Close(None)).await?;
                    return Ok(());
                }
                live = None;
            }
            Some(_) => {}
            None if status == Status::Queued || status == Status::Running => {
                // A job this process does not track cannot progress.
                anyhow::bail!("job {id} is {} but not tracked", status.as_str());
            }
            None => {}
        }
    }
}
