//! The SQLite backend: one machine's jobs in a WAL database under
//! `--data`: the handle (`db`), the tables and their versions (`schema`),
//! rows (`jobs`), runs (`lease`), frames and checkpoints (`frames`),
//! deletion (`retention`).

mod db;
mod frames;
mod jobs;
mod lease;
mod retention;
mod schema;

pub use db::Sqlite;
