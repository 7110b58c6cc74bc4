//! The service's domain: jobs from submission to their end, owned by one
//! type, [`Jobs`]. Request handlers and worker threads call it; it calls
//! the store, the queue and the live news, and nothing here knows HTTP.

mod attempt;
mod cancel;
mod error;
mod hello;
mod hub;
mod lease;
mod lifecycle;
mod lookup;
mod running;
mod submit;
mod subscription;
mod wakeup;

pub use attempt::{Attempt, Outcome};
pub use error::{Fault, JobsError, ListError, SubmitError};
pub use lifecycle::Jobs;
#[cfg(test)]
pub(crate) use lifecycle::jobs_for_tests;
pub use lookup::{ListFilter, Page};
pub use running::StopReason;
pub use subscription::{Event, Subscription};
