//! Disk that comes back (issue 17), in process: deleting an ended job,
//! `--retention` by count and by age, and a job cancelled before it ran
//! leaving nothing large behind.

mod support;

use std::path::Path;
use std::time::Duration;

use serde_json::json;
use support::*;

const LONG: Duration = Duration::from_secs(120);

/// What the store of data directory `dir` holds. SQLite: the bytes of
/// every file in `dir` (the database and its log). PostgreSQL: the bytes
/// of the jobs' rows, frames and checkpoints (it reuses a deleted row's
/// space for new rows rather than giving it back to the file system).
fn dir_bytes(dir: &Path) -> u64 {
    if let Some(server) = suite_server() {
        let sum = psql(
            &database_for(&server, dir),
            "SELECT (COALESCE((SELECT SUM(octet_length(positions) + octet_length(stats))
                               FROM frames), 0)
                   + COALESCE((SELECT SUM(octet_length(data)) FROM checkpoints), 0)
                   + COALESCE((SELECT SUM(octet_length(hello) + octet_length(spec))
                               FROM jobs), 0))::BIGINT",
        );
        return sum.trim().parse().expect("a byte count");
    }
    std::fs::read_dir(dir)
        .expect("a data directory")
        .filter_map(Result::ok)
        .filter_map(|e| e.metadata().ok())
        .map(|m| m.len())
        .sum()
}

async fn get_status(s: &Service, path: &str) -> u16 {
    client()
        .get(s.url(path))
        .send()
        .await
        .expect("request")
        .status()
        .as_u16()
}

/// `DELETE` of a finished job deletes it with its frames, and the data
/// directory shrinks back (nothing was ever deleted before).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn deleting_a_finished_job_removes_it_with_its_frames_and_gives_the_disk_back() {
    let data = data_dir("delete");
    let s = Service::start(&data, &["--workers", "1"]).await;
    let empty = dir_bytes(&data);
    // 61 frames of 40² particles: ~1.2 MB of positions.
    let id = submit(&s, &hanging(40, 2.0)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    job_after_done(&s, &id).await;
    let full = dir_bytes(&data);
    assert!(full > empty + 1_000_000, "{empty} -> {full}");
    assert_eq!(status(&delete_job(&s, &id).await), "succeeded");
    let after = dir_bytes(&data);
    assert!(
        after + 1_000_000 < full,
        "the directory went {empty} -> {full} -> {after} bytes"
    );
    for path in [
        format!("/v1/jobs/{id}"),
        format!("/v1/jobs/{id}/frames/0"),
        format!("/v1/jobs/{id}/result"),
    ] {
        assert_eq!(get_status(&s, &path).await, 404, "{path}");
    }
    assert_eq!(delete(&s, &id).await.status(), 404);
    s.stop().await;
}

/// `--retention 1` keeps only the most recently ended job; `--retention
/// 1s` deletes every ended job a second after its end; running jobs stay.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn retention_deletes_ended_jobs_by_count_and_by_age() {
    let s = Service::start(
        &data_dir("keep-one"),
        &["--workers", "1", "--retention", "1"],
    )
    .await;
    let first = submit(&s, &hanging(4, 0.1)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    job_after_done(&s, &first).await;
    let second = submit(&s, &hanging(4, 0.1)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    job_after_done(&s, &second).await;
    let start = std::time::Instant::now();
    while get_status(&s, &format!("/v1/jobs/{first}")).await != 404 {
        assert!(start.elapsed() < LONG, "the older job was never deleted");
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    assert_eq!(get_status(&s, &format!("/v1/jobs/{second}")).await, 200);
    s.stop().await;

    let s = Service::start(
        &data_dir("keep-1s"),
        &["--workers", "1", "--retention", "1s"],
    )
    .await;
    let long = submit(&s, &hanging(30, 30.0)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    wait_for(&s, &long, LONG, |j| status(j) == "running").await;
    assert_eq!(status(&delete_job(&s, &long).await), "cancelled");
    let start = std::time::Instant::now();
    while get_status(&s, &format!("/v1/jobs/{long}")).await != 404 {
        assert!(
            start.elapsed() < LONG,
            "the cancelled job was never deleted"
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    s.stop().await;
}

/// Submitting then cancelling a 335-byte spec of 250,000 particles grew
/// the data by 10.5 MiB (its hello) each time: now the hello is built
/// when a job starts, so one that never runs stores next to nothing; its
/// stream still begins with a hello.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_job_cancelled_before_it_ran_stores_no_hello() {
    let data = data_dir("no-hello");
    let s = Service::start(&data, &["--workers", "1"]).await;
    // Small frames, so what the blocker writes meanwhile stays small.
    let blocker = submit(&s, &hanging(10, 600.0)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    wait_for(&s, &blocker, LONG, |j| status(j) == "running").await;
    let before = dir_bytes(&data);
    let mut big = hanging(4, 0.1);
    big["cloth"]["grid"] = json!([1000, 250]);
    big["cloth"]["pinned"] = json!([[0, 0], [999, 0]]);
    big["duration"] = json!(1.0 / 30.0);
    let mut last = String::new();
    for _ in 0..3 {
        let job = submit(&s, &big).await;
        assert_eq!(status(&job), "queued");
        last = job["id"].as_str().expect("id").to_owned();
        assert_eq!(status(&delete_job(&s, &last).await), "cancelled");
    }
    let after = dir_bytes(&data);
    assert!(
        after < before + 5_000_000,
        "three cancelled submissions grew the data {before} -> {after} bytes"
    );
    let got = read_stream(&s.ws_url(&format!("/v1/jobs/{last}/stream"))).await;
    assert_eq!(got.hello["grid"], json!([1000, 250]));
    assert_eq!(got.end["type"], json!("cancelled"));
    delete(&s, &blocker).await;
    s.stop().await;
}
