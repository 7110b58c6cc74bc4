//! `drapery bench`: benchmark studies that write CSV and an SVG plot.
//! Speed is measured here and in criterion, never in timed unit tests.

mod csvfile;
mod fit;
mod plot;
mod precision;
mod runner;
mod scale;
mod stress;

use std::process::ExitCode;

use crate::cli::BenchCommand;

/// Runs one study.
pub fn run(cmd: &BenchCommand) -> anyhow::Result<ExitCode> {
    match cmd {
        BenchCommand::Precision(args) => precision::run(args),
        BenchCommand::Stress(args) => stress::run(args),
        BenchCommand::Scale(args) => scale::run(args),
    }
}
