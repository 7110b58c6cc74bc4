//! The worker pool: OS threads that claim jobs and run the solver
//! (`pool`), the thread that keeps their leases (`keeper`), and the one
//! module that talks to the core (`run`).

mod keeper;
mod pool;
mod run;

pub use keeper::spawn as spawn_keeper;
pub use pool::spawn;
