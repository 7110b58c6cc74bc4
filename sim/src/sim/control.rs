//! How a caller watches and stops a run without the core knowing who it is
//! (a terminal progress bar, a service worker, a test).

use std::sync::atomic::{AtomicBool, Ordering};

/// Progress after each frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    /// Frames finished (frame 0 counts as done at start).
    pub frame: usize,
    /// Frames in the run.
    pub frames: usize,
    /// Steps taken so far.
    pub steps: usize,
    /// Simulated time reached.
    pub time: f64,
}

/// A cancel flag checked before every step, and a progress callback.
#[derive(Default, Clone, Copy)]
pub struct Control<'a> {
    /// Set to stop the run at the next step boundary.
    pub cancel: Option<&'a AtomicBool>,
    /// Called after every frame.
    pub progress: Option<&'a (dyn Fn(Progress) + Sync)>,
}

impl std::fmt::Debug for Control<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Control")
            .field("cancelled", &self.is_cancelled())
            .field("progress", &self.progress.is_some())
            .finish()
    }
}

impl Control<'_> {
    /// `true` once the cancel flag is set.
    pub fn is_cancelled(&self) -> bool {
        self.cancel.is_some_and(|c| c.load(Ordering::Relaxed))
    }
}
