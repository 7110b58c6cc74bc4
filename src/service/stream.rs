//! `GET /v1/jobs/{id}/stream`: the WebSocket protocol of DESIGN.md, over a
//! job's [`Subscription`]: `hello`, then per frame a `stats` text message
//! and a binary frame, then `done`, `failed` or `cancelled` (or
//! `interrupted` at a shutdown). The messages are [`StreamMessage`]s; the
//! pacing (a slow client never slows the solver) is the subscription's.

use axum::extract::ws::rejection::WebSocketUpgradeRejection;
use axum::extract::ws::{CloseFrame, Message, WebSocket, WebSocketUpgrade, close_code};
use axum::extract::{Extension, Path, State};
use axum::http::HeaderMap;
use axum::response::Response;
use serde::Deserialize;
use utoipa::IntoParams;

use super::auth::check_origin;
use super::error::{ApiError, ErrorResponse};
use super::extract::Query;
use super::frame_bytes::binary_frame;
use super::jobs::{Event, Fault, Subscription};
use super::keys::Owner;
use super::protocol::{Interrupted, Stats, StreamMessage};
use super::state::AppState;

/// Where to start.
#[derive(Debug, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct StreamQuery {
    /// First frame to send (default 0): stored frames from here are
    /// replayed, then the stream goes live.
    #[param(minimum = 0)]
    from: Option<u64>,
    /// The API key, for a browser, which cannot set the `Authorization`
    /// header on a WebSocket.
    #[allow(dead_code)]
    access_token: Option<String>,
}

/// Stream a job's frames over WebSocket (live, or replayed when ended).
///
/// Text messages are `StreamMessage`s (schema
/// `#/components/schemas/StreamMessage`): `hello` first, then for each
/// frame a `stats` message followed by a binary frame (frame u32, vertex
/// count u32, time f64, little-endian; then f32 x, y, z per particle),
/// then `done`, `failed` or `cancelled`; `interrupted` if the server shuts
/// down first; a job deleted before its end (cancelled, then deleted)
/// closes the stream with code 1000 and the reason `the job was deleted`.
#[utoipa::path(
    get, path = "/v1/jobs/{id}/stream", tag = "frames",
    params(("id" = String, Path, description = "Job id"), StreamQuery),
    responses(
        (status = 101, description = "Switching to WebSocket: hello, then stats + binary frame per frame, then done/failed/cancelled"),
        (status = 400, description = "Not a WebSocket handshake, or a bad `from`", body = ErrorResponse),
        (status = 401, description = "Missing or invalid API key", body = ErrorResponse),
        (status = 403, description = "A browser page of another origin (see --cors-origin)", body = ErrorResponse),
        (status = 404, description = "No such job", body = ErrorResponse),
    ),
    security(("api_key" = []))
)]
pub async fn stream(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
    Query(q): Query<StreamQuery>,
    headers: HeaderMap,
    ws: Result<WebSocketUpgrade, WebSocketUpgradeRejection>,
) -> Result<Response, ApiError> {
    check_origin(&headers, &state.config.cors_origins)?;
    let sub = state
        .jobs
        .subscribe(&owner, &id, q.from.unwrap_or(0))
        .await?;
    // The job is checked first, so a missing one is 404 for any client.
    let ws = ws.map_err(|e| {
        ApiError::bad_request(format!(
            "{}: open this stream with a WebSocket client",
            e.body_text()
        ))
    })?;
    Ok(ws.on_upgrade(move |socket| async move {
        let id = sub.id();
        if let Err(e) = send(socket, sub).await {
            tracing::debug!(%id, error = %e, "stream ended early");
        }
    }))
}

/// Why a stream stopped before its end.
#[derive(Debug, thiserror::Error)]
enum StreamError {
    #[error(transparent)]
    Job(#[from] Fault),
    /// The client went away.
    #[error(transparent)]
    Socket(#[from] axum::Error),
    #[error("the job ended with status {0}, which is no end")]
    NoEnd(&'static str),
}

/// Sends the whole stream of `sub` over `socket`.
async fn send(mut socket: WebSocket, mut sub: Subscription) -> Result<(), StreamError> {
    let hello = match sub.hello().await {
        Ok(hello) => hello,
        Err(Fault::Vanished(_)) => return Ok(socket.send(deleted()).await?),
        Err(e) => return Err(e.into()),
    };
    socket.send(Message::Text(hello.into())).await?;
    while let Some(event) = sub.next().await? {
        match event {
            Event::Frame(f) => {
                let stats = StreamMessage::Stats(Stats::new(f.n, &f.stats));
                socket.send(Message::Text(stats.to_json().into())).await?;
                socket
                    .send(Message::Binary(
                        binary_frame(f.n, f.time, &f.positions).into(),
                    ))
                    .await?;
            }
            Event::End(end) => {
                let status = end.status.as_str();
                let message = StreamMessage::end(end).ok_or(StreamError::NoEnd(status))?;
                socket.send(Message::Text(message.to_json().into())).await?;
                socket.send(Message::Close(None)).await?;
            }
            Event::Interrupted => {
                let bye = StreamMessage::Interrupted(Interrupted::shutdown());
                socket.send(Message::Text(bye.to_json().into())).await?;
                socket.send(Message::Close(None)).await?;
            }
            Event::Deleted => socket.send(deleted()).await?,
        }
    }
    Ok(())
}

/// The close of a stream whose job was deleted before its end: no end
/// message can be told truly (the job's record is gone), so the close
/// frame says why the frames stop.
fn deleted() -> Message {
    Message::Close(Some(CloseFrame {
        code: close_code::NORMAL,
        reason: "the job was deleted".into(),
    }))
}
