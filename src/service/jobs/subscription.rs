//! A stream's view of one job: its hello, then every stored frame from
//! where the client asked, in order, then how the job ended.
//!
//! Backpressure: the solver never waits for a client. A subscription reads
//! frames from the store at its consumer's pace and only waits when it has
//! caught up: on the job's watch channel (`hub`) if the job runs on this
//! node, else by looking at the job in the store every [`FOLLOW_POLL`]
//! (it is queued, or runs on another node). A stalled client holds nothing
//! but its own socket, and no client misses a frame: frames are stored
//! before they are announced, and `frames_done` only grows.

use std::sync::Arc;
use std::time::Duration;

use tokio::sync::watch;

use super::error::{Fault, JobsError};
use super::hub::Live;
use super::lifecycle::Jobs;
use crate::service::job::{JobId, Status};
use crate::service::keys::Owner;
use crate::service::protocol::End;
use crate::service::store::StoredFrame;

/// How often a stream of a job that does not run here looks at it again.
pub const FOLLOW_POLL: Duration = Duration::from_millis(200);

/// What a subscription delivers next.
#[derive(Debug)]
pub enum Event {
    /// The next stored frame.
    Frame(StoredFrame),
    /// The job ended and every frame from the start was delivered.
    End(End),
    /// The server is shutting down before the job ended.
    Interrupted,
    /// The job was deleted (it had ended: cancelled twice, or by
    /// retention) before every frame was delivered.
    Deleted,
}

/// One client's reading of one job.
#[derive(Debug)]
pub struct Subscription {
    jobs: Arc<Jobs>,
    id: JobId,
    /// The next frame to deliver.
    next: u64,
    /// News of a job this node runs; `None`: follow it in the store.
    live: Option<watch::Receiver<Live>>,
    /// Frames stored and status as last seen; `None`: look again.
    known: Option<(u64, Status)>,
    finished: bool,
}

impl Jobs {
    /// Subscribes `owner` to job `id`, starting at frame `from`.
    pub async fn subscribe(
        self: &Arc<Self>,
        owner: &Owner,
        id: &str,
        from: u64,
    ) -> Result<Subscription, JobsError> {
        let row = self.get(owner, id).await?;
        let live = self.hub.subscribe(row.id);
        Ok(Subscription {
            jobs: Arc::clone(self),
            id: row.id,
            next: from,
            live,
            known: None,
            finished: false,
        })
    }
}

impl Subscription {
    pub fn id(&self) -> JobId {
        self.id
    }

    /// The job's hello message (stored once it started, else built).
    pub async fn hello(&self) -> Result<String, Fault> {
        let id = self.id;
        self.jobs.blocking(move |jobs| jobs.hello_of(id)).await
    }

    /// The next event; `None` after the end or the interruption.
    pub async fn next(&mut self) -> Result<Option<Event>, Fault> {
        if self.finished {
            return Ok(None);
        }
        loop {
            let (frames, status) = match self.known {
                Some(k) => k,
                None => {
                    let Some(k) = self.news().await? else {
                        self.finished = true;
                        return Ok(Some(Event::Deleted));
                    };
                    self.known = Some(k);
                    k
                }
            };
            if self.next < frames
                && let Some(f) = self.frame(self.next).await?
            {
                self.next += 1;
                return Ok(Some(Event::Frame(f)));
            }
            if status.is_terminal() && self.next >= frames {
                self.finished = true;
                return Ok(Some(Event::End(self.end(status, frames).await?)));
            }
            if !self.wait().await? {
                self.finished = true;
                return Ok(Some(Event::Interrupted));
            }
            self.known = None;
        }
    }

    /// What is stored now, and whether more can come; `None` if the job
    /// is gone.
    async fn news(&mut self) -> Result<Option<(u64, Status)>, Fault> {
        if let Some(rx) = &mut self.live {
            let l = *rx.borrow_and_update();
            return Ok(Some((l.frames, l.status)));
        }
        let id = self.id;
        let row = self
            .jobs
            .blocking(move |jobs| Ok::<_, Fault>(jobs.store.job(id)?))
            .await?;
        Ok(row.map(|r| (r.frames_done, r.status)))
    }

    /// Waits for news of a job that has not ended; `false` when the
    /// server is shutting down instead.
    async fn wait(&mut self) -> Result<bool, Fault> {
        let Some(rx) = &mut self.live else {
            if self.jobs.is_stopping() {
                return Ok(false);
            }
            // It may have started here since: then its channel tells.
            self.live = self.jobs.hub.subscribe(self.id);
            if self.live.is_none() {
                tokio::time::sleep(FOLLOW_POLL).await;
            }
            return Ok(true);
        };
        if rx.changed().await.is_ok() {
            return Ok(true);
        }
        // The channel closed: the job ended (its last value says so), it
        // stopped here without ending (shutdown, lost lease), or the whole
        // server is shutting down. From now on, the store tells.
        self.live = None;
        Ok(!self.jobs.is_stopping())
    }

    async fn frame(&self, n: u64) -> Result<Option<StoredFrame>, Fault> {
        let id = self.id;
        self.jobs
            .blocking(move |jobs| Ok::<_, Fault>(jobs.store.frame(id, n)?))
            .await
    }

    /// How the job ended, as recorded.
    async fn end(&self, status: Status, frames: u64) -> Result<End, Fault> {
        let id = self.id;
        let row = self
            .jobs
            .blocking(move |jobs| Ok::<_, Fault>(jobs.store.job(id)?))
            .await?;
        Ok(End {
            status,
            frames,
            error: row.as_ref().and_then(|r| r.failure()),
            stats: row.as_ref().and_then(|r| r.summary()),
        })
    }
}
