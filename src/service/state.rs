//! What the HTTP layer shares: the settings and the jobs.

use std::sync::Arc;

use super::config::Config;
use super::jobs::Jobs;
use super::store::Store;

/// The service's state, cheap to clone (two `Arc`s).
#[derive(Debug, Clone)]
pub struct AppState {
    pub config: Arc<Config>,
    pub jobs: Arc<Jobs>,
}

impl AppState {
    /// A service with `config` over `store`. Nothing runs until
    /// `server::run`.
    pub fn new(config: Config, store: Store) -> Self {
        let config = Arc::new(config);
        Self {
            jobs: Arc::new(Jobs::new(Arc::clone(&config), store)),
            config,
        }
    }
}
