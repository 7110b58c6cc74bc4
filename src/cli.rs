//! Command-line arguments (DESIGN.md "Command line").

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

/// Cloth simulation: run a job spec, validate one, or serve jobs.
#[derive(Debug, Parser)]
#[command(name = "drapery", version, about)]
pub struct Cli {
    /// Log as JSON lines instead of text.
    #[arg(long, global = true, env = "DRAPERY_LOG_JSON")]
    pub log_json: bool,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run one job spec and write its frames and statistics.
    Run(RunArgs),
    /// Check a job spec and print every error.
    Validate(ValidateArgs),
}

/// `drapery run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The job spec (JSON).
    pub spec: PathBuf,
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Frame format.
    #[arg(long, value_enum, default_value_t = Format::Obj)]
    pub format: Format,
    /// Never draw a progress bar, even on a terminal.
    #[arg(long)]
    pub quiet: bool,
}

/// Output formats of `drapery run`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// `frames/frame_NNNNN.obj`, one OBJ per frame.
    Obj,
    /// `cloth.pc2` point cache plus `cloth.obj` with the topology.
    Pc2,
    /// `cloth.glb`: binary glTF, frames as morph targets with an animation.
    Glb,
}

/// `drapery validate`.
#[derive(Debug, Args)]
pub struct ValidateArgs {
    /// The job spec (JSON).
    pub spec: PathBuf,
}
