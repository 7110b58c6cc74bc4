//! Live job news for stream clients: per active job a `watch` channel
//! holding how many frames are stored and the job's status.
//!
//! A watch channel keeps only the latest value, so the solver never waits
//! for a client and a slow client never queues messages: each client reads
//! the frames themselves from the store, at its own pace, up to the count
//! it last saw. Only jobs running on this node have a channel (opened when
//! a worker here claims the job); a stream of any other job follows it in
//! the store (`subscription`). A channel is closed with the job's end only
//! after the end is recorded, so no end is ever missed.

use std::collections::HashMap;
use std::sync::Mutex;

use tokio::sync::watch;

use crate::service::job::{JobId, Status};

/// What a stream client needs to know to catch up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Live {
    /// Frames stored: `0..frames`.
    pub frames: u64,
    pub status: Status,
}

/// The channels of the jobs running on this node.
#[derive(Debug, Default)]
pub struct Hub {
    jobs: Mutex<HashMap<JobId, watch::Sender<Live>>>,
}

impl Hub {
    /// Starts tracking a job.
    pub fn open(&self, id: JobId, live: Live) {
        let (tx, _) = watch::channel(live);
        self.lock().insert(id, tx);
    }

    /// A receiver for a tracked job; `None` once it ended.
    pub fn subscribe(&self, id: JobId) -> Option<watch::Receiver<Live>> {
        self.lock().get(&id).map(watch::Sender::subscribe)
    }

    /// Changes a tracked job's news and wakes its clients.
    pub fn update(&self, id: JobId, f: impl FnOnce(&mut Live)) {
        if let Some(tx) = self.lock().get(&id) {
            tx.send_modify(f);
        }
    }

    /// Publishes the job's end and stops tracking it; receivers keep the
    /// last value.
    pub fn close(&self, id: JobId, status: Status) {
        if let Some(tx) = self.lock().remove(&id) {
            tx.send_modify(|l| l.status = status);
        }
    }

    /// Stops tracking a job that did not end here (shutdown, or its lease
    /// lost): its clients see the channel gone with the job unfinished and
    /// follow it in the store.
    pub fn drop_job(&self, id: JobId) {
        self.lock().remove(&id);
    }

    /// Drops every channel (shutdown): clients see their sender gone.
    pub fn close_all(&self) {
        self.lock().clear();
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<JobId, watch::Sender<Live>>> {
        self.jobs.lock().unwrap_or_else(|p| p.into_inner())
    }
}
