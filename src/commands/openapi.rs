//! `drapery openapi [--write DIR]`: the service's API description.

use std::process::ExitCode;

use anyhow::Context;

use crate::cli::OpenapiArgs;
use crate::service::openapi;

/// Prints the OpenAPI YAML, or writes it and the job schema to `DIR`.
pub fn run(args: &OpenapiArgs) -> anyhow::Result<ExitCode> {
    match &args.write {
        None => print!("{}", openapi::yaml()),
        Some(dir) => {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
            std::fs::write(dir.join("openapi.yaml"), openapi::yaml())?;
            std::fs::write(dir.join("job.schema.json"), openapi::job_schema())?;
            eprintln!("wrote {}/openapi.yaml and job.schema.json", dir.display());
        }
    }
    Ok(ExitCode::SUCCESS)
}
