//! What needs a real `drapery serve` process besides the recovery tests
//! (`service_recovery.rs`): the container's health check command.

mod support;

use support::*;

/// `drapery health` (the container's health check) succeeds against a live
/// server and fails against a closed port.
#[tokio::test]
async fn health_command_probes_the_server() {
    let s = Server::start(&data_dir("health"), &[]);
    let addr = s.base.trim_start_matches("http://").to_owned();
    let probe = |a: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_drapery"))
            .args(["health", "--addr", a])
            .output()
            .expect("runs")
            .status
            .success()
    };
    assert!(probe(&addr));
    assert!(!probe("127.0.0.1:9"));
}

/// SIGTERM while a client holds a half-sent request (headers sent, 1 of
/// 100 body bytes) exits within the grace period: it ran on for 30-40 s
/// with `--shutdown-grace 5`, its listener closed, until SIGKILL.
#[tokio::test]
async fn sigterm_exits_within_the_grace_period_while_a_client_holds_a_half_sent_request() {
    use std::time::{Duration, Instant};
    use tokio::io::AsyncWriteExt;

    let mut s = Server::start(&data_dir("term-held"), &["--shutdown-grace", "5"]);
    let addr = s.base.trim_start_matches("http://").to_owned();
    let mut held = tokio::net::TcpStream::connect(&addr)
        .await
        .expect("connects");
    held.write_all(
        b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 100\r\n\r\n{",
    )
    .await
    .expect("writes");
    let mut head = tokio::net::TcpStream::connect(&addr)
        .await
        .expect("connects");
    head.write_all(b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\n")
        .await
        .expect("writes");
    tokio::time::sleep(Duration::from_secs(2)).await;
    let start = Instant::now();
    let exited = tokio::task::spawn_blocking(move || s.terminate(Duration::from_secs(25)))
        .await
        .expect("joined");
    assert!(exited, "exits 0 after SIGTERM");
    assert!(
        start.elapsed() < Duration::from_secs(15),
        "took {:?} with --shutdown-grace 5",
        start.elapsed()
    );
    drop((held, head));
}
