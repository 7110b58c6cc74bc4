//! The lease keeper: one thread per node that renews the leases of the
//! jobs its workers run (`Jobs::renew_leases`), until the node has shut
//! down and its last job has stopped (a job winding down at a shutdown
//! still needs its lease to record its checkpoint and requeue).

use std::sync::Arc;
use std::thread::JoinHandle;

use crate::service::jobs::Jobs;

/// Starts the keeper; it ends once shutting down with nothing running.
pub fn spawn(jobs: &Arc<Jobs>) -> std::io::Result<JoinHandle<()>> {
    let jobs = Arc::clone(jobs);
    std::thread::Builder::new()
        .name("lease-keeper".into())
        .spawn(move || {
            let every = jobs.renew_interval();
            while !(jobs.is_stopping() && jobs.running_count() == 0) {
                std::thread::sleep(every);
                jobs.renew_leases();
            }
        })
}
