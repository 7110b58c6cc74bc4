//! Connections a hostile client holds (issue 17), in process over raw
//! sockets: a head that never ends, a silent keep-alive connection, more
//! sockets than the cap, a body announced huge, a body that stops coming.
//! Margins are wide: the machine may be loaded.

mod support;

use std::time::{Duration, Instant};

use support::*;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

/// Reads until the server closes the socket (or `limit` passes); returns
/// what it sent and how long it took.
async fn until_closed(sock: &mut TcpStream, limit: Duration) -> (String, Duration) {
    let start = Instant::now();
    let mut got = Vec::new();
    let mut buf = [0u8; 4096];
    loop {
        match tokio::time::timeout(limit.saturating_sub(start.elapsed()), sock.read(&mut buf)).await
        {
            Ok(Ok(0)) | Ok(Err(_)) => break,
            Ok(Ok(n)) => got.extend_from_slice(&buf[..n]),
            Err(_) => panic!("still open after {limit:?}"),
        }
    }
    (String::from_utf8_lossy(&got).into_owned(), start.elapsed())
}

async fn connect(s: &Service) -> TcpStream {
    TcpStream::connect(s.base.trim_start_matches("http://"))
        .await
        .expect("connects")
}

/// A client that sends `GET /healthz HTTP/1.1\r\nHost: x\r\n` and nothing
/// more was held for minutes: it is closed after `--header-timeout`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_request_that_never_finishes_its_headers_is_closed() {
    let s = Service::start(&data_dir("slow-head"), &["--header-timeout", "1"]).await;
    let mut sock = connect(&s).await;
    sock.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
        .await
        .expect("writes");
    let (_, took) = until_closed(&mut sock, Duration::from_secs(30)).await;
    assert!(took >= Duration::from_millis(900), "closed early: {took:?}");
    s.stop().await;
}

/// A kept-alive connection that goes silent after its request is closed
/// after `--idle-timeout`, and a request in time is served as usual.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_idle_keep_alive_connection_is_closed() {
    let s = Service::start(
        &data_dir("idle"),
        &["--idle-timeout", "1", "--header-timeout", "30"],
    )
    .await;
    let mut sock = connect(&s).await;
    sock.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n")
        .await
        .expect("writes");
    let (answer, took) = until_closed(&mut sock, Duration::from_secs(30)).await;
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    assert!(took >= Duration::from_millis(900), "closed early: {took:?}");
    s.stop().await;
}

/// With more idle sockets than `--max-connections`, the extra ones wait;
/// once the timeouts close the idle ones, `/healthz` answers again (it
/// stopped answering, with "Too many open files" every second).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn connections_beyond_the_cap_wait_and_the_server_keeps_answering() {
    let s = Service::start(
        &data_dir("cap"),
        &["--max-connections", "8", "--header-timeout", "1"],
    )
    .await;
    let mut hogs = Vec::new();
    for _ in 0..40 {
        let mut sock = connect(&s).await;
        let _ = sock
            .write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
            .await;
        hogs.push(sock);
    }
    let start = Instant::now();
    let r = tokio::time::timeout(
        Duration::from_secs(60),
        client().get(s.url("/healthz")).send(),
    )
    .await
    .expect("answered within a minute")
    .expect("request");
    assert_eq!(r.status(), 200);
    assert!(start.elapsed() < Duration::from_secs(60));
    drop(hogs);
    s.stop().await;
}

/// `Content-Length: 1000000000000` with a tiny body was waited on: it is
/// refused at once with `413` in the error envelope.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_huge_content_length_is_refused_with_413_at_once() {
    let s = Service::start(&data_dir("huge"), &[]).await;
    let mut sock = connect(&s).await;
    sock.write_all(
        b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 1000000000000\r\n\r\n{",
    )
    .await
    .expect("writes");
    let (answer, took) = until_closed(&mut sock, Duration::from_secs(20)).await;
    assert!(answer.starts_with("HTTP/1.1 413"), "{answer}");
    assert!(answer.contains("payload_too_large"), "{answer}");
    assert!(took < Duration::from_secs(10), "{took:?}");
    s.stop().await;
}

/// A body that stops arriving gets `408` after `--body-timeout`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_body_that_stops_arriving_gets_408() {
    let s = Service::start(&data_dir("slow-body"), &["--body-timeout", "1"]).await;
    let mut sock = connect(&s).await;
    sock.write_all(
        b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 100\r\n\r\n{",
    )
    .await
    .expect("writes");
    let (answer, took) = until_closed(&mut sock, Duration::from_secs(30)).await;
    assert!(answer.starts_with("HTTP/1.1 408"), "{answer}");
    assert!(answer.contains("request_timeout"), "{answer}");
    assert!(took >= Duration::from_millis(900), "{took:?}");
    s.stop().await;
}

/// Stopping the service while a client holds a half-sent request returns
/// within the grace period (it waited for the client before).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stopping_while_a_client_holds_a_half_sent_request_ends_in_the_grace_period() {
    let s = Service::start(
        &data_dir("stop-held"),
        &["--shutdown-grace", "2", "--body-timeout", "600"],
    )
    .await;
    let mut held = connect(&s).await;
    held.write_all(
        b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 100\r\n\r\n{",
    )
    .await
    .expect("writes");
    let mut head = connect(&s).await;
    head.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
        .await
        .expect("writes");
    tokio::time::sleep(Duration::from_millis(300)).await;
    let start = Instant::now();
    tokio::time::timeout(Duration::from_secs(30), s.stop())
        .await
        .expect("stops");
    assert!(
        start.elapsed() < Duration::from_secs(15),
        "{:?}",
        start.elapsed()
    );
}
