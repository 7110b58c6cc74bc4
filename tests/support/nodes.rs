//! Nodes sharing one PostgreSQL store, as real `drapery serve` processes,
//! and what the multi-node tests compare: every frame of a job, as bytes.

use std::time::Duration;

use serde_json::Value;

use super::{Endpoint, Server, client, data_dir, job, status, wait_for};

/// How long a node's lease lasts in these tests (the default is 20 s):
/// short, so a takeover is seconds.
pub const TEST_LEASE: &str = "3";

/// Starts node `name` on the store at `url` with `workers` workers, one
/// solver thread, the test lease (unless `extra` sets one) and checkpoints
/// every half second.
pub fn node(url: &str, name: &str, workers: u32, extra: &[&str]) -> Server {
    let workers = workers.to_string();
    let mut flags = vec![
        "--store",
        url,
        "--node",
        name,
        "--workers",
        &workers,
        "--threads",
        "1",
        "--checkpoint-seconds",
        "0.5",
    ];
    if !extra.contains(&"--lease-seconds") {
        flags.extend(["--lease-seconds", TEST_LEASE]);
    }
    flags.extend_from_slice(extra);
    Server::start(&data_dir(name), &flags)
}

/// Submits `spec` through `s`; the job's id.
pub async fn submit_id(s: &impl Endpoint, spec: &Value) -> String {
    super::submit(s, spec).await["id"]
        .as_str()
        .expect("an id")
        .to_owned()
}

/// Every frame of a job that ended, each as the binary frame the API
/// serves (index, time and positions: equal bytes are equal frames).
pub async fn all_frames(s: &impl Endpoint, id: &str) -> Vec<Vec<u8>> {
    let j = job(s, id).await;
    let total = j["progress"]["frames_total"]
        .as_u64()
        .expect("frames_total");
    let mut frames = Vec::new();
    for n in 0..total {
        let r = client()
            .get(s.url(&format!("/v1/jobs/{id}/frames/{n}")))
            .header("accept", "application/octet-stream")
            .send()
            .await
            .expect("request");
        assert_eq!(r.status(), 200, "frame {n} of {id}");
        frames.push(r.bytes().await.expect("body").to_vec());
    }
    frames
}

/// Waits for the job to end; it must have succeeded.
pub async fn succeeded(s: &impl Endpoint, id: &str, limit: Duration) -> Value {
    let j = wait_for(s, id, limit, |j| {
        matches!(status(j), "succeeded" | "failed" | "cancelled")
    })
    .await;
    assert_eq!(status(&j), "succeeded", "{j}");
    j
}

/// The job's `node`.
pub fn node_of(j: &Value) -> Option<&str> {
    j["node"].as_str()
}
