//! `drapery`: the command line. Parses arguments, sets up logging, and hands
//! off to a command; nothing else lives here.

use clap::Parser;

use drapery::cli::{Cli, Command};
use drapery::commands;

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    if matches!(cli.command, Command::Run(_) | Command::Bench(_)) {
        // Executes the command again with huge pages where it lacks them.
        drapery::huge_pages::ensure();
    }
    drapery::logging::init(cli.log_json);
    if let Err(e) = drapery::threads::init(cli.threads) {
        eprintln!("error: --threads: {e}");
        return std::process::ExitCode::FAILURE;
    }
    let result = match cli.command {
        Command::Run(args) => commands::run::run(&args),
        Command::Validate(args) => commands::validate::run(&args),
        Command::Serve(args) => commands::serve::run(&args),
        Command::Openapi(args) => commands::openapi::run(&args),
        Command::Health(args) => commands::health::run(&args),
        Command::Bench(cmd) => commands::bench::run(&cmd),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
