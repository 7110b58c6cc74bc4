//! `GET /v1/jobs/{id}/stream`: the WebSocket protocol of DESIGN.md, over a
//! job's [`Subscription`]: `hello`, then per frame a `stats` text message
//! and a binary frame, then `done`, `failed` or `cancelled` (or
//! `interrupted` at a shutdown). The messages are [`StreamMessage`]s; the
//! pacing (a slow client never slows the solver) is the subscription's.

use axum::extract::ws::rejection::WebSocketUpgradeRejection;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Extension, Path, Query, State};
use axum::response::{IntoResponse, Response};
use serde::Deserialize;
use utoipa::IntoParams;

use super::error::{ApiError, ErrorResponse};
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
    from: Option<u64>,
}

/// Stream a job's frames over WebSocket (live, or replayed when ended).
///
/// Text messages are `StreamMessage`s (schema
/// `#/components/schemas/StreamMessage`): `hello` first, then for each
/// frame a `stats` message followed by a binary frame (frame u32, vertex
/// count u32, time f64, little-endian; then f32 x, y, z per particle),
/// then `done`, `failed` or `cancelled`; `interrupted` if the server shuts
/// down first.
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
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
    Query(q): Query<StreamQuery>,
    ws: Result<WebSocketUpgrade, WebSocketUpgradeRejection>,
) -> Result<Response, ApiError> {
    let sub = state
        .jobs
        .subscribe(&owner, &id, q.from.unwrap_or(0))
        .await?;
    // The job is checked first, so a missing one is 404 for any client.
    let ws = match ws {
        Ok(ws) => ws,
        Err(e) => return Ok(e.into_response()),
    };
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
    socket
        .send(Message::Text(sub.hello().await?.into()))
        .await?;
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
        }
    }
    Ok(())
}
