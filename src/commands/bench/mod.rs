//! `drapery bench`: benchmark studies that write CSV and an SVG plot.
//! Speed is measured here and in criterion, never in timed unit tests.

mod fit;
mod plot;
mod precision;
mod runner;
mod scale;
mod stress;

use std::path::Path;
use std::process::ExitCode;

use anyhow::Context;

use crate::cli::BenchCommand;

/// Runs one study.
pub fn run(cmd: &BenchCommand) -> anyhow::Result<ExitCode> {
    match cmd {
        BenchCommand::Precision(args) => precision::run(args),
        BenchCommand::Stress(args) => stress::run(args),
        BenchCommand::Scale(args) => scale::run(args),
    }
}

/// Peak resident memory of this process so far (`VmHWM`), MiB; `None`
/// where `/proc` does not say.
fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// Writes `rows` as CSV with a header from the row type's field names.
fn write_csv<T: serde::Serialize>(
    path: &Path,
    rows: impl IntoIterator<Item = T>,
) -> anyhow::Result<()> {
    let mut w =
        csv::Writer::from_path(path).with_context(|| format!("creating {}", path.display()))?;
    for row in rows {
        w.serialize(row)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    w.flush()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
