//! The `drapery` package: the command line and the service around
//! the `drapery-sim` core. See ARCHITECTURE.md for the whole picture.

pub mod cli;
pub mod commands;
pub mod logging;
pub mod service;
pub mod specfile;
pub mod threads;
