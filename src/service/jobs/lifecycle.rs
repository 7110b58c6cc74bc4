//! [`Jobs`]: the one owner of every job's life on this node. It holds the
//! store (which is also the queue), the live news for streams, the handles
//! of the jobs running here and the counters, and is the only code that
//! changes them together: submission, cancellation, lookups, recovery at
//! start, stream subscriptions (the other files of this folder), a
//! worker's attempt at a job (`attempt`) and the renewal of its leases
//! (`lease`).
//!
//! Its methods that touch the store are blocking; the async ones, for
//! request handlers, run that work on tokio's blocking pool.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

use tokio::sync::Semaphore;

use super::error::Fault;
use super::hub::Hub;
use super::running::{Running, StopReason};
use super::wakeup::Wakeup;
use crate::service::config::Config;
use crate::service::job::Status;
use crate::service::metrics::Metrics;
use crate::service::store::{Store, StoreError};

/// Every job of this service.
#[derive(Debug)]
pub struct Jobs {
    pub(super) config: Arc<Config>,
    pub(super) store: Store,
    /// Where idle workers wait for a job.
    pub(super) wakeup: Wakeup,
    pub(super) hub: Hub,
    pub(super) running: Running,
    pub(super) metrics: Metrics,
    /// Shutting down: workers stop at the next frame (with a checkpoint)
    /// and take no new job; submissions are refused.
    stopping: AtomicBool,
    /// Held from a submission's capacity check to its insert, so this
    /// node never takes the queue past its capacity (several nodes may,
    /// by a job each at most).
    submit: Mutex<()>,
    /// Turns of result downloads (`--max-downloads`): each is built and
    /// held whole in memory until sent (`service::held_body`).
    pub(super) downloads: Arc<Semaphore>,
    /// Turns of submissions' checks, one per solver thread (`--threads`,
    /// every core by default): parsing a spec and building its meshes to
    /// check them can take up to the memory budget of a job for a second
    /// or two, and more at once would only share the cores and add up the
    /// memory.
    pub(super) checks: Arc<Semaphore>,
}

impl Jobs {
    pub fn new(config: Arc<Config>, store: Store) -> Self {
        Self {
            metrics: Metrics::new(&config.node),
            downloads: Arc::new(Semaphore::new(config.max_downloads)),
            checks: Arc::new(Semaphore::new(drapery_sim::parallel::threads())),
            config,
            store,
            wakeup: Wakeup::default(),
            hub: Hub::default(),
            running: Running::default(),
            stopping: AtomicBool::new(false),
            submit: Mutex::new(()),
        }
    }

    /// Queues again the jobs an earlier process of this node left running
    /// (they resume from their checkpoints); returns how many jobs wait.
    pub fn recover(&self) -> Result<usize, StoreError> {
        let waiting = self.store.recover(&self.config.node)?;
        self.wakeup.ring_all();
        Ok(waiting)
    }

    /// Shutdown begins: no job is accepted or started any more, running
    /// jobs stop at their next frame with a checkpoint, and every stream
    /// hears that its channel closed.
    pub fn begin_shutdown(&self) {
        self.stopping.store(true, Ordering::SeqCst);
        self.wakeup.ring_all();
        self.hub.close_all();
    }

    /// The service's settings.
    pub fn config(&self) -> &Config {
        &self.config
    }

    pub fn is_stopping(&self) -> bool {
        self.stopping.load(Ordering::SeqCst)
    }

    /// The flag workers wait on.
    pub(super) fn stopping_flag(&self) -> &AtomicBool {
        &self.stopping
    }

    /// Asks every running job to stop at its next step (the shutdown's
    /// grace period is over).
    pub fn stop_all_running(&self) {
        self.running.stop_all(StopReason::Shutdown);
    }

    /// Stops the jobs that ran past their wall-time limit; called
    /// periodically.
    pub fn enforce_deadlines(&self) {
        self.running.stop_overdue(Instant::now());
    }

    /// Jobs running in this process.
    pub fn running_count(&self) -> usize {
        self.running.len()
    }

    /// Jobs waiting for a worker, on every node; `None` if the store
    /// does not answer.
    pub fn queued_count(&self) -> Option<usize> {
        let counts = self.store.count_by_status().ok()?;
        Some(queued(&counts))
    }

    /// The Prometheus exposition of this node.
    pub fn metrics_text(&self) -> Result<String, StoreError> {
        let counts = self.store.count_by_status()?;
        Ok(self.metrics.render(
            &counts,
            queued(&counts),
            self.running.len(),
            self.config.workers,
        ))
    }

    /// This node's name.
    pub fn node(&self) -> &str {
        &self.config.node
    }

    pub(super) fn submit_lock(&self) -> MutexGuard<'_, ()> {
        self.submit.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Runs blocking work (the store) off the async executor.
    pub(super) async fn blocking<T, E>(
        self: &Arc<Self>,
        f: impl FnOnce(&Jobs) -> Result<T, E> + Send + 'static,
    ) -> Result<T, E>
    where
        T: Send + 'static,
        E: From<Fault> + Send + 'static,
    {
        let jobs = Arc::clone(self);
        tokio::task::spawn_blocking(move || f(&jobs))
            .await
            .map_err(|e| E::from(Fault::from(e)))?
    }
}

/// The queued jobs of counts by status.
pub(super) fn queued(counts: &[(Status, u64)]) -> usize {
    counts
        .iter()
        .find(|(s, _)| *s == Status::Queued)
        .map_or(0, |(_, n)| *n as usize)
}

/// A node of one worker over a store of its own under the test directory
/// `tag`, for the tests of this folder and the worker's.
#[cfg(test)]
pub(crate) fn jobs_for_tests(tag: &str) -> Arc<Jobs> {
    use crate::cli::{Cli, Command};
    use clap::Parser;
    let argv = [
        "drapery",
        "serve",
        "--workers",
        "1",
        "--queue-capacity",
        "4",
        "--max-wall-seconds",
        "60",
        "--checkpoint-seconds",
        "1",
        "--shutdown-grace",
        "1",
    ];
    let Command::Serve(args) = Cli::try_parse_from(argv).expect("flags").command else {
        unreachable!("parsed as serve");
    };
    let config = Config::from_args(&args).expect("a configuration");
    let store = Store::open(&crate::test_dir(tag)).expect("store");
    Arc::new(Jobs::new(Arc::new(config), store))
}
