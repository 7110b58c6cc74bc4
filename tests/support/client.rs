//! Clients of a service: HTTP through reqwest, the stream through
//! tokio-tungstenite, and the binary frame parsed by hand (not by the
//! service's own code, so the layout is checked).

use std::time::{Duration, Instant};

use futures_util::StreamExt;
use serde_json::Value;
use tokio_tungstenite::tungstenite::Message;

use super::Endpoint;

pub fn client() -> reqwest::Client {
    reqwest::Client::new()
}

/// Submits `spec`; returns the job JSON (asserting 201).
pub async fn submit(s: &impl Endpoint, spec: &Value) -> Value {
    let r = client()
        .post(s.url("/v1/jobs"))
        .json(spec)
        .send()
        .await
        .expect("request");
    assert_eq!(
        r.status(),
        201,
        "submit: {}",
        r.text().await.unwrap_or_default()
    );
    r.json().await.expect("job JSON")
}

/// `GET path` without a key, as JSON.
pub async fn get_json(s: &impl Endpoint, path: &str) -> Value {
    client()
        .get(s.url(path))
        .send()
        .await
        .expect("request")
        .json()
        .await
        .expect("a JSON body")
}

pub async fn job(s: &impl Endpoint, id: &str) -> Value {
    get_json(s, &format!("/v1/jobs/{id}")).await
}

/// Polls the job until `pred` holds (panics after `limit`).
pub async fn wait_for(
    s: &impl Endpoint,
    id: &str,
    limit: Duration,
    pred: impl Fn(&Value) -> bool,
) -> Value {
    let start = Instant::now();
    loop {
        let j = job(s, id).await;
        if pred(&j) {
            return j;
        }
        assert!(start.elapsed() < limit, "timed out waiting; job is {j}");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

pub fn status(j: &Value) -> &str {
    j["status"].as_str().unwrap_or("")
}

pub fn frames_done(j: &Value) -> u64 {
    j["progress"]["frames_done"].as_u64().unwrap_or(0)
}

/// A binary frame, parsed.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    pub index: u32,
    pub time: f64,
    pub positions: Vec<[f32; 3]>,
}

pub fn parse_frame(b: &[u8]) -> Frame {
    assert!(b.len() >= 16, "binary frame too short");
    let index = u32::from_le_bytes(b[0..4].try_into().expect("4 bytes"));
    let count = u32::from_le_bytes(b[4..8].try_into().expect("4 bytes")) as usize;
    let time = f64::from_le_bytes(b[8..16].try_into().expect("8 bytes"));
    assert_eq!(b.len(), 16 + 12 * count, "length matches the vertex count");
    let positions = b[16..]
        .chunks_exact(12)
        .map(|c| {
            let f = |k: usize| f32::from_le_bytes(c[k..k + 4].try_into().expect("4 bytes"));
            [f(0), f(4), f(8)]
        })
        .collect();
    Frame {
        index,
        time,
        positions,
    }
}

/// Everything one stream delivered.
#[derive(Debug, Default)]
pub struct Streamed {
    pub hello: Value,
    pub stats: Vec<Value>,
    pub frames: Vec<Frame>,
    pub end: Value,
}

/// Reads a whole stream: hello, stats/binary pairs, the end message.
pub async fn read_stream(url: &str) -> Streamed {
    let (mut ws, _) = tokio_tungstenite::connect_async(url)
        .await
        .expect("WebSocket connects");
    let mut out = Streamed::default();
    while let Some(msg) = ws.next().await {
        match msg.expect("stream message") {
            Message::Text(t) => {
                let v: Value = serde_json::from_str(&t).expect("JSON text message");
                match v["type"].as_str() {
                    Some("hello") => out.hello = v,
                    Some("stats") => out.stats.push(v),
                    Some(_) => {
                        out.end = v;
                    }
                    None => panic!("message without type: {v}"),
                }
            }
            Message::Binary(b) => out.frames.push(parse_frame(&b)),
            Message::Close(_) => break,
            _ => {}
        }
    }
    out
}

/// `DELETE /v1/jobs/{id}`, whatever it answers.
pub async fn delete(s: &impl Endpoint, id: &str) -> reqwest::Response {
    client()
        .delete(s.url(&format!("/v1/jobs/{id}")))
        .send()
        .await
        .expect("request")
}

/// `DELETE /v1/jobs/{id}` answered `200`: the job as it is then.
pub async fn delete_job(s: &impl Endpoint, id: &str) -> Value {
    let r = delete(s, id).await;
    assert_eq!(r.status(), 200);
    r.json().await.expect("JSON")
}

/// The `error.code` of an error response.
pub async fn error_code(r: reqwest::Response) -> String {
    let v: Value = r.json().await.expect("a JSON error body");
    v["error"]["code"].as_str().expect("error.code").to_owned()
}

/// The `error` object of an error response.
pub async fn error_of(r: reqwest::Response) -> Value {
    let v: Value = r.json().await.expect("a JSON error body");
    v["error"].clone()
}

/// Waits (up to two minutes) for the job to succeed.
pub async fn job_after_done(s: &impl Endpoint, id: &str) -> Value {
    wait_for(s, id, Duration::from_secs(120), |j| {
        status(j) == "succeeded"
    })
    .await
}

/// The value of metric `name` (a series whose name and labels start with
/// `name`, whatever labels follow, such as the node's) in a Prometheus
/// exposition.
pub fn metric(text: &str, name: &str) -> Option<f64> {
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .find(|l| l.starts_with(name))
        .and_then(|l| l.rsplit(' ').next())
        .and_then(|v| v.parse().ok())
}
