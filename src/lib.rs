//! The `drapery` package: the command line and the service around
//! the `drapery-sim` core. See ARCHITECTURE.md for the whole picture.

pub mod cli;
pub mod commands;
pub mod huge_pages;
pub mod logging;
pub mod service;
pub mod specfile;
pub mod threads;

/// A fresh directory for a unit test under the crate's `target/tmp` (the
/// integration tests' `CARGO_TARGET_TMPDIR`): kept for a look after a
/// failure, gone with `cargo clean`, never left in the system temp dir.
#[cfg(test)]
pub(crate) fn test_dir(tag: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("target/tmp")
        .join(format!("drapery-{tag}-{}", uuid::Uuid::now_v7()))
}
