//! The service's API over real sockets: a `drapery serve` process on a
//! free port, reqwest for HTTP, tokio-tungstenite for WebSocket.

mod support;

use std::time::{Duration, Instant};

use futures_util::StreamExt;
use serde_json::{Value, json};
use support::*;

const LONG: Duration = Duration::from_secs(120);

/// Submitted and streamed at once: hello, then every frame in order as a
/// stats message and a binary frame, then `done`; frame 0 is the rest
/// grid, and the stream agrees with `/frames/{n}` in both encodings.
#[tokio::test]
async fn live_stream_delivers_every_frame_in_order() {
    let s = Server::start(&data_dir("live"), &[]);
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
}

async fn job_after_done(s: &Server, id: &str) -> Value {
    wait_for(s, id, LONG, |j| status(j) == "succeeded").await
}

/// A finished job streams again; `?from=N` starts at frame N.
#[tokio::test]
async fn finished_job_replays_from_any_frame() {
    let s = Server::start(&data_dir("replay"), &[]);
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
}

/// One client connects and reads nothing while another streams the whole
/// job: the reader gets every frame as it is produced (it finishes within
/// a second of the job), and the stalled client, when it finally reads,
/// still gets every frame.
#[tokio::test]
async fn stalled_client_does_not_hold_back_the_solver_or_others() {
    let s = Server::start(&data_dir("stall"), &[]);
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
}

/// Cancelling a running job stops it within a step; the stream ends with
/// `cancelled`; a second cancel is idempotent; a finished job cannot be.
#[tokio::test]
async fn cancel_a_running_job() {
    let s = Server::start(&data_dir("cancel"), &[]);
    let id = submit(&s, &hanging(30, 30.0)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    wait_for(&s, &id, LONG, |j| {
        status(j) == "running" && frames_done(j) >= 2
    })
    .await;
    let url = s.ws_url(&format!("/v1/jobs/{id}/stream"));
    let watcher = tokio::spawn(async move { read_stream(&url).await });
    let http = client();
    let r = http
        .delete(s.url(&format!("/v1/jobs/{id}")))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 200);
    let j: Value = r.json().await.expect("JSON");
    assert_eq!(status(&j), "cancelled");
    assert!(frames_done(&j) < 901, "it stopped early");
    let got = watcher.await.expect("watcher");
    assert_eq!(got.end["type"], json!("cancelled"));
    assert_eq!(got.frames.len() as u64, frames_done(&j));
    let again = http
        .delete(s.url(&format!("/v1/jobs/{id}")))
        .send()
        .await
        .expect("request");
    assert_eq!(again.status(), 200);

    let quick = submit(&s, &hanging(4, 0.1)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    job_after_done(&s, &quick).await;
    let r = http
        .delete(s.url(&format!("/v1/jobs/{quick}")))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 409);
    assert_eq!(error_code(r).await, "conflict");
}

async fn error_code(r: reqwest::Response) -> String {
    let v: Value = r.json().await.expect("a JSON error body");
    v["error"]["code"].as_str().expect("error.code").to_owned()
}

async fn error_of(r: reqwest::Response) -> Value {
    let v: Value = r.json().await.expect("a JSON error body");
    v["error"].clone()
}

/// Every kind of bad request gets its status and a JSON error that says
/// what and where.
#[tokio::test]
async fn bad_requests_get_the_right_status_and_a_json_error() {
    let s = Server::start(
        &data_dir("errors"),
        &["--max-body-bytes", "4096", "--max-particles", "400"],
    );
    let http = client();
    let post = |body: String| {
        http.post(s.url("/v1/jobs"))
            .header("content-type", "application/json")
            .body(body)
            .send()
    };

    let r = post("{\"cloth\": ".into()).await.expect("request");
    assert_eq!(r.status(), 400);
    assert_eq!(error_code(r).await, "malformed_json");

    let mut spec = hanging(5, 0.1);
    spec["cloth"]["colour"] = json!("red");
    let r = post(spec.to_string()).await.expect("request");
    assert_eq!(r.status(), 422);
    let e = error_of(r).await;
    assert_eq!(e["code"], json!("invalid_spec"));
    assert_eq!(e["path"], json!("cloth.colour"));

    let mut spec = hanging(5, 0.1);
    spec["cloth"]["grid"] = json!([1, 5]);
    spec["fps"] = json!(-3);
    let r = post(spec.to_string()).await.expect("request");
    assert_eq!(r.status(), 422);
    let e = error_of(r).await;
    assert_eq!(e["path"], json!("cloth.grid[0]"));
    assert!(e["details"].as_array().is_some_and(|d| d.len() >= 2), "{e}");

    let r = post(hanging(21, 0.1).to_string()).await.expect("request");
    assert_eq!(r.status(), 422);
    let e = error_of(r).await;
    assert!(
        e["message"].as_str().is_some_and(|m| m.contains("400")),
        "names the limit: {e}"
    );

    let mut spec = hanging(5, 0.1);
    spec["name"] = json!("x".repeat(5000));
    let r = post(spec.to_string()).await.expect("request");
    assert_eq!(r.status(), 413);
    assert_eq!(error_code(r).await, "payload_too_large");

    let missing = "01234567-89ab-7def-8123-456789abcdef";
    for path in [
        format!("/v1/jobs/{missing}"),
        format!("/v1/jobs/{missing}/frames/0"),
        format!("/v1/jobs/{missing}/result"),
        format!("/v1/jobs/{missing}/stream"),
    ] {
        let r = http.get(s.url(&path)).send().await.expect("request");
        assert_eq!(r.status(), 404, "{path}");
        assert_eq!(error_code(r).await, "not_found", "{path}");
    }
    let r = http
        .delete(s.url(&format!("/v1/jobs/{missing}")))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 404);

    let r = http
        .get(s.url("/v1/jobs?status=done"))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 400);
    assert_eq!(error_of(r).await["path"], json!("status"));

    let id = submit(&s, &hanging(5, 0.2)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let r = http
        .get(s.url(&format!("/v1/jobs/{id}/frames/999")))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 404);
    let r = http
        .get(s.url(&format!("/v1/jobs/{id}/result?format=fbx")))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 400);
}

/// With keys set, `/v1` needs a valid bearer key, and a key sees only its
/// own jobs; health and metrics stay open.
#[tokio::test]
async fn api_keys_gate_and_separate_owners() {
    let s = Server::start(
        &data_dir("keys"),
        &[
            "--api-key",
            "alice:alice-secret-1",
            "--api-key",
            "bob:bob-secret-22",
        ],
    );
    let http = client();
    let r = http.get(s.url("/v1/jobs")).send().await.expect("request");
    assert_eq!(r.status(), 401);
    assert_eq!(error_code(r).await, "unauthorized");
    let r = http
        .get(s.url("/v1/jobs"))
        .bearer_auth("mallory-secret")
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 401);

    let r = http
        .post(s.url("/v1/jobs"))
        .bearer_auth("alice-secret-1")
        .json(&hanging(4, 0.1))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 201);
    let id = r.json::<Value>().await.expect("JSON")["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let as_bob = http
        .get(s.url(&format!("/v1/jobs/{id}")))
        .bearer_auth("bob-secret-22")
        .send()
        .await
        .expect("request");
    assert_eq!(
        as_bob.status(),
        404,
        "another owner's job does not exist for bob"
    );
    let bobs: Value = http
        .get(s.url("/v1/jobs"))
        .bearer_auth("bob-secret-22")
        .send()
        .await
        .expect("request")
        .json()
        .await
        .expect("JSON");
    assert_eq!(bobs["jobs"], json!([]));
    let alices: Value = http
        .get(s.url("/v1/jobs"))
        .bearer_auth("alice-secret-1")
        .send()
        .await
        .expect("request")
        .json()
        .await
        .expect("JSON");
    assert_eq!(alices["jobs"][0]["id"], json!(id));
    let r = http
        .get(s.url(&format!("/v1/jobs/{id}")))
        .bearer_auth("alice-secret-1")
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 200);
    // Browsers cannot set headers on a WebSocket: the key may ride in the
    // query, with the same ownership rules.
    let r = http
        .get(s.url(&format!("/v1/jobs/{id}?access_token=alice-secret-1")))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 200);
    let r = http
        .get(s.url(&format!("/v1/jobs/{id}?access_token=bob-secret-22")))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 404);
    let got =
        read_stream(&s.ws_url(&format!("/v1/jobs/{id}/stream?access_token=alice-secret-1"))).await;
    assert_eq!(got.hello["job"], json!(id));
    assert_eq!(
        http.get(s.url("/healthz"))
            .send()
            .await
            .expect("request")
            .status(),
        200
    );
}

/// With one worker busy and a queue of one, the next submission is
/// refused with 429 and Retry-After; the list pages newest first and
/// filters by status.
#[tokio::test]
async fn full_queue_refuses_with_retry_after_and_list_pages() {
    let s = Server::start(
        &data_dir("queue"),
        &["--workers", "1", "--queue-capacity", "1"],
    );
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
    let r = http
        .delete(s.url(&format!("/v1/jobs/{b}")))
        .send()
        .await
        .expect("request");
    assert_eq!(status(&r.json::<Value>().await.expect("JSON")), "cancelled");
    submit(&s, &hanging(4, 0.1)).await;
    let r = http
        .delete(s.url(&format!("/v1/jobs/{a}")))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 200);

    let metrics = http
        .get(s.url("/metrics"))
        .send()
        .await
        .expect("request")
        .text()
        .await
        .expect("text");
    assert!(
        metrics.contains("drapery_jobs{status=\"cancelled\"}"),
        "{metrics}"
    );
    assert!(
        metrics.contains("drapery_jobs_rejected_queue_full_total 1"),
        "{metrics}"
    );
    assert!(metrics.contains("drapery_step_seconds_bucket"), "{metrics}");
}

/// Downloads of a finished job: a zip with one OBJ per frame, a PC2 cache
/// with the right header, a binary glTF.
#[tokio::test]
async fn results_download_in_three_formats() {
    let s = Server::start(&data_dir("results"), &[]);
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
}

/// Health, readiness, and the OpenAPI document the server serves is the
/// one checked in as `api/openapi.yaml`.
#[tokio::test]
async fn operations_endpoints_and_served_openapi_match_the_checked_in_file() {
    let s = Server::start(&data_dir("ops"), &[]);
    let http = client();
    assert_eq!(
        http.get(s.url("/healthz"))
            .send()
            .await
            .expect("request")
            .status(),
        200
    );
    let ready = get_json(&s, "/readyz").await;
    assert_eq!(ready["status"], json!("ready"));
    let served: utoipa::openapi::OpenApi = http
        .get(s.url("/openapi.json"))
        .send()
        .await
        .expect("request")
        .json()
        .await
        .expect("an OpenAPI document");
    let checked_in = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("api/openapi.yaml"),
    )
    .expect("api/openapi.yaml");
    assert!(
        served.to_yaml().expect("YAML") == checked_in,
        "the served document differs from api/openapi.yaml: run `cargo run -- openapi --write api`"
    );
    let schema = get_json(&s, "/job.schema.json").await;
    assert_eq!(
        schema["$schema"],
        json!("https://json-schema.org/draft/2020-12/schema")
    );
}

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

/// A job that runs past `--max-wall-seconds` fails with `limit_exceeded`
/// naming the flag, keeping the frames it stored.
#[tokio::test]
async fn wall_time_limit_fails_the_job() {
    let s = Server::start(&data_dir("wall"), &["--max-wall-seconds", "0.5"]);
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
}

/// With `--cors-origin`, a browser preflight from that origin is allowed
/// (and the bearer header may be sent); other origins get no allowance.
#[tokio::test]
async fn cors_allows_only_configured_origins() {
    let s = Server::start(
        &data_dir("cors"),
        &["--cors-origin", "http://viewer.example"],
    );
    let http = client();
    let preflight = |origin: &'static str| {
        http.request(reqwest::Method::OPTIONS, s.url("/v1/jobs"))
            .header("origin", origin)
            .header("access-control-request-method", "POST")
            .header(
                "access-control-request-headers",
                "authorization,content-type",
            )
            .send()
    };
    let ok = preflight("http://viewer.example").await.expect("request");
    assert_eq!(
        ok.headers()
            .get("access-control-allow-origin")
            .and_then(|v| v.to_str().ok()),
        Some("http://viewer.example")
    );
    let allowed = ok
        .headers()
        .get("access-control-allow-headers")
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_ascii_lowercase();
    assert!(allowed.contains("authorization"), "{allowed}");
    let other = preflight("http://evil.example").await.expect("request");
    assert!(other.headers().get("access-control-allow-origin").is_none());
}
