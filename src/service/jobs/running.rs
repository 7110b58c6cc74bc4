//! The jobs running in this process, each with the stop flag its solver
//! checks every step, and why it was asked to stop.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

use crate::service::job::JobId;

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
    /// Another node took the job over (this one stopped renewing its
    /// lease): this node writes nothing more for it.
    LeaseLost = 4,
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
            4 => StopReason::LeaseLost,
            _ => StopReason::None,
        }
    }
}

/// The handles of the running jobs.
#[derive(Debug, Default)]
pub struct Running(Mutex<HashMap<JobId, Arc<RunHandle>>>);

impl Running {
    pub fn insert(&self, id: JobId, handle: Arc<RunHandle>) {
        self.lock().insert(id, handle);
    }

    pub fn remove(&self, id: JobId) {
        self.lock().remove(&id);
    }

    /// Stops job `id` if it runs here.
    pub fn stop(&self, id: JobId, reason: StopReason) {
        if let Some(h) = self.lock().get(&id) {
            h.stop(reason);
        }
    }

    /// Stops every running job.
    pub fn stop_all(&self, reason: StopReason) {
        for h in self.lock().values() {
            h.stop(reason);
        }
    }

    /// Stops the jobs past their deadline.
    pub fn stop_overdue(&self, now: Instant) {
        for h in self.lock().values() {
            if now >= h.deadline && !h.cancel.load(Ordering::SeqCst) {
                h.stop(StopReason::WallTime);
            }
        }
    }

    pub fn len(&self) -> usize {
        self.lock().len()
    }

    /// The jobs running here.
    pub fn ids(&self) -> Vec<JobId> {
        self.lock().keys().copied().collect()
    }

    fn lock(&self) -> MutexGuard<'_, HashMap<JobId, Arc<RunHandle>>> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn the_first_stop_reason_wins_and_deadlines_stop_for_wall_time() {
        let h = RunHandle::new(Instant::now() + Duration::from_secs(3600));
        assert_eq!(h.reason(), StopReason::None);
        h.stop(StopReason::Cancelled);
        h.stop(StopReason::Shutdown);
        assert_eq!(h.reason(), StopReason::Cancelled);
        assert!(h.cancel.load(Ordering::SeqCst));

        let running = Running::default();
        let late = Arc::new(RunHandle::new(Instant::now()));
        let early = Arc::new(RunHandle::new(Instant::now() + Duration::from_secs(3600)));
        running.insert(JobId::generate(), Arc::clone(&late));
        running.insert(JobId::generate(), Arc::clone(&early));
        running.stop_overdue(Instant::now());
        assert_eq!(late.reason(), StopReason::WallTime);
        assert_eq!(early.reason(), StopReason::None);
    }
}
