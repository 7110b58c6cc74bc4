//! What every part of the service shares: configuration, the store, the
//! queue, live news, metrics, and the handles of running jobs.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use drapery_sim::spec::Limits;

use super::auth::Keys;
use super::hub::Hub;
use super::metrics::Metrics;
use super::queue::Queue;
use super::store::Store;

/// Settings from `drapery serve`'s flags.
#[derive(Debug, Clone)]
pub struct Config {
    pub workers: usize,
    pub queue_capacity: usize,
    /// Size limits a submitted spec must meet.
    pub limits: Limits,
    pub max_wall_seconds: f64,
    pub max_body_bytes: usize,
    pub keys: Keys,
    pub cors_origins: Vec<String>,
    pub checkpoint_seconds: f64,
    pub shutdown_grace: f64,
}

/// Why a running job is being stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum StopReason {
    None = 0,
    /// Its owner cancelled it.
    Cancelled = 1,
    /// It ran past the wall-time limit.
    WallTime = 2,
    /// The server is shutting down and the grace period is over.
    Shutdown = 3,
}

/// The cancel flag of a running job (checked by the solver every step).
#[derive(Debug)]
pub struct RunHandle {
    pub cancel: AtomicBool,
    reason: AtomicU8,
    pub deadline: Instant,
}

impl RunHandle {
    pub fn new(deadline: Instant) -> Self {
        Self {
            cancel: AtomicBool::new(false),
            reason: AtomicU8::new(StopReason::None as u8),
            deadline,
        }
    }

    /// Asks the solver to stop at its next step; the first reason wins.
    pub fn stop(&self, reason: StopReason) {
        let _ = self.reason.compare_exchange(
            StopReason::None as u8,
            reason as u8,
            Ordering::SeqCst,
            Ordering::SeqCst,
        );
        self.cancel.store(true, Ordering::SeqCst);
    }

    pub fn reason(&self) -> StopReason {
        match self.reason.load(Ordering::SeqCst) {
            1 => StopReason::Cancelled,
            2 => StopReason::WallTime,
            3 => StopReason::Shutdown,
            _ => StopReason::None,
        }
    }
}

/// The service's shared state.
#[derive(Debug)]
pub struct Shared {
    pub config: Config,
    pub store: Store,
    pub queue: Queue,
    pub hub: Hub,
    pub metrics: Metrics,
    pub running: Mutex<HashMap<String, Arc<RunHandle>>>,
    /// Shutting down: workers stop at the next frame (with a checkpoint)
    /// and take no new job.
    pub stopping: AtomicBool,
    /// Held from a submission's capacity check to its push.
    submit: Mutex<()>,
}

impl Shared {
    pub fn new(config: Config, store: Store) -> Self {
        Self {
            queue: Queue::new(),
            config,
            store,
            hub: Hub::default(),
            metrics: Metrics::default(),
            running: Mutex::new(HashMap::new()),
            stopping: AtomicBool::new(false),
            submit: Mutex::new(()),
        }
    }

    pub fn running(&self) -> std::sync::MutexGuard<'_, HashMap<String, Arc<RunHandle>>> {
        self.running.lock().unwrap_or_else(|p| p.into_inner())
    }

    pub fn submit_lock(&self) -> std::sync::MutexGuard<'_, ()> {
        self.submit.lock().unwrap_or_else(|p| p.into_inner())
    }

    pub fn is_stopping(&self) -> bool {
        self.stopping.load(Ordering::SeqCst)
    }
}
