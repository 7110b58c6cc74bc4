//! The bounded job queue between the API and the worker threads.
//!
//! Workers are OS threads, not async tasks: a solver step is seconds of
//! CPU that must not sit on the async executor. They block on a condition
//! variable, waking every few hundred milliseconds to notice a shutdown.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

use crate::service::job::JobId;

/// FIFO of queued jobs. The capacity for new submissions is checked by
/// `Jobs::submit` under its submission lock.
#[derive(Debug, Default)]
pub struct Queue {
    items: Mutex<VecDeque<JobId>>,
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
    pub fn push(&self, job: JobId) {
        self.lock().push_back(job);
        self.ready.notify_one();
    }

    /// Removes a waiting job (cancelled); `true` if it was waiting.
    pub fn remove(&self, id: JobId) -> bool {
        let mut items = self.lock();
        let before = items.len();
        items.retain(|q| *q != id);
        items.len() != before
    }

    /// The oldest job, waiting for one; `None` once `stop` is set.
    pub fn pop(&self, stop: &AtomicBool) -> Option<JobId> {
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

    fn lock(&self) -> std::sync::MutexGuard<'_, VecDeque<JobId>> {
        self.items.lock().unwrap_or_else(|p| p.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pops_in_order_without_removed_jobs() {
        let q = Queue::new();
        let [one, two, four] = [JobId::generate(), JobId::generate(), JobId::generate()];
        q.push(one);
        q.push(two);
        q.push(four);
        assert!(q.remove(two));
        assert!(!q.remove(two));
        assert_eq!(q.len(), 2);
        let stop = AtomicBool::new(false);
        assert_eq!(q.pop(&stop), Some(one));
        assert_eq!(q.pop(&stop), Some(four));
        stop.store(true, Ordering::SeqCst);
        assert_eq!(q.pop(&stop), None, "a set stop flag ends the wait");
    }
}
