//! The worker pool: OS threads that take queued jobs and run the solver
//! (`pool`), and the one module that talks to the core (`run`).

mod pool;
mod run;

pub use pool::spawn;
