//! A job's life through the API, in process over a real socket:
//! cancellation, the queue's limit and the list, the wall-time limit,
//! downloads, and a shutdown that requeues what runs.

mod support;

use std::time::Duration;

use serde_json::{Value, json};
use support::*;

const LONG: Duration = Duration::from_secs(120);

/// Cancelling a running job stops it within a step; the stream ends with
/// `cancelled`; a second cancel is idempotent; a finished job cannot be.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cancel_a_running_job() {
    let s = Service::start(&data_dir("cancel"), &[]).await;
    let id = submit(&s, &hanging(30, 30.0)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let j = wait_for(&s, &id, LONG, |j| {
        status(j) == "running" && frames_done(j) >= 2
    })
    .await;
    // A running job shows its time so far, not only once it ends.
    assert!(
        j["timings"]["run_seconds"]
            .as_f64()
            .is_some_and(|t| t > 0.0),
        "{j}"
    );
    let url = s.ws_url(&format!("/v1/jobs/{id}/stream"));
    let watcher = tokio::spawn(async move { read_stream(&url).await });
    let http = client();
    let j = delete_job(&s, &id).await;
    assert_eq!(status(&j), "cancelled");
    assert!(frames_done(&j) < 901, "it stopped early");
    let got = watcher.await.expect("watcher");
    assert_eq!(got.end["type"], json!("cancelled"));
    assert_eq!(got.frames.len() as u64, frames_done(&j));
    delete_job(&s, &id).await;

    let quick = submit(&s, &hanging(4, 0.1)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    job_after_done(&s, &quick).await;
    // NOTE: this was `409 conflict` ("a finished job cannot be
    // cancelled"); issue 17 makes `DELETE` of an ended job delete it.
    assert_eq!(status(&delete_job(&s, &quick).await), "succeeded");
    let gone = http
        .get(s.url(&format!("/v1/jobs/{quick}")))
        .send()
        .await
        .expect("request");
    assert_eq!(gone.status(), 404);
    s.stop().await;
}

/// With one worker busy and a queue of one, the next submission is
/// refused with 429 and Retry-After; the list pages newest first and
/// filters by status.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn full_queue_refuses_with_retry_after_and_list_pages() {
    let s = Service::start(
        &data_dir("queue"),
        &["--workers", "1", "--queue-capacity", "1"],
    )
    .await;
    let a = submit(&s, &hanging(30, 30.0)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    wait_for(&s, &a, LONG, |j| status(j) == "running").await;
    let b = submit(&s, &hanging(4, 0.1)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let http = client();
    let r = http
        .post(s.url("/v1/jobs"))
        .json(&hanging(4, 0.1))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 429);
    assert!(r.headers().get("retry-after").is_some());
    assert_eq!(error_code(r).await, "queue_full");

    let page = get_json(&s, "/v1/jobs?limit=1").await;
    assert_eq!(page["jobs"][0]["id"], json!(b), "newest first");
    let cursor = page["next_cursor"]
        .as_str()
        .expect("a next page")
        .to_owned();
    let page2 = get_json(&s, &format!("/v1/jobs?limit=1&cursor={cursor}")).await;
    assert_eq!(page2["jobs"][0]["id"], json!(a));
    assert_eq!(page2["next_cursor"], Value::Null);
    let running = get_json(&s, "/v1/jobs?status=running").await;
    assert_eq!(running["jobs"].as_array().map(Vec::len), Some(1));

    // Cancelling the queued job frees its place at once.
    assert_eq!(status(&delete_job(&s, &b).await), "cancelled");
    submit(&s, &hanging(4, 0.1)).await;
    delete_job(&s, &a).await;

    let metrics = http
        .get(s.url("/metrics"))
        .send()
        .await
        .expect("request")
        .text()
        .await
        .expect("text");
    assert!(metrics.contains("status=\"cancelled\"}"), "{metrics}");
    assert_eq!(
        metric(&metrics, "drapery_jobs_rejected_queue_full_total{"),
        Some(1.0),
        "{metrics}"
    );
    assert!(metrics.contains("drapery_step_seconds_bucket"), "{metrics}");
    s.stop().await;
}

/// A job that runs past `--max-wall-seconds` fails with `limit_exceeded`
/// naming the flag, keeping the frames it stored.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn wall_time_limit_fails_the_job() {
    let s = Service::start(&data_dir("wall"), &["--max-wall-seconds", "0.5"]).await;
    let id = submit(&s, &hanging(30, 60.0)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let j = wait_for(&s, &id, LONG, |j| status(j) == "failed").await;
    assert_eq!(j["error"]["code"], json!("limit_exceeded"));
    assert!(
        j["error"]["message"]
            .as_str()
            .is_some_and(|m| m.contains("--max-wall-seconds")),
        "{j}"
    );
    assert!(
        j["timings"]["run_seconds"]
            .as_f64()
            .is_some_and(|t| t < 5.0)
    );
    assert!(frames_done(&j) < 1801);
    s.stop().await;
}

/// Downloads of a finished job: a zip with one OBJ per frame, a PC2 cache
/// with the right header, a binary glTF.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn results_download_in_three_formats() {
    let s = Service::start(&data_dir("results"), &[]).await;
    let id = submit(&s, &hanging(6, 0.5)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    job_after_done(&s, &id).await;
    let http = client();
    let get = |format: &str| {
        http.get(s.url(&format!("/v1/jobs/{id}/result?format={format}")))
            .send()
    };
    let zip = get("obj").await.expect("request");
    assert_eq!(zip.status(), 200);
    assert_eq!(
        zip.headers()
            .get("content-type")
            .and_then(|v| v.to_str().ok()),
        Some("application/zip")
    );
    let bytes = zip.bytes().await.expect("body");
    let mut archive = zip::ZipArchive::new(std::io::Cursor::new(bytes.to_vec())).expect("a zip");
    assert_eq!(archive.len(), 16);
    let mut first = String::new();
    std::io::Read::read_to_string(
        &mut archive
            .by_name("frames/frame_00015.obj")
            .expect("last frame"),
        &mut first,
    )
    .expect("text");
    assert_eq!(first.lines().filter(|l| l.starts_with("v ")).count(), 36);
    assert_eq!(first.lines().filter(|l| l.starts_with("f ")).count(), 50);

    let pc2 = get("pc2")
        .await
        .expect("request")
        .bytes()
        .await
        .expect("body");
    assert_eq!(&pc2[..12], b"POINTCACHE2\0");
    assert_eq!(pc2.len(), 32 + 16 * 36 * 12);

    let glb = get("glb")
        .await
        .expect("request")
        .bytes()
        .await
        .expect("body");
    assert_eq!(&glb[..4], b"glTF");
    assert_eq!(
        u32::from_le_bytes(glb[8..12].try_into().expect("4")) as usize,
        glb.len()
    );
    s.stop().await;
}

/// Downloads beyond `--max-downloads` wait their turn instead of being
/// built at once: four at a time with one turn all arrive, whole and
/// alike (a turn not given back with its body would leave the others
/// `429` after their wait).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn downloads_beyond_the_limit_wait_their_turn() {
    let s = Service::start(&data_dir("turns"), &["--max-downloads", "1"]).await;
    let id = submit_id(&s, &hanging(30, 2.0)).await;
    job_after_done(&s, &id).await;
    let http = client();
    let url = s.url(&format!("/v1/jobs/{id}/result?format=glb"));
    let gets = (0..4).map(|_| {
        let (http, url) = (http.clone(), url.clone());
        tokio::spawn(async move {
            let r = http.get(url).send().await.expect("request");
            let length = r.content_length();
            (r.status(), length, r.bytes().await.expect("body"))
        })
    });
    let mut bodies = Vec::new();
    for get in gets.collect::<Vec<_>>() {
        let (status, length, body) = get.await.expect("joined");
        assert_eq!(status, 200);
        assert_eq!(length, Some(body.len() as u64), "sent with its length");
        bodies.push(body);
    }
    assert_eq!(&bodies[0][..4], b"glTF");
    assert!(bodies.iter().all(|b| *b == bodies[0]));
    s.stop().await;
}

/// Stopping the service (what SIGTERM does) stops a running job at a
/// frame and queues it again, and returns only once the workers are
/// joined; a service started again on the same data resumes the job from
/// that frame, as its second attempt.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stopping_the_service_requeues_the_running_job_and_joins_workers() {
    let data = data_dir("stop");
    let flags = ["--workers", "1", "--checkpoint-seconds", "1000"];
    let s = Service::start(&data, &flags).await;
    let id = submit(&s, &hanging(30, 30.0)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let before = wait_for(&s, &id, LONG, |j| {
        status(j) == "running" && frames_done(j) >= 3
    })
    .await;
    let jobs = std::sync::Arc::clone(&s.state.jobs);
    tokio::time::timeout(Duration::from_secs(30), s.stop())
        .await
        .expect("stops within the grace period");
    assert_eq!(jobs.running_count(), 0, "no job runs once stopped");

    let s = Service::start(&data, &flags).await;
    let resumed = wait_for(&s, &id, LONG, |j| {
        j["timings"]["attempts"] == json!(2) && frames_done(j) > frames_done(&before)
    })
    .await;
    assert_eq!(status(&resumed), "running");
    delete_job(&s, &id).await;
    s.stop().await;
}
