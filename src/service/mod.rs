//! `drapery serve`: the simulation service (DESIGN.md "Service").
//!
//! ```text
//! HTTP ──▶ axum router ──▶ api (REST) ──▶ store (SQLite, WAL) ◀── workers (threads, solver)
//!                    └───▶ stream (WebSocket) ◀── hub (watch per job) ◀──┘
//! ```
//!
//! The solver runs on worker threads, never on the async executor; the
//! store is the single source of truth, so a restart recovers every job
//! and every stored frame.

mod api;
mod auth;
mod error;
mod hello;
mod hub;
mod job;
mod metrics;
pub mod openapi;
mod ops;
mod queue;
mod results;
mod state;
mod store;
mod stream;
mod viewer;
mod worker;

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::Context;
use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::http::{HeaderValue, Method, header};
use axum::routing::get;
use drapery_sim::spec::Limits;
use tower_http::cors::{AllowOrigin, Any, CorsLayer};
use tower_http::trace::TraceLayer;
use tracing::{info, warn};

use crate::cli::ServeArgs;
pub use auth::Keys;
use hub::Live;
use job::Status;
use queue::Queued;
pub use state::Config;
use state::{Shared, StopReason};
use store::Store;

impl Config {
    /// The configuration `drapery serve`'s flags describe.
    pub fn from_args(a: &ServeArgs) -> anyhow::Result<Self> {
        let workers = a.workers.unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
        });
        anyhow::ensure!(workers >= 1, "--workers must be at least 1");
        anyhow::ensure!(a.queue_capacity >= 1, "--queue-capacity must be at least 1");
        anyhow::ensure!(
            a.max_wall_seconds > 0.0 && a.max_duration > 0.0,
            "--max-wall-seconds and --max-duration must be positive"
        );
        let core = Limits::default();
        Ok(Self {
            workers,
            queue_capacity: a.queue_capacity,
            limits: Limits {
                max_particles: a.max_particles,
                max_triangles: a.max_triangles,
                max_duration: a.max_duration,
                max_frames: a.max_frames,
                max_steps: core.max_steps,
            },
            max_wall_seconds: a.max_wall_seconds,
            max_body_bytes: a.max_body_bytes,
            keys: Keys::parse(&a.api_keys).map_err(anyhow::Error::msg)?,
            cors_origins: a.cors_origins.clone(),
            checkpoint_seconds: a.checkpoint_seconds,
            shutdown_grace: a.shutdown_grace,
        })
    }
}

/// The HTTP routes over `shared`.
fn router(shared: &Arc<Shared>) -> Router {
    let v1 = Router::new()
        .route("/jobs", get(api::list).post(api::submit))
        .route("/jobs/{id}", get(api::get).delete(api::cancel))
        .route("/jobs/{id}/frames/{n}", get(api::frame))
        .route("/jobs/{id}/result", get(api::result))
        .route("/jobs/{id}/stream", get(stream::stream))
        .route_layer(axum::middleware::from_fn_with_state(
            Arc::clone(shared),
            auth::require_key,
        ));
    let mut app = Router::new()
        .nest("/v1", v1)
        .route("/healthz", get(ops::healthz))
        .route("/readyz", get(ops::readyz))
        .route("/metrics", get(ops::metrics))
        .route("/openapi.json", get(ops::openapi_json))
        .route("/job.schema.json", get(ops::job_schema))
        .route("/", get(viewer::index))
        .route("/assets/{file}", get(viewer::asset))
        .route("/examples", get(viewer::examples))
        .route("/examples/{name}", get(viewer::example))
        .layer(DefaultBodyLimit::max(shared.config.max_body_bytes))
        .layer(
            TraceLayer::new_for_http().make_span_with(|req: &axum::http::Request<_>| {
                tracing::info_span!("request", method = %req.method(), path = %req.uri().path())
            }),
        )
        .with_state(Arc::clone(shared));
    if let Some(cors) = cors(&shared.config.cors_origins) {
        app = app.layer(cors);
    }
    app
}

fn cors(origins: &[String]) -> Option<CorsLayer> {
    if origins.is_empty() {
        return None;
    }
    let layer = CorsLayer::new()
        .allow_methods([Method::GET, Method::POST, Method::DELETE])
        .allow_headers([header::AUTHORIZATION, header::CONTENT_TYPE, header::ACCEPT])
        .expose_headers([header::LOCATION, header::RETRY_AFTER]);
    Some(if origins.iter().any(|o| o == "*") {
        layer.allow_origin(Any)
    } else {
        let list: Vec<HeaderValue> = origins
            .iter()
            .filter_map(|o| HeaderValue::from_str(o).ok())
            .collect();
        layer.allow_origin(AllowOrigin::list(list))
    })
}

/// Queues again the jobs an earlier process left queued or running.
fn recover(shared: &Shared) -> anyhow::Result<usize> {
    let jobs = shared.store.unfinished()?;
    for row in &jobs {
        if row.status == Status::Running {
            // Interrupted by a crash: it resumes from its checkpoint.
            shared.store.requeue(row.seq, row.run_seconds)?;
        }
        shared.hub.open(
            &row.id,
            Live {
                frames: row.frames_done,
                status: Status::Queued,
            },
        );
        shared.queue.push(Queued {
            seq: row.seq,
            id: row.id.clone(),
        });
    }
    Ok(jobs.len())
}

/// Runs the service until SIGTERM or SIGINT.
pub fn serve(args: &ServeArgs) -> anyhow::Result<std::process::ExitCode> {
    let config = Config::from_args(args)?;
    let store = Store::open(&args.data)
        .with_context(|| format!("opening the job store in {}", args.data.display()))?;
    let shared = Arc::new(Shared::new(config, store));
    let recovered = recover(&shared)?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .thread_name("http")
        .build()?;
    runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind(args.addr)
            .await
            .with_context(|| format!("binding {}", args.addr))?;
        let addr = listener.local_addr()?;
        let workers = worker::spawn(&shared, shared.config.workers);
        info!(
            %addr,
            workers = shared.config.workers,
            data = %args.data.display(),
            recovered,
            auth = shared.config.keys.enabled(),
            viewer_bytes = viewer::load_size(),
            "listening"
        );
        // Tests and scripts read the address from the first stdout line.
        println!("listening on http://{addr}");

        let reaper = {
            let shared = Arc::clone(&shared);
            tokio::spawn(async move {
                let mut tick = tokio::time::interval(Duration::from_millis(250));
                loop {
                    tick.tick().await;
                    worker::enforce_deadlines(&shared);
                }
            })
        };
        let app = router(&shared);
        let stopping = {
            let shared = Arc::clone(&shared);
            async move {
                shutdown_signal().await;
                info!("shutdown requested: no new requests; running jobs checkpoint");
                shared.stopping.store(true, Ordering::SeqCst);
                shared.queue.wake_all();
                shared.hub.close_all();
            }
        };
        axum::serve(listener, app)
            .with_graceful_shutdown(stopping)
            .await?;
        reaper.abort();
        drain(&shared, workers).await;
        info!("stopped");
        anyhow::Ok(())
    })?;
    Ok(std::process::ExitCode::SUCCESS)
}

/// Waits for workers to stop at a frame (and checkpoint) within the grace
/// period; then asks the stragglers to stop at their next step.
async fn drain(shared: &Arc<Shared>, workers: Vec<std::thread::JoinHandle<()>>) {
    let grace = Duration::from_secs_f64(shared.config.shutdown_grace.max(0.0));
    let start = Instant::now();
    while !shared.running().is_empty() && start.elapsed() < grace {
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let late = shared.running().len();
    if late > 0 {
        warn!(
            jobs = late,
            "grace period over: stopping jobs mid-frame; they resume from their last checkpoint"
        );
        for h in shared.running().values() {
            h.stop(StopReason::Shutdown);
        }
    }
    let _ = tokio::task::spawn_blocking(move || {
        for w in workers {
            let _ = w.join();
        }
    })
    .await;
}

async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        () = ctrl_c => {}
        () = term => {}
    }
}
