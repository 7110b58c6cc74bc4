//! `drapery serve`: the simulation service, until SIGTERM or SIGINT.

use std::process::ExitCode;

use crate::cli::ServeArgs;
use crate::service;

/// Runs the service; its errors come back with their causes.
pub fn run(args: &ServeArgs) -> anyhow::Result<ExitCode> {
    service::serve(args)?;
    Ok(ExitCode::SUCCESS)
}
