//! A team of threads that waits for the next loop by spinning, so that a
//! loop of a few microseconds can be shared between cores.
//!
//! Why not rayon's pool: its idle workers fall asleep some 20 µs after
//! their last job, and waking one on the 2-core benchmark VM costs about
//! 10 µs (an interrupt to a halted virtual CPU). The solver's loops come
//! every 20–100 µs, with serial work between them (a line sweep, a
//! contact test), so nearly every loop paid the wake-up: measured on two
//! loops of 5.7 µs each after 28 µs of serial work, rayon took 42.3 µs
//! against 39.4 µs serially, this team 34.0 µs (the ideal is 33.7 µs).
//!
//! How: the caller publishes a job (a task `Fn(index)` and a count) and
//! takes indices itself from the front; helpers claim indices from the
//! back, each with a compare-and-swap on one word `end << 32 | next`, run
//! them, and count them done; the caller returns once every index is
//! done. A helper spins for [`SPIN`], then yields its core for up to
//! [`IDLE`] (so that another job's thread, in the service, gets the core
//! it needs), then parks until the next job.
//!
//! Which thread runs an index never changes what the index computes:
//! determinism is the callers' business (fixed chunks, sums in order).

use std::cell::Cell;
use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::sync::atomic::AtomicBool;
use std::sync::atomic::AtomicPtr;
use std::sync::atomic::AtomicU64;
use std::sync::atomic::AtomicUsize;
use std::sync::atomic::Ordering::{AcqRel, Acquire, Relaxed, Release, SeqCst};
use std::sync::{Arc, Mutex, TryLockError};
use std::thread::{JoinHandle, Thread};
use std::time::{Duration, Instant};

/// How long an idle helper spins before it starts yielding its core.
pub const SPIN: Duration = Duration::from_micros(10);
/// How long an idle helper waits (spinning, then yielding) before it
/// parks: longer than the serial gaps inside a step, shorter than the
/// pause between frames of a slow client.
pub const IDLE: Duration = Duration::from_millis(3);

type Task<'a> = dyn Fn(usize) + Sync + 'a;

/// The published job: the task, its lifetime erased (see [`Team::run`]).
struct Job {
    task: *const Task<'static>,
}

struct Shared {
    /// `end << 32 | next`: indices `next..end` of the current job are
    /// unclaimed (the caller claims `next`, helpers `end - 1`).
    state: AtomicU64,
    job: AtomicPtr<Job>,
    done: AtomicUsize,
    panic: Mutex<Option<Box<dyn std::any::Any + Send>>>,
    quit: AtomicBool,
    /// Per helper: parked, or about to park.
    sleeping: Vec<AtomicBool>,
}

/// A caller and `threads - 1` helpers.
pub struct Team {
    shared: Arc<Shared>,
    /// Held by the thread whose job the team runs: a second caller (another
    /// job of the service) runs its loop alone instead of waiting.
    busy: Mutex<()>,
    threads: Vec<Thread>,
    handles: Vec<JoinHandle<()>>,
}

impl std::fmt::Debug for Team {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Team")
            .field("threads", &self.threads())
            .finish()
    }
}

thread_local! {
    /// Whether this thread is running an index of a job: a loop inside a
    /// task runs on its thread alone.
    static INSIDE: Cell<bool> = const { Cell::new(false) };
    /// Whether this thread's loops run alone, helpers or not
    /// (`super::Tuner`).
    static ALONE: Cell<bool> = const { Cell::new(false) };
}

/// Makes this thread's loops run alone (`true`) or shared again.
pub fn set_alone(alone: bool) {
    ALONE.set(alone);
}

/// Whether this thread's loops run alone ([`set_alone`]).
#[cfg(test)]
pub fn alone() -> bool {
    ALONE.get()
}

impl Team {
    /// A team of `threads` threads (the caller counts as one). If the
    /// operating system refuses a thread (a container's thread limit),
    /// the team keeps the helpers it has and says so in a warning: fewer
    /// threads change no result, only the speed.
    pub fn new(threads: usize) -> Self {
        Self::spawned_by(threads, |name, body| {
            std::thread::Builder::new().name(name).spawn(body)
        })
    }

    /// [`Team::new`] with helpers started by `spawn` (tests refuse some).
    fn spawned_by(
        threads: usize,
        mut spawn: impl FnMut(String, Box<dyn FnOnce() + Send>) -> std::io::Result<JoinHandle<()>>,
    ) -> Self {
        let helpers = threads.max(1) - 1;
        let shared = Arc::new(Shared {
            state: AtomicU64::new(0),
            job: AtomicPtr::new(std::ptr::null_mut()),
            done: AtomicUsize::new(0),
            panic: Mutex::new(None),
            quit: AtomicBool::new(false),
            sleeping: (0..helpers).map(|_| AtomicBool::new(false)).collect(),
        });
        let mut handles: Vec<JoinHandle<()>> = Vec::with_capacity(helpers);
        for k in 0..helpers {
            let helper_shared = Arc::clone(&shared);
            match spawn(
                format!("solver-{}", k + 1),
                Box::new(move || helper(&helper_shared, k)),
            ) {
                Ok(handle) => handles.push(handle),
                Err(e) => {
                    // Helpers are numbered in order, so the ones started
                    // are `0..k`; a refused one's `sleeping` flag is never
                    // set, so no job wakes it.
                    tracing::warn!(
                        wanted = threads,
                        running = k + 1,
                        "the operating system refused a solver thread ({e}); running on fewer"
                    );
                    break;
                }
            }
        }
        let threads = handles.iter().map(|h| h.thread().clone()).collect();
        Self {
            shared,
            busy: Mutex::new(()),
            threads,
            handles,
        }
    }

    /// Threads, the caller's included.
    pub fn threads(&self) -> usize {
        self.threads.len() + 1
    }

    /// Whether a loop started here now would be shared: the team has
    /// helpers, this thread is not already inside a task, and its loops
    /// are not set to run alone.
    pub fn can_share(&self) -> bool {
        !self.threads.is_empty() && !INSIDE.get() && !ALONE.get()
    }

    /// Runs `task(i)` for every `i` in `0..count`, on the caller and the
    /// helpers, and returns when all are done; a task's panic is raised
    /// here after every index has finished. Alone (no helpers, inside a
    /// task, or the team busy with another caller's job) the indices run
    /// in order on the caller.
    pub fn run(&self, count: usize, task: &(dyn Fn(usize) + Sync)) {
        let guard = if count > 1 && self.can_share() {
            match self.busy.try_lock() {
                Ok(g) => Some(g),
                Err(TryLockError::Poisoned(p)) => Some(p.into_inner()),
                Err(TryLockError::WouldBlock) => None,
            }
        } else {
            None
        };
        let Some(_guard) = guard else {
            (0..count).for_each(task);
            return;
        };
        assert!(count < 1 << 32, "a job of {count} indices");
        let s = &*self.shared;
        // SAFETY: only the lifetime is erased. The task is dereferenced by
        // a helper only after it claimed an index of this job, and this
        // function returns (it cannot unwind: every task runs under
        // `catch_unwind`) only once every claimed index is done, so the
        // task and `job` outlive every use.
        #[allow(unsafe_code)]
        let task: *const Task<'static> =
            unsafe { std::mem::transmute::<*const Task<'_>, *const Task<'static>>(task) };
        let mut job = Job { task };
        s.job.store(&mut job, Relaxed);
        s.done.store(0, Relaxed);
        s.state.store((count as u64) << 32, SeqCst);
        for (k, sleeping) in s.sleeping.iter().enumerate() {
            if sleeping.swap(false, SeqCst) {
                self.threads[k].unpark();
            }
        }
        INSIDE.set(true);
        while let Some(i) = claim(s, true) {
            run_one(s, &job, i);
        }
        let mut waited = 0u32;
        while s.done.load(Acquire) < count {
            // A helper is finishing its index (or was preempted in it).
            waited = waited.saturating_add(1);
            if waited < 1 << 10 {
                std::hint::spin_loop();
            } else {
                std::thread::yield_now();
            }
        }
        INSIDE.set(false);
        let panic = s.panic.lock().unwrap_or_else(|p| p.into_inner()).take();
        if let Some(p) = panic {
            resume_unwind(p);
        }
    }
}

impl Drop for Team {
    fn drop(&mut self) {
        self.shared.quit.store(true, SeqCst);
        for t in &self.threads {
            t.unpark();
        }
        for h in self.handles.drain(..) {
            // A helper's panics are caught per task; a join error is
            // nothing left to report.
            let _ = h.join();
        }
    }
}

/// Claims an unclaimed index of the current job: the caller the lowest
/// (`front`), helpers the highest. A loop's pieces are its rows in
/// order, so the caller keeps taking the first ones and a helper the
/// last ones, loop after loop: each core works on the particles whose
/// cache lines it already holds, and only the pieces where they meet
/// change hands.
fn claim(s: &Shared, front: bool) -> Option<usize> {
    claim_from(&s.state, front)
}

/// [`claim`] on any word `end << 32 | next` of unclaimed indices
/// (`super::flow` keeps one per stage).
pub(super) fn claim_from(state: &AtomicU64, front: bool) -> Option<usize> {
    let mut cur = state.load(Acquire);
    loop {
        let (end, next) = (cur >> 32, cur & 0xffff_ffff);
        if next >= end {
            return None;
        }
        let (new, index) = if front {
            (cur + 1, next)
        } else {
            (cur - (1 << 32), end - 1)
        };
        match state.compare_exchange_weak(cur, new, AcqRel, Acquire) {
            Ok(_) => return Some(index as usize),
            Err(c) => cur = c,
        }
    }
}

/// Runs index `i` of `job` and counts it done, a panic kept for the caller.
fn run_one(s: &Shared, job: &Job, i: usize) {
    // SAFETY: see `Team::run`: `i` is claimed and not yet counted done, so
    // the caller is still inside `run` and the task alive.
    #[allow(unsafe_code)]
    let task = unsafe { &*job.task };
    if let Err(p) = catch_unwind(AssertUnwindSafe(|| task(i))) {
        *s.panic.lock().unwrap_or_else(|p| p.into_inner()) = Some(p);
    }
    s.done.fetch_add(1, Release);
}

/// A helper's life: claim and run indices; idle, spin, yield, then park.
fn helper(s: &Shared, k: usize) {
    INSIDE.set(true);
    crate::subnormals::set_for_thread();
    loop {
        let mut since = Instant::now();
        let mut polls = 0u32;
        loop {
            if let Some(i) = claim(s, false) {
                // SAFETY: the claim synchronised with the job's publication,
                // and the job lives until `i` is done (`Team::run`).
                #[allow(unsafe_code)]
                let job = unsafe { &*s.job.load(Acquire) };
                run_one(s, job, i);
                since = Instant::now();
                polls = 0;
                continue;
            }
            if s.quit.load(Relaxed) {
                return;
            }
            polls = polls.wrapping_add(1);
            if !polls.is_multiple_of(64) {
                std::hint::spin_loop();
                continue;
            }
            let idle = since.elapsed();
            if idle > IDLE {
                break;
            }
            if idle > SPIN {
                std::thread::yield_now();
            }
        }
        // Park, unless a job came in the meantime (the caller swaps the
        // flag after publishing, so one of the two sees the other).
        s.sleeping[k].store(true, SeqCst);
        let cur = s.state.load(SeqCst);
        if (cur & 0xffff_ffff) < (cur >> 32) || s.quit.load(SeqCst) {
            s.sleeping[k].store(false, SeqCst);
            continue;
        }
        std::thread::park();
        s.sleeping[k].store(false, SeqCst);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicUsize;

    #[test]
    fn every_index_runs_once_on_any_team() {
        for threads in [1, 2, 3] {
            let team = Team::new(threads);
            assert_eq!(team.threads(), threads);
            for count in [0, 1, 2, 7, 100] {
                for _ in 0..50 {
                    let hits: Vec<AtomicUsize> = (0..count).map(|_| AtomicUsize::new(0)).collect();
                    team.run(count, &|i| {
                        hits[i].fetch_add(1, Relaxed);
                    });
                    assert!(hits.iter().all(|h| h.load(Relaxed) == 1));
                }
            }
        }
    }

    /// The caller's claims run up from the front, a helper's down from
    /// the back, and they meet without an index claimed twice.
    #[test]
    fn claims_meet_from_both_ends() {
        let team = Team::new(1);
        let s = &*team.shared;
        s.state.store(5 << 32, SeqCst);
        let order = [true, false, true, false, false, true];
        let got: Vec<Option<usize>> = order.iter().map(|&front| claim(s, front)).collect();
        assert_eq!(got, [Some(0), Some(4), Some(1), Some(3), Some(2), None]);
    }

    #[test]
    fn a_loop_inside_a_task_runs_alone_and_whole() {
        let team = Team::new(2);
        let total = AtomicUsize::new(0);
        team.run(4, &|_| {
            team.run(10, &|j| {
                total.fetch_add(j, Relaxed);
            });
        });
        assert_eq!(total.load(Relaxed), 4 * 45);
    }

    #[test]
    fn a_task_panic_reaches_the_caller_after_the_others_finish() {
        let team = Team::new(2);
        let finished = AtomicUsize::new(0);
        let caught = catch_unwind(AssertUnwindSafe(|| {
            team.run(8, &|i| {
                if i == 3 {
                    panic!("index three");
                }
                finished.fetch_add(1, Relaxed);
            });
        }));
        assert!(caught.is_err());
        assert_eq!(finished.load(Relaxed), 7);
        // The team still works.
        let hits = AtomicUsize::new(0);
        team.run(5, &|_| {
            hits.fetch_add(1, Relaxed);
        });
        assert_eq!(hits.load(Relaxed), 5);
    }

    /// A refused thread leaves a smaller team that still runs every
    /// index once, instead of a panic at start-up.
    #[test]
    fn a_refused_thread_leaves_a_smaller_team() {
        let mut started = 0;
        let team = Team::spawned_by(4, |name, body| {
            started += 1;
            if started == 2 {
                return Err(std::io::Error::other("thread limit"));
            }
            std::thread::Builder::new().name(name).spawn(body)
        });
        assert_eq!(team.threads(), 2);
        let hits: Vec<AtomicUsize> = (0..100).map(|_| AtomicUsize::new(0)).collect();
        for _ in 0..20 {
            team.run(100, &|i| {
                hits[i].fetch_add(1, Relaxed);
            });
        }
        assert!(hits.iter().all(|h| h.load(Relaxed) == 20));
    }

    /// A helper parked after its idle time wakes for the next job.
    #[test]
    fn a_parked_helper_wakes_for_the_next_job() {
        let team = Team::new(2);
        std::thread::sleep(IDLE * 3);
        let hits = AtomicUsize::new(0);
        team.run(64, &|_| {
            hits.fetch_add(1, Relaxed);
        });
        assert_eq!(hits.load(Relaxed), 64);
    }
}
