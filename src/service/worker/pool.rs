//! Worker threads: each claims the next job from the store, runs one
//! attempt at it, and goes on to the next until the service shuts down.
//!
//! A job resumes from its stored checkpoint when it has one (after a
//! restart or a shutdown), so frames already stored are not redone except
//! those after the checkpoint, which come out identical (the checkpoint
//! holds everything the steps read) and replace their copies. A panic in a
//! job fails that job only; the worker goes on to the next. A store that
//! cannot be reached fails no job: the worker lets it go, its lease
//! lapses, and a node (this one, maybe) resumes it once the store is back.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Instant;

use tracing::{error, info_span};

use super::run::{RunError, is_lost, simulate};
use crate::service::error_code::ErrorCode;
use crate::service::job::{JobError, JobId};
use crate::service::jobs::{Attempt, Jobs, Outcome};
use crate::service::store::StoreError;

/// Starts `n` workers; they end once the service shuts down (join them).
pub fn spawn(jobs: &Arc<Jobs>, n: usize) -> std::io::Result<Vec<JoinHandle<()>>> {
    (0..n)
        .map(|k| {
            let jobs = Arc::clone(jobs);
            std::thread::Builder::new()
                .name(format!("worker-{k}"))
                .spawn(move || work(&jobs, k))
        })
        .collect()
}

fn work(jobs: &Jobs, k: usize) {
    while let Some(a) = jobs.next_attempt() {
        let id = a.row.id;
        let span = info_span!("job", %id, worker = k);
        let _entered = span.enter();
        guarded(jobs, id, || attempt(jobs, &a));
    }
}

/// Runs one attempt; a panic, or an error that kept its end from being
/// recorded, fails that job alone and leaves the worker running.
fn guarded(jobs: &Jobs, id: JobId, f: impl FnOnce() -> Result<(), StoreError>) {
    let failure = match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => return,
        Ok(Err(e)) if is_lost(&e) => {
            tracing::warn!(error = %e, "the job's end could not be recorded; its lease will lapse");
            jobs.release(id);
            return;
        }
        Ok(Err(e)) => format!("the job's end could not be recorded: {e}"),
        Err(panic) => {
            let message = panic
                .downcast_ref::<&str>()
                .map(|s| (*s).to_owned())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            format!("the solver panicked: {message}")
        }
    };
    error!(%failure, "job failed");
    jobs.fail(id, &failure);
}

/// Runs a claimed job, records the outcome.
fn attempt(jobs: &Jobs, attempt: &Attempt) -> Result<(), StoreError> {
    let started = Instant::now();
    let outcome = match simulate(jobs, attempt) {
        Ok(outcome) => outcome,
        Err(RunError::Store(e)) if is_lost(&e) => Outcome::Lost,
        Err(e) => Outcome::Failed(
            JobError {
                code: ErrorCode::Internal,
                message: e.to_string(),
            },
            None,
        ),
    };
    let run_seconds = attempt.row.run_seconds + started.elapsed().as_secs_f64();
    jobs.conclude(attempt, outcome, run_seconds)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::job::Status;
    use crate::service::keys::Owner;

    fn jobs() -> Arc<Jobs> {
        crate::service::jobs::jobs_for_tests("worker")
    }

    const SPEC: &str = r#"{"cloth": {"grid": [3, 3], "size": [1, 1]}, "material": "cotton", "duration": 0.1, "fps": 10}"#;

    /// A job that panics is failed with the panic's message, its stream
    /// hears `failed`, and the worker (this thread) carries on.
    #[tokio::test]
    async fn a_panicking_job_fails_alone() {
        let jobs = jobs();
        let owner = Owner(None);
        let row = jobs
            .submit(&owner, SPEC.as_bytes())
            .await
            .expect("submitted");
        let claimed = jobs.claim().expect("claims").expect("a queued job");
        assert_eq!(claimed.row.id, row.id);
        let mut sub = jobs
            .subscribe(&owner, &row.id.to_string(), 0)
            .await
            .expect("subscribed");
        guarded(&jobs, row.id, || panic!("index out of bounds"));
        let row = jobs.get(&owner, &row.id.to_string()).await.expect("exists");
        assert_eq!(row.status, Status::Failed);
        let error = row.failure().expect("an error");
        assert_eq!(error.code, ErrorCode::Internal);
        assert!(
            error.message.contains("panicked: index out of bounds"),
            "{error:?}"
        );
        let mut end = None;
        while let Some(event) = sub.next().await.expect("an event") {
            if let crate::service::jobs::Event::End(e) = event {
                end = Some(e);
            }
        }
        assert_eq!(end.map(|e| e.status), Some(Status::Failed));
        guarded(&jobs, row.id, || Ok(()));
    }

    /// A queued job runs to the end on this thread: every frame stored, in
    /// order, and `succeeded` with its statistics.
    #[tokio::test]
    async fn a_queued_job_runs_to_success() {
        let jobs = jobs();
        let owner = Owner(None);
        let row = jobs
            .submit(&owner, SPEC.as_bytes())
            .await
            .expect("submitted");
        let worker = {
            let jobs = Arc::clone(&jobs);
            tokio::task::spawn_blocking(move || {
                let a = jobs.claim()?.expect("a queued job");
                assert_eq!(a.row.id, row.id);
                attempt(&jobs, &a)
            })
        };
        worker.await.expect("joined").expect("recorded");
        let row = jobs.get(&owner, &row.id.to_string()).await.expect("exists");
        assert_eq!(row.status, Status::Succeeded);
        assert_eq!(row.frames_done, 2);
        assert_eq!(row.attempts, 1);
        assert!(row.summary().is_some_and(|s| s["frames"] == 2));
    }
}
