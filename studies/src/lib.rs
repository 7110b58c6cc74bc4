//! # drapery-studies: what the benchmark studies run
//!
//! The studies of `drapery bench` (work–precision, stress, scale) and the
//! stress suite's tests all run scenes through one [`runner`]; the
//! [`stress`] suite's cases and checks live here too, outside the core's
//! public API, so `drapery bench stress` (full size) and `cargo test`
//! (small size) run the very same cases.

pub mod runner;
pub mod stress;
