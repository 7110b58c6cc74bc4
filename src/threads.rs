//! The solver's threads: one rayon pool for the whole process, sized once
//! at start (`--threads`, `DRAPERY_THREADS`; default: every core).
//!
//! The core splits its work into fixed chunks, so the number of threads
//! changes speed, never results. In the service every worker's steps draw
//! on this one pool: with `--workers 2` on two cores, two jobs each get
//! about a core, and a lone job gets both.

/// Sizes the global pool; `None` leaves rayon's default (every core).
pub fn init(threads: Option<u16>) -> Result<(), rayon::ThreadPoolBuildError> {
    let Some(n) = threads else {
        return Ok(());
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(usize::from(n))
        .thread_name(|k| format!("solver-{k}"))
        .build_global()
}

/// Runs `f` on one of the pool's own threads and waits for it.
///
/// PERF: a parallel loop started from outside the pool is handed to it
/// and its caller sleeps until the pool is done, so every loop pays a
/// wake-up of both workers (tens of µs on the 2-core VM, hundreds of
/// times a second). Started from a pool thread, the loop's first half
/// runs where it is and only the rest waits for a second worker. For one
/// simulation at a time (the CLI); the service's workers stay outside
/// the pool, because a pool thread waiting on a join may pick up a
/// whole other job and hold its own until that one ends.
pub fn on_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    rayon::scope(|_| f())
}
