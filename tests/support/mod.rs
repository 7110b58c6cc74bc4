//! What the service tests share: a service to talk to (in this process,
//! or a real `drapery serve` process where a test needs one), the specs
//! they submit, and clients for HTTP and the WebSocket stream.

#![allow(dead_code, unused_imports)]

mod client;
mod in_process;
mod nodes;
mod postgres;
mod process;
mod specs;

pub use client::*;
pub use in_process::Service;
pub use nodes::*;
pub use postgres::*;
pub use process::Server;
pub use specs::*;

/// Where a service listens.
pub trait Endpoint {
    /// `http://127.0.0.1:PORT`.
    fn base(&self) -> &str;

    fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base())
    }

    fn ws_url(&self, path: &str) -> String {
        format!("{}{path}", self.base().replacen("http://", "ws://", 1))
    }
}
