//! Idle workers' waiting room. The store is the queue (a worker claims
//! the oldest queued job there); an idle worker waits here between looks,
//! woken at once by a submission to this node and otherwise every
//! [`POLL`], which is how it hears of jobs submitted to other nodes and of
//! leases that lapsed.
//!
//! Workers are OS threads, not async tasks: a solver step is seconds of
//! CPU that must not sit on the async executor.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

/// The longest an idle worker waits before looking at the store again.
pub const POLL: Duration = Duration::from_millis(500);

/// A condition variable with a count of wake-ups, so a wake-up between a
/// worker's look at the store and its wait is not lost.
#[derive(Debug, Default)]
pub struct Wakeup {
    rings: Mutex<u64>,
    ready: Condvar,
}

impl Wakeup {
    /// The wake-ups so far: pass to [`Wakeup::wait`] after looking.
    pub fn seen(&self) -> u64 {
        *self.lock()
    }

    /// Wakes one waiting worker (a job was submitted here).
    pub fn ring(&self) {
        *self.lock() += 1;
        self.ready.notify_one();
    }

    /// Wakes every waiting worker (shutdown).
    pub fn ring_all(&self) {
        *self.lock() += 1;
        self.ready.notify_all();
    }

    /// Waits up to `timeout` for a wake-up after `seen`, or for `stop`.
    pub fn wait(&self, seen: u64, stop: &AtomicBool, timeout: Duration) {
        let rings = self.lock();
        if *rings != seen || stop.load(Ordering::SeqCst) {
            return;
        }
        let _ = self
            .ready
            .wait_timeout(rings, timeout)
            .unwrap_or_else(|p| p.into_inner());
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, u64> {
        self.rings.lock().unwrap_or_else(|p| p.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Instant;

    #[test]
    fn a_ring_before_the_wait_is_not_lost_and_the_wait_is_bounded() {
        let w = Wakeup::default();
        let stop = AtomicBool::new(false);
        let seen = w.seen();
        w.ring();
        let start = Instant::now();
        w.wait(seen, &stop, Duration::from_secs(10));
        assert!(start.elapsed() < Duration::from_secs(1), "rung already");
        let start = Instant::now();
        w.wait(w.seen(), &stop, Duration::from_millis(50));
        assert!(start.elapsed() >= Duration::from_millis(40), "waited");
        stop.store(true, Ordering::SeqCst);
        let start = Instant::now();
        w.wait(w.seen(), &stop, Duration::from_secs(10));
        assert!(start.elapsed() < Duration::from_secs(1), "stopping");
    }
}
