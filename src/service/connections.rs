//! The HTTP connections: accepted up to `--max-connections` at once, each
//! served by hyper (HTTP/1.1, WebSocket upgrades) under a watchdog, and
//! all of them closed within the grace period at shutdown.
//!
//! The watchdog sees a connection's traffic through [`Watched`] and its
//! requests through the service wrapper, and closes it when
//!
//! - a request's head has been arriving for longer than
//!   `--header-timeout` since its first byte (slowloris), or
//! - no request is being handled and nothing was read or written for
//!   `--idle-timeout` (an idle keep-alive connection, or a client that
//!   stopped reading its response).
//!
//! A body's time is the body reader's (`guard::read_body`,
//! `--body-timeout`). At shutdown no connection is accepted any more,
//! every open one is asked to finish its request and close (hyper's
//! graceful shutdown), and whatever is still open when the grace period
//! ends — a client holding a half-sent request, say — is dropped, so the
//! process exits in time whatever its clients do. A connection upgraded to
//! a WebSocket leaves this accounting: its stream task ends on the
//! server's `interrupted` message.

use std::future::Future;
use std::io;
use std::pin::Pin;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::task::{Context, Poll};
use std::time::{Duration, Instant};

use axum::Router;
use axum::body::Body;
use hyper::body::Incoming;
use hyper_util::rt::TokioIo;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{OwnedSemaphorePermit, Semaphore, watch};
use tokio::task::JoinSet;
use tower_service::Service;
use tracing::{debug, warn};

/// How often a connection's watchdog looks at its clock.
const WATCH_TICK: Duration = Duration::from_millis(200);
/// The pause after a failed accept (out of file descriptors, say), so the
/// loop neither spins nor floods the log.
const ACCEPT_BACKOFF: Duration = Duration::from_millis(100);

/// The limits of every connection.
#[derive(Debug, Clone, Copy)]
pub struct ConnectionLimits {
    pub max_connections: usize,
    pub header_timeout: Duration,
    pub idle_timeout: Duration,
}

/// Serves `app` on `listener` until `shutdown` completes; then closes
/// every connection, waiting at most `grace` for their requests.
pub async fn serve(
    listener: TcpListener,
    app: Router,
    limits: ConnectionLimits,
    shutdown: impl Future<Output = ()>,
    grace: Duration,
) {
    let permits = Arc::new(Semaphore::new(limits.max_connections));
    let (stop, stopped) = watch::channel(false);
    let mut open = JoinSet::new();
    tokio::pin!(shutdown);
    loop {
        // A free slot first: beyond the cap, clients wait in the backlog.
        let permit = tokio::select! {
            permit = Arc::clone(&permits).acquire_owned() => match permit {
                Ok(p) => p,
                Err(_) => break,
            },
            () = &mut shutdown => break,
        };
        let stream = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => stream,
                Err(e) => {
                    warn!(error = %e, "accepting a connection failed");
                    tokio::time::sleep(ACCEPT_BACKOFF).await;
                    continue;
                }
            },
            () = &mut shutdown => break,
        };
        while open.try_join_next().is_some() {}
        open.spawn(connection(
            stream,
            app.clone(),
            limits,
            stopped.clone(),
            permit,
        ));
    }
    drop(listener);
    let _ = stop.send(true);
    let closed =
        tokio::time::timeout(grace, async { while open.join_next().await.is_some() {} }).await;
    if closed.is_err() {
        warn!(
            connections = open.len(),
            "grace period over: dropping connections with unfinished requests"
        );
        open.shutdown().await;
    }
}

/// Serves one connection until it closes, the watchdog closes it, or the
/// server stops.
async fn connection(
    stream: TcpStream,
    app: Router,
    limits: ConnectionLimits,
    mut stop: watch::Receiver<bool>,
    _slot: OwnedSemaphorePermit,
) {
    let _ = stream.set_nodelay(true);
    let clock = Arc::new(Clock::new());
    let io = TokioIo::new(Watched {
        inner: stream,
        clock: Arc::clone(&clock),
    });
    let service = {
        let clock = Arc::clone(&clock);
        hyper::service::service_fn(move |req: hyper::Request<Incoming>| {
            let handling = Handling::begin(&clock);
            let mut app = app.clone();
            async move {
                let response = app.call(req.map(Body::new)).await;
                drop(handling);
                response
            }
        })
    };
    let conn = hyper::server::conn::http1::Builder::new()
        .keep_alive(true)
        .serve_connection(io, service)
        .with_upgrades();
    tokio::pin!(conn);
    let mut tick = tokio::time::interval(WATCH_TICK);
    let mut stopping = *stop.borrow();
    if stopping {
        conn.as_mut().graceful_shutdown();
    }
    loop {
        tokio::select! {
            served = conn.as_mut() => {
                if let Err(e) = served {
                    debug!(error = %e, "connection ended with an error");
                }
                return;
            }
            changed = stop.changed(), if !stopping => {
                stopping = true;
                if changed.is_ok() {
                    conn.as_mut().graceful_shutdown();
                }
            }
            _ = tick.tick() => {
                if let Some(why) = clock.expired(&limits) {
                    debug!(why, "closing the connection");
                    return;
                }
            }
        }
    }
}

/// When a connection last moved, and whether it is in a request.
#[derive(Debug)]
struct Clock {
    start: Instant,
    /// Milliseconds since `start` of the last byte read or written, or of
    /// the last request's end.
    last: AtomicU64,
    /// Milliseconds since `start` of the first byte of a request head not
    /// yet handed to the service; [`NONE`] when there is none.
    head_since: AtomicU64,
    /// Requests being handled.
    handling: AtomicUsize,
}

const NONE: u64 = u64::MAX;

impl Clock {
    fn new() -> Self {
        Self {
            start: Instant::now(),
            last: AtomicU64::new(0),
            head_since: AtomicU64::new(NONE),
            handling: AtomicUsize::new(0),
        }
    }

    fn now(&self) -> u64 {
        self.start.elapsed().as_millis() as u64
    }

    fn read(&self) {
        let now = self.now();
        self.last.store(now, Ordering::SeqCst);
        if self.handling.load(Ordering::SeqCst) == 0 {
            let _ = self
                .head_since
                .compare_exchange(NONE, now, Ordering::SeqCst, Ordering::SeqCst);
        }
    }

    fn wrote(&self) {
        self.last.store(self.now(), Ordering::SeqCst);
    }

    /// Why the connection should close now, if it should.
    fn expired(&self, limits: &ConnectionLimits) -> Option<&'static str> {
        if self.handling.load(Ordering::SeqCst) > 0 {
            return None;
        }
        let now = self.now();
        let since = |t: u64| Duration::from_millis(now.saturating_sub(t));
        let head = self.head_since.load(Ordering::SeqCst);
        if head != NONE && since(head) > limits.header_timeout {
            return Some("the request head took longer than --header-timeout");
        }
        (since(self.last.load(Ordering::SeqCst)) > limits.idle_timeout)
            .then_some("silent for longer than --idle-timeout")
    }
}

/// A request in the service: the clock knows, until it is dropped.
struct Handling(Arc<Clock>);

impl Handling {
    fn begin(clock: &Arc<Clock>) -> Self {
        clock.handling.fetch_add(1, Ordering::SeqCst);
        clock.head_since.store(NONE, Ordering::SeqCst);
        Self(Arc::clone(clock))
    }
}

impl Drop for Handling {
    fn drop(&mut self) {
        self.0.wrote();
        self.0.handling.fetch_sub(1, Ordering::SeqCst);
    }
}

/// A socket that tells its [`Clock`] when bytes move.
#[derive(Debug)]
struct Watched<T> {
    inner: T,
    clock: Arc<Clock>,
}

impl<T: AsyncRead + Unpin> AsyncRead for Watched<T> {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let before = buf.filled().len();
        let polled = Pin::new(&mut self.inner).poll_read(cx, buf);
        if buf.filled().len() > before {
            self.clock.read();
        }
        polled
    }
}

impl<T: AsyncWrite + Unpin> AsyncWrite for Watched<T> {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        data: &[u8],
    ) -> Poll<io::Result<usize>> {
        let polled = Pin::new(&mut self.inner).poll_write(cx, data);
        if matches!(polled, Poll::Ready(Ok(n)) if n > 0) {
            self.clock.wrote();
        }
        polled
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_flush(cx)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_shutdown(cx)
    }

    fn poll_write_vectored(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[io::IoSlice<'_>],
    ) -> Poll<io::Result<usize>> {
        let polled = Pin::new(&mut self.inner).poll_write_vectored(cx, bufs);
        if matches!(polled, Poll::Ready(Ok(n)) if n > 0) {
            self.clock.wrote();
        }
        polled
    }

    fn is_write_vectored(&self) -> bool {
        self.inner.is_write_vectored()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: ConnectionLimits = ConnectionLimits {
        max_connections: 1,
        header_timeout: Duration::from_millis(50),
        idle_timeout: Duration::from_millis(200),
    };

    #[test]
    fn a_slow_head_and_a_silent_connection_expire_but_a_handled_request_does_not() {
        let clock = Arc::new(Clock::new());
        assert_eq!(clock.expired(&LIMITS), None);
        clock.read();
        std::thread::sleep(Duration::from_millis(80));
        assert!(clock.expired(&LIMITS).is_some_and(|w| w.contains("head")));
        let handling = Handling::begin(&clock);
        std::thread::sleep(Duration::from_millis(250));
        assert_eq!(clock.expired(&LIMITS), None, "a handler may take its time");
        drop(handling);
        assert_eq!(clock.expired(&LIMITS), None);
        std::thread::sleep(Duration::from_millis(250));
        assert!(clock.expired(&LIMITS).is_some_and(|w| w.contains("idle")));
    }
}
