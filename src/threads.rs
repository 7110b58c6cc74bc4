//! The solver's threads: one team for the whole process
//! (`drapery_sim::parallel::Team`), sized once at start (`--threads`,
//! `DRAPERY_THREADS`; default: every core).
//!
//! The core splits its work so that the number of threads changes speed,
//! never results. In the service the workers' jobs take turns with the
//! team loop by loop: a loop started while another job's loop has it runs
//! on its job's own thread, so with `--workers 2` on two cores two jobs
//! each get about a core, and a lone job gets both.

/// Sizes the process's team; `None` leaves the default (every core).
pub fn init(threads: Option<u16>) -> anyhow::Result<()> {
    let Some(n) = threads else {
        return Ok(());
    };
    drapery_sim::parallel::init(usize::from(n))
        .map_err(|used| anyhow::anyhow!("the solver already runs on {used} threads"))
}
