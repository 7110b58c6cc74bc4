//! The service's settings, from `drapery serve`'s flags (or their
//! environment variables), checked once at start.

use std::time::Duration;

use drapery_sim::spec::Limits;

use super::cost::Budgets;
use super::keys::{KeyError, Keys};
use crate::cli::{Retention, ServeArgs};

/// Settings from `drapery serve`'s flags.
#[derive(Debug, Clone)]
pub struct Config {
    /// Solver threads of this node; 0 for an API-only node.
    pub workers: usize,
    /// This node's name among the nodes sharing the store.
    pub node: String,
    /// Seconds a lease lasts without renewal.
    pub lease_seconds: f64,
    pub queue_capacity: usize,
    /// Size limits a submitted spec must meet.
    pub limits: Limits,
    pub max_wall_seconds: f64,
    pub max_body_bytes: usize,
    pub keys: Keys,
    pub cors_origins: Vec<String>,
    pub checkpoint_seconds: f64,
    pub shutdown_grace: f64,
    /// Open connections at most.
    pub max_connections: usize,
    /// A request head's time from its first byte.
    pub header_timeout: Duration,
    /// A request body's time to arrive whole.
    pub body_timeout: Duration,
    /// A kept-alive connection's silence between requests.
    pub idle_timeout: Duration,
    /// Result downloads built and held at once.
    pub max_downloads: usize,
    /// Per-job memory, disk and estimated time.
    pub budgets: Budgets,
    /// Which ended jobs are deleted.
    pub retention: Vec<Retention>,
}

/// Flags that cannot configure a service.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error(
        "--workers 0 makes an API-only node, which needs a store other nodes share: --store postgres://USER@HOST/DB"
    )]
    NoWorkers,
    #[error("--node {0:?}: expected 1 to 63 letters, digits, '.', '_' or '-'")]
    Node(String),
    #[error("--lease-seconds must be between 1 and 3600")]
    Lease,
    #[error("--store-connections must be at least 1")]
    NoStoreConnections,
    #[error("--queue-capacity must be at least 1")]
    NoQueue,
    #[error("--max-wall-seconds and --max-duration must be positive")]
    NonPositiveLimit,
    #[error("--max-connections must be at least 1")]
    NoConnections,
    #[error("--max-downloads must be at least 1")]
    NoDownloads,
    #[error("{0} must be a positive number of seconds")]
    Timeout(&'static str),
    #[error("--job-memory-budget, --job-disk-budget and --job-time-budget must be positive")]
    NonPositiveBudget,
    #[error(
        "{flag} must be at most {core}: stored jobs are loaded again under the solver's own limits"
    )]
    AboveCore { flag: &'static str, core: f64 },
    #[error(transparent)]
    Key(#[from] KeyError),
}

impl Config {
    /// The configuration `drapery serve`'s flags describe.
    pub fn from_args(a: &ServeArgs) -> Result<Self, ConfigError> {
        let workers = a.workers.unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
        });
        if workers < 1 && a.store.is_none() {
            return Err(ConfigError::NoWorkers);
        }
        let node = match &a.node {
            Some(n) => n.clone(),
            None => host_name(),
        };
        let valid = |c: char| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-');
        if node.is_empty() || node.len() > 63 || !node.chars().all(valid) {
            return Err(ConfigError::Node(node));
        }
        if !(1.0..=3600.0).contains(&a.lease_seconds) {
            return Err(ConfigError::Lease);
        }
        if a.store_connections < 1 {
            return Err(ConfigError::NoStoreConnections);
        }
        if a.queue_capacity < 1 {
            return Err(ConfigError::NoQueue);
        }
        if !(a.max_wall_seconds > 0.0 && a.max_duration > 0.0) {
            return Err(ConfigError::NonPositiveLimit);
        }
        if a.max_connections < 1 {
            return Err(ConfigError::NoConnections);
        }
        if a.max_downloads < 1 {
            return Err(ConfigError::NoDownloads);
        }
        let seconds = |flag: &'static str, s: f64| {
            Duration::try_from_secs_f64(s)
                .ok()
                .filter(|d| !d.is_zero())
                .ok_or(ConfigError::Timeout(flag))
        };
        let budgets = Budgets {
            memory_bytes: a.job_memory_budget,
            disk_bytes: a.job_disk_budget,
            seconds: a.job_time_budget,
        };
        if budgets.memory_bytes == 0
            || budgets.disk_bytes == 0
            || budgets.seconds.is_nan()
            || budgets.seconds <= 0.0
        {
            return Err(ConfigError::NonPositiveBudget);
        }
        let core = Limits::default();
        let limits = Limits {
            max_particles: a.max_particles,
            max_triangles: a.max_triangles,
            max_duration: a.max_duration,
            max_frames: a.max_frames,
            max_steps: core.max_steps,
            max_obstacles: core.max_obstacles,
        };
        // A job admitted under the service's limits is loaded again (worker,
        // stream, downloads) under the core's, so those bound the flags.
        let bounded = |l: &Limits| {
            [
                l.max_particles as f64,
                l.max_triangles as f64,
                l.max_duration,
                l.max_frames as f64,
            ]
        };
        let flags = [
            "--max-particles",
            "--max-triangles",
            "--max-duration",
            "--max-frames",
        ];
        for ((flag, ours), theirs) in flags.into_iter().zip(bounded(&limits)).zip(bounded(&core)) {
            if ours > theirs {
                return Err(ConfigError::AboveCore { flag, core: theirs });
            }
        }
        Ok(Self {
            workers,
            node,
            lease_seconds: a.lease_seconds,
            queue_capacity: a.queue_capacity,
            limits,
            max_wall_seconds: a.max_wall_seconds,
            max_body_bytes: a.max_body_bytes,
            keys: Keys::parse(&a.api_keys)?,
            cors_origins: a.cors_origins.clone(),
            checkpoint_seconds: a.checkpoint_seconds,
            shutdown_grace: a.shutdown_grace,
            max_connections: a.max_connections,
            header_timeout: seconds("--header-timeout", a.header_timeout)?,
            body_timeout: seconds("--body-timeout", a.body_timeout)?,
            idle_timeout: seconds("--idle-timeout", a.idle_timeout)?,
            max_downloads: a.max_downloads,
            budgets,
            retention: a.retention.clone(),
        })
    }
}

/// The machine's host name (the default node name), or `drapery` where
/// none can be read.
fn host_name() -> String {
    let read = |p: &str| std::fs::read_to_string(p).ok();
    read("/proc/sys/kernel/hostname")
        .or_else(|| read("/etc/hostname"))
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|h| h.trim().to_owned())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "drapery".to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::{Cli, Command};
    use clap::Parser;

    fn config(flags: &[&str]) -> Result<Config, ConfigError> {
        let argv = ["drapery", "serve"].iter().chain(flags);
        let Command::Serve(args) = Cli::try_parse_from(argv).expect("flags").command else {
            unreachable!("parsed as serve");
        };
        Config::from_args(&args)
    }

    /// An API-only node needs a store other nodes share; node names and
    /// leases are checked, each error naming its flag.
    #[test]
    fn node_flags_are_checked_naming_the_flag() {
        let e = config(&["--workers", "0"]).expect_err("no shared store");
        assert!(e.to_string().contains("--store postgres://"), "{e}");
        let pg = ["--store", "postgres://u@h/db"];
        let c = config(&[&pg[..], &["--workers", "0", "--node", "api-1"]].concat())
            .expect("an API-only node");
        assert_eq!((c.workers, c.node.as_str()), (0, "api-1"));
        assert!(
            !config(&[]).expect("defaults").node.is_empty(),
            "the host name"
        );
        for bad in ["", "a b", "ü", &"x".repeat(64)] {
            let e = config(&["--node", bad]).expect_err("a bad name");
            assert!(e.to_string().starts_with("--node"), "{e}");
        }
        for bad in ["0", "0.5", "4000", "NaN"] {
            let e = config(&["--lease-seconds", bad]).expect_err("a bad lease");
            assert!(e.to_string().starts_with("--lease-seconds"), "{e}");
        }
        let e = config(&["--store-connections", "0"]).expect_err("no connections");
        assert!(e.to_string().starts_with("--store-connections"), "{e}");
    }

    /// Every client-facing bound must let something through.
    #[test]
    fn bounds_of_zero_are_refused_naming_the_flag() {
        for flag in ["--queue-capacity", "--max-connections", "--max-downloads"] {
            let e = config(&[flag, "0"]).expect_err("zero");
            assert!(e.to_string().starts_with(flag), "{e}");
        }
        assert_eq!(config(&[]).expect("defaults").max_downloads, 2);
    }

    /// The service cannot admit what its workers, streams and downloads
    /// would refuse when they load the stored spec under the core's limits.
    #[test]
    fn limits_above_the_core_are_refused_naming_the_flag() {
        let core = Limits::default();
        let flags = [
            ("--max-particles", core.max_particles as f64),
            ("--max-triangles", core.max_triangles as f64),
            ("--max-duration", core.max_duration),
            ("--max-frames", core.max_frames as f64),
        ];
        for (flag, at) in flags {
            let e = config(&[flag, &(2.0 * at).to_string()]).expect_err("above the core");
            assert!(e.to_string().starts_with(flag), "{e}");
            config(&[flag, &at.to_string()]).expect("the core's own limit");
        }
    }
}
