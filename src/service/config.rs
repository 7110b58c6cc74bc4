//! The service's settings, from `drapery serve`'s flags (or their
//! environment variables), checked once at start.

use drapery_sim::spec::Limits;

use super::keys::{KeyError, Keys};
use crate::cli::ServeArgs;

/// Settings from `drapery serve`'s flags.
#[derive(Debug, Clone)]
pub struct Config {
    pub workers: usize,
    pub queue_capacity: usize,
    /// Size limits a submitted spec must meet.
    pub limits: Limits,
    pub max_wall_seconds: f64,
    pub max_body_bytes: usize,
    pub keys: Keys,
    pub cors_origins: Vec<String>,
    pub checkpoint_seconds: f64,
    pub shutdown_grace: f64,
}

/// Flags that cannot configure a service.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("--workers must be at least 1")]
    NoWorkers,
    #[error("--queue-capacity must be at least 1")]
    NoQueue,
    #[error("--max-wall-seconds and --max-duration must be positive")]
    NonPositiveLimit,
    #[error(transparent)]
    Key(#[from] KeyError),
}

impl Config {
    /// The configuration `drapery serve`'s flags describe.
    pub fn from_args(a: &ServeArgs) -> Result<Self, ConfigError> {
        let workers = a.workers.unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
        });
        if workers < 1 {
            return Err(ConfigError::NoWorkers);
        }
        if a.queue_capacity < 1 {
            return Err(ConfigError::NoQueue);
        }
        if !(a.max_wall_seconds > 0.0 && a.max_duration > 0.0) {
            return Err(ConfigError::NonPositiveLimit);
        }
        let core = Limits::default();
        Ok(Self {
            workers,
            queue_capacity: a.queue_capacity,
            limits: Limits {
                max_particles: a.max_particles,
                max_triangles: a.max_triangles,
                max_duration: a.max_duration,
                max_frames: a.max_frames,
                max_steps: core.max_steps,
            },
            max_wall_seconds: a.max_wall_seconds,
            max_body_bytes: a.max_body_bytes,
            keys: Keys::parse(&a.api_keys)?,
            cors_origins: a.cors_origins.clone(),
            checkpoint_seconds: a.checkpoint_seconds,
            shutdown_grace: a.shutdown_grace,
        })
    }
}
