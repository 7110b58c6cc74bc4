//! `drapery serve`: the simulation service (DESIGN.md "Service").
//!
//! ```text
//! HTTP ──▶ server::app ──▶ api (REST) ─────▶ jobs::Jobs ──▶ store (SQLite, or PostgreSQL
//!                     └──▶ stream (WebSocket) ──┘  │  ▲          ▲   shared by nodes)
//!                                                  ▼  │          │ claims, leases, frames
//!                                                   hub ◀─── worker (threads, solver)
//! ```
//!
//! Handlers only extract, call [`Jobs`], and answer; `Jobs` owns every
//! change to a job. The solver runs on worker threads, never on the async
//! executor; the store is the single source of truth and the queue, so a
//! restart recovers every job and every stored frame, and nodes sharing a
//! PostgreSQL store share its jobs (a worker claims one under a lease).

mod accept;
mod allocator;
mod api;
mod auth;
mod config;
mod connections;
mod cost;
mod error;
mod error_code;
mod extract;
mod frame_bytes;
mod guard;
mod held_body;
mod job;
mod jobs;
mod keys;
mod metrics;
pub mod openapi;
mod ops;
pub mod protocol;
mod results;
mod server;
mod state;
mod store;
mod stream;
mod view;
mod viewer;
mod worker;

pub use config::{Config, ConfigError};
pub use error_code::ErrorCode;
pub use job::{JobError, JobId, Status};
pub use jobs::Jobs;
pub use keys::{KeyError, Keys};
pub use server::{ServeError, app, open_store, run, serve};
pub use state::AppState;
pub use store::{Store, StoreError};
