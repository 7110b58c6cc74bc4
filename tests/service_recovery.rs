//! The service survives its process: SIGKILL mid-job loses no submitted
//! job and no stored frame, and SIGTERM stops cleanly with a checkpoint.

mod support;

use std::time::Duration;

use serde_json::{Value, json};
use support::*;

const LONG: Duration = Duration::from_secs(180);

async fn frame_bytes(s: &Server, id: &str, n: u64) -> Vec<u8> {
    let r = client()
        .get(s.url(&format!("/v1/jobs/{id}/frames/{n}")))
        .header("accept", "application/octet-stream")
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 200, "frame {n} of {id}");
    r.bytes().await.expect("body").to_vec()
}

/// Kill -9 while a job runs and another waits; restart on the same data:
/// the finished job is intact, the interrupted one resumes from its
/// checkpoint (a second attempt) and completes with every frame in order,
/// and the queued one runs.
#[tokio::test]
async fn killed_server_resumes_jobs_on_restart() {
    let data = data_dir("kill");
    let mut s = Server::start(&data, &["--workers", "1", "--checkpoint-seconds", "0.2"]);
    let done_id = submit(&s, &hanging(6, 0.3)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let done = wait_for(&s, &done_id, LONG, |j| status(j) == "succeeded").await;
    let done_frames: Vec<Vec<u8>> = {
        let mut v = Vec::new();
        for n in 0..frames_done(&done) {
            v.push(frame_bytes(&s, &done_id, n).await);
        }
        v
    };

    let long_id = submit(&s, &drape(24, 3.0)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let queued_id = submit(&s, &hanging(5, 0.2)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let before = wait_for(&s, &long_id, LONG, |j| frames_done(j) >= 20).await;
    s.kill();

    let s = Server::start(&data, &["--workers", "1"]);
    let after = job(&s, &long_id).await;
    assert!(
        frames_done(&after) >= frames_done(&before),
        "no stored frame lost: {} then {}",
        frames_done(&before),
        frames_done(&after)
    );
    let got = read_stream(&s.ws_url(&format!("/v1/jobs/{long_id}/stream"))).await;
    assert_eq!(got.end["type"], json!("done"), "{:?}", got.end);
    assert_eq!(got.frames.len(), 91);
    for (k, f) in got.frames.iter().enumerate() {
        assert_eq!(f.index as usize, k);
        assert!(f.positions.iter().flatten().all(|c| c.is_finite()));
    }
    let resumed = job(&s, &long_id).await;
    assert_eq!(status(&resumed), "succeeded");
    assert_eq!(resumed["timings"]["attempts"], json!(2));
    assert_eq!(
        resumed["stats"]["frames"],
        json!(91),
        "stats cover every frame"
    );

    let q = wait_for(&s, &queued_id, LONG, |j| status(j) == "succeeded").await;
    assert_eq!(frames_done(&q), 7);
    let again = job(&s, &done_id).await;
    assert_eq!(again["status"], done["status"]);
    assert_eq!(again["stats"], done["stats"]);
    for (n, bytes) in done_frames.iter().enumerate() {
        assert_eq!(&frame_bytes(&s, &done_id, n as u64).await, bytes);
    }
}

/// SIGTERM: the server stops taking requests, the running job stops at a
/// frame with a checkpoint, the process exits 0; after a restart the job
/// resumes where it stopped and completes.
#[tokio::test]
async fn graceful_shutdown_checkpoints_and_resumes() {
    let data = data_dir("term");
    let mut s = Server::start(&data, &["--workers", "1", "--checkpoint-seconds", "1000"]);
    let id = submit(&s, &drape(24, 3.0)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    wait_for(&s, &id, LONG, |j| frames_done(j) >= 10).await;
    assert!(
        s.terminate(Duration::from_secs(30)),
        "exits 0 within the grace period"
    );

    let s = Server::start(&data, &["--workers", "1", "--checkpoint-seconds", "1000"]);
    let got = read_stream(&s.ws_url(&format!("/v1/jobs/{id}/stream"))).await;
    assert_eq!(got.end["type"], json!("done"));
    assert_eq!(got.frames.len(), 91);
    let j: Value = job(&s, &id).await;
    assert_eq!(j["timings"]["attempts"], json!(2));
    // Checkpoints are otherwise 1000 s apart, so the resume used the
    // shutdown's; the statistics count each of the 3 s / (1/240 s) steps
    // once across both attempts.
    let steps_total = j["stats"]["steps"].as_u64().expect("steps");
    assert_eq!(steps_total, 720);
}
