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
