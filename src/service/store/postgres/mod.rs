//! The PostgreSQL backend: the jobs of every node sharing one database,
//! which is also their queue: the connections (`pool`), the tables and
//! their versions (`schema`), rows (`jobs`), claims and leases (`lease`),
//! frames, checkpoints and deletion (`frames`).

mod frames;
mod jobs;
mod lease;
mod pool;
mod schema;

pub use pool::Postgres;
