//! Nodes under load on one PostgreSQL: twenty jobs over two worker nodes
//! each run exactly once (and how long they take on one node against
//! two); a worker node killed and started again takes its own job back at
//! once; the database stopped and started again under load: clear 503s
//! while it is down, and every job accepted before finishes after, with
//! every frame.

mod support;

use std::time::{Duration, Instant};

use serde_json::Value;
use support::*;

const LONG: Duration = Duration::from_secs(300);

/// One scenario at a time: each starts its own nodes on two cores.
static SERIAL: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// Submits `n` short jobs through the given nodes in turn and waits for
/// all; returns their ids and the wall time from first submission to
/// last end.
async fn run_batch(nodes: &[&Server], n: usize) -> (Vec<String>, Duration) {
    let start = Instant::now();
    let mut ids = Vec::new();
    for k in 0..n {
        ids.push(submit_id(nodes[k % nodes.len()], &hanging(12, 1.0)).await);
    }
    for id in &ids {
        succeeded(nodes[0], id, LONG).await;
    }
    (ids, start.elapsed())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn twenty_jobs_over_two_worker_nodes_each_run_exactly_once() {
    let _one = SERIAL.lock().await;
    let pg = Cluster::start();

    let solo_url = pg.database("solo");
    let solo = node(&solo_url, "solo", 1, &[]);
    let (_, alone) = run_batch(&[&solo], 20).await;
    drop(solo);

    let url = pg.database("pair");
    let (a, b) = (node(&url, "a", 1, &[]), node(&url, "b", 1, &[]));
    let (ids, together) = run_batch(&[&a, &b], 20).await;
    eprintln!(
        "20 short jobs: {:.1} s on one node, {:.1} s on two ({:.2}x)",
        alone.as_secs_f64(),
        together.as_secs_f64(),
        alone.as_secs_f64() / together.as_secs_f64()
    );
    let mut by_node = [0, 0];
    for id in &ids {
        let j = job(&a, id).await;
        assert_eq!(j["timings"]["attempts"], 1, "run exactly once: {j}");
        assert_eq!(
            j["progress"]["frames_done"], j["progress"]["frames_total"],
            "{j}"
        );
        match node_of(&j) {
            Some("a") => by_node[0] += 1,
            Some("b") => by_node[1] += 1,
            other => panic!("ran on {other:?}"),
        }
    }
    assert!(
        by_node[0] > 0 && by_node[1] > 0,
        "both nodes worked: {by_node:?}"
    );
    // The store holds each job once, with its frames once.
    let rows = psql(&url, "SELECT COUNT(*), SUM(frames_done) FROM jobs");
    assert_eq!(rows.trim(), format!("20|{}", 20 * 31));
    let frames = psql(&url, "SELECT COUNT(*) FROM frames");
    assert_eq!(frames.trim(), (20 * 31).to_string());
}

/// A worker node killed and started again under the same name queues
/// its job again at start and resumes it from the checkpoint, long before
/// the lease (60 s here) would have let another node take it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_restarted_worker_node_resumes_its_job_at_once() {
    let _one = SERIAL.lock().await;
    let pg = Cluster::start();
    let url = pg.database("restart");
    let long_lease = ["--lease-seconds", "60"];
    let mut w = node(&url, "w", 1, &long_lease);
    let spec = hanging(24, 3.0);
    let id = submit_id(&w, &spec).await;
    wait_for(&w, &id, LONG, |j| frames_done(j) >= 20).await;
    w.kill();
    let restarted = Instant::now();
    let w = node(&url, "w", 1, &long_lease);
    let done = succeeded(&w, &id, LONG).await;
    assert!(
        restarted.elapsed() < Duration::from_secs(50),
        "no wait for the lease"
    );
    assert_eq!(done["timings"]["attempts"], 2, "{done}");
    let again = submit_id(&w, &spec).await;
    succeeded(&w, &again, LONG).await;
    assert!(all_frames(&w, &id).await == all_frames(&w, &again).await);
}

/// PostgreSQL stopped under load: requests get 503 `store_unavailable`
/// with a Retry-After, readiness says so; once it is back, every job
/// accepted before finishes with every frame, as an uninterrupted run.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_database_stopped_and_started_under_load_loses_nothing() {
    let _one = SERIAL.lock().await;
    let pg = Cluster::start();
    let url = pg.database("outage");
    let a = node(&url, "a", 1, &[]);
    let b = node(&url, "b", 1, &[]);
    let spec = hanging(20, 3.0);
    let mut ids = Vec::new();
    for k in 0..4 {
        ids.push(submit_id(if k % 2 == 0 { &a } else { &b }, &spec).await);
    }
    wait_for(&a, &ids[0], LONG, |j| frames_done(j) >= 10).await;

    pg.stop();
    let r = client()
        .get(a.url(&format!("/v1/jobs/{}", ids[0])))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 503);
    assert!(r.headers().contains_key("retry-after"));
    assert_eq!(error_code(r).await, "store_unavailable");
    let r = client()
        .post(b.url("/v1/jobs"))
        .json(&spec)
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 503);
    assert_eq!(error_code(r).await, "store_unavailable");
    let r = client()
        .get(a.url("/readyz"))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 503);
    let ready: Value = r.json().await.expect("JSON");
    assert_eq!(ready["store"], false, "{ready}");
    assert_eq!(ready["error"]["code"], "store_unavailable");
    tokio::time::sleep(Duration::from_secs(4)).await;
    pg.start_server();

    let reference = submit_id(&a, &spec).await;
    for id in &ids {
        succeeded(&a, id, LONG).await;
    }
    succeeded(&a, &reference, LONG).await;
    let expected = all_frames(&a, &reference).await;
    for id in &ids {
        assert!(
            all_frames(&b, id).await == expected,
            "job {id} lost or changed a frame"
        );
    }
}
