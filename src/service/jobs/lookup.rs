//! Reading jobs as a caller may see them: one job, a page of the list, a
//! stored frame, the whole animation. Another owner's job is "not found",
//! exactly like a missing one, so ids cannot be probed.

use std::sync::Arc;
use std::time::Duration;

use tokio::sync::OwnedSemaphorePermit;

use super::error::{Fault, JobsError, ListError};
use super::lifecycle::Jobs;
use crate::service::job::{JobId, Status};
use crate::service::keys::Owner;
use crate::service::results::{self, Format};
use crate::service::store::{JobRow, StoredFrame};

/// Longest wait for a download's turn before `429`.
const DOWNLOAD_WAIT: Duration = Duration::from_secs(10);

/// Which jobs a listing shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ListFilter {
    status: Option<Status>,
    limit: usize,
    /// `seq` of the last job of the previous page.
    before: Option<i64>,
}

impl ListFilter {
    /// The filter of a listing's parameters: a status name, a page size
    /// (1..=500, default 50), the previous page's `next_cursor`.
    pub fn parse(
        status: Option<&str>,
        limit: Option<usize>,
        cursor: Option<&str>,
    ) -> Result<Self, ListError> {
        let status = match status {
            None => None,
            Some(s) => Some(Status::parse(s).ok_or_else(|| ListError::Status(s.to_owned()))?),
        };
        let limit = limit.unwrap_or(50);
        if !(1..=500).contains(&limit) {
            return Err(ListError::Limit);
        }
        // A cursor is a `next_cursor`: 1 to 18 digits, nothing else.
        let before = match cursor {
            None => None,
            Some(c) if (1..=18).contains(&c.len()) && c.bytes().all(|b| b.is_ascii_digit()) => {
                Some(c.parse::<i64>().map_err(|_| ListError::Cursor)?)
            }
            Some(_) => return Err(ListError::Cursor),
        };
        Ok(Self {
            status,
            limit,
            before,
        })
    }
}

/// A page of jobs, newest first.
#[derive(Debug, Clone)]
pub struct Page {
    pub jobs: Vec<JobRow>,
    /// The cursor of the next page; `None` on the last.
    pub next_cursor: Option<String>,
}

impl Jobs {
    /// Job `id`, if `owner` may see it.
    pub async fn get(self: &Arc<Self>, owner: &Owner, id: &str) -> Result<JobRow, JobsError> {
        let (owner, id) = (owner.clone(), id.to_owned());
        self.blocking(move |jobs| jobs.visible(&owner, &id)).await
    }

    /// The jobs `owner` may see that pass `filter`, newest first.
    pub async fn list(
        self: &Arc<Self>,
        owner: &Owner,
        filter: ListFilter,
    ) -> Result<Page, JobsError> {
        let mine = owner.filter().map(str::to_owned);
        let mut rows = self
            .blocking(move |jobs| {
                Ok::<_, JobsError>(jobs.store.list(
                    mine.as_deref(),
                    filter.status,
                    filter.before,
                    filter.limit + 1,
                )?)
            })
            .await?;
        let more = rows.len() > filter.limit;
        rows.truncate(filter.limit);
        let next_cursor = more
            .then(|| rows.last().map(|r| r.seq.to_string()))
            .flatten();
        Ok(Page {
            jobs: rows,
            next_cursor,
        })
    }

    /// Stored frame `n` of job `id`.
    pub async fn frame(
        self: &Arc<Self>,
        owner: &Owner,
        id: &str,
        n: u64,
    ) -> Result<StoredFrame, JobsError> {
        let (owner, id) = (owner.clone(), id.to_owned());
        self.blocking(move |jobs| {
            let row = jobs.visible(&owner, &id)?;
            jobs.store
                .frame(row.id, n)?
                .ok_or(JobsError::FrameNotStored {
                    n,
                    done: row.frames_done,
                    total: row.frames_total,
                })
        })
        .await
    }

    /// The stored animation of an ended job in `format`, with the job and
    /// the download turn it holds (`--max-downloads`; released when the
    /// body is sent or dropped). A request waits [`DOWNLOAD_WAIT`] at most
    /// for its turn; the job is checked before it waits, so a wrong id or
    /// a running job is answered at once.
    pub async fn download(
        self: &Arc<Self>,
        owner: &Owner,
        id: &str,
        format: Format,
    ) -> Result<(JobRow, Vec<u8>, OwnedSemaphorePermit), JobsError> {
        let row = self.get(owner, id).await?;
        if !row.status.is_terminal() {
            return Err(JobsError::NotEnded(row.status));
        }
        if row.frames_done == 0 {
            return Err(JobsError::NoFrames);
        }
        let turn = Arc::clone(&self.downloads).acquire_owned();
        let Ok(Ok(turn)) = tokio::time::timeout(DOWNLOAD_WAIT, turn).await else {
            return Err(JobsError::DownloadsBusy {
                turns: self.config.max_downloads,
            });
        };
        let (owner, id) = (owner.clone(), id.to_owned());
        self.blocking(move |jobs| {
            // Read again: the job may have been deleted while this waited.
            let row = jobs.visible(&owner, &id)?;
            let bytes = results::build(&jobs.store, &row, format).map_err(Fault::from)?;
            Ok((row, bytes, turn))
        })
        .await
    }

    /// Job `id` if `owner` may see it.
    pub(super) fn visible(&self, owner: &Owner, id: &str) -> Result<JobRow, JobsError> {
        let id = JobId::parse(id).ok_or(JobsError::NotFound)?;
        match self.store.job(id)? {
            Some(r) if owner.may_see(&r.owner) => Ok(r),
            Some(_) | None => Err(JobsError::NotFound),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn list_filters_parse_with_the_parameter_at_fault() {
        let f = ListFilter::parse(Some("running"), Some(20), Some("17")).expect("valid");
        assert_eq!(
            f,
            ListFilter {
                status: Some(Status::Running),
                limit: 20,
                before: Some(17)
            }
        );
        assert_eq!(
            ListFilter::parse(None, None, None).expect("valid").limit,
            50
        );
        let e = ListFilter::parse(Some("done"), None, None).expect_err("unknown");
        assert_eq!(e.parameter(), "status");
        assert_eq!(
            e.to_string(),
            "unknown status \"done\"; expected queued, running, succeeded, failed or cancelled"
        );
        for limit in [0, 501] {
            let e = ListFilter::parse(None, Some(limit), None).expect_err("out of range");
            assert_eq!(e, ListError::Limit);
            assert_eq!(e.parameter(), "limit");
        }
        let e = ListFilter::parse(None, None, Some("x")).expect_err("not a cursor");
        assert_eq!(e.parameter(), "cursor");
    }
}
