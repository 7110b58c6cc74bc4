//! Admission by cost and the disk budget in fact (issue 17), in process.

mod support;

use std::time::Duration;

use serde_json::json;
use support::*;

const LONG: Duration = Duration::from_secs(120);

/// The job — a 1000x250 grid, 600 s at 33 fps, 19,801 frames,
/// about 55 hours here — was accepted and held a worker until the wall
/// limit: it is refused with `422 over_budget`, the message naming the
/// budget's flag and the estimate, every budget it exceeds in `details`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_job_beyond_the_budgets_is_refused_naming_the_budget_and_the_estimate() {
    let s = Service::start(&data_dir("budget"), &["--workers", "1"]).await;
    let spec = json!({
        "name": "huge",
        "cloth": {"grid": [1000, 250], "size": [4.0, 1.0]},
        "material": "cotton",
        "duration": 600.0,
        "fps": 33
    });
    let r = client()
        .post(s.url("/v1/jobs"))
        .json(&spec)
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 422);
    let e = error_of(r).await;
    assert_eq!(e["code"], json!("over_budget"));
    let message = e["message"].as_str().unwrap_or("");
    assert!(
        message.contains("estimated disk") && message.contains("--job-disk-budget"),
        "{e}"
    );
    let details: Vec<&str> = e["details"]
        .as_array()
        .expect("details")
        .iter()
        .filter_map(|d| d["message"].as_str())
        .collect();
    assert!(
        details
            .iter()
            .any(|d| d.contains("wall time") && d.contains("--job-time-budget")),
        "{details:?}"
    );
    let metrics = client()
        .get(s.url("/metrics"))
        .send()
        .await
        .expect("request")
        .text()
        .await
        .expect("text");
    assert_eq!(
        metric(&metrics, "drapery_jobs_rejected_over_budget_total{"),
        Some(1.0),
        "{metrics}"
    );
    s.stop().await;
}

/// The disk budget holds in fact, not only in the estimate: a job that
/// stores more than `--job-disk-budget` (here: one admitted under a larger
/// budget, resumed after a restart under a smaller one) fails with
/// `limit_exceeded` naming the flag.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_job_that_stores_more_than_the_disk_budget_fails_with_limit_exceeded() {
    let data = data_dir("disk-budget");
    let s = Service::start(&data, &["--workers", "1"]).await;
    let id = submit(&s, &hanging(30, 30.0)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    wait_for(&s, &id, LONG, |j| {
        status(j) == "running" && frames_done(j) >= 3
    })
    .await;
    s.stop().await;

    let s = Service::start(&data, &["--workers", "1", "--job-disk-budget", "20KB"]).await;
    let j = wait_for(&s, &id, LONG, |j| status(j) == "failed").await;
    assert_eq!(j["error"]["code"], json!("limit_exceeded"), "{j}");
    assert!(
        j["error"]["message"]
            .as_str()
            .is_some_and(|m| m.contains("--job-disk-budget")),
        "{j}"
    );
    s.stop().await;
}
