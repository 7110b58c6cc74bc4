//! `drapery health`: GET `/healthz` of a running server over plain TCP.
//!
//! A container health check must not need curl in a slim image; one
//! HTTP/1.0 request and a look at the status line is all it takes.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::process::ExitCode;
use std::time::Duration;

use crate::cli::HealthArgs;

/// Exit 0 when the server answers 200, 1 otherwise.
pub fn run(args: &HealthArgs) -> anyhow::Result<ExitCode> {
    let timeout = Duration::from_secs(3);
    let mut stream = TcpStream::connect_timeout(&args.addr, timeout)?;
    stream.set_read_timeout(Some(timeout))?;
    stream.set_write_timeout(Some(timeout))?;
    write!(
        stream,
        "GET /healthz HTTP/1.0\r\nHost: {}\r\nConnection: close\r\n\r\n",
        args.addr
    )?;
    let mut head = [0u8; 32];
    let n = stream.read(&mut head)?;
    let line = String::from_utf8_lossy(&head[..n]);
    if line.starts_with("HTTP/1.0 200") || line.starts_with("HTTP/1.1 200") {
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!("unhealthy: {}", line.lines().next().unwrap_or(""));
        Ok(ExitCode::FAILURE)
    }
}
