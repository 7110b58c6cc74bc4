//! Three nodes on one PostgreSQL (two workers, one API-only): a worker
//! node killed with SIGKILL mid-job loses the job to the other after its
//! lease lapses, and the job finishes there with frames identical, bit for
//! bit, to an uninterrupted run; a stream opened on the API-only node
//! delivers every frame through the takeover; a cancel asked on the
//! API-only node reaches the worker; each node's metrics are its own.

mod support;

use std::time::{Duration, Instant};

use support::*;

const LONG: Duration = Duration::from_secs(240);

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_killed_worker_nodes_job_finishes_on_another_node_identically() {
    let pg = Cluster::start();
    let url = pg.database("takeover");
    let api = node(&url, "api", 0, &[]);
    let mut workers = [node(&url, "a", 1, &[]), node(&url, "b", 1, &[])];

    let spec = hanging(24, 4.0);
    let first = submit_id(&api, &spec).await;
    let stream = {
        let url = api.ws_url(&format!("/v1/jobs/{first}/stream"));
        tokio::spawn(async move { read_stream(&url).await })
    };
    let running = wait_for(&api, &first, LONG, |j| {
        status(j) == "running" && frames_done(j) >= 30
    })
    .await;
    // Kill the node running `first`; the other, idle, takes it over from
    // its last checkpoint once the lease lapses.
    let (dead, survivor) = match node_of(&running) {
        Some("a") => (0, "b"),
        Some("b") => (1, "a"),
        _ => panic!("a worker node runs it: {running}"),
    };
    workers[dead].kill();
    let killed_at = Instant::now();
    let taken = wait_for(&api, &first, LONG, |j| {
        node_of(j) == Some(survivor) && status(j) == "running"
    })
    .await;
    eprintln!(
        "takeover of {first} by node {survivor}: {:.1} s after SIGKILL (lease {TEST_LEASE} s)",
        killed_at.elapsed().as_secs_f64()
    );
    assert!(taken["timings"]["attempts"].as_u64() >= Some(2), "{taken}");
    let done = succeeded(&api, &first, LONG).await;
    assert_eq!(node_of(&done), Some(survivor));

    // The stream on the API-only node saw every frame once, in order.
    let streamed: Streamed = stream.await.expect("the stream task");
    assert_eq!(streamed.end["type"], "done", "{:?}", streamed.end);
    let indices: Vec<u32> = streamed.frames.iter().map(|f| f.index).collect();
    let total = done["progress"]["frames_total"].as_u64().expect("total") as u32;
    assert_eq!(indices, (0..total).collect::<Vec<_>>());

    // Bit for bit what an uninterrupted run stores.
    let second = submit_id(&api, &spec).await;
    let again = succeeded(&api, &second, LONG).await;
    assert_eq!(again["timings"]["attempts"], 1);
    let interrupted = all_frames(&api, &first).await;
    let reference = all_frames(&api, &second).await;
    assert_eq!(interrupted.len(), reference.len());
    for (n, (x, y)) in interrupted.iter().zip(&reference).enumerate() {
        assert!(x == y, "frame {n} differs from the uninterrupted run");
    }
    check_cancel_and_metrics(&api, &workers[1 - dead], survivor).await;
}

/// A cancel asked on the API-only node stops the job on the worker node;
/// metrics are per node.
async fn check_cancel_and_metrics(api: &Server, worker: &Server, name: &str) {
    let id = submit_id(api, &hanging(24, 20.0)).await;
    wait_for(api, &id, LONG, |j| {
        status(j) == "running" && frames_done(j) >= 2
    })
    .await;
    let asked = Instant::now();
    let j = delete_job(api, &id).await;
    assert_eq!(status(&j), "cancelled", "{j}");
    eprintln!(
        "cancel through the API-only node: {:.2} s",
        asked.elapsed().as_secs_f64()
    );

    let text = |s: &Server| {
        let url = s.url("/metrics");
        async move {
            client()
                .get(url)
                .send()
                .await
                .expect("request")
                .text()
                .await
                .expect("text")
        }
    };
    let w = text(worker).await;
    assert!(
        w.contains(&format!("drapery_workers{{node=\"{name}\"}} 1")),
        "{w}"
    );
    assert!(
        w.contains(&format!("drapery_frames_total{{node=\"{name}\"}}")),
        "{w}"
    );
    let a = text(api).await;
    assert!(a.contains("drapery_workers{node=\"api\"} 0"), "{a}");
    assert!(a.contains("drapery_frames_total{node=\"api\"} 0"), "{a}");
    let ready = get_json(api, "/readyz").await;
    assert_eq!(ready["node"], "api");
    assert_eq!(ready["workers"], 0);
}
