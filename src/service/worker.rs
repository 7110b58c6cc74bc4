//! The worker pool: OS threads that take queued jobs, run the solver, and
//! store every frame as it is produced.
//!
//! A job resumes from its stored checkpoint when it has one (after a
//! restart or a shutdown), so frames already stored are not redone except
//! those after the checkpoint, which come out identical (the checkpoint
//! holds everything the steps read) and replace their copies. A panic in a
//! job fails that job only; the worker goes on to the next.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use drapery_sim::math::Vec3;
use drapery_sim::sim::{Checkpoint, Control, FrameStats, SimError, Simulation};
use serde_json::json;
use tracing::{error, info, info_span, warn};

use super::job::{JobError, Status, now};
use super::queue::Queued;
use super::state::{RunHandle, Shared, StopReason};
use super::store::{Ending, JobRow, StoredFrame};

/// Starts `n` workers.
pub fn spawn(shared: &Arc<Shared>, n: usize) -> Vec<std::thread::JoinHandle<()>> {
    (0..n)
        .map(|k| {
            let shared = Arc::clone(shared);
            std::thread::Builder::new()
                .name(format!("worker-{k}"))
                .spawn(move || work(&shared, k))
                .unwrap_or_else(|e| panic!("cannot start worker thread: {e}"))
        })
        .collect()
}

fn work(shared: &Shared, k: usize) {
    while let Some(job) = shared.queue.pop(&shared.stopping) {
        let span = info_span!("job", id = %job.id, worker = k);
        let _entered = span.enter();
        guarded(shared, &job, || run(shared, &job));
    }
}

/// Runs one job; a panic, or an error that kept its end from being
/// recorded, fails that job alone and leaves the worker running.
fn guarded(shared: &Shared, job: &Queued, f: impl FnOnce() -> anyhow::Result<()>) {
    let failure = match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => return,
        Ok(Err(e)) => format!("the job's end could not be recorded: {e:#}"),
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
    shared.running().remove(&job.id);
    let error = error_json("internal", &failure);
    let ending = Ending {
        status: Status::Failed,
        error: Some(&error),
        stats: None,
        finished_at: now(),
        run_seconds: 0.0,
    };
    if let Err(e) = shared.store.finish(job.seq, &ending) {
        error!(error = %e, "could not record the failure either");
    }
    shared.hub.close(&job.id, Status::Failed);
}

/// How one attempt at a job ended.
enum Outcome {
    Succeeded(String),
    Failed(JobError, Option<String>),
    Cancelled(Option<String>),
    /// Shutdown: back to the queue, to resume from the checkpoint.
    Interrupted,
}

fn run(shared: &Shared, job: &Queued) -> anyhow::Result<()> {
    let Some(row) = shared.store.job(&job.id)? else {
        return Ok(());
    };
    if row.status != Status::Queued {
        // Cancelled while it waited.
        return Ok(());
    }
    let left = (shared.config.max_wall_seconds - row.run_seconds).max(0.0);
    let handle = Arc::new(RunHandle::new(
        Instant::now() + Duration::from_secs_f64(left.min(1e9)),
    ));
    // The handle is in place before the job is marked running, so a
    // cancel that finds it running also finds its stop flag; a cancel that
    // won the race leaves it not queued, and it does not start.
    shared.running().insert(row.id.clone(), Arc::clone(&handle));
    if !shared.store.mark_running(row.seq, now())? {
        shared.running().remove(&row.id);
        return Ok(());
    }
    shared.hub.update(&row.id, |l| l.status = Status::Running);
    info!(attempt = row.attempts + 1, "job started");

    let started = Instant::now();
    let outcome = simulate(shared, &row, &handle);
    shared.running().remove(&row.id);
    let run_seconds = row.run_seconds + started.elapsed().as_secs_f64();
    let (status, error, stats) = match outcome {
        Ok(Outcome::Interrupted) => {
            shared.store.requeue(row.seq, run_seconds)?;
            shared.hub.update(&row.id, |l| l.status = Status::Queued);
            info!("job interrupted by shutdown; it resumes at the next start");
            return Ok(());
        }
        Ok(Outcome::Succeeded(stats)) => (Status::Succeeded, None, Some(stats)),
        Ok(Outcome::Cancelled(stats)) => (Status::Cancelled, None, stats),
        Ok(Outcome::Failed(e, stats)) => (Status::Failed, Some(e), stats),
        Err(e) => (
            Status::Failed,
            Some(JobError {
                code: "internal".into(),
                message: format!("{e:#}"),
            }),
            None,
        ),
    };
    let error = error.map(|e| error_json(&e.code, &e.message));
    shared.store.finish(
        row.seq,
        &Ending {
            status,
            error: error.as_deref(),
            stats: stats.as_deref(),
            finished_at: now(),
            run_seconds,
        },
    )?;
    shared.hub.close(&row.id, status);
    info!(status = status.as_str(), run_seconds, "job ended");
    Ok(())
}

fn simulate(shared: &Shared, row: &JobRow, handle: &RunHandle) -> anyhow::Result<Outcome> {
    let scene = row.scene()?;
    let mut sim = Simulation::new(&scene)?;
    let mut rec = sim.recorder();
    if let Some((frame, data)) = shared.store.checkpoint(row.seq)?
        && frame > 0
    {
        let checkpoint: Checkpoint = serde_json::from_slice(&data)?;
        sim.resume(checkpoint)?;
        for s in shared.store.frame_stats(row.seq, frame)? {
            rec.record(serde_json::from_str(&s)?, &Default::default());
        }
        info!(frame, "resumed from checkpoint");
    }

    let control = Control {
        cancel: Some(&handle.cancel),
        progress: None,
    };
    let interval = Duration::from_secs_f64(shared.config.checkpoint_seconds.max(0.0));
    let mut last_checkpoint = Instant::now();
    let started = Instant::now();
    let result = sim.run(&control, &mut rec, |s, stats| {
        let stopping = shared.is_stopping();
        let checkpoint = (stopping || last_checkpoint.elapsed() >= interval)
            .then(|| serde_json::to_vec(&s.checkpoint()))
            .transpose()
            .map_err(|e| e.to_string())?;
        if checkpoint.is_some() {
            last_checkpoint = Instant::now();
        }
        let frame = StoredFrame {
            n: stats.frame as u64,
            time: stats.time,
            positions: encode_positions(&s.state().x),
            stats: frame_stats_json(s, stats),
        };
        shared
            .store
            .put_frame(row.seq, &frame, checkpoint.as_deref())
            .map_err(|e| e.to_string())?;
        shared.metrics.frames.inc();
        if stats.steps > 0 {
            shared
                .metrics
                .step_seconds
                .observe(stats.step_seconds / stats.steps as f64);
        }
        shared
            .hub
            .update(&row.id, |l| l.frames = l.frames.max(frame.n + 1));
        if stopping {
            return Err("interrupted by shutdown".to_owned());
        }
        Ok(())
    });
    let summary = |rec: &drapery_sim::sim::StatsRecorder| {
        let mut v =
            serde_json::to_value(rec.finish(row.run_seconds + started.elapsed().as_secs_f64()))
                .unwrap_or_default();
        if let Some(o) = v.as_object_mut() {
            o.remove("per_frame");
        }
        v.to_string()
    };
    Ok(match result {
        Ok(()) => Outcome::Succeeded(summary(&rec)),
        Err(SimError::Cancelled { .. }) => match handle.reason() {
            StopReason::WallTime => Outcome::Failed(
                JobError {
                    code: "limit_exceeded".into(),
                    message: format!(
                        "wall time limit of {} s reached (--max-wall-seconds)",
                        shared.config.max_wall_seconds
                    ),
                },
                Some(summary(&rec)),
            ),
            StopReason::Shutdown => Outcome::Interrupted,
            _ => Outcome::Cancelled(Some(summary(&rec))),
        },
        Err(SimError::Output(_)) if shared.is_stopping() => Outcome::Interrupted,
        Err(e @ SimError::NonFinite { .. }) => Outcome::Failed(
            JobError {
                code: "non_finite".into(),
                message: e.to_string(),
            },
            Some(summary(&rec)),
        ),
        Err(e) => {
            warn!(error = %e, "job failed");
            Outcome::Failed(
                JobError {
                    code: "internal".into(),
                    message: e.to_string(),
                },
                Some(summary(&rec)),
            )
        }
    })
}

/// f32 xyz per particle, little-endian: the stream's binary frame body.
pub fn encode_positions(x: &[Vec3]) -> Vec<u8> {
    let mut out = Vec::with_capacity(x.len() * 12);
    for p in x {
        for c in p.iter() {
            out.extend_from_slice(&(*c as f32).to_le_bytes());
        }
    }
    out
}

/// A frame's statistics as stored and streamed: [`FrameStats`] plus each
/// obstacle's pose at the frame (translation, rotation `[x, y, z, w]`) so
/// a viewer can move the hello's obstacle meshes, and the particles in
/// contact (`contact_particles`) so it can highlight them.
fn frame_stats_json(sim: &Simulation, stats: &FrameStats) -> String {
    let mut v = serde_json::to_value(stats).unwrap_or_default();
    if !sim.obstacles().is_empty() {
        let poses: Vec<_> = sim
            .obstacles()
            .iter()
            .map(|c| {
                let p = c.trajectory.pose(stats.time);
                let q = p.rotation.coords;
                json!({
                    "translation": [p.translation.x, p.translation.y, p.translation.z],
                    "rotation": [q.x, q.y, q.z, q.w],
                })
            })
            .collect();
        v["obstacles"] = json!(poses);
        let touching: Vec<u32> = sim.contacts().iter().map(|c| c.particle).collect();
        v["contact_particles"] = json!(touching);
    }
    v.to_string()
}

fn error_json(code: &str, message: &str) -> String {
    json!({ "code": code, "message": message }).to_string()
}

/// Sets the stop flag of jobs past their wall-time limit; called
/// periodically by the server.
pub fn enforce_deadlines(shared: &Shared) {
    let now = Instant::now();
    for h in shared.running().values() {
        if now >= h.deadline && !h.cancel.load(Ordering::SeqCst) {
            h.stop(StopReason::WallTime);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::auth::Keys;
    use crate::service::hub::Live;
    use crate::service::state::Config;
    use crate::service::store::{NewJob, Store};
    use drapery_sim::spec::Limits;

    fn shared() -> Shared {
        let dir = std::env::temp_dir().join(format!("drapery-worker-{}", uuid::Uuid::now_v7()));
        let config = Config {
            workers: 1,
            queue_capacity: 4,
            limits: Limits::default(),
            max_wall_seconds: 60.0,
            max_body_bytes: 1 << 20,
            keys: Keys::default(),
            cors_origins: Vec::new(),
            checkpoint_seconds: 1.0,
            shutdown_grace: 1.0,
        };
        Shared::new(config, Store::open(&dir).expect("store"))
    }

    /// A job that panics is failed with the panic's message, its stream
    /// hears `failed`, and the worker (this thread) carries on.
    #[test]
    fn a_panicking_job_fails_alone() {
        let s = shared();
        let seq = s
            .store
            .insert_job(&NewJob {
                id: "j",
                owner: "",
                name: "t",
                spec: "{}",
                hello: "{}",
                frames_total: 2,
                created_at: now(),
            })
            .expect("insert");
        s.hub.open(
            "j",
            Live {
                frames: 0,
                status: Status::Running,
            },
        );
        let rx = s.hub.subscribe("j").expect("tracked");
        let job = Queued {
            seq,
            id: "j".into(),
        };
        guarded(&s, &job, || panic!("index out of bounds"));
        let row = s.store.job("j").expect("read").expect("exists");
        assert_eq!(row.status, Status::Failed);
        let error = row.error.expect("an error");
        assert!(error.contains("panicked: index out of bounds"), "{error}");
        assert_eq!(rx.borrow().status, Status::Failed);
        guarded(&s, &job, || Ok(()));
    }
}
