//! The bounded job queue between the API and the worker threads.
//!
//! Workers are OS threads, not async tasks: a solver step is seconds of
//! CPU that must not sit on the async executor. They block on a condition
//! variable, waking every few hundred milliseconds to notice a shutdown.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

/// A job waiting for a worker.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Queued {
    pub seq: i64,
    pub id: String,
}

/// FIFO of queued jobs. The capacity for new submissions is checked by
/// the API under its submission lock (`Shared::submit_lock`).
#[derive(Debug, Default)]
pub struct Queue {
    items: Mutex<VecDeque<Queued>>,
    ready: Condvar,
}

impl Queue {
    pub fn new() -> Self {
        Self {
            items: Mutex::new(VecDeque::new()),
            ready: Condvar::new(),
        }
    }

    /// Adds a job at the back.
    pub fn push(&self, job: Queued) {
        self.lock().push_back(job);
        self.ready.notify_one();
    }

    /// Removes a waiting job (cancelled); `true` if it was waiting.
    pub fn remove(&self, seq: i64) -> bool {
        let mut items = self.lock();
        let before = items.len();
        items.retain(|q| q.seq != seq);
        items.len() != before
    }

    /// The oldest job, waiting for one; `None` once `stop` is set.
    pub fn pop(&self, stop: &AtomicBool) -> Option<Queued> {
        let mut items = self.lock();
        loop {
            if stop.load(Ordering::SeqCst) {
                return None;
            }
            if let Some(job) = items.pop_front() {
                return Some(job);
            }
            items = self
                .ready
                .wait_timeout(items, Duration::from_millis(200))
                .unwrap_or_else(|p| p.into_inner())
                .0;
        }
    }

    /// Jobs waiting.
    pub fn len(&self) -> usize {
        self.lock().len()
    }

    /// Wakes every waiting worker (shutdown).
    pub fn wake_all(&self) {
        self.ready.notify_all();
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, VecDeque<Queued>> {
        self.items.lock().unwrap_or_else(|p| p.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(seq: i64) -> Queued {
        Queued {
            seq,
            id: seq.to_string(),
        }
    }

    #[test]
    fn pops_in_order_without_removed_jobs() {
        let q = Queue::new();
        q.push(job(1));
        q.push(job(2));
        q.push(job(4));
        assert!(q.remove(2));
        assert!(!q.remove(2));
        assert_eq!(q.len(), 2);
        let stop = AtomicBool::new(false);
        assert_eq!(q.pop(&stop), Some(job(1)));
        assert_eq!(q.pop(&stop), Some(job(4)));
        stop.store(true, Ordering::SeqCst);
        assert_eq!(q.pop(&stop), None, "a set stop flag ends the wait");
    }
}
