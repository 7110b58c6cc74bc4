//! The WebSocket stream, in process over a real socket: every frame in
//! order, live or replayed from any frame, at each client's own pace, in
//! the message shapes the protocol documents.

mod support;

use std::time::{Duration, Instant};

use futures_util::StreamExt;
use serde_json::{Value, json};
use support::*;
use tokio_tungstenite::tungstenite::Message;

/// Submitted and streamed at once: hello, then every frame in order as a
/// stats message and a binary frame, then `done`; frame 0 is the rest
/// grid, and the stream agrees with `/frames/{n}` in both encodings.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn live_stream_delivers_every_frame_in_order() {
    let s = Service::start(&data_dir("live"), &[]).await;
    let job = submit(&s, &drape(10, 1.0)).await;
    let id = job["id"].as_str().expect("id").to_owned();
    assert!(matches!(status(&job), "queued" | "running"));
    let got = read_stream(&s.ws_url(&format!("/v1/jobs/{id}/stream"))).await;

    assert_eq!(got.hello["grid"], json!([10, 10]));
    assert_eq!(got.hello["vertices"], json!(100));
    assert_eq!(
        got.hello["triangles"].as_array().map(Vec::len),
        Some(2 * 9 * 9)
    );
    let sphere = &got.hello["obstacles"][0];
    assert!(
        sphere["triangles"]
            .as_array()
            .is_some_and(|t| t.len() > 100)
    );
    let total = 31;
    assert_eq!(got.frames.len(), total, "every frame");
    assert_eq!(got.stats.len(), total);
    for (k, (f, st)) in got.frames.iter().zip(&got.stats).enumerate() {
        assert_eq!(f.index as usize, k, "in order");
        assert_eq!(st["frame"], json!(k));
        assert!((f.time - k as f64 / 30.0).abs() < 1e-9);
        assert_eq!(f.positions.len(), 100);
        assert!(f.positions.iter().flatten().all(|c| c.is_finite()));
        assert!(
            st["obstacles"][0]["rotation"].is_array(),
            "poses ride along"
        );
    }
    // Frame 0 is the flat grid at z = 0.35; the cloth then falls.
    assert!(
        got.frames[0]
            .positions
            .iter()
            .all(|p| (p[2] - 0.35).abs() < 1e-6)
    );
    assert!(got.frames[total - 1].positions[0][2] < 0.3);
    assert_eq!(got.end["type"], json!("done"));
    assert!(got.end["stats"]["steps"].as_u64().is_some_and(|n| n >= 240));

    let final_job = job_after_done(&s, &id).await;
    assert_eq!(final_job["progress"]["frames_done"], json!(total));
    assert!(final_job["stats"]["finite"].as_bool().unwrap_or(false));

    let http = client();
    let bin = http
        .get(s.url(&format!("/v1/jobs/{id}/frames/7")))
        .header("accept", "application/octet-stream")
        .send()
        .await
        .expect("request");
    assert_eq!(bin.status(), 200);
    assert_eq!(
        parse_frame(&bin.bytes().await.expect("body")),
        got.frames[7]
    );
    let js = get_json(&s, &format!("/v1/jobs/{id}/frames/7")).await;
    assert_eq!(js["frame"], json!(7));
    let v: Vec<[f32; 3]> = serde_json::from_value(js["vertices"].clone()).expect("vertices");
    assert_eq!(v, got.frames[7].positions);
    s.stop().await;
}

/// A finished job streams again; `?from=N` starts at frame N.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn finished_job_replays_from_any_frame() {
    let s = Service::start(&data_dir("replay"), &[]).await;
    let id = submit(&s, &hanging(8, 0.5)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    job_after_done(&s, &id).await;
    let all = read_stream(&s.ws_url(&format!("/v1/jobs/{id}/stream"))).await;
    let tail = read_stream(&s.ws_url(&format!("/v1/jobs/{id}/stream?from=10"))).await;
    assert_eq!(all.frames.len(), 16);
    assert_eq!(tail.hello, all.hello);
    assert_eq!(tail.frames, all.frames[10..]);
    assert_eq!(tail.end["type"], json!("done"));
    let none = read_stream(&s.ws_url(&format!("/v1/jobs/{id}/stream?from=99"))).await;
    assert!(none.frames.is_empty());
    assert_eq!(none.end["type"], json!("done"));
    s.stop().await;
}

/// One client connects and reads nothing while another streams the whole
/// job: the reader gets every frame as it is produced (it finishes within
/// a second of the job), and the stalled client, when it finally reads,
/// still gets every frame.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stalled_client_does_not_hold_back_the_solver_or_others() {
    let s = Service::start(&data_dir("stall"), &[]).await;
    // 40² frames are ~19 kB: 61 of them overflow the socket buffers of a
    // client that does not read.
    let id = submit(&s, &hanging(40, 2.0)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let url = s.ws_url(&format!("/v1/jobs/{id}/stream"));
    let (mut stalled, _) = tokio_tungstenite::connect_async(&url)
        .await
        .expect("connects");
    let reader = tokio::spawn({
        let url = url.clone();
        async move {
            let got = read_stream(&url).await;
            (got, Instant::now())
        }
    });
    let done = job_after_done(&s, &id).await;
    let job_end = Instant::now();
    let (got, reader_end) = reader.await.expect("reader task");
    assert_eq!(got.frames.len(), 61);
    assert!(
        got.frames
            .iter()
            .enumerate()
            .all(|(k, f)| f.index as usize == k)
    );
    assert!(
        reader_end <= job_end + Duration::from_secs(2),
        "the reader lagged the job by {:?}",
        reader_end.saturating_duration_since(job_end)
    );
    assert_eq!(done["progress"]["frames_done"], json!(61));

    let mut frames = 0;
    while let Some(Ok(m)) = stalled.next().await {
        match m {
            tokio_tungstenite::tungstenite::Message::Binary(b) => {
                assert_eq!(parse_frame(&b).index, frames);
                frames += 1;
            }
            tokio_tungstenite::tungstenite::Message::Close(_) => break,
            _ => {}
        }
    }
    assert_eq!(frames, 61, "the stalled client lost no frame");
    s.stop().await;
}

/// The stream's text messages are the protocol's `StreamMessage`s with
/// exactly their documented fields: a hello with the grid and the
/// obstacle meshes, per frame a `stats` with the solver's statistics the
/// viewer plots, the obstacles' poses and the contacts, and an end that
/// says `done` with `status: "succeeded"`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stream_messages_have_the_documented_shape() {
    let s = Service::start(&data_dir("shape"), &[]).await;
    let id = submit(&s, &drape(6, 0.2)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let got = read_stream(&s.ws_url(&format!("/v1/jobs/{id}/stream"))).await;
    let keys = |v: &Value| -> Vec<String> {
        let mut k: Vec<String> = v
            .as_object()
            .map(|o| o.keys().cloned().collect())
            .unwrap_or_default();
        k.sort();
        k
    };

    assert_eq!(
        keys(&got.hello),
        [
            "duration",
            "fps",
            "frames",
            "grid",
            "job",
            "name",
            "obstacles",
            "triangles",
            "type",
            "vertices"
        ]
    );
    assert_eq!(got.hello["type"], json!("hello"));
    assert_eq!(got.hello["job"], json!(id));
    assert_eq!(got.hello["name"], json!("drape-6"));
    assert_eq!(got.hello["frames"], json!(7));
    assert_eq!(got.hello["fps"], json!(30.0));
    assert_eq!(got.hello["duration"], json!(0.2));
    assert_eq!(
        keys(&got.hello["obstacles"][0]),
        ["moving", "triangles", "vertices"]
    );
    assert_eq!(got.hello["obstacles"][0]["moving"], json!(false));

    assert_eq!(got.stats.len(), 7);
    for (k, st) in got.stats.iter().enumerate() {
        assert_eq!(st["type"], json!("stats"));
        assert_eq!(st["frame"], json!(k));
        for field in [
            "time",
            "steps",
            "cg_iterations",
            "contacts",
            "kinetic_energy",
            "collision_seconds",
            "step_seconds",
            "contact_particles",
        ] {
            assert!(st.get(field).is_some(), "stats lacks {field}: {st}");
        }
        assert_eq!(keys(&st["obstacles"][0]), ["rotation", "translation"]);
    }

    assert_eq!(
        keys(&got.end),
        ["error", "frames", "stats", "status", "type"]
    );
    assert_eq!(got.end["type"], json!("done"));
    assert_eq!(got.end["status"], json!("succeeded"));
    assert_eq!(got.end["frames"], json!(7));
    assert_eq!(got.end["error"], Value::Null);
    assert_eq!(got.end["stats"]["frames"], json!(7));

    for message in [&got.hello, &got.end].into_iter().chain(&got.stats) {
        let parsed: Result<drapery::service::protocol::StreamMessage, _> =
            serde_json::from_value(message.clone());
        assert!(parsed.is_ok(), "not a StreamMessage: {message}");
    }
    s.stop().await;
}

/// A queued job cancelled and then deleted at once (two `DELETE`s) under
/// a stream that follows it: the stream still ends in order, with
/// `cancelled` if it saw the cancel, else with a close naming the
/// deletion, never by dropping the connection.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stream_of_a_job_deleted_under_it_closes_naming_why() {
    let s = Service::start(&data_dir("deleted"), &["--workers", "1"]).await;
    let busy = submit_id(&s, &hanging(30, 30.0)).await;
    wait_for(&s, &busy, Duration::from_secs(60), |j| {
        status(j) == "running"
    })
    .await;
    let id = submit_id(&s, &hanging(6, 0.5)).await;
    let url = s.ws_url(&format!("/v1/jobs/{id}/stream"));
    let (mut ws, _) = tokio_tungstenite::connect_async(url)
        .await
        .expect("connects");
    let Some(Ok(Message::Text(hello))) = ws.next().await else {
        panic!("no hello");
    };
    assert!(hello.contains("\"hello\""), "{hello}");
    for _ in 0..2 {
        assert_eq!(status(&delete_job(&s, &id).await), "cancelled");
    }
    let mut end = None;
    let closed = loop {
        match ws.next().await {
            Some(Ok(Message::Text(t))) => end = Some(t.to_string()),
            Some(Ok(Message::Close(c))) => break c.map(|c| c.reason.to_string()),
            Some(Ok(_)) => {}
            other => panic!("the stream ended without a close: {other:?}"),
        }
    };
    match end {
        Some(t) => assert!(t.contains("\"cancelled\""), "{t}"),
        None => assert_eq!(closed.as_deref(), Some("the job was deleted")),
    }
    delete_job(&s, &busy).await;
    s.stop().await;
}
