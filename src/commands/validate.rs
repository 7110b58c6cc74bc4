//! `drapery validate SPEC`: every error, one per line; exit 2 if any.

use std::process::ExitCode;

use drapery_sim::spec::Limits;

use crate::cli::ValidateArgs;
use crate::specfile;

/// Prints `ok` and the scene's size, or every error.
pub fn run(args: &ValidateArgs) -> anyhow::Result<ExitCode> {
    let text = super::files::read_spec(&args.spec)?;
    match specfile::load(&text, &Limits::default()) {
        Ok(scene) => {
            println!(
                "ok: {} ({}x{} particles, {} obstacles, {} frames)",
                scene.name,
                scene.cloth.nu,
                scene.cloth.nv,
                scene.obstacles.len(),
                scene.frames + 1
            );
            Ok(ExitCode::SUCCESS)
        }
        Err(e) => {
            for err in e.errors() {
                println!("{err}");
            }
            Ok(ExitCode::from(2))
        }
    }
}
