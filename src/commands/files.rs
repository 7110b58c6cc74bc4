//! Reading the files a command is given, with the path in every error.

use std::path::Path;

use anyhow::Context;

/// Reads a spec file, with the path in the error.
pub(crate) fn read_spec(path: &Path) -> anyhow::Result<String> {
    std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))
}
