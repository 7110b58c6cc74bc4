//! One module per subcommand.

pub mod bench;
mod files;
pub mod health;
pub mod openapi;
pub mod run;
pub mod serve;
pub mod validate;
