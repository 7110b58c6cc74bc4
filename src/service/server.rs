//! The service as a whole: [`app`], its routes over an [`AppState`];
//! [`run`], which serves them on a listener with the workers running until
//! a shutdown future completes; and [`serve`], `drapery serve` itself.
//!
//! Shutdown: when the future completes, no new connection is accepted,
//! in-flight requests finish (connections still open when the grace period
//! ends are dropped, whatever their clients hold), streams are told
//! `interrupted`, running jobs stop at their next frame with a checkpoint
//! (or, past the grace period, at their next step) and are queued again,
//! and every worker thread is joined before `run` returns. Connections
//! and jobs wind down at the same time, so `run` returns about one grace
//! period after the signal at most.

use std::future::Future;
use std::net::SocketAddr;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::http::{HeaderValue, Method, header};
use axum::middleware::from_fn_with_state;
use axum::routing::get;
use tokio::net::TcpListener;
use tower_http::cors::{AllowOrigin, Any, CorsLayer};
use tower_http::trace::TraceLayer;
use tracing::{info, warn};

use super::auth::Gate;
use super::config::{Config, ConfigError};
use super::connections::{self, ConnectionLimits};
use super::jobs::Jobs;
use super::state::AppState;
use super::store::{Store, StoreError};
use super::{api, auth, guard, openapi, ops, stream, viewer, worker};
use crate::cli::ServeArgs;

/// How often running jobs are checked against their wall-time limit.
const DEADLINE_CHECK: Duration = Duration::from_millis(250);
/// How often `--retention` deletes the ended jobs it no longer keeps.
const RETENTION_CHECK: Duration = Duration::from_secs(2);

/// Why the service could not start, or stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("opening the job store {place}")]
    Store {
        place: String,
        #[source]
        source: StoreError,
    },
    #[error(transparent)]
    Runtime(std::io::Error),
    #[error("binding {addr}")]
    Bind {
        addr: SocketAddr,
        #[source]
        source: std::io::Error,
    },
    /// Jobs left by an earlier process could not be queued again.
    #[error(transparent)]
    Recover(StoreError),
    #[error("starting the worker threads")]
    Workers(#[source] std::io::Error),
    #[error("a startup task failed: {0}")]
    Task(tokio::task::JoinError),
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// The HTTP routes over `state`.
///
/// With API keys, `/v1` and `/metrics` need a key in the `Authorization`
/// header; `?access_token=` is accepted instead only by the stream and the
/// download, which a browser opens without headers. `/healthz`, `/readyz`,
/// the documents and the viewer stay open (probes carry no secrets). Every
/// `/v1` body is read by `guard::read_body` once the key is checked.
pub fn app(state: AppState) -> Router {
    let header_key = from_fn_with_state(Gate::header(&state), auth::require_key);
    let any_key = from_fn_with_state(Gate::header_or_query(&state), auth::require_key);
    let body = from_fn_with_state(state.clone(), guard::read_body);
    let api = Router::new()
        .route("/jobs", get(api::list).post(api::submit))
        .route("/jobs/{id}", get(api::get).delete(api::cancel))
        .route("/jobs/{id}/frames/{n}", get(api::frame))
        .route_layer(body.clone())
        .route_layer(header_key.clone());
    let browser = Router::new()
        .route("/jobs/{id}/result", get(api::result))
        .route("/jobs/{id}/stream", get(stream::stream))
        .route_layer(body)
        .route_layer(any_key);
    let cors = cors(&state.config.cors_origins);
    let mut app = Router::new()
        .nest("/v1", api.merge(browser))
        .route("/healthz", get(ops::healthz))
        .route("/readyz", get(ops::readyz))
        .route("/metrics", get(ops::metrics).route_layer(header_key))
        .route("/openapi.json", get(openapi::serve_document))
        .route("/job.schema.json", get(openapi::serve_job_schema))
        .route("/", get(viewer::index))
        .route("/assets/{file}", get(viewer::asset))
        .route("/examples", get(viewer::examples))
        .route("/examples/{name}", get(viewer::example))
        .layer(DefaultBodyLimit::max(state.config.max_body_bytes))
        .layer(axum::middleware::from_fn(guard::envelope))
        .layer(
            TraceLayer::new_for_http().make_span_with(|req: &axum::http::Request<_>| {
                tracing::info_span!("request", method = %req.method(), path = %req.uri().path())
            }),
        )
        .with_state(state);
    if let Some(cors) = cors {
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

/// Serves `state` on `listener` until `shutdown` completes: queues again
/// the jobs an earlier process left, starts the workers, serves, then
/// shuts down gracefully and joins the workers.
pub async fn run(
    listener: TcpListener,
    state: AppState,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> Result<(), ServeError> {
    let jobs = Arc::clone(&state.jobs);
    let recovered = {
        let jobs = Arc::clone(&jobs);
        tokio::task::spawn_blocking(move || jobs.recover())
            .await
            .map_err(ServeError::Task)?
            .map_err(ServeError::Recover)?
    };
    let addr = listener.local_addr()?;
    let workers = worker::spawn(&jobs, state.config.workers)
        .and_then(|mut w| {
            w.push(worker::spawn_keeper(&jobs)?);
            Ok(w)
        })
        .map_err(|e| {
            // The ones started end at their next look at the store.
            jobs.begin_shutdown();
            ServeError::Workers(e)
        })?;
    info!(
        %addr,
        node = %state.config.node,
        workers = state.config.workers,
        recovered,
        auth = state.config.keys.enabled(),
        viewer_bytes = viewer::load_size(),
        "listening"
    );
    let reaper = tokio::spawn(reap(Arc::clone(&jobs)));
    let (signalled, heard) = tokio::sync::oneshot::channel::<()>();
    let stopping = {
        let jobs = Arc::clone(&jobs);
        async move {
            shutdown.await;
            info!("shutdown requested: no new connections; running jobs checkpoint");
            jobs.begin_shutdown();
            let _ = signalled.send(());
        }
    };
    let config = &state.config;
    let limits = ConnectionLimits {
        max_connections: config.max_connections,
        header_timeout: config.header_timeout,
        idle_timeout: config.idle_timeout,
    };
    let http = connections::serve(
        listener,
        app(state.clone()),
        limits,
        stopping,
        grace(config),
    );
    let winding_down = async {
        let _ = heard.await;
        // Also when serving ended otherwise: the workers only end once told.
        jobs.begin_shutdown();
        drain(&jobs, config, workers).await;
    };
    tokio::join!(http, winding_down);
    reaper.abort();
    info!("stopped");
    Ok(())
}

/// The periodic duties: wall-time limits (every 250 ms) and, with
/// `--retention`, the deletion of ended jobs it no longer keeps.
async fn reap(jobs: Arc<Jobs>) {
    let mut deadlines = tokio::time::interval(DEADLINE_CHECK);
    let mut retention = tokio::time::interval(RETENTION_CHECK);
    let retains = !jobs.config().retention.is_empty();
    loop {
        tokio::select! {
            _ = deadlines.tick() => jobs.enforce_deadlines(),
            _ = retention.tick(), if retains => {
                let jobs = Arc::clone(&jobs);
                match tokio::task::spawn_blocking(move || jobs.apply_retention()).await {
                    Ok(Ok(0)) => {}
                    Ok(Ok(n)) => info!(deleted = n, "retention deleted ended jobs"),
                    Ok(Err(e)) => warn!(error = %e, "retention failed"),
                    Err(e) => warn!(error = %e, "retention task failed"),
                }
            }
        }
    }
}

/// `--shutdown-grace` as a duration.
fn grace(config: &Config) -> Duration {
    Duration::try_from_secs_f64(config.shutdown_grace.max(0.0)).unwrap_or(Duration::MAX)
}

/// Waits for workers to stop at a frame (and checkpoint) within the grace
/// period; then asks the stragglers to stop at their next step, and joins
/// every worker.
async fn drain(jobs: &Jobs, config: &Config, workers: Vec<JoinHandle<()>>) {
    let grace = grace(config);
    let start = Instant::now();
    while jobs.running_count() > 0 && start.elapsed() < grace {
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let late = jobs.running_count();
    if late > 0 {
        warn!(
            jobs = late,
            "grace period over: stopping jobs mid-frame; they resume from their last checkpoint"
        );
        jobs.stop_all_running();
    }
    let _ = tokio::task::spawn_blocking(move || {
        for w in workers {
            let _ = w.join();
        }
    })
    .await;
}

/// `drapery serve`: runs the service on `args.addr` until SIGTERM or
/// SIGINT.
pub fn serve(args: &ServeArgs) -> Result<(), ServeError> {
    super::allocator::return_large_blocks();
    let config = Config::from_args(args)?;
    let store = open_store(args)?;
    let state = AppState::new(config, store);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .thread_name("http")
        .build()
        .map_err(ServeError::Runtime)?;
    let served = runtime.block_on(async {
        let listener = TcpListener::bind(args.addr)
            .await
            .map_err(|source| ServeError::Bind {
                addr: args.addr,
                source,
            })?;
        // Tests and scripts read the address from the first stdout line.
        println!("listening on http://{}", listener.local_addr()?);
        run(listener, state, shutdown_signal()).await
    });
    // A blocking task still running (a large download being built) does
    // not hold the exit back.
    runtime.shutdown_timeout(Duration::from_secs(1));
    served
}

/// The store `--store` names (PostgreSQL), else SQLite under `--data`.
pub fn open_store(args: &ServeArgs) -> Result<Store, ServeError> {
    match &args.store {
        Some(url) => {
            let store = Store::connect(url, args.store_connections).map_err(|source| {
                ServeError::Store {
                    place: "given by --store".into(),
                    source,
                }
            })?;
            info!("job store connected (PostgreSQL)");
            Ok(store)
        }
        None => {
            let store = Store::open(&args.data).map_err(|source| ServeError::Store {
                place: format!("in {}", args.data.display()),
                source,
            })?;
            info!(data = %args.data.display(), "job store opened");
            Ok(store)
        }
    }
}

/// SIGINT or SIGTERM.
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
