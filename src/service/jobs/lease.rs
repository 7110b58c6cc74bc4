//! Keeping this node's leases: while a job runs here, its lease in the
//! store is renewed every [`RENEW_EVERY`] (or a quarter of the lease, if
//! shorter), and the renewal brings back what other nodes said of the
//! job: a cancel asked on any node stops it here, and a job this node no
//! longer holds (the lease lapsed while the store was out of reach, and
//! another node took it over) is stopped without writing anything more.

use std::time::Duration;

use tracing::warn;

use super::lifecycle::Jobs;
use super::running::StopReason;

/// The longest time between two renewals: also how long a cancel asked
/// on another node may take to reach the worker.
pub const RENEW_EVERY: Duration = Duration::from_secs(1);

impl Jobs {
    /// How often this node renews its leases.
    pub fn renew_interval(&self) -> Duration {
        let quarter =
            Duration::try_from_secs_f64(self.config.lease_seconds / 4.0).unwrap_or(RENEW_EVERY);
        quarter.min(RENEW_EVERY)
    }

    /// Renews the leases of the jobs running here; stops those cancelled
    /// elsewhere and those lost to another node. A store that does not
    /// answer is not an error here: the next renewal tries again, and the
    /// jobs' own writes fail meanwhile.
    pub fn renew_leases(&self) {
        let ids = self.running.ids();
        if ids.is_empty() {
            return;
        }
        let held = match self
            .store
            .renew(&self.config.node, self.config.lease_seconds, &ids)
        {
            Ok(held) => held,
            Err(e) => {
                warn!(error = %e, jobs = ids.len(), "renewing leases failed");
                return;
            }
        };
        for id in ids {
            match held.iter().find(|(h, _)| *h == id) {
                Some((_, true)) => self.running.stop(id, StopReason::Cancelled),
                Some((_, false)) => {}
                None => {
                    warn!(%id, "lease lost to another node: stopping the job here");
                    self.running.stop(id, StopReason::LeaseLost);
                }
            }
        }
    }
}
