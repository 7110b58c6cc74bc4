//! The pool of connections to the PostgreSQL store (and why it is built
//! this way).
//!
//! Why tokio-postgres on a runtime of its own: the store's interface is
//! blocking (the SQLite backend is, and worker threads call it), so each
//! call is `block_on` on this small runtime, whose one thread also drives
//! the connections. Its callers are worker threads and tokio's blocking
//! pool, never the async executor. Connections are pooled here (a few
//! lines, not a crate): at most `--store-connections` at once; a closed
//! one (the server restarted) is dropped, and a call that met one is tried
//! once more on a fresh connection.

use std::sync::Mutex;
use std::time::Duration;

use tokio::runtime::Runtime;
use tokio::sync::Semaphore;
use tokio_postgres::{Client, Config, NoTls};

use super::schema;
use crate::service::store::error::{Result, StoreError};

/// How long connecting may take before the store counts as unavailable.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(3);

/// The database's clock, as unix seconds: leases are compared on one
/// clock, whatever the nodes' clocks say.
pub const NOW: &str = "extract(epoch from clock_timestamp())::float8";

/// A pool of connections to one database.
pub struct Postgres {
    runtime: Option<Runtime>,
    config: Config,
    idle: Mutex<Vec<Client>>,
    slots: Semaphore,
}

impl std::fmt::Debug for Postgres {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Postgres")
            .field("hosts", &self.config.get_hosts())
            .field("dbname", &self.config.get_dbname())
            .finish_non_exhaustive()
    }
}

impl Postgres {
    /// Connects to `url` with at most `connections` connections at once,
    /// and migrates the schema.
    pub fn connect(url: &str, connections: usize) -> Result<Self> {
        if !(url.starts_with("postgres://") || url.starts_with("postgresql://")) {
            return Err(StoreError::Url(format!(
                "{url:?} is not a postgres://USER@HOST/DB URL"
            )));
        }
        let mut config: Config = url
            .parse()
            .map_err(|e| StoreError::Url(format!("{e}; expected postgres://USER@HOST/DB")))?;
        if config.get_connect_timeout().is_none() {
            config.connect_timeout(CONNECT_TIMEOUT);
        }
        config.application_name("drapery");
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("store")
            .enable_all()
            .build()
            .map_err(|e| StoreError::Unavailable(format!("starting the store's runtime: {e}")))?;
        let store = Self {
            runtime: Some(runtime),
            config,
            idle: Mutex::new(Vec::new()),
            slots: Semaphore::new(connections.max(1)),
        };
        store.with(async |c| schema::migrate(c).await)??;
        Ok(store)
    }

    /// Runs `f` on a pooled connection, on the store's runtime; a call
    /// that met a connection the server had closed runs once more on a
    /// fresh one.
    pub(super) fn with<T>(
        &self,
        f: impl AsyncFn(&mut Client) -> std::result::Result<T, tokio_postgres::Error>,
    ) -> Result<T> {
        let Some(runtime) = &self.runtime else {
            return Err(StoreError::Unavailable("the store is closed".into()));
        };
        runtime.block_on(async {
            let _slot = self
                .slots
                .acquire()
                .await
                .map_err(|_| StoreError::Unavailable("the store is closed".into()))?;
            let (mut client, pooled) = match self.take_idle() {
                Some(c) => (c, true),
                None => (self.open().await?, false),
            };
            let mut result = f(&mut client).await;
            if pooled && result.is_err() && client.is_closed() {
                client = self.open().await?;
                result = f(&mut client).await;
            }
            if !client.is_closed() {
                self.idle
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .push(client);
            }
            result.map_err(StoreError::from)
        })
    }

    /// An idle connection that is still open.
    fn take_idle(&self) -> Option<Client> {
        let mut idle = self.idle.lock().unwrap_or_else(|p| p.into_inner());
        while let Some(c) = idle.pop() {
            if !c.is_closed() {
                return Some(c);
            }
        }
        None
    }

    /// A new connection, driven by the store's runtime.
    async fn open(&self) -> Result<Client> {
        let (client, connection) = self.config.connect(NoTls).await?;
        tokio::spawn(async move {
            if let Err(e) = connection.await {
                tracing::debug!(error = %e, "store connection ended");
            }
        });
        Ok(client)
    }
}

impl Drop for Postgres {
    /// The runtime goes without waiting (a drop may happen on the async
    /// executor, where waiting is not allowed); its connections close.
    fn drop(&mut self) {
        self.idle.lock().unwrap_or_else(|p| p.into_inner()).clear();
        if let Some(runtime) = self.runtime.take() {
            runtime.shutdown_background();
        }
    }
}
