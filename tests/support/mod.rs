//! A real `drapery serve` process on a free port, and clients for it.

#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use futures_util::StreamExt;
use serde_json::{Value, json};
use tokio_tungstenite::tungstenite::Message;

/// A server process; killed when dropped.
pub struct Server {
    pub child: Child,
    pub base: String,
    pub data: PathBuf,
}

/// A fresh data directory under the system's temp dir.
pub fn data_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("drapery-test-{tag}-{}", uuid::Uuid::now_v7()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

impl Server {
    /// Starts `drapery serve` on port 0 with `data` and extra flags, and
    /// waits for its "listening on" line.
    pub fn start(data: &Path, flags: &[&str]) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_drapery"))
            .args(["serve", "--addr", "127.0.0.1:0", "--data"])
            .arg(data)
            .args(flags)
            .env("RUST_LOG", "warn")
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("drapery starts");
        let stdout = child.stdout.take().expect("stdout");
        let mut line = String::new();
        BufReader::new(stdout)
            .read_line(&mut line)
            .expect("reads the address line");
        let base = line
            .trim()
            .strip_prefix("listening on ")
            .unwrap_or_else(|| panic!("unexpected first line {line:?}"))
            .to_owned();
        Self {
            child,
            base,
            data: data.to_owned(),
        }
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }

    pub fn ws_url(&self, path: &str) -> String {
        format!("{}{path}", self.base.replacen("http://", "ws://", 1))
    }

    /// SIGKILL: no chance to clean up.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// SIGTERM, then waits up to `limit` for the exit; returns whether it
    /// exited successfully in time.
    pub fn terminate(&mut self, limit: Duration) -> bool {
        let pid = self.child.id().to_string();
        let _ = Command::new("kill").args(["-TERM", &pid]).status();
        let start = Instant::now();
        while start.elapsed() < limit {
            if let Ok(Some(status)) = self.child.try_wait() {
                return status.success();
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        false
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A hanging cloth pinned at two corners: `n`² particles for `duration`
/// seconds at 30 fps.
pub fn hanging(n: u32, duration: f64) -> Value {
    json!({
        "name": format!("hanging-{n}"),
        "cloth": {"grid": [n, n], "size": [1.0, 1.0], "origin": [0, 0, 1],
                  "u": [1, 0, 0], "v": [0, 0, -1],
                  "pinned": [[0, 0], [n - 1, 0]]},
        "material": "cotton",
        "duration": duration,
        "fps": 30,
        "solver": {"dt": 1.0 / 240.0}
    })
}

/// A cloth dropping onto a sphere (collision in the loop).
pub fn drape(n: u32, duration: f64) -> Value {
    json!({
        "name": format!("drape-{n}"),
        "cloth": {"grid": [n, n], "size": [1.0, 1.0], "origin": [-0.5, -0.5, 0.35]},
        "material": "cotton",
        "obstacles": [{"sphere": {"center": [0, 0, 0], "radius": 0.25}, "friction": 0.4}],
        "duration": duration,
        "fps": 30,
        "solver": {"dt": 1.0 / 240.0}
    })
}

pub fn client() -> reqwest::Client {
    reqwest::Client::new()
}

/// Submits `spec`; returns the job JSON (asserting 201).
pub async fn submit(s: &Server, spec: &Value) -> Value {
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
pub async fn get_json(s: &Server, path: &str) -> Value {
    client()
        .get(s.url(path))
        .send()
        .await
        .expect("request")
        .json()
        .await
        .expect("a JSON body")
}

pub async fn job(s: &Server, id: &str) -> Value {
    get_json(s, &format!("/v1/jobs/{id}")).await
}

/// Polls the job until `pred` holds (panics after `limit`).
pub async fn wait_for(
    s: &Server,
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
