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
