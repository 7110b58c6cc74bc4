//! A stream's view of one job: its hello, then every stored frame from
//! where the client asked, in order, then how the job ended.
//!
//! Backpressure: the solver never waits for a client. A subscription reads
//! frames from the store at its consumer's pace and only waits on the
//! job's watch channel (`hub`) when it has caught up, so a stalled client
//! holds nothing but its own socket, and no client misses a frame.

use std::sync::Arc;

use tokio::sync::watch;

use super::error::{Fault, JobsError};
use super::hub::Live;
use super::lifecycle::Jobs;
use crate::service::job::{JobId, Status};
use crate::service::keys::Owner;
use crate::service::protocol::End;
use crate::service::store::StoredFrame;

/// What a subscription delivers next.
#[derive(Debug)]
pub enum Event {
    /// The next stored frame.
    Frame(StoredFrame),
    /// The job ended and every frame from the start was delivered.
    End(End),
    /// The server is shutting down before the job ended.
    Interrupted,
}

/// One client's reading of one job.
#[derive(Debug)]
pub struct Subscription {
    jobs: Arc<Jobs>,
    id: JobId,
    /// The next frame to deliver.
    next: u64,
    /// News of a job this process runs or queues; `None` once it ended.
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
        // Subscribe before reading the job, so an end between the two is
        // seen: a job without a channel has ended (workers close it only
        // after recording the end).
        let live = JobId::parse(id).and_then(|id| self.hub.subscribe(id));
        let row = self.get(owner, id).await?;
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
                    let k = self.news().await?;
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
            if !self.wait(status).await? {
                self.finished = true;
                return Ok(Some(Event::Interrupted));
            }
            self.known = None;
        }
    }

    /// What is stored now, and whether more can come.
    async fn news(&mut self) -> Result<(u64, Status), Fault> {
        if let Some(rx) = &mut self.live {
            let l = *rx.borrow_and_update();
            return Ok((l.frames, l.status));
        }
        let id = self.id;
        let row = self
            .jobs
            .blocking(move |jobs| Ok::<_, Fault>(jobs.store.job(id)?))
            .await?
            .ok_or(Fault::Vanished(id))?;
        Ok((row.frames_done, row.status))
    }

    /// Waits for news of a job that has not ended (`status` as last
    /// seen); `false` when the server is shutting down instead.
    async fn wait(&mut self, status: Status) -> Result<bool, Fault> {
        let Some(rx) = &mut self.live else {
            return match status {
                // A job this process does not track cannot progress.
                Status::Queued | Status::Running => Err(Fault::Untracked {
                    id: self.id,
                    status,
                }),
                Status::Succeeded | Status::Failed | Status::Cancelled => Ok(true),
            };
        };
        if rx.changed().await.is_ok() {
            return Ok(true);
        }
        // The channel closed: the job ended (its last value says so) or the
        // server is shutting down.
        if !rx.borrow().status.is_terminal() {
            return Ok(false);
        }
        self.live = None;
        Ok(true)
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
