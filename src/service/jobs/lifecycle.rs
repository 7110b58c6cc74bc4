//! [`Jobs`]: the one owner of every job's life. It holds the store, the
//! queue, the live news for streams, the handles of running jobs and the
//! counters, and is the only code that changes them together: submission,
//! cancellation, lookups, recovery at start, stream subscriptions (the
//! other files of this folder) and a worker's attempt at a job
//! (`attempt`).
//!
//! Its methods that touch the store are blocking (SQLite); the async ones,
//! for request handlers, run that work on tokio's blocking pool.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

use super::error::Fault;
use super::hub::{Hub, Live};
use super::queue::Queue;
use super::running::{Running, StopReason};
use crate::service::config::Config;
use crate::service::job::Status;
use crate::service::metrics::Metrics;
use crate::service::store::{Store, StoreError};

/// Every job of this service.
#[derive(Debug)]
pub struct Jobs {
    pub(super) config: Arc<Config>,
    pub(super) store: Store,
    pub(super) queue: Queue,
    pub(super) hub: Hub,
    pub(super) running: Running,
    pub(super) metrics: Metrics,
    /// Shutting down: workers stop at the next frame (with a checkpoint)
    /// and take no new job; submissions are refused.
    stopping: AtomicBool,
    /// Held from a submission's capacity check to its push, so the queue
    /// never holds more than its capacity.
    submit: Mutex<()>,
}

impl Jobs {
    pub fn new(config: Arc<Config>, store: Store) -> Self {
        Self {
            config,
            store,
            queue: Queue::new(),
            hub: Hub::default(),
            running: Running::default(),
            metrics: Metrics::default(),
            stopping: AtomicBool::new(false),
            submit: Mutex::new(()),
        }
    }

    /// Queues again the jobs an earlier process left queued or running;
    /// returns how many. A job that was running resumes from its
    /// checkpoint.
    pub fn recover(&self) -> Result<usize, StoreError> {
        let jobs = self.store.unfinished()?;
        for row in &jobs {
            if row.status == Status::Running {
                // Interrupted by a crash: it resumes from its checkpoint.
                self.store.requeue(row.id, row.run_seconds)?;
            }
            self.hub.open(
                row.id,
                Live {
                    frames: row.frames_done,
                    status: Status::Queued,
                },
            );
            self.queue.push(row.id);
        }
        Ok(jobs.len())
    }

    /// Shutdown begins: no job is accepted or started any more, running
    /// jobs stop at their next frame with a checkpoint, and every stream
    /// hears that its channel closed.
    pub fn begin_shutdown(&self) {
        self.stopping.store(true, Ordering::SeqCst);
        self.queue.wake_all();
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

    /// Jobs waiting for a worker.
    pub fn queued_count(&self) -> usize {
        self.queue.len()
    }

    /// The store answers.
    pub fn store_ok(&self) -> bool {
        self.store.count_by_status().is_ok()
    }

    /// The Prometheus exposition.
    pub fn metrics_text(&self) -> Result<String, StoreError> {
        let counts = self.store.count_by_status()?;
        Ok(self
            .metrics
            .render(&counts, self.queue.len(), self.running.len()))
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
