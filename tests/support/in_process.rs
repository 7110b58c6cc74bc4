//! The service in the test's own process: the same flags as `drapery
//! serve`, `drapery::service::run` on a listener bound to port 0, over a
//! real socket, with a shutdown the test triggers.

use std::path::{Path, PathBuf};

use clap::Parser;
use drapery::cli::{Cli, Command};
use drapery::service::{AppState, Config, ServeError, open_store, run};
use tokio::net::TcpListener;
use tokio::sync::oneshot;
use tokio::task::JoinHandle;

use super::Endpoint;

/// A running service. [`Service::stop`] shuts it down as SIGTERM would
/// and waits until every worker thread is joined; dropping it without
/// `stop` (a failed test) only tells the workers to stop.
pub struct Service {
    pub base: String,
    pub data: PathBuf,
    pub state: AppState,
    stop: Option<oneshot::Sender<()>>,
    task: Option<JoinHandle<Result<(), ServeError>>>,
}

impl Endpoint for Service {
    fn base(&self) -> &str {
        &self.base
    }
}

impl Service {
    /// The service `drapery serve --data DATA FLAGS...` would run, on a
    /// free port of 127.0.0.1.
    pub async fn start(data: &Path, flags: &[&str]) -> Self {
        let data_arg = data.to_str().expect("a UTF-8 temp path");
        let store = super::store_flags(data);
        let argv = ["drapery", "serve", "--data", data_arg]
            .into_iter()
            .chain(store.iter().map(String::as_str))
            .chain(flags.iter().copied());
        let Command::Serve(args) = Cli::try_parse_from(argv).expect("valid flags").command else {
            unreachable!("parsed as serve");
        };
        let config = Config::from_args(&args).expect("a valid configuration");
        // Off the executor: a PostgreSQL store connects by blocking.
        let store = tokio::task::spawn_blocking(move || open_store(&args))
            .await
            .expect("joined")
            .expect("the store opens");
        let state = AppState::new(config, store);
        let listener = TcpListener::bind("127.0.0.1:0").await.expect("binds");
        let base = format!("http://{}", listener.local_addr().expect("an address"));
        let (stop, stopped) = oneshot::channel::<()>();
        let task = tokio::spawn(run(listener, state.clone(), async move {
            let _ = stopped.await;
        }));
        Self {
            base,
            data: data.to_owned(),
            state,
            stop: Some(stop),
            task: Some(task),
        }
    }

    /// Shuts down and waits for `run` to return: requests finished,
    /// running jobs stopped at a frame and queued again, workers joined.
    pub async fn stop(mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(task) = self.task.take() {
            task.await
                .expect("the service task ends")
                .expect("the service stops without error");
        }
    }
}

impl Drop for Service {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        // The runtime may be gone before `run` sees the signal; the workers
        // must not go on simulating for the rest of the test binary.
        self.state.jobs.begin_shutdown();
    }
}
